// `hdabench compare`: load a dataset, run the flight method and the reference
// methods on two of its frames, write the outputs (reference/compare_outputs.h,
// docs/compare-results.md) and print the Markdown table.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "calib/error.h"
#include "datasets/dataset.h"
#include "reference/compare.h"
#include "reference/compare_outputs.h"
#include "reference/flight_outputs.h"
#include "reference/flight_run.h"
#include "tools/command_support.h"
#include "tools/commands.h"
#include "tools/exit_codes.h"

namespace hdabench::tools {

int RunCompareCommand(const CompareCommandOptions& options, std::ostream& out, std::ostream& err) {
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << "hdabench compare: " << line << "\n";
  };
  reference::CompareOptions compare;
  try {
    compare.methods = reference::ParseMethodList(options.methods);
  } catch (const InputError& e) {
    err << "hdabench compare: --methods: " << e.what() << "\n";
    return kExitUsage;
  }
  if (options.site_size_m.has_value()) compare.hda.quadtree.site_size_m = *options.site_size_m;
  compare.hda.fault_match_noise_px = options.fault_match_noise_px;
  compare.colmap.executable = options.colmap_executable;
  compare.colmap.timeout_s = options.colmap_timeout_s;
  compare.colmap.use_all_frames = options.colmap_all_frames;
  compare.opengv_dense_features = options.opengv_dense;
  const std::vector<std::string> invalid = compare.Validate();
  if (!invalid.empty()) {
    err << "hdabench compare: unusable options:\n";
    for (const std::string& problem : invalid) err << "  " << problem << "\n";
    return kExitUsage;
  }

  const PairLoad pair = LoadDatasetPair(options.dataset_dir, options.frames, options.out_dir,
                                        "compare", err, progress);
  if (pair.exit_code != kExitOk) return pair.exit_code;
  const datasets::Dataset& dataset = *pair.dataset;
  const std::pair<int, int> frames = pair.frames;

  // The flight method runs on one core, as on the flight computer; the
  // reference methods are timed the same way.
  cv::setNumThreads(1);
  const std::string workspace = (std::filesystem::path(options.out_dir) / "colmap").string();
  reference::CompareRun run;
  try {
    run = reference::RunCompare(dataset, frames.first, frames.second, compare, workspace, progress);
  } catch (const InputError& e) {
    err << "hdabench compare: " << e.what() << "\n";
    return kExitInput;
  }

  progress("writing " + options.out_dir);
  std::vector<std::string> written;
  try {
    const auto& f1 = dataset.frames[static_cast<size_t>(frames.first)].image;
    const auto& f2 = dataset.frames[static_cast<size_t>(frames.second)].image;
    written = reference::WriteCompareOutputs(run, f1, f2, options.out_dir, options.figures);
  } catch (const InputError& e) {
    err << "hdabench compare: " << e.what() << "\n";
    return kExitInput;
  }
  out << reference::CompareMarkdown(run);
  out << "\nwrote " << written.size() << " files to " << options.out_dir
      << " (compare.json, compare.csv, compare.md, compare_timings.json, flight/"
      << (run.colmap_workspace.empty() ? "" : ", colmap/") << ")\n";
  int failed = 0;
  for (const reference::MethodSummary& s : run.summaries) {
    if (s.ok) continue;
    ++failed;
    err << "hdabench compare: method " << s.method << " failed: " << s.failure << "\n";
  }
  // The report never changes the exit code: a problem is a warning line.
  if (options.report) {
    WriteReportAfterCommand(options.out_dir, options.dataset_dir, "compare", options.quiet, out,
                            err);
  }
  return failed > 0 ? kExitExternal : kExitOk;
}

}  // namespace hdabench::tools
