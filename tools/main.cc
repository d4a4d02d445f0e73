// hdabench: the bench's single binary. This file only parses the command line
// (CLI11 is included here and nowhere else) and maps errors to exit codes; the
// subcommands live in commands.h and the work in the modules.
#include <exception>
#include <iostream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "calib/error.h"
#include "hda/hda_options.h"
#include "tools/commands.h"
#include "tools/exit_codes.h"
#include "tools/version.h"

namespace hdabench::tools {
namespace {

// Parses "a,b,..." into exactly `count` integers; a CLI::ValidationError
// (exit code 2) names the flag and the expected form otherwise.
std::vector<int> ParseIntList(const std::string& text, size_t count, const std::string& flag,
                              const std::string& form) {
  std::vector<int> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    size_t used = 0;
    int value = 0;
    try {
      value = std::stoi(item, &used);
    } catch (const std::logic_error&) {
      used = std::string::npos;
    }
    if (used != item.size()) {
      throw CLI::ValidationError(flag, "expected " + form + " (whole numbers), got '" + text + "'");
    }
    values.push_back(value);
  }
  if (values.size() != count) {
    throw CLI::ValidationError(flag, "expected " + form + ", got '" + text + "'");
  }
  return values;
}

int Main(int argc, char** argv) {
  CLI::App app{"hdabench: test bench for the NOVA-C hazard detection and avoidance method.\n"
               "Exit codes: 0 ok, 1 checks failed, 2 bad command line, 3 unusable input,\n"
               "4 an external program failed, 70 internal error.",
               "hdabench"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kVersionString);

  CLI::App* version = app.add_subcommand("version", "Print the version and the libraries in use");

  CLI::App* dataset = app.add_subcommand("dataset", "Create and check datasets (docs/dataset-format.md)");
  dataset->require_subcommand(1);
  DatasetCheckOptions check_options;
  std::string frames_text;
  CLI::App* check = dataset->add_subcommand(
      "check", "Validate a dataset: print a summary, or every problem (exit 1)");
  check->add_option("DIR", check_options.dataset_dir, "Dataset folder (holds manifest.json)")->required();
  check->add_option("--frames", frames_text, "Two frame indices i,j for the baseline line (default: first,last)");

  DatasetCreateOptions create_options;
  CLI::App* create = dataset->add_subcommand(
      "create", "Write the built-in small example dataset (deterministic for a seed)");
  create->add_option("DIR", create_options.out_dir, "Folder to create (must not exist, or be empty)")->required();
  create->add_option("--seed", create_options.seed, "Random seed")->capture_default_str();

  SynthCommandOptions synth_options;
  CLI::App* synth = app.add_subcommand(
      "synth", "Generate a synthetic lunar dataset with ground truth (docs/synthetic-scenes.md)");
  synth->add_option("--out", synth_options.out_dir, "Folder to create (must not exist, or be empty)")->required();
  synth->add_option("--preset", synth_options.preset,
                    "novac-lateral, novac-boresight, truck or aircraft")->capture_default_str();
  synth->add_option("--terrain", synth_options.terrain, "mare, cratered or rocky (default: the preset's)");
  synth->add_option("--seed", synth_options.seed, "Random seed: same seed, same bytes")->capture_default_str();
  synth->add_option("--threads", synth_options.threads, "Worker threads (0: all cores); output does not depend on it")
      ->capture_default_str();
  synth->add_option("--image-size", synth_options.image_size_px, "Square imager side in pixels (default 1024; 2048 variant)");
  synth->add_option("--camera-model", synth_options.camera_model_file, "A .cameramodel to use instead of the default camera");
  synth->add_option("--set", synth_options.overrides,
                    "Override any parameter: key=value (e.g. render.sun_elevation_deg=15, terrain.rock_k=0.01)");
  synth->add_flag("--quiet", synth_options.quiet, "No progress lines");

  TruthCommandOptions truth_options;
  std::string roi_text;
  CLI::App* truth = app.add_subcommand(
      "truth", "True slope, roughness and hazard height of an ROI of a dataset with truth");
  truth->add_option("DATASET", truth_options.dataset_dir, "Dataset folder")->required();
  truth->add_option("--frame", truth_options.frame, "Frame index")->capture_default_str();
  truth->add_option("--roi", roi_text, "x,y,w,h in pixels")->required();
  truth->add_flag("--json", truth_options.json, "Print JSON instead of a table");

  RunFlightOptions run_options;
  std::string run_frames_text;
  double processor_scale = hda::HdaOptions().processor_scale;
  double budget_s = hda::HdaOptions().compute_budget_s;
  bool no_figures = false;
  CLI::App* run = app.add_subcommand(
      "run", "Run the flight HDA method on two frames of a dataset: results, figures, per-ROI table");
  run->add_option("DATASET", run_options.dataset_dir, "Dataset folder")->required();
  run->add_option("--frames", run_frames_text,
                  "Two different frame indices i,j (default: frame 0 and the frame whose baseline is\n"
                  "closest to the paper's 30 m at 566 m)");
  run->add_option("--out", run_options.out_dir, "Output folder (created if missing; files replaced)")
      ->required();
  CLI::Option* scale_option =
      run->add_option("--processor-scale", processor_scale,
                      "This machine's seconds per second of the flight computer's work")
          ->capture_default_str();
  CLI::Option* budget_option =
      run->add_option("--budget-s", budget_s, "Computation budget on the flight computer, seconds")
          ->capture_default_str();
  double run_site_size_m = hda::HdaOptions().quadtree.site_size_m;
  CLI::Option* run_site_option =
      run->add_option("--site-size-m", run_site_size_m,
                      "Side of a landing site, metres (sets the quadtree's smallest ROI)")
          ->capture_default_str();
  run->add_flag("--no-figures", no_figures, "Do not write figures/");
  bool run_no_report = false;
  run->add_flag("--no-report", run_no_report, "Do not write report.html and report.md");
  run->add_flag("--quiet", run_options.quiet, "No progress lines");

  CompareCommandOptions compare_options;
  std::string compare_frames_text;
  bool compare_no_figures = false;
  CLI::App* compare = app.add_subcommand(
      "compare",
      "Compare the flight method with COLMAP, OpenGV, Ceres and the truth per ROI on two frames");
  compare->add_option("DATASET", compare_options.dataset_dir, "Dataset folder")->required();
  compare->add_option("--frames", compare_frames_text,
                      "Two different frame indices i,j (default: as hdabench run)");
  compare->add_option("--methods", compare_options.methods,
                      "Comma-separated methods, or all: flight, flight-refined, colmap-nav,\n"
                      "colmap-free, opengv-stewenius, opengv-nister, opengv-eight-point,\n"
                      "opengv-eigensolver, opengv-two-point (flight always runs)")
      ->capture_default_str();
  compare->add_option("--out", compare_options.out_dir,
                      "Output folder (created if missing; files replaced)")
      ->required();
  double compare_site_size_m = hda::HdaOptions().quadtree.site_size_m;
  CLI::Option* site_option =
      compare->add_option("--site-size-m", compare_site_size_m,
                          "Side of a landing site, metres (sets the quadtree's smallest ROI)")
          ->capture_default_str();
  compare->add_option("--colmap", compare_options.colmap_executable,
                      "The colmap program: a name on PATH or a path")
      ->capture_default_str();
  compare->add_option("--colmap-timeout-s", compare_options.colmap_timeout_s,
                      "Time limit of each COLMAP step, seconds")
      ->capture_default_str();
  compare->add_flag("--colmap-all-frames", compare_options.colmap_all_frames,
                    "colmap-free on every frame of the collection window, not only the pair");
  compare->add_option("--fault-match-noise-px", compare_options.fault_match_noise_px,
                      "Fault injection for testing the gate: Gaussian noise added to the flight\n"
                      "method's image-2 matches, pixels per axis (0: none)")
      ->capture_default_str();
  compare->add_flag("--opengv-dense", compare_options.opengv_dense,
                    "OpenGV on denser ORB matches (2000 keypoints per ROI, FAST threshold 5)\n"
                    "instead of the flight matcher's");
  compare->add_flag("--no-figures", compare_no_figures, "Do not write flight/figures/");
  bool compare_no_report = false;
  compare->add_flag("--no-report", compare_no_report, "Do not write report.html and report.md");
  compare->add_flag("--quiet", compare_options.quiet, "No progress lines");

  ReportCommandOptions report_options;
  CLI::App* report = app.add_subcommand(
      "report", "The HTML report (report.html, every figure embedded) and report.md of a run or\n"
                "compare folder (docs/report.md)");
  report->add_option("RUN_DIR", report_options.run_dir,
                     "Folder written by hdabench run or hdabench compare")
      ->required();
  report->add_option("--dataset", report_options.dataset_dir,
                     "The dataset folder, for its maps (default: looked for beside RUN_DIR)");
  report->add_option("--python", report_options.python,
                     "Python interpreter with matplotlib that draws the plots")
      ->capture_default_str();
  report->add_flag("--quiet", report_options.quiet, "No note lines");

  GateCommandOptions gate_options;
  CLI::App* gate = app.add_subcommand(
      "gate", "Merge gate: a suite of datasets through the comparison, metrics against thresholds");
  gate->add_option("--suite", gate_options.suite_file, "Suite file (docs/gate.md)")->required();
  gate->add_option("--thresholds", gate_options.thresholds_file, "Thresholds file (docs/gate.md)")
      ->required();
  gate->add_option("--baseline", gate_options.baseline_file,
                   "Metrics of main (metrics.json of an earlier gate): fail on a regression");
  gate->add_option("--write-baseline", gate_options.write_baseline_file,
                   "Write this run's metrics to this file, as a new baseline");
  gate->add_option("--out", gate_options.out_dir,
                   "Output folder; a rerun into it resumes, reusing complete entries")
      ->required();
  gate->add_option("--jobs", gate_options.jobs, "Suite entries run at once")->capture_default_str();
  gate->add_option("--colmap", gate_options.colmap_executable,
                   "The colmap program: a name on PATH or a path")
      ->capture_default_str();
  gate->add_option("--fault-match-noise-px", gate_options.fault_match_noise_px,
                   "Fault injection for testing the gate: noise on the flight method's matches, px")
      ->capture_default_str();
  gate->add_flag("--quiet", gate_options.quiet, "No progress lines");

  CLI::App* ingest = app.add_subcommand("ingest", "Convert outside data into a dataset");
  ingest->require_subcommand(1);
  IngestStereoLunarOptions stereolunar_options;
  CLI::App* stereolunar = ingest->add_subcommand(
      "stereolunar",
      "Convert one sun position of a StereoLunar nadir pair (docs/stereolunar.md) into a dataset");
  stereolunar->add_option("PAIR_DIR", stereolunar_options.pair_dir,
                          "Pair folder (im_NNNNN.jpg and .exr)")
      ->required();
  stereolunar->add_option("--out", stereolunar_options.out_dir,
                          "Folder to create (must not exist, or be empty)")
      ->required();
  stereolunar->add_option("--sun", stereolunar_options.sun, "Sun position, 0-based (0, 1 or 2)")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  stereolunar->add_option("--cameras", stereolunar_options.cameras_file,
                          "cameras.txt (default: PAIR_DIR/cameras.txt, else PAIR_DIR/../cameras.txt)");

  CalibrateCommandOptions calibrate_options;
  CLI::App* calibrate = app.add_subcommand(
      "calibrate",
      "Calibrate a camera (or a pair) from chessboard images with mrcal, and judge the result\n"
      "(docs/calibration.md)");
  calibrate->add_option("IMAGES", calibrate_options.images, "Chessboard images of the camera")
      ->required();
  calibrate->add_option("--pair", calibrate_options.pair_images,
                        "Images of a second camera calibrated together with the first: one per "
                        "image, in the same order");
  calibrate->add_option("--board", calibrate_options.board,
                        "Inner corners per row x rows, e.g. 9x6 (OpenCV's patternSize)")
      ->required();
  calibrate->add_option("--spacing", calibrate_options.spacing,
                        "Distance between neighbouring corners (metres, or 1 for squares)")
      ->required();
  calibrate->add_option("--lensmodel", calibrate_options.lensmodel,
                        "mrcal lens model, e.g. LENSMODEL_OPENCV8 or\n"
                        "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100")
      ->capture_default_str();
  calibrate->add_option("--detector", calibrate_options.detector,
                        "Corner detector: auto (mrgingham for square boards, else OpenCV), opencv, "
                        "mrgingham")
      ->capture_default_str();
  calibrate->add_option("--focal-px", calibrate_options.focal_px,
                        "Focal-length seed for mrcal in pixels (0: estimated from the corners)")
      ->capture_default_str();
  calibrate->add_option("--min-views", calibrate_options.min_views,
                        "Fewest images with the whole board, per camera")
      ->capture_default_str();
  calibrate->add_option("--out", calibrate_options.out_dir,
                        "Folder to create (must not exist, or be empty)")
      ->required();
  calibrate->add_option("--hda-range-m", calibrate_options.hda_range_m,
                        "HDA geometry of the slope-error figure: range to the site, m")
      ->capture_default_str();
  calibrate->add_option("--hda-baseline-m", calibrate_options.hda_baseline_m,
                        "HDA geometry: baseline between the two images, m")
      ->capture_default_str();
  calibrate->add_option("--hda-site-m", calibrate_options.hda_site_m,
                        "HDA geometry: landing-site side, m")
      ->capture_default_str();
  calibrate->add_option("--slope-samples", calibrate_options.slope_samples,
                        "Monte Carlo re-solves behind the slope-error figure")
      ->capture_default_str();
  calibrate->add_option("--seed", calibrate_options.seed, "Random seed of the Monte Carlo noise")
      ->capture_default_str();
  calibrate->add_flag("--quiet", calibrate_options.quiet, "No progress lines");

  CalibDiffCommandOptions calib_diff_options;
  CLI::App* calib_diff = app.add_subcommand(
      "calib-diff", "Projection difference between two calibrations of one camera (median, max, "
                    "heat map)");
  calib_diff->add_option("A", calib_diff_options.model_a, "The reference .cameramodel (e.g. the last one)")
      ->required();
  calib_diff->add_option("B", calib_diff_options.model_b, "The .cameramodel to compare with it")
      ->required();
  calib_diff->add_option("--out", calib_diff_options.out_dir,
                         "Folder for calib-diff.json and calib-diff.png (created if missing)")
      ->required();
  calib_diff->add_option("--gridn", calib_diff_options.gridn,
                         "Grid points across the imager's width")
      ->capture_default_str();
  calib_diff->add_flag("--with-uncertainty", calib_diff_options.with_uncertainty,
                       "Also A's projection uncertainty on the grid, and how much of the "
                       "difference it covers (A must come from a calibration)");

  DemoOptions demo_options;
  CLI::App* demo = app.add_subcommand(
      "demo",
      "The main job on the built-in default: generate the default synthetic dataset and compare\n"
      "every method on it");
  demo->add_option("--out", demo_options.out_dir, "Output folder (replaced on each run)")->capture_default_str();
  demo->add_option("--seed", demo_options.seed, "Random seed")->capture_default_str();
  demo->add_option("--image-size", demo_options.image_size_px, "Square imager side in pixels (default 1024)");
  demo->add_option("--threads", demo_options.threads, "Worker threads (0: all cores)")->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }

