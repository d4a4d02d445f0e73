// `hdabench dataset check` and `hdabench dataset create`: load, call, print.
// The checks themselves live in datasets/ (docs/dataset-format.md).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "datasets/dataset.h"
#include "datasets/example.h"
#include "datasets/navigation.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/text.h"
#include "tools/util/angles.h"

namespace hdabench::tools {

namespace {

namespace fs = std::filesystem;

using util::kRadToDeg;

void PrintSummary(const datasets::Dataset& dataset, const std::string& dir, int frame1, int frame2,
                  std::ostream& out) {
  const calib::CameraModel& camera = dataset.camera;
  const datasets::FrameRecord& first = dataset.frames.front();
  const datasets::FrameRecord& last = dataset.frames.back();
  out << "dataset " << dir << ": ok\n";
  out << "  name:        " << dataset.name << "\n";
  if (!dataset.description.empty()) out << "  description: " << dataset.description << "\n";
  out << "  camera:      " << camera.LensModelName() << ", " << camera.WidthPx() << " x "
      << camera.HeightPx() << " px (" << dataset.camera_model_file << ")\n";
  out << "  frames:      " << dataset.frames.size() << ", " << util::FixedText(first.time_s, 3) << " .. "
      << util::FixedText(last.time_s, 3) << " s (" << util::FixedText(last.time_s - first.time_s, 3) << " s)";
  const std::vector<int> imaged = datasets::FramesWithImages(dataset.frames);
  if (imaged.size() != dataset.frames.size()) out << "; images for frames " << util::JoinInts(imaged);
  out << "\n";
  out << "  navigation:  " << dataset.nav.size() << " samples, " << util::FixedText(dataset.nav.front().time_s, 3)
      << " .. " << util::FixedText(dataset.nav.back().time_s, 3) << " s"
      << (dataset.nav_has_velocity ? ", velocity" : "") << (dataset.nav_has_sigmas ? ", sigmas" : "")
      << "\n";
  if (dataset.lrf.empty()) {
    out << "  lrf:         none (the flight method takes the range from the navigation, docs/faults.md)\n";
  } else {
    out << "  lrf:         " << dataset.lrf.size() << " samples, " << util::FixedText(dataset.lrf.front().time_s, 3)
        << " .. " << util::FixedText(dataset.lrf.back().time_s, 3) << " s\n";
  }
  const datasets::FrameRecord& a = dataset.frames[static_cast<size_t>(frame1)];
  const datasets::FrameRecord& b = dataset.frames[static_cast<size_t>(frame2)];
  const Rigid3d cam2_from_cam1 = dataset.Cam2FromCam1(frame1, frame2);
  const double rotation_deg = datasets::RotationAngleRad(cam2_from_cam1.rotation) * kRadToDeg;
  out << "  frames " << frame1 << " -> " << frame2 << ": dt " << util::FixedText(b.time_s - a.time_s, 3)
      << " s, baseline " << util::FixedText(dataset.BaselineM(frame1, frame2), 3) << " m, rotation "
      << util::FixedText(rotation_deg, 4) << " deg\n";
  if (!dataset.lrf.empty()) {
    out << "  lrf range:   " << util::FixedText(dataset.LrfRangeAt(a.time_s), 3) << " m at frame " << frame1
        << ", " << util::FixedText(dataset.LrfRangeAt(b.time_s), 3) << " m at frame " << frame2 << "\n";
  }
  const Eigen::Vector3d& g = dataset.gravity_in_local_mps2;
  out << "  gravity:     (" << util::FixedText(g.x(), 4) << ", " << util::FixedText(g.y(), 4) << ", " << util::FixedText(g.z(), 4)
      << ") m/s^2; ILS (" << util::FixedText(dataset.ils_in_local_m.x(), 3) << ", "
      << util::FixedText(dataset.ils_in_local_m.y(), 3) << ", " << util::FixedText(dataset.ils_in_local_m.z(), 3)
      << ") m\n";
  out << "  truth:       ";
  if (dataset.truth.Empty()) {
    out << "none\n";
  } else {
    out << "points for " << dataset.truth.points.size() << " of " << dataset.frames.size()
        << " frames";
    if (dataset.truth.dem.has_value()) {
      const datasets::TruthDem& dem = *dataset.truth.dem;
      out << "; DEM " << dem.width_cells << " x " << dem.height_cells << " cells of "
          << util::FixedText(dem.spacing_m, 3) << " m";
    }
    if (!dataset.truth.navigation_file.empty()) {
      out << "; true navigation (" << dataset.truth.navigation.size() << " samples)";
    }
    if (!dataset.truth.rocks_file.empty()) out << "; " << dataset.truth.rocks.size() << " rocks";
    out << "\n";
  }
}

}  // namespace

int RunDatasetCheck(const DatasetCheckOptions& options, std::ostream& out, std::ostream& err) {
  const std::string& dir = options.dataset_dir;
  const int folder = CheckDatasetFolder(dir, "dataset check", err);
  if (folder != kExitOk) return folder;
  const datasets::DatasetLoadResult result = datasets::LoadDataset(dir);
  if (!result.Ok()) {
    err << result.problems.size() << " problem(s) in " << dir << ":\n";
    for (const datasets::Problem& problem : result.problems) err << problem.ToString() << "\n";
    return kExitCheckFailed;
  }
  const datasets::Dataset& dataset = *result.dataset;
  const int num_frames = static_cast<int>(dataset.frames.size());
  int frame1 = 0;
  int frame2 = num_frames - 1;
  if (options.frames.has_value()) {
    frame1 = options.frames->first;
    frame2 = options.frames->second;
    for (const int frame : {frame1, frame2}) {
      if (frame < 0 || frame >= num_frames) {
        err << "hdabench dataset check: --frames: frame " << frame << " is not in " << dir
            << ", which has frames 0.." << num_frames - 1 << "\n";
        return kExitUsage;
      }
    }
  }
  PrintSummary(dataset, dir, frame1, frame2, out);
  return kExitOk;
}

int RunDatasetCreate(const DatasetCreateOptions& options, std::ostream& out, std::ostream& err) {
  const std::string& dir = options.out_dir;
  std::error_code ec;
  if (fs::exists(dir, ec) && (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec))) {
    err << "hdabench dataset create: " << dir
        << ": exists and is not an empty folder; choose a new folder\n";
    return kExitUsage;
  }
  const datasets::Dataset dataset = datasets::MakeExampleDataset(options.seed);
  try {
    datasets::WriteDataset(dataset, dir);
  } catch (const InputError& e) {
    err << "hdabench dataset create: " << e.what() << "\n";
    return kExitInput;
  }
  // What was written must load cleanly; anything else is a bug in the bench.
  const datasets::DatasetLoadResult check = datasets::LoadDataset(dir);
  if (!check.Ok()) {
    err << "hdabench dataset create: internal error: the written dataset has "
        << check.problems.size() << " problem(s):\n";
    for (const datasets::Problem& problem : check.problems) err << problem.ToString() << "\n";
    return kExitInternal;
  }
  out << "wrote example dataset '" << dataset.name << "' (seed " << options.seed << ") to " << dir
      << ":\n";
  out << "  " << datasets::kManifestFileName << "\n";
  out << "  " << dataset.camera_model_file << " (" << dataset.camera.LensModelName() << ", "
      << dataset.camera.WidthPx() << " x " << dataset.camera.HeightPx() << " px)\n";
  out << "  " << dataset.frames_file << " and " << dataset.frames.size() << " images in "
      << fs::path(dataset.frames.front().image_path).parent_path().string() << "/\n";
  out << "  " << dataset.nav_file << " (" << dataset.nav.size() << " samples)\n";
  out << "  " << dataset.lrf_file << " (" << dataset.lrf.size() << " samples)\n";
  if (!dataset.truth.Empty()) {
    out << "  truth: " << dataset.truth.points.size() << " point rasters"
        << (dataset.truth.dem.has_value() ? " and a DEM" : "") << "\n";
  }
  return kExitOk;
}

