// `hdabench compare`: load a dataset, run the flight method and the reference
// methods on two of its frames, write the outputs (reference/compare/compare_outputs.h,
// docs/compare-results.md) and print the Markdown table.
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>

#include "tools/util/error.h"
#include "tools/util/text.h"
#include "datasets/dataset.h"
#include "hda/hda_options.h"
#include "reference/compare/compare.h"
#include "reference/compare/method.h"
#include "reference/compare/compare_outputs.h"
#include "reference/flight/flight_outputs.h"
#include "reference/flight/flight_run.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

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
  std::vector<HdaFlag> flags;
  if (options.site_size_m) flags.push_back({"--site-size-m", "quadtree.site_size_m", *options.site_size_m});
  if (options.fault_match_noise_px) {
    flags.push_back({"--fault-match-noise-px", "fault_match_noise_px", *options.fault_match_noise_px});
  }
  const int settings_code =
      BuildHdaSettings(options.params_file, flags, options.hda_sets, "compare", err, &compare.hda);
  if (settings_code != kExitOk) return settings_code;
  compare.colmap.executable = options.colmap_executable;
  compare.colmap.timeout_s = options.colmap_timeout_s;
  compare.colmap.use_all_frames = options.colmap_all_frames;
  reference::ColmapSettings colmap;
  colmap.max_features = options.colmap_max_features;
  colmap.first_octave = options.colmap_first_octave;
  colmap.octave_resolution = options.colmap_octave_resolution;
  colmap.peak_threshold = options.colmap_peak_threshold;
  colmap.nav_band_px = options.colmap_nav_band_px;
  colmap.ApplyTo(&compare.colmap);
  compare.opengv_dense_features = options.opengv_dense;
  compare.opengv_overlap_tiles = options.opengv_overlap_tiles;
  compare.external.program = options.external_program;
  compare.external.args = options.external_args;
  if (options.external_timeout_s) compare.external.timeout_s = *options.external_timeout_s;
  compare.external.work_dir = (std::filesystem::path(options.out_dir) / "external").string();
  const std::vector<std::string> invalid = compare.Validate();
  if (!invalid.empty()) {
    err << "hdabench compare: unusable options:\n";
    for (const std::string& problem : invalid) err << "  " << problem << "\n";
    return kExitUsage;
  }

  const PairLoad pair = LoadDatasetPair(options.dataset_dir, options.frames, options.out_dir,
                                        "compare", err, progress, /*read_dem=*/true,
                                        "compare.json");
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

namespace {

// What `compare` parses into: its options, the --frames text, --site-size-m
// (set only when given) and the negated output flags.
struct CompareArgs {
  CompareCommandOptions options;
  std::string frames_text;
  double site_size_m = hda::HdaOptions().quadtree.site_size_m;
  bool no_figures = false;
  bool no_report = false;
  CLI::Option* site_option = nullptr;
};

// Completes the options of `compare` from what was parsed into `args`, then runs it.
int RunParsedCompare(CompareArgs& args) {
  args.options.frames = ParseFramesFlag(args.frames_text);
  args.options.figures = !args.no_figures;
  args.options.report = !args.no_report;
  if (args.site_option->count() > 0) args.options.site_size_m = args.site_size_m;
  return RunCompareCommand(args.options, std::cout, std::cerr);
}

}  // namespace

