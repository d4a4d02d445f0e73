// Helpers shared by the hdabench commands: the same messages and exit codes
// everywhere.
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <ostream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "datasets/dataset.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/error.h"
#include "reference/flight/hda_params.h"

namespace CLI {
class App;
class Option;
class Validator;
}  // namespace CLI

namespace hdabench::tools {

// Adds --seed to `app`: a whole number in [0, 2^64 - 1], digits only, its
// default shown. (CLI11 alone takes "-1" and "99999999999999999999999" as
// 2^64 - 1, a different scene without a word.)
CLI::Option* AddSeedOption(CLI::App* app, std::uint64_t* seed, const std::string& help);

// A check for an int flag whose 0 means "the default" (--threads,
// --image-size): a whole number >= 0 that fits an int, where CLI11 alone
// took -5 and quietly meant the default.
CLI::Validator NonNegativeWhole();

// Parses a flag's text "a,b,..." into exactly `count` integers; otherwise throws
// CLI::ValidationError (exit code 2) naming `flag` and the expected `form`.
std::vector<int> ParseIntList(const std::string& text, std::size_t count, const std::string& flag,
                              const std::string& form);

// The same for numbers "a,b,..." (finite decimals).
std::vector<double> ParseNumberList(const std::string& text, std::size_t count, const std::string& flag,
                                    const std::string& form);

// The --frames flag's "i,j" as a pair (ParseIntList); nothing when `text` is
// empty, i.e. the flag was not given.
std::optional<std::pair<int, int>> ParseFramesFlag(const std::string& text);

// Runs `work`, mapping the library's errors to exit codes with one line on
// err (prefixed by `command`): InputError and UnsupportedError 3 (kExitInput),
// ExternalError 4 (kExitExternal); otherwise what `work` returns (0 when it
// returns nothing).
template <typename Work>
int WithExitCodes(const std::string& command, std::ostream& err, Work work) {
  try {
    if constexpr (std::is_void_v<decltype(work())>) {
      work();
      return kExitOk;
    } else {
      return work();
    }
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  } catch (const UnsupportedError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  } catch (const ExternalError& e) {
    err << command << e.what() << "\n";
    return kExitExternal;
  }
}

// A board's "WxH" inner corners ("9x6" -> 9, 6); false when the text is not
// two whole numbers joined by 'x' or 'X'.
bool ParseBoardSize(const std::string& text, int* width, int* height);

// kExitOk when `dir` is a folder; otherwise prints "hdabench <command>: <dir>:
// no such folder" (or "is not a folder") to err and returns kExitInput.
int CheckDatasetFolder(const std::string& dir, const std::string& command, std::ostream& err);

// Loads the dataset in `dir`. On problems prints "hdabench <command>: N
// problem(s) in DIR (see hdabench dataset check):" and each problem to err and
// returns nothing: the command then exits with kExitInput.
std::optional<datasets::Dataset> LoadDatasetOrReport(const std::string& dir,
                                                     const datasets::LoadOptions& load,
                                                     const std::string& command, std::ostream& err);

// The folders that making `path` (with its missing parents) is about to
// create, noted before they are made, so that a command refused before it
// writes anything can remove them again: Remove() removes those still empty,
// deepest first, and never a folder that existed before.
class NewFolders {
 public:
  explicit NewFolders(const std::filesystem::path& path);
  void Remove() const;

 private:
  std::filesystem::path path_;
  std::filesystem::path top_;  // the highest folder that did not exist; empty when `path` existed
};

// Whether `path` is `folder` or lies inside it, both resolved first (made
// absolute; symbolic links, "." and ".." followed as far as the folders
// exist). A sibling whose name starts with the folder's is not inside it; an
// empty path (a command without an output folder) is inside nothing.
bool IsSameOrInsideFolder(const std::string& path, const std::string& folder);

// Whether `out_dir` may take a command's results: not `dataset_dir` (when
// given) nor inside it, and holding no dataset or other command's results
// (OtherCommandsResults; `own_file` marks the command's own, which a rerun
// replaces). kExitOk when it may; otherwise one line after `prefix`
// ("hdabench run: ") says why, and kExitInput.
int CheckOutputFolder(const std::string& out_dir, const std::string& dataset_dir, const std::string& own_file,
                      const std::string& prefix, std::ostream& err);

// What an output folder already holds of another command's results: "a
// dataset (DIR/manifest.json)", "the results of hdabench compare
// (DIR/compare.json)", ...: the first of the files that mark a dataset or a
// command's results (manifest.json, result.json, compare.json, imagery.json,
// study.json, metrics.json, faults.json) at its top, but `own_file`, the mark of the
// command's own results. Empty when it holds none, or out_dir is empty.
std::string OtherCommandsResults(const std::string& out_dir, const std::string& own_file);

// A dataset loaded with its images and truth, and the frame pair to use.
struct PairLoad {
  int exit_code = 0;  // kExitOk, or the code the command exits with (the message is printed)
  std::optional<datasets::Dataset> dataset;
  std::pair<int, int> frames{0, 1};
};

// What `run` and `compare` do before their work: checks that the frames (when
// given) differ, the dataset folder exists and the output folder (when given)
// is neither it nor inside it and holds no other command's results
// (OtherCommandsResults with own_result_file; nothing is written then),
// prepares the output folder,
// loads the dataset and takes the given frames (checked against the dataset)
// or reference::DefaultFramePair. Only the pair's images and truth points are
// read whole (datasets::LoadOptions::frames_used; the other frames' files are
// checked as files), and the DEM's heights only with `read_dem`;
// `with_next_frame` reads the frame after image 2 whole too (the frame that
// takes image 2's place when it is dropped). Prints "hdabench <command>: ..."
// on a problem: equal or missing frames exit kExitUsage, an unusable dataset
// or output folder kExitInput.
PairLoad LoadDatasetPair(const std::string& dataset_dir,
                         const std::optional<std::pair<int, int>>& frames,
                         const std::string& out_dir, const std::string& command,
                         std::ostream& err, const std::function<void(const std::string&)>& progress,
                         bool read_dem, const std::string& own_result_file, bool with_next_frame = false);

// The flight method's parameters of `run` and `compare`: the --params file
// (when not empty, its values checked), then the command's own flags that
// were given, then every --set in order ("hda.KEY=VALUE"), each over the
// ones before; then HdaOptions::Validate. On a problem prints
// "hdabench <command>: ..." and returns kExitInput (an unreadable or invalid
// --params file) or kExitUsage (a bad --set or flag value); kExitOk otherwise.
struct HdaFlag {
  std::string flag;  // "--site-size-m"
  std::string key;   // "quadtree.site_size_m"
  double value = 0.0;
};
int BuildHdaSettings(const std::string& params_file, const std::vector<HdaFlag>& flags,
                     const std::vector<std::string>& sets, const std::string& command,
                     std::ostream& err, reference::HdaSettings* settings);

// The help text of --params and --set.
inline constexpr char kParamsHelp[] =
    "JSON file of the flight method's parameters (docs/flight-parameters.md; presets in\n"
    "params/): {\"quadtree\": {\"site_size_m\": 40}, \"max_relief_m\": 5, ...}";
inline constexpr char kSetHelp[] =
    "One flight-method parameter, over --params and the other flags: hda.KEY=VALUE\n"
    "(hda.max_relief_m=5, hda.quadtree.site_size_m=40; repeatable). The lengths not\n"
    "given follow the LRF range and the baseline (docs/flight-parameters.md)";

}  // namespace hdabench::tools
