// `hdabench run`: load a dataset, run the flight method on two of its frames,
// write the outputs (reference/flight_outputs.h, docs/flight-results.md) and
// print the report.
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core/utility.hpp>

#include "calib/error.h"
#include "datasets/dataset.h"
#include "hda/pipeline.h"
#include "reference/flight_outputs.h"
#include "reference/flight_run.h"
#include "tools/command_support.h"
#include "tools/commands.h"
#include "tools/exit_codes.h"

namespace hdabench::tools {

int RunFlight(const RunFlightOptions& options, std::ostream& out, std::ostream& err) {
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << "hdabench run: " << line << "\n";
  };
  hda::HdaOptions hda_options;
  if (options.processor_scale.has_value()) hda_options.processor_scale = *options.processor_scale;
  if (options.budget_s.has_value()) hda_options.compute_budget_s = *options.budget_s;
  if (options.site_size_m.has_value()) hda_options.quadtree.site_size_m = *options.site_size_m;
  const std::vector<std::string> invalid = hda_options.Validate();
  if (!invalid.empty()) {
    err << "hdabench run: unusable options (--processor-scale, --budget-s, --site-size-m):\n";
    for (const std::string& problem : invalid) err << "  " << problem << "\n";
    return kExitUsage;
  }

  const PairLoad pair = LoadDatasetPair(options.dataset_dir, options.frames, options.out_dir, "run",
                                        err, progress);
  if (pair.exit_code != kExitOk) return pair.exit_code;
  const datasets::Dataset& dataset = *pair.dataset;
  const std::pair<int, int> frames = pair.frames;

  progress("flight method on frames " + std::to_string(frames.first) + "," +
           std::to_string(frames.second));
  // The flight method runs on one core, as on the flight computer (OpenCV's
  // parallel loops would otherwise use every core; results do not change).
  cv::setNumThreads(1);
  const reference::FlightRun run =
      reference::RunFlight(dataset, frames.first, frames.second, hda_options);

  progress("writing " + options.out_dir);
  std::vector<std::string> written;
  try {
    written = reference::WriteFlightOutputs(run, dataset.frames[static_cast<size_t>(frames.first)].image,
                                            dataset.frames[static_cast<size_t>(frames.second)].image,
                                            options.out_dir,
                                            options.figures);
  } catch (const InputError& e) {
    err << "hdabench run: " << e.what() << "\n";
    return kExitInput;
  }
  out << reference::FlightReport(run);
  out << "wrote " << written.size() << " files to " << options.out_dir
      << " (result.json, timings.json, rois.csv, points/"
      << (options.figures ? ", figures/" : "") << ")\n";
  // The report never changes the exit code: a problem is a warning line.
  if (options.report) {
    WriteReportAfterCommand(options.out_dir, options.dataset_dir, "run", options.quiet, out, err);
  }
  return kExitOk;
}

}  // namespace hdabench::tools