  if (version->parsed()) {
    std::cout << VersionReport();
    return kExitOk;
  }
  if (check->parsed()) {
    if (!frames_text.empty()) {
      const std::vector<int> pair = ParseIntList(frames_text, 2, "--frames", "i,j");
      check_options.frames = std::make_pair(pair[0], pair[1]);
    }
    return RunDatasetCheck(check_options, std::cout, std::cerr);
  }
  if (report->parsed()) return RunReportCommand(report_options, std::cout, std::cerr);
  if (gate->parsed()) return RunGateCommand(gate_options, std::cout, std::cerr);
  if (compare->parsed()) {
    if (!compare_frames_text.empty()) {
      const std::vector<int> pair = ParseIntList(compare_frames_text, 2, "--frames", "i,j");
      compare_options.frames = std::make_pair(pair[0], pair[1]);
    }
    compare_options.figures = !compare_no_figures;
    compare_options.report = !compare_no_report;
    if (site_option->count() > 0) compare_options.site_size_m = compare_site_size_m;
    return RunCompareCommand(compare_options, std::cout, std::cerr);
  }
  if (run->parsed()) {
    if (!run_frames_text.empty()) {
      const std::vector<int> pair = ParseIntList(run_frames_text, 2, "--frames", "i,j");
      run_options.frames = std::make_pair(pair[0], pair[1]);
    }
    if (scale_option->count() > 0) run_options.processor_scale = processor_scale;
    if (budget_option->count() > 0) run_options.budget_s = budget_s;
    if (run_site_option->count() > 0) run_options.site_size_m = run_site_size_m;
    run_options.figures = !no_figures;
    run_options.report = !run_no_report;
    return RunFlight(run_options, std::cout, std::cerr);
  }
  if (create->parsed()) return RunDatasetCreate(create_options, std::cout, std::cerr);
  if (stereolunar->parsed()) return RunIngestStereoLunar(stereolunar_options, std::cout, std::cerr);
  if (demo->parsed()) return RunDemo(demo_options, std::cout, std::cerr);
  if (calibrate->parsed()) return RunCalibrate(calibrate_options, std::cout, std::cerr);
  if (calib_diff->parsed()) return RunCalibDiff(calib_diff_options, std::cout, std::cerr);
  if (synth->parsed()) return RunSynth(synth_options, std::cout, std::cerr);
  if (truth->parsed()) {
    const std::vector<int> roi = ParseIntList(roi_text, 4, "--roi", "x,y,w,h");
    std::copy(roi.begin(), roi.end(), truth_options.roi);
    return RunTruth(truth_options, std::cout, std::cerr);
  }
  std::cerr << "hdabench: no command given; see hdabench --help\n";
  return kExitUsage;
}

}  // namespace
}  // namespace hdabench::tools

int main(int argc, char** argv) {
  using namespace hdabench::tools;
  try {
    return Main(argc, argv);
  } catch (const CLI::ValidationError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const hdabench::InputError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const hdabench::UnsupportedError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const hdabench::ExternalError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitExternal;
  } catch (const std::exception& e) {
    std::cerr << "hdabench: internal error: " << e.what() << "\n";
    return kExitInternal;
  } catch (...) {
    std::cerr << "hdabench: internal error: unknown exception\n";
    return kExitInternal;
  }
}
