#include "tools/cli/command_support.h"

#include <charconv>
#include <cstdint>
#include <filesystem>
#include <string_view>
#include <system_error>
#include <utility>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "tools/util/text.h"
#include "reference/flight/flight_outputs.h"
#include "reference/flight/flight_run.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace fs = std::filesystem;

std::vector<int> ParseIntList(const std::string& text, std::size_t count, const std::string& flag,
                              const std::string& form) {
  std::vector<int> values;
  // "1,2," has an empty third item, which is refused.
  for (const std::string_view item : util::SplitAtCommas(text)) {
    int value = 0;
    if (util::ParseInt(item, &value) != util::ParseStatus::kOk) {
      throw CLI::ValidationError(flag, "expected " + form + " (whole numbers), got '" + text + "'");
    }
    values.push_back(value);
  }
  if (values.size() != count) {
    throw CLI::ValidationError(flag, "expected " + form + ", got '" + text + "'");
  }
  return values;
}

std::vector<double> ParseNumberList(const std::string& text, std::size_t count, const std::string& flag,
                                    const std::string& form) {
  std::vector<double> values;
  for (const std::string_view item : util::SplitAtCommas(text)) {
    double value = 0.0;
    if (util::ParseDouble(item, &value) != util::ParseStatus::kOk) {
      throw CLI::ValidationError(flag, "expected " + form + " (numbers), got '" + text + "'");
    }
    values.push_back(value);
  }
  if (values.size() != count) {
    throw CLI::ValidationError(flag, "expected " + form + ", got '" + text + "'");
  }
  return values;
}

CLI::Validator NonNegativeWhole() {
  return CLI::Validator(
      [](std::string& text) -> std::string {
        int value = 0;
        if (util::ParseInt(text, &value) != util::ParseStatus::kOk || value < 0) {
          return "expected a whole number >= 0, got '" + text + "'";
        }
        return "";
      },
      "");
}

CLI::Option* AddSeedOption(CLI::App* app, std::uint64_t* seed, const std::string& help) {
  const CLI::Validator whole_number(
      [](std::string& text) -> std::string {
        std::uint64_t value = 0;
        const char* end = text.data() + text.size();
        const std::from_chars_result parsed = std::from_chars(text.data(), end, value);
        if (text.empty() || parsed.ec != std::errc() || parsed.ptr != end) {
          return "expected a whole number in [0, 18446744073709551615], got '" + text + "'";
        }
        return "";
      },
      "");
  return app->add_option("--seed", *seed, help)->check(whole_number)->capture_default_str();
}

bool ParseBoardSize(const std::string& text, int* width, int* height) {
  // Whole numbers that fit an int either side of the x: "4294967305x6" is
  // refused, not wrapped to 9 x 6.
  const size_t x = text.find_first_of("xX");
  int w = 0, h = 0;
  if (x == std::string::npos || util::ParseInt(std::string_view(text).substr(0, x), &w) != util::ParseStatus::kOk ||
      util::ParseInt(std::string_view(text).substr(x + 1), &h) != util::ParseStatus::kOk) {
    return false;
  }
  *width = w;
  *height = h;
  return true;
}

std::optional<std::pair<int, int>> ParseFramesFlag(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const std::vector<int> pair = ParseIntList(text, 2, "--frames", "i,j");
  return std::make_pair(pair[0], pair[1]);
}

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

namespace {

// `path` made absolute, with symbolic links, "." and ".." resolved as far as
// the folders exist (the rest lexically), without a trailing separator.
// Empty when the path is empty or cannot be made absolute.
fs::path Resolved(const std::string& path) {
  if (path.empty()) return {};
  std::error_code error;
  const fs::path absolute = fs::absolute(path, error);
  if (error) return {};
  fs::path resolved = fs::weakly_canonical(absolute, error);
  if (error) resolved = absolute.lexically_normal();
  if (!resolved.has_filename() && resolved.has_parent_path()) resolved = resolved.parent_path();
  return resolved;
}

// The file at the top of an output folder that says whose results it holds.
struct ResultSignature {
  const char* file;
  const char* what;
};
constexpr ResultSignature kResultSignatures[] = {
    {"manifest.json", "a dataset"},
    {"result.json", "the results of hdabench run"},
    {"compare.json", "the results of hdabench compare"},
    {"imagery.json", "the results of hdabench imagery pair"},
    {"study.json", "an observability study"},
    {"metrics.json", "the results of hdabench gate"},
    {"faults.json", "the results of hdabench faults"},
};

}  // namespace

std::string OtherCommandsResults(const std::string& out_dir, const std::string& own_file) {
  if (out_dir.empty()) return "";
  for (const ResultSignature& signature : kResultSignatures) {
    if (own_file == signature.file) continue;
    std::error_code ec;
    const fs::path file = fs::path(out_dir) / signature.file;
    if (fs::exists(file, ec)) return std::string(signature.what) + " (" + file.string() + ")";
  }
  return "";
}

int CheckOutputFolder(const std::string& out_dir, const std::string& dataset_dir, const std::string& own_file,
                      const std::string& prefix, std::ostream& err) {
  if (!dataset_dir.empty() && IsSameOrInsideFolder(out_dir, dataset_dir)) {
    err << prefix << "--out " << out_dir << ": is the dataset folder " << dataset_dir
        << " or inside it; the results would be written among the dataset's files: give a folder "
           "outside it\n";
    return kExitInput;
  }
  const std::string held = OtherCommandsResults(out_dir, own_file);
  if (!held.empty()) {
    err << prefix << "--out " << out_dir << ": holds " << held << "; give a new folder"
        << (own_file.empty() ? "" : ", or one holding this command's own results (" + own_file + ")") << "\n";
    return kExitInput;
  }
  return kExitOk;
}