namespace {

// What `dataset check` parses into: its options and the --frames text.
struct DatasetCheckArgs {
  DatasetCheckOptions options;
  std::string frames_text;
};

// dataset check: DIR and --frames.
Command AddDatasetCheckCommand(CLI::App& dataset) {
  const auto args = std::make_shared<DatasetCheckArgs>();
  CLI::App* check = dataset.add_subcommand(
      "check", "Validate a dataset: print a summary, or every problem (exit 1)");
  check->add_option("DIR", args->options.dataset_dir, "Dataset folder (holds manifest.json)")
      ->required();
  check->add_option("--frames", args->frames_text,
                    "Two frame indices i,j for the baseline line (default: first,last)");
  return {check, [args] {
            args->options.frames = ParseFramesFlag(args->frames_text);
            return RunDatasetCheck(args->options, std::cout, std::cerr);
          }};
}

// dataset create: DIR and --seed.
Command AddDatasetCreateCommand(CLI::App& dataset) {
  const auto options = std::make_shared<DatasetCreateOptions>();
  CLI::App* create = dataset.add_subcommand(
      "create", "Write the built-in small example dataset (deterministic for a seed)");
  create->add_option("DIR", options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  AddSeedOption(create, &options->seed, "Random seed");
  return {create, [options] { return RunDatasetCreate(*options, std::cout, std::cerr); }};
}

}  // namespace

// dataset, which needs one of check and create.
std::vector<Command> AddDatasetCommands(CLI::App& app) {
  CLI::App* dataset =
      app.add_subcommand("dataset", "Create and check datasets (docs/dataset-format.md)");
  dataset->require_subcommand(1);
  return {AddDatasetCheckCommand(*dataset), AddDatasetCreateCommand(*dataset)};
}

}  // namespace hdabench::tools
