// `hdabench run`: load a dataset, run the flight method on two of its frames,
// write the outputs (reference/flight/flight_outputs.h, docs/flight-results.md) and
// print the report.
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>

#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/text.h"
#include "datasets/dataset.h"
#include "hda/hda_options.h"
#include "hda/pipeline.h"
#include "reference/flight/calibration_check.h"
#include "reference/flight/flight_outputs.h"
#include "reference/flight/flight_run.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

int RunFlight(const RunFlightOptions& options, std::ostream& out, std::ostream& err) {
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << "hdabench run: " << line << "\n";
  };
  std::vector<HdaFlag> flags;
  if (options.flight_instructions_per_s) {
    flags.push_back({"--flight-rate", "flight_instructions_per_s", *options.flight_instructions_per_s});
  }
  if (options.budget_s) flags.push_back({"--budget-s", "compute_budget_s", *options.budget_s});
  if (options.site_size_m) flags.push_back({"--site-size-m", "quadtree.site_size_m", *options.site_size_m});
  reference::HdaSettings hda_settings;
  const int settings_code =
      BuildHdaSettings(options.params_file, flags, options.hda_sets, "run", err, &hda_settings);
  if (settings_code != kExitOk) return settings_code;

  const PairLoad pair = LoadDatasetPair(options.dataset_dir, options.frames, options.out_dir, "run",
                                        err, progress, /*read_dem=*/true, "result.json");
  if (pair.exit_code != kExitOk) return pair.exit_code;
  const datasets::Dataset& dataset = *pair.dataset;
  const std::pair<int, int> frames = pair.frames;

  progress("flight method on frames " + std::to_string(frames.first) + "," +
           std::to_string(frames.second));
  // The flight method runs on one core, as on the flight computer (OpenCV's
  // parallel loops would otherwise use every core; results do not change).
  cv::setNumThreads(1);
  reference::FlightRun run;
  if (const int code = WithExitCodes("hdabench run: ", err, [&] {
        run = reference::RunFlight(dataset, frames.first, frames.second, hda_settings, options.rois_px);
      });
      code != kExitOk) {
    return code;
  }
  for (const reference::DerivedParam& d : run.derived_options) {
    progress("from the geometry: " + d.key + " = " + util::ShortestText(d.value) + " (" + d.rule + ")");
  }

  progress("writing " + options.out_dir);
  std::vector<std::string> written;
  if (const int code = WithExitCodes("hdabench run: ", err, [&] {
        written = reference::WriteFlightOutputs(run, dataset.frames[static_cast<size_t>(frames.first)].image,
                                                dataset.frames[static_cast<size_t>(frames.second)].image,
                                                options.out_dir, options.figures);
      });
      code != kExitOk) {
    return code;
  }
  out << reference::FlightReport(run);
  out << "wrote " << written.size() << " files to " << options.out_dir
      << " (result.json, timings.json, rois.csv, points/"
      << (options.figures ? ", figures/" : "") << ")\n";
  // After the outputs: a check that cannot run loses nothing of the run. An
  // earlier run's check never stays beside this run's results.
  int check_code = kExitOk;
  const std::filesystem::path check_path = std::filesystem::path(options.out_dir) / "calibration_check.json";
  std::error_code removed;
  std::filesystem::remove(check_path, removed);
  if (options.calibration_check_samples > 0 && !run.calibration.available) {
    err << "hdabench run: --calibration-check: no calibration term to check: " << run.calibration.why << "\n";
    check_code = kExitInput;
  } else if (options.calibration_check_samples > 0) {
    progress("calibration check: " + std::to_string(options.calibration_check_samples) +
             " re-solves of " + run.calibration.model_file);
    check_code = WithExitCodes("hdabench run: --calibration-check: ", err, [&] {
      const reference::CalibrationCheck check = reference::CheckCalibrationTerm(
          dataset, run, options.calibration_check_samples, options.calibration_check_seed,
          [&](int done, int samples) {
            progress("calibration check: re-solve " + std::to_string(done) + " of " + std::to_string(samples));
          });
      util::WriteFileAtomically(check_path, reference::CalibrationCheckJson(check));
      out << reference::CalibrationCheckLine(check) << "\n";
    });
  }
  // The report never changes the exit code: a problem is a warning line.
  if (options.report) {
    WriteReportAfterCommand(options.out_dir, options.dataset_dir, "run", options.quiet, out, err);
  }
  return check_code;
}