NewFolders::NewFolders(const fs::path& path) : path_(path.lexically_normal()) {
  if (!path_.has_filename() && path_.has_parent_path()) path_ = path_.parent_path();  // "a/b/" is "a/b"
  std::error_code ec;
  for (fs::path p = path_; !p.empty() && !fs::exists(p, ec) && !ec; p = p.parent_path()) {
    top_ = p;
    if (p == p.parent_path()) break;
  }
}

void NewFolders::Remove() const {
  if (top_.empty()) return;
  std::error_code ec;
  for (fs::path p = path_;; p = p.parent_path()) {
    if (!fs::is_directory(p, ec) || !fs::is_empty(p, ec) || ec || !fs::remove(p, ec)) return;
    if (p == top_ || p == p.parent_path()) return;
  }
}

bool IsSameOrInsideFolder(const std::string& path, const std::string& folder) {
  const fs::path resolved_path = Resolved(path);
  const fs::path resolved_folder = Resolved(folder);
  if (resolved_path.empty() || resolved_folder.empty()) return false;
  const fs::path relative = resolved_path.lexically_relative(resolved_folder);
  return !relative.empty() && *relative.begin() != "..";
}

PairLoad LoadDatasetPair(const std::string& dataset_dir,
                         const std::optional<std::pair<int, int>>& frames,
                         const std::string& out_dir, const std::string& command,
                         std::ostream& err, const std::function<void(const std::string&)>& progress,
                         bool read_dem, const std::string& own_result_file, bool with_next_frame) {
  PairLoad result;
  const std::string prefix = "hdabench " + command + ": ";
  if (frames.has_value() && frames->first == frames->second) {
    err << prefix << "--frames " << frames->first << "," << frames->second
        << ": the two frames must differ\n";
    result.exit_code = kExitUsage;
    return result;
  }
  result.exit_code = CheckDatasetFolder(dataset_dir, command, err);
  if (result.exit_code != kExitOk) return result;
  result.exit_code = CheckOutputFolder(out_dir, dataset_dir, own_result_file, prefix, err);
  if (result.exit_code != kExitOk) return result;
  // The folders made here and still empty are removed again when the dataset
  // or its frames turn out unusable: a refused command leaves nothing behind.
  const NewFolders made_here(out_dir);
  try {
    reference::PrepareOutputFolder(out_dir);
  } catch (const InputError& e) {
    err << prefix << "--out " << e.what() << "\n";
    result.exit_code = kExitInput;
    return result;
  }
  progress("loading " + dataset_dir);
  datasets::LoadOptions load;
  load.keep_images = true;
  load.keep_truth = true;
  load.read_dem = read_dem;
  load.frames_used = [&frames, with_next_frame](const datasets::Dataset& tables) {
    const std::pair<int, int> pair = frames.has_value() ? *frames : reference::DefaultFramePair(tables);
    std::vector<int> used = {pair.first, pair.second};
    if (with_next_frame && pair.second + 1 < static_cast<int>(tables.frames.size())) {
      used.push_back(pair.second + 1);
    }
    return used;
  };
  result.dataset = LoadDatasetOrReport(dataset_dir, load, command, err);
  if (!result.dataset.has_value()) {
    made_here.Remove();
    result.exit_code = kExitInput;
    return result;
  }
  const int num_frames = static_cast<int>(result.dataset->frames.size());
  result.frames = frames.has_value() ? *frames : reference::DefaultFramePair(*result.dataset);
  for (const int frame : {result.frames.first, result.frames.second}) {
    if (frame < 0 || frame >= num_frames) {
      err << prefix << "--frames: frame " << frame << " is not in " << dataset_dir
          << ", which has frames 0.." << num_frames - 1 << "\n";
      result.dataset.reset();
      made_here.Remove();
      result.exit_code = kExitUsage;
      return result;
    }
  }
  return result;
}

int BuildHdaSettings(const std::string& params_file, const std::vector<HdaFlag>& flags,
                     const std::vector<std::string>& sets, const std::string& command,
                     std::ostream& err, reference::HdaSettings* settings) {
  const std::string prefix = "hdabench " + command + ": ";
  if (!params_file.empty()) {
    try {
      settings->ReadFile(params_file);
      settings->Validate(params_file);
    } catch (const InputError& e) {
      err << prefix << "--params: " << e.what() << "\n";
      return kExitInput;
    }
  }
  try {
    for (const HdaFlag& f : flags) settings->Set(f.key, f.value, f.flag);
    for (const std::string& set : sets) {
      const size_t equals = set.find('=');
      const std::string where = "--set " + set;
      if (set.rfind("hda.", 0) != 0 || equals == std::string::npos) {
        throw InputError(where + ": expected hda.KEY=VALUE");
      }
      settings->SetText(set.substr(4, equals - 4), set.substr(equals + 1), where);
    }
    settings->Validate("the command line");
  } catch (const InputError& e) {
    err << prefix << e.what() << "\n";
    return kExitUsage;
  }
  return kExitOk;
}

}  // namespace hdabench::tools
