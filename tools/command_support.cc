#include "tools/command_support.h"

#include <filesystem>
#include <system_error>
#include <utility>

#include "tools/exit_codes.h"

namespace hdabench::tools {

namespace fs = std::filesystem;

int CheckDatasetFolder(const std::string& dir, const std::string& command, std::ostream& err) {
  std::error_code ec;
  const fs::file_status status = fs::status(dir, ec);
  if (ec || !fs::exists(status)) {
    err << "hdabench " << command << ": " << dir << ": no such folder\n";
    return kExitInput;
  }
  if (!fs::is_directory(status)) {
    err << "hdabench " << command << ": " << dir << ": is not a folder; expected a dataset folder\n";
    return kExitInput;
  }
  return kExitOk;
}

std::optional<datasets::Dataset> LoadDatasetOrReport(const std::string& dir,
                                                     const datasets::LoadOptions& load,
                                                     const std::string& command, std::ostream& err) {
  datasets::DatasetLoadResult loaded = datasets::LoadDataset(dir, load);
  if (!loaded.Ok()) {
    err << "hdabench " << command << ": " << loaded.problems.size() << " problem(s) in " << dir
        << " (see hdabench dataset check):\n";
    for (const datasets::Problem& p : loaded.problems) err << "  " << p.ToString() << "\n";
    return std::nullopt;
  }
  return std::move(loaded.dataset);
}

}  // namespace hdabench::tools