namespace {

// What `run` parses into: its options, and the flags that only set them when
// given (the HdaOptions defaults are shown in --help).
struct RunArgs {
  RunFlightOptions options;
  std::string frames_text;
  std::vector<std::string> rois_text;
  double flight_instructions_per_s = hda::HdaOptions().flight_instructions_per_s;
  double budget_s = hda::HdaOptions().compute_budget_s;
  double site_size_m = hda::HdaOptions().quadtree.site_size_m;
  bool no_figures = false;
  bool no_report = false;
  CLI::Option* rate_option = nullptr;
  CLI::Option* budget_option = nullptr;
  CLI::Option* site_option = nullptr;
};

// Completes the options of `run` from what was parsed into `args`, then runs it.
int RunParsedFlight(RunArgs& args) {
  args.options.frames = ParseFramesFlag(args.frames_text);
  for (const std::string& text : args.rois_text) {
    const std::vector<int> v = ParseIntList(text, 4, "--roi", "X,Y,WIDTH,HEIGHT");
    args.options.rois_px.emplace_back(v[0], v[1], v[2], v[3]);
  }
  if (args.rate_option->count() > 0) args.options.flight_instructions_per_s = args.flight_instructions_per_s;
  if (args.budget_option->count() > 0) args.options.budget_s = args.budget_s;
  if (args.site_option->count() > 0) args.options.site_size_m = args.site_size_m;
  args.options.figures = !args.no_figures;
  args.options.report = !args.no_report;
  return RunFlight(args.options, std::cout, std::cerr);
}

}  // namespace

// run: DATASET, --frames, --out, the flight method's options and the outputs.
Command AddRunCommand(CLI::App& app) {
  const auto args = std::make_shared<RunArgs>();
  CLI::App* run = app.add_subcommand(
      "run",
      "Run the flight HDA method on two frames of a dataset: results, figures, per-ROI table");
  run->add_option("DATASET", args->options.dataset_dir, "Dataset folder")->required();
  run->add_option(
      "--frames", args->frames_text,
      "Two different frame indices i,j (default: frame 0 and the frame whose baseline is\n"
      "closest to the paper's 30 m at 566 m)");
  run->add_option("--out", args->options.out_dir,
                  "Output folder (created if missing; files replaced)")
      ->required();
  args->rate_option =
      run->add_option("--flight-rate", args->flight_instructions_per_s,
                      "The flight computer's speed, in this machine's (x86-64) instructions per\n"
                      "second; the budget counts the method's work, never a clock")
          ->capture_default_str();
  args->budget_option =
      run->add_option("--budget-s", args->budget_s,
                      "Computation budget on the flight computer, seconds (the work predicted to\n"
                      "take longer is not evaluated)")
          ->capture_default_str();
  args->site_option =
      run->add_option("--site-size-m", args->site_size_m,
                      "Side of a landing site, metres (sets the quadtree's smallest ROI; default:\n"
                      "the lander's 10 m, scaled when its image is under one ORB patch or over a\n"
                      "quarter of the image)");
  run->add_option("--roi", args->rois_text,
                  "An ROI given in image 1's pixels, X,Y,WIDTH,HEIGHT (top-left pixel, size;\n"
                  "repeatable): the quadtree is not run (a test target, a surveyed site; hdabench\n"
                  "ingest target prints the board's box)")
      ->allow_extra_args(false);
  run->add_option("--params", args->options.params_file, kParamsHelp);
  run->add_option("--set", args->options.hda_sets, kSetHelp)->allow_extra_args(false);
  run->add_option("--calibration-check", args->options.calibration_check_samples,
                  "Re-solve the dataset's calibration (a .cameramodel with mrcal's\n"
                  "optimization_inputs) N times, run the method with each re-solved model and\n"
                  "write calibration_check.json: each ROI's slope spread beside its predicted\n"
                  "calibration sigma (0: no check)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  run->add_option("--calibration-seed", args->options.calibration_check_seed,
                  "Seed of the corner noise of --calibration-check's re-solves")
      ->capture_default_str();
  run->add_flag("--no-figures", args->no_figures, "Do not write figures/");
  run->add_flag("--no-report", args->no_report, "Do not write report.html and report.md");
  run->add_flag("--quiet", args->options.quiet, "No progress lines");
  return {run, [args] { return RunParsedFlight(*args); }};
}

}  // namespace hdabench::tools
