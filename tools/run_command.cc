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
  if (options.frames.has_value() && options.frames->first == options.frames->second) {
    err << "hdabench run: --frames " << options.frames->first << "," << options.frames->second
        << ": the two frames must differ\n";
    return kExitUsage;
  }
  hda::HdaOptions hda_options;
  if (options.processor_scale.has_value()) hda_options.processor_scale = *options.processor_scale;
  if (options.budget_s.has_value()) hda_options.compute_budget_s = *options.budget_s;
  const std::vector<std::string> invalid = hda_options.Validate();
  if (!invalid.empty()) {
    err << "hdabench run: unusable options (--processor-scale, --budget-s):\n";
    for (const std::string& problem : invalid) err << "  " << problem << "\n";
    return kExitUsage;
  }

  const int folder = CheckDatasetFolder(options.dataset_dir, "run", err);
  if (folder != kExitOk) return folder;
  try {
    reference::PrepareOutputFolder(options.out_dir);
  } catch (const InputError& e) {
    err << "hdabench run: --out " << e.what() << "\n";
    return kExitInput;
  }

  progress("loading " + options.dataset_dir);
  datasets::LoadOptions load;
  load.keep_images = true;
  load.keep_truth = true;
  const std::optional<datasets::Dataset> loaded =
      LoadDatasetOrReport(options.dataset_dir, load, "run", err);
  if (!loaded.has_value()) return kExitInput;
  const datasets::Dataset& dataset = *loaded;
  const int num_frames = static_cast<int>(dataset.frames.size());
  const std::pair<int, int> frames =
      options.frames.has_value() ? *options.frames : reference::DefaultFramePair(dataset);
  for (const int frame : {frames.first, frames.second}) {
    if (frame < 0 || frame >= num_frames) {
      err << "hdabench run: --frames: frame " << frame << " is not in " << options.dataset_dir
          << ", which has frames 0.." << num_frames - 1 << "\n";
      return kExitUsage;
    }
  }

  progress("flight method on frames " + std::to_string(frames.first) + "," +
           std::to_string(frames.second));
  const hda::HdaInput input = reference::MakeHdaInput(dataset, frames.first, frames.second);
  reference::FlightRun run;
  run.dataset_name = dataset.name;
  run.frame1 = frames.first;
  run.frame2 = frames.second;
  run.lens_model = dataset.camera.LensModelName();
  run.image_width_px = dataset.camera.WidthPx();
  run.image_height_px = dataset.camera.HeightPx();
  run.baseline_m = dataset.BaselineM(frames.first, frames.second);
  run.lrf_range_m = input.lrf_range_m;
  run.options = hda_options;
  // The flight method runs on one core, as on the flight computer (OpenCV's
  // parallel loops would otherwise use every core; results do not change).
  cv::setNumThreads(1);
  run.result = hda::RunHda(input, dataset.camera, hda_options);
  run.truths = reference::TruthOfRois(dataset, frames.first, run.result);

  progress("writing " + options.out_dir);
  std::vector<std::string> written;
  try {
    written = reference::WriteFlightOutputs(run, input.image1, input.image2, options.out_dir,
                                            options.figures);
  } catch (const InputError& e) {
    err << "hdabench run: " << e.what() << "\n";
    return kExitInput;
  }
  out << reference::FlightReport(run);
  out << "wrote " << written.size() << " files to " << options.out_dir
      << " (result.json, timings.json, rois.csv, points/"
      << (options.figures ? ", figures/" : "") << ")\n";
  return kExitOk;
}

}  // namespace hdabench::tools