// compare: DATASET, --frames, --methods, --out and the reference methods' options.
Command AddCompareCommand(CLI::App& app) {
  const auto args = std::make_shared<CompareArgs>();
  CompareCommandOptions& options = args->options;
  CLI::App* compare = app.add_subcommand(
      "compare",
      "Compare the flight method with COLMAP, OpenGV, Ceres and the truth per ROI on two frames");
  compare->add_option("DATASET", options.dataset_dir, "Dataset folder")->required();
  compare->add_option("--frames", args->frames_text,
                      "Two different frame indices i,j (default: as hdabench run)");
  compare->add_option("--methods", options.methods,
                      "Comma-separated methods, or all (flight always runs):\n" +
                          reference::MethodListText())
      ->capture_default_str();
  compare->add_option("--out", options.out_dir,
                      "Output folder (created if missing; files replaced)")
      ->required();
  args->site_option =
      compare->add_option("--site-size-m", args->site_size_m,
                          "Side of a landing site, metres (default: as hdabench run)");
  compare->add_option("--params", options.params_file, kParamsHelp);
  compare->add_option("--set", options.hda_sets, kSetHelp)->allow_extra_args(false);
  compare->add_option("--colmap", options.colmap_executable,
                      "The colmap program: a name on PATH or a path")
      ->capture_default_str();
  compare->add_option("--colmap-timeout-s", options.colmap_timeout_s,
                      "Time limit of each COLMAP step, seconds")
      ->capture_default_str();
  compare->add_flag("--colmap-all-frames", options.colmap_all_frames,
                    "colmap-free on every frame of the collection window, not only the pair");
  compare->add_option("--colmap-max-features", options.colmap_max_features,
                      "SIFT features COLMAP keeps per image (the largest scales first)")
      ->capture_default_str();
  compare->add_option_function<std::string>(
              "--colmap-first-octave",
              [&options](const std::string& value) {
                if (value == "auto") {
                  options.colmap_first_octave.reset();
                  return;
                }
                int octave = 0;
                if (!CLI::detail::lexical_cast(value, octave)) {
                  throw CLI::ValidationError("--colmap-first-octave", "'" + value + "' is not an integer or auto");
                }
                options.colmap_first_octave = octave;
              },
              "COLMAP's first SIFT octave, in [-2, 2]: -1 upsamples the images twice, -2 four\n"
              "times (more small-scale keypoints, in the smooth blocks the quadtree keeps); auto:\n"
              "-2 when the smallest ROI is under 64 px and the image at most 2048 px, else -1")
      ->default_str("auto");
  compare->add_option("--colmap-octave-resolution", options.colmap_octave_resolution,
                      "COLMAP's SIFT levels per octave")
      ->capture_default_str();
  compare->add_option("--colmap-peak-threshold", options.colmap_peak_threshold,
                      "COLMAP's SIFT difference-of-Gaussian peak threshold")
      ->capture_default_str();
  compare->add_option("--colmap-nav-band-px", options.colmap_nav_band_px,
                      "colmap-nav's SIFT matching guided by the nav epipolar geometry: the band's\n"
                      "half-width, pixels (0: exact matching of every descriptor pair, as colmap-free)")
      ->capture_default_str();
  compare->add_option("--fault-match-noise-px", options.fault_match_noise_px,
                      "Fault injection for testing the gate: Gaussian noise added to the flight\n"
                      "method's image-2 matches, pixels per axis (default 0: none)");
  compare->add_flag("--opengv-dense", options.opengv_dense,
                    "OpenGV on denser ORB matches (2000 keypoints per ROI, FAST threshold 5)\n"
                    "instead of the flight matcher's");
  compare->add_option("--opengv-overlap-tiles", options.opengv_overlap_tiles,
                      "OpenGV's pair pose also from features over the whole overlap: at most this many\n"
                      "tiles of the ROIs' size spread over image 1, clear of the ROIs (0: the ROIs' matches only)")
      ->capture_default_str();
  compare->add_option("--external-program", options.external_program,
                      "The external method's program (docs/external-method.md): run as PROGRAM [ARGS]\n"
                      "INPUT_JSON OUTPUT_JSON in <out>/external; a path, or a name on PATH");
  compare->add_option("--external-arg", options.external_args,
                      "An argument of the external method's program, before the two files (repeatable)")
      ->allow_extra_args(false);
  compare->add_option("--external-timeout-s", options.external_timeout_s,
                      "Time limit of the external method's program, seconds; past it the program is ended\n"
                      "and its column fails")
      ->default_str(util::ShortestText(reference::ExternalMethodOptions().timeout_s));
  compare->add_flag("--no-figures", args->no_figures, "Do not write flight/figures/");
  compare->add_flag("--no-report", args->no_report, "Do not write report.html and report.md");
  compare->add_flag("--quiet", options.quiet, "No progress lines");
  return {compare, [args] { return RunParsedCompare(*args); }};
}

}  // namespace hdabench::tools
