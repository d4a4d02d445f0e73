// Path rules of the dataset format (docs/dataset-format.md), for the reader
// and the writer. Reading and writing files: tools/util/files.h.
#pragma once

#include <filesystem>
#include <string>

namespace hdabench::datasets::internal {

// Checks a path written in a dataset (manifest or frames table): it must be
// non-empty, relative, use '/' separators and stay inside the dataset folder
// (no ".." component). Returns an empty string when it is acceptable, else
// what is wrong.
std::string CheckDatasetPath(const std::string& path);

// The lexically normal form used to compare dataset paths ("a/./b" == "a/b").
std::string NormalDatasetPath(const std::string& path);

}  // namespace hdabench::datasets::internal
