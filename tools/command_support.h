// Helpers shared by the hdabench commands that read a dataset: the same
// messages and exit codes everywhere.
#pragma once

#include <optional>
#include <ostream>
#include <string>

#include "datasets/dataset.h"

namespace hdabench::tools {

// kExitOk when `dir` is a folder; otherwise prints "hdabench <command>: <dir>:
// no such folder" (or "is not a folder") to err and returns kExitInput.
int CheckDatasetFolder(const std::string& dir, const std::string& command, std::ostream& err);

// Loads the dataset in `dir`. On problems prints "hdabench <command>: N
// problem(s) in DIR (see hdabench dataset check):" and each problem to err and
// returns nothing: the command then exits with kExitInput.
std::optional<datasets::Dataset> LoadDatasetOrReport(const std::string& dir,
                                                     const datasets::LoadOptions& load,
                                                     const std::string& command, std::ostream& err);

}  // namespace hdabench::tools
