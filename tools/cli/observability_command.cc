// `hdabench observability`: the paper's observability study (a Monte Carlo of
// the slope error against the baseline, reference/observability), whole or
// one shard; `hdabench observability merge`: shards into the whole study.
#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "calib/camera_model.h"
#include "datasets/synth/synth.h"
#include "reference/flight/hda_params.h"
#include "reference/observability/observability.h"
#include "tools/cli/command_line.h"
#include "reference/flight/flight_outputs.h"
#include "tools/cli/command_support.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/error.h"
#include "tools/util/parallel_for.h"
#include "tools/util/text.h"

namespace hdabench::tools {
namespace {

struct ObservabilityArgs {
  std::string geometries = "lateral,forward,boresight";
  std::string baselines = "2:60:2";
  std::string pixel_noises = "0.05,0.1,0.25,0.5";
  std::string points = "50";
  reference::StudyOptions study;
  std::string camera_file;
  std::string params_file;
  std::vector<std::string> hda_sets;
  std::string shard = "1/1";
  int threads = 0;
  std::string out_dir;
  std::string python = "/usr/bin/python3";
  bool no_figures = false;
  bool quiet = false;
};

struct MergeArgs {
  std::vector<std::string> dirs;
  std::string out_dir;
  std::string python = "/usr/bin/python3";
  bool no_figures = false;
};

// The figures of a whole study; a failure is a warning (the numbers are written).
void DrawFigures(const std::string& dir, const std::string& python, bool no_figures, const std::string& command,
                 std::ostream& out, std::ostream& err) {
  if (no_figures) return;
  const std::string problem = reference::WriteStudyPlots(dir, python);
  if (problem.empty()) {
    out << "figures: " << dir << "/figures/slope_error_vs_baseline.png, sigma_check.png\n";
  } else {
    err << command << "warning: no figures: " << problem << "\n";
  }
}

// "a,b,c" as numbers; "start:stop:step" (stop included when the steps reach
// it within a millionth of a step) as the numbers from start to stop.
std::vector<double> ParseNumberList(const std::string& text, const std::string& flag) {
  const auto number = [&](const std::string& item) {
    double v = 0.0;
    if (util::ParseDouble(item, &v) != util::ParseStatus::kOk || !std::isfinite(v)) {
      throw CLI::ValidationError(flag, "'" + item + "' in '" + text + "' is not a number");
    }
    return v;
  };
  std::vector<std::string> parts;
  std::stringstream in(text);
  std::string item;
  if (text.find(':') != std::string::npos) {
    while (std::getline(in, item, ':')) parts.push_back(item);
    if (parts.size() != 3) throw CLI::ValidationError(flag, "'" + text + "': expected START:STOP:STEP");
    const double start = number(parts[0]), stop = number(parts[1]), step = number(parts[2]);
    if (!(step > 0.0) || stop < start) {
      throw CLI::ValidationError(flag, "'" + text + "': expected STEP > 0 and STOP >= START");
    }
    const double count = std::floor((stop - start) / step + 1e-6);
    if (count > 100000) throw CLI::ValidationError(flag, "'" + text + "': more than 100000 values");
    std::vector<double> values;
    for (int i = 0; i <= static_cast<int>(count); ++i) values.push_back(start + i * step);
    return values;
  }
  // An empty item (a trailing comma) is refused as any other; a value given
  // twice would only be studied twice.
  std::vector<double> values;
  for (const std::string_view part : util::SplitAtCommas(text)) {
    values.push_back(number(std::string(part)));
    if (std::find(values.begin(), values.end() - 1, values.back()) != values.end() - 1) {
      throw CLI::ValidationError(flag, "'" + text + "' gives " + util::ShortestText(values.back()) + " twice");
    }
  }
  if (values.empty()) throw CLI::ValidationError(flag, "expected at least one number");
  return values;
}

int RunObservability(ObservabilityArgs& args) {
  const std::string command = "hdabench observability: ";
  std::ostream& err = std::cerr;
  std::ostream& out = std::cout;
  if (args.out_dir.empty()) {
    err << command << "--out is required\n";
    return kExitUsage;
  }
  reference::StudyOptions& study = args.study;
  reference::StudyShard shard;
  try {
    study.geometries.clear();
    std::stringstream in(args.geometries);
    std::string item;
    while (std::getline(in, item, ',')) study.geometries.push_back(reference::ParseStudyGeometry(item));
    shard = util::ParseShard(args.shard);
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitUsage;
  }
  study.baselines_m = ParseNumberList(args.baselines, "--baseline");
  study.pixel_noises_px = ParseNumberList(args.pixel_noises, "--pixel-noise");
  study.points.clear();
  for (const double p : ParseNumberList(args.points, "--points")) {
    if (p != std::floor(p) || p < 3 || p > 1e6) {
      err << command << "--points: " << util::ShortestText(p) << " is not a whole number in [3, 1000000]\n";
      return kExitUsage;
    }
    study.points.push_back(static_cast<int>(p));
  }
  // The flight method's options: the file, then --set; the lengths not given
  // follow the slant range as in `run` (docs/flight-parameters.md), and the
  // nav and LRF sigmas the method assumes follow the study's noise.
  reference::HdaSettings settings;
  if (const int code = BuildHdaSettings(args.params_file, {}, args.hda_sets, "observability", err, &settings);
      code != kExitOk) {
    return code;
  }
  const int threads = util::WorkerThreads(args.threads);
  return WithExitCodes(command, err, [&] {
    const calib::CameraModel camera = args.camera_file.empty()
                                          ? datasets::synth::DefaultSynthCamera(1024, 30.0)
                                          : calib::CameraModel::Load(args.camera_file);
    reference::ResolveStudyHdaOptions(settings, camera, &study);
    if (const std::vector<std::string> errors = study.Validate(); !errors.empty()) {
      for (const std::string& e : errors) err << command << e << "\n";
      return kExitUsage;
    }
    // The output folder before the study, not after it: a folder that
    // cannot be written, or one holding a dataset or another command's
    // results, costs no trials.
    if (const int code = CheckOutputFolder(args.out_dir, "", "study.json", command, err); code != kExitOk) {
      return code;
    }
    reference::PrepareOutputFolder(args.out_dir);
    const size_t total = reference::StudySettings(study).size();
    if (!args.quiet) {
      err << command << total << " settings x " << study.trials << " trials"
          << (shard.Whole() ? "" : ", shard " + args.shard) << ", " << threads << (threads == 1 ? " thread\n" : " threads\n");
    }
    const auto progress = [&](const reference::SettingStats& s, int done, int count) {
      if (args.quiet) return;
      err << command << done << "/" << count << ": " << reference::ToString(s.setting.geometry) << ", "
          << s.setting.points << " points, " << util::ShortestText(s.setting.pixel_noise_px) << " px, baseline "
          << util::ShortestText(s.setting.baseline_m) << " m: p95 |slope error| "
          << (std::isinf(s.p95_abs_error_deg) ? std::string("inf") : util::FixedText(s.p95_abs_error_deg, 2))
          << " deg, " << s.fits << "/" << s.trials << " fitted\n";
    };
    const std::vector<reference::SettingStats> stats = reference::RunStudy(study, camera, shard, threads, progress);
    const std::vector<std::string> written = reference::WriteStudyFolder(
        args.out_dir, reference::StudyJsonText(study, camera, shard), stats, shard.Whole(), study.requirement_deg);
    out << "wrote " << written.size() << " files to " << args.out_dir << "\n";
    if (shard.Whole()) {
      out << reference::BaselinesCsv(reference::SmallestBaselines(stats, study.requirement_deg));
      DrawFigures(args.out_dir, args.python, args.no_figures, command, out, err);
    }
    return kExitOk;
  });
}

int RunObservabilityMerge(const MergeArgs& args) {
  const std::string command = "hdabench observability merge: ";
  // Not over a dataset, another command's results or a shard being merged.
  if (const int code = CheckOutputFolder(args.out_dir, "", "study.json", command, std::cerr); code != kExitOk) {
    return code;
  }
  for (const std::string& dir : args.dirs) {
    if (IsSameOrInsideFolder(args.out_dir, dir)) {
      std::cerr << command << "--out " << args.out_dir << " is, or is inside, the shard " << dir
                << " being merged; choose another folder\n";
      return kExitInput;
    }
  }
  return WithExitCodes(command, std::cerr, [&] {
    const reference::MergedStudy merged = reference::MergeStudyFolders(args.dirs);
    const std::vector<std::string> written = reference::WriteStudyFolder(
        args.out_dir, merged.study_json_text, merged.stats, true, merged.requirement_deg);
    std::cout << "merged " << args.dirs.size() << " shards (" << merged.stats.size() << " settings); wrote "
              << written.size() << " files to " << args.out_dir << "\n";
    std::cout << reference::BaselinesCsv(reference::SmallestBaselines(merged.stats, merged.requirement_deg));
    DrawFigures(args.out_dir, args.python, args.no_figures, command, std::cout, std::cerr);
    return kExitOk;
  });
}

}  // namespace

std::vector<Command> AddObservabilityCommands(CLI::App& app) {
  const auto args = std::make_shared<ObservabilityArgs>();
  reference::StudyOptions& s = args->study;
  CLI::App* study = app.add_subcommand(
      "observability",
      "The paper's observability study: slope error against baseline for lateral, forward and boresight\n"
      "motion, by Monte Carlo through the flight method's own triangulation and plane fit (docs/observability.md)");
  study->add_option("--geometry", args->geometries,
                    "Motions to study: lateral (east, across the line of sight), forward (level,\n"
                    "toward the site), boresight (along the optical axis); comma-separated")
      ->capture_default_str();
  study->add_option("--baseline", args->baselines, "Baselines, metres: START:STOP:STEP or a list")->capture_default_str();
  study->add_option("--pixel-noise", args->pixel_noises, "Pixel noise per axis and image, 1 sigma, px (list)")
      ->capture_default_str();
  study->add_option("--points", args->points, "Feature points per site (list)")->capture_default_str();
  study->add_option("--trials", s.trials, "Trials per setting")->capture_default_str();
  study->add_option("--camera", args->camera_file,
                    "Camera model (.cameramodel; default: the synthetic scenes' 1024 px, 30 deg camera)");
  study->add_option("--altitude", s.altitude_m, "Camera 1 above the site, metres")->capture_default_str();
  study->add_option("--downrange", s.downrange_m, "Camera 1 short of the site horizontally, metres")
      ->capture_default_str();
  study->add_option("--site-size-m", s.site_size_m, "Side of the square site, metres")->capture_default_str();
  study->add_option("--min-slope-deg", s.min_slope_deg, "Smallest drawn site slope, degrees")->capture_default_str();
  study->add_option("--max-slope-deg", s.max_slope_deg, "Largest drawn site slope, degrees")->capture_default_str();
  study->add_option("--relief-m", s.relief_sigma_m, "Small-scale relief off the site's plane, 1 sigma, metres")
      ->capture_default_str();
  study->add_option("--nav-position-sigma-m", s.nav_position_sigma_m,
                    "Nav relative translation error per axis, 1 sigma, metres")
      ->capture_default_str();
  study->add_option("--nav-attitude-sigma-deg", s.nav_attitude_sigma_deg,
                    "Nav relative rotation and camera 1 attitude error per axis, 1 sigma, degrees")
      ->capture_default_str();
  study->add_option("--lrf-sigma-m", s.lrf_sigma_m, "LRF range error, 1 sigma, metres")->capture_default_str();
  study->add_option("--requirement-deg", s.requirement_deg, "Slope requirement on the p95 of |slope error|, degrees")
      ->capture_default_str();
  AddSeedOption(study, &s.seed, "Study seed");
  study->add_option("--params", args->params_file, kParamsHelp);
  study->add_option("--set", args->hda_sets, kSetHelp)->allow_extra_args(false);
  study->add_option("--shard", args->shard, "Run slice K of N (K/N); merge the slices with `observability merge`")
      ->capture_default_str();
  study->add_option("--threads", args->threads, "Worker threads (0: every core this process may use; the numbers do not depend on it)")
      ->check(NonNegativeWhole())
      ->capture_default_str();
  study->add_option("--out", args->out_dir, "Output folder (created; files replaced); required");
  study->add_option("--python", args->python, "Python 3 with matplotlib, for the figures")->capture_default_str();
  study->add_flag("--no-figures", args->no_figures, "Do not draw figures/");
  study->add_flag("--quiet", args->quiet, "No progress lines");

  const auto merge_args = std::make_shared<MergeArgs>();
  CLI::App* merge = study->add_subcommand("merge", "Merge the shards of one study into the whole study's outputs");
  merge->add_option("DIRS", merge_args->dirs, "The shards' output folders")->required();
  merge->add_option("--out", merge_args->out_dir, "Output folder (created; files replaced)")->required();
  merge->add_option("--python", merge_args->python, "Python 3 with matplotlib, for the figures")
      ->capture_default_str();
  merge->add_flag("--no-figures", merge_args->no_figures, "Do not draw figures/");
  // The study's --out is checked when it runs (not for merge); merge comes
  // first: a parsed merge has its parent parsed too.
  study->require_subcommand(0, 1);
  return {{merge, [merge_args] { return RunObservabilityMerge(*merge_args); }},
          {study, [args] { return RunObservability(*args); }}};
}

}  // namespace hdabench::tools
