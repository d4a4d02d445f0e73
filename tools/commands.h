// Entry points of the hdabench subcommands. tools/main.cc parses the command
// line (CLI11) and calls these; each returns an exit code from exit_codes.h and
// writes its report to `out` and problems to `err`. The work itself lives in the
// modules: these functions only load, call and print.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>

namespace hdabench::tools {

struct DatasetCheckOptions {
  std::string dataset_dir;                     // the dataset folder (holds manifest.json)
  std::optional<std::pair<int, int>> frames;   // frame indices for the baseline line; default: first and last
};
int RunDatasetCheck(const DatasetCheckOptions& options, std::ostream& out, std::ostream& err);

struct DatasetCreateOptions {
  std::string out_dir;     // folder to create; must not exist or be empty
  std::uint64_t seed = 1;  // same seed, same bytes
};
int RunDatasetCreate(const DatasetCreateOptions& options, std::ostream& out, std::ostream& err);

struct DemoOptions {
  std::string out_dir = "hdabench-demo";  // replaced on each run; the dataset goes in out_dir/dataset
  std::uint64_t seed = 1;                 // same seed, same bytes
};
// The main job on the built-in default. Today: create the example dataset and
// check it (later: the full reference comparison on it).
int RunDemo(const DemoOptions& options, std::ostream& out, std::ostream& err);

}  // namespace hdabench::tools
