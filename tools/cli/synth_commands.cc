// hdabench synth and hdabench truth.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <future>
#include <iomanip>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"
#include "tools/util/text.h"
#include "calib/camera_model.h"
#include "datasets/dataset.h"
#include "datasets/faults.h"
#include "datasets/synth/chessboard.h"
#include "datasets/synth/synth.h"
#include "datasets/synth/truth.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"
#include "reference/flight/flight_run.h"

namespace hdabench::tools {

namespace fs = std::filesystem;
namespace synth = datasets::synth;

namespace {

// synth --frames: "all" (no chooser), "pair", "pair+next", or indices and
// ranges "0,6", "0-6". InputError naming the bad item.
std::function<std::vector<int>(const datasets::Dataset&)> FramesToRenderFlag(const std::string& text) {
  const std::string_view trimmed = util::Trim(text);
  if (trimmed == "all") return {};
  if (trimmed == "pair" || trimmed == "pair+next") {
    const bool with_next = trimmed == "pair+next";
    return [with_next](const datasets::Dataset& dataset) { return reference::PairFramesToRender(dataset, with_next); };
  }
  std::vector<std::pair<int, int>> ranges;  // FIRST-LAST, inclusive
  for (const std::string_view item : util::SplitAtCommas(trimmed)) {
    const std::string_view part = util::Trim(item);
    const size_t dash = part.find('-', 1);
    int first = 0, last = 0;
    const bool ok = dash == std::string_view::npos
                        ? util::ParseInt(part, &first) == util::ParseStatus::kOk && (last = first, true)
                        : util::ParseInt(part.substr(0, dash), &first) == util::ParseStatus::kOk &&
                              util::ParseInt(part.substr(dash + 1), &last) == util::ParseStatus::kOk;
    if (!ok || first < 0 || last < first) {
      throw InputError("--frames: '" + std::string(part) +
                       "' is not a frame index or a range FIRST-LAST; expected all, pair, pair+next or a list "
                       "such as 0,6 or 0-6");
    }
    ranges.emplace_back(first, last);
  }
  // Expanded against the scene's frames: a range past the last frame stops at
  // the first frame the scene does not have, which the check of the list then
  // names (a range such as 0-2000000000 costs nothing).
  return [ranges](const datasets::Dataset& dataset) {
    const int count = static_cast<int>(dataset.frames.size());
    std::vector<int> frames;
    for (const auto& [first, last] : ranges) {
      for (int f = first; f <= last; ++f) {
        frames.push_back(f);
        if (f >= count) break;
      }
    }
    return frames;
  };
}

}  // namespace

int RunSynth(const SynthCommandOptions& options, std::ostream& out, std::ostream& err) {
  std::error_code ec;
  if (fs::exists(options.out_dir, ec) &&
      (!fs::is_directory(options.out_dir, ec) || !fs::is_empty(options.out_dir, ec))) {
    err << "hdabench synth: " << options.out_dir
        << " already exists and is not an empty folder; choose a new --out\n";
    return kExitUsage;
  }
  // The scene comes from flags alone, so an unknown preset, an unknown or
  // unparsable --set and options the scene cannot have are bad flag values
  // (exit 2); only the camera model file is an input that can be unusable (exit 3).
  synth::SynthOptions synth_options;
  synth::TerrainOptions terrain;
  try {
    synth_options = synth::SynthPreset(options.preset);
    if (!options.terrain.empty()) synth_options.terrain = options.terrain;
    if (options.image_size_px > 0) synth_options.image_size_px = options.image_size_px;
    synth_options.camera_model_file = options.camera_model_file;
    synth_options.threads = util::WorkerThreads(options.threads);
    terrain = synth::TerrainPreset(synth_options.terrain);
    for (const std::string& override_text : options.overrides) {
      const size_t eq = override_text.find('=');
      if (eq == std::string::npos || eq == 0) {
        throw InputError("--set expects key=value, got '" + override_text + "'");
      }
      synth::ApplyOverride(override_text.substr(0, eq), override_text.substr(eq + 1), &synth_options,
                           &terrain);
    }
    synth::ScaleTerrain(synth_options.terrain_scale, &terrain);
    synth_options.frames_to_render = FramesToRenderFlag(options.frames);
  } catch (const InputError& e) {
    err << "hdabench synth: " << e.what() << "\n";
    return kExitUsage;
  }
  if (!options.camera_model_file.empty()) {
    try {
      synth_options.camera_model.emplace(calib::CameraModel::Load(options.camera_model_file));
    } catch (const InputError& e) {
      err << "hdabench synth: --camera-model: " << e.what() << "\n";
      return kExitInput;
    }
  }
  std::vector<datasets::Fault> faults;
  for (const std::string& text : options.faults) {
    try {
      faults.push_back(datasets::ParseOneFault(text));
    } catch (const InputError& e) {
      err << "hdabench synth: --fault " << e.what() << " (hdabench faults --list)\n";
      return kExitUsage;
    }
    try {
      datasets::CheckFaultMagnitude(faults.back());  // before the scene is rendered
    } catch (const InputError& e) {
      err << "hdabench synth: --" << e.what() << " (hdabench faults --list)\n";  // "--fault NAME=M: why"
      return kExitUsage;
    }
  }

  int last_percent = -1;
  std::string last_stage;
  const synth::SynthProgress progress = [&](const std::string& stage, double fraction) {
    if (options.quiet) return;
    const int percent = static_cast<int>(fraction * 100.0);
    if (stage == last_stage && percent / 10 == last_percent / 10 && percent != 100) return;
    last_stage = stage;
    last_percent = percent;
    err << "hdabench synth: " << stage << " " << percent << "%\n";
  };
  synth::SynthSummary summary;
  std::optional<datasets::Dataset> generated;
  try {
    // Its InputErrors are the options': the camera model was read above.
    generated.emplace(synth::GenerateSynthDataset(synth_options, terrain, options.seed, progress, &summary));
  } catch (const InputError& e) {
    err << "hdabench synth: " << e.what() << "\n";
    return kExitUsage;
  }
  datasets::Dataset& dataset = *generated;
  if (!faults.empty()) {
    // On the pair `run` takes; a fault that cannot apply is an InputError
    // (exit 3) before anything is written.
    const std::pair<int, int> pair = reference::DefaultFramePair(dataset);
    std::string labels;
    for (const datasets::Fault& fault : faults) {
      datasets::ApplyFault(fault, pair.first, pair.second, options.seed, &dataset);
      labels += (labels.empty() ? "" : ", ") + datasets::FaultLabel(fault);
    }
    dataset.description += " Sensor faults (docs/faults.md) on frames " + std::to_string(pair.first) + "," +
                           std::to_string(pair.second) + ": " + labels + "; the truth is the scene's.";
    out << "applied " << labels << " to frames " << pair.first << "," << pair.second << "\n";
  }
  // The maps need only the truth in memory: they are drawn and encoded while
  // the dataset is written (mostly one core's work), and written after it.
  const auto maps_start = std::chrono::steady_clock::now();
  std::future<std::vector<synth::TruthMapFile>> encoded_maps =
      util::StartBeside("truth maps", [&dataset] { return synth::EncodeTruthMaps(dataset); });
  datasets::WriteDataset(dataset, options.out_dir);
  synth::WriteTruthMapFiles(encoded_maps.get(), (fs::path(options.out_dir) / "maps").string());
  const double maps_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - maps_start).count();
  out << "wrote synthetic dataset '" << dataset.name << "' to " << options.out_dir << "\n  "
      << summary.Summary() << "\n  maps: " << (fs::path(options.out_dir) / "maps").string()
      << "/{elevation,slope,hazards,safety}.png; dataset and maps written in " << util::FixedText(maps_s, 2)
      << " s\n";
  // Peak resident memory of this process so far (Linux reports kilobytes).
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) == 0) {
    out << "  peak memory: " << usage.ru_maxrss / 1024 << " MB\n";
  }
  return kExitOk;
}

int RunTruth(const TruthCommandOptions& options, std::ostream& out, std::ostream& err) {
  datasets::LoadOptions load;
  load.decode_images = false;
  load.keep_truth = true;
  const std::optional<datasets::Dataset> loaded =
      LoadDatasetOrReport(options.dataset_dir, load, "truth", err);
  if (!loaded.has_value()) return kExitInput;
  const datasets::Dataset& dataset = *loaded;
  if (options.frame < 0 || options.frame >= static_cast<int>(dataset.frames.size())) {
    err << "hdabench truth: --frame " << options.frame << " is not a frame of the dataset (0.."
        << dataset.frames.size() - 1 << ")\n";
    return kExitUsage;
  }
  const synth::PixelRoi roi{options.roi[0], options.roi[1], options.roi[2], options.roi[3]};
  // The flag's own problems first (exit 2): a box the image cannot hold, or
  // one too thin for a plane (a strip a pixel wide gave a slope near 90 deg).
  const int width = dataset.camera.WidthPx(), height = dataset.camera.HeightPx();
  if (roi.width < 3 || roi.height < 3 || roi.x < 0 || roi.y < 0 || roi.x > width - roi.width ||
      roi.y > height - roi.height) {
    err << "hdabench truth: --roi " << roi.x << "," << roi.y << "," << roi.width << "," << roi.height
        << ": expected a box of at least 3 x 3 px inside the " << width << " x " << height << " px image\n";
    return kExitUsage;
  }
  synth::RoiTruth truth;
  try {
    truth = synth::ComputeRoiTruth(dataset, options.frame, roi);
  } catch (const InputError& e) {
    err << "hdabench truth: " << e.what() << "\n";
    return kExitInput;
  }
  if (options.json) {
    nlohmann::ordered_json j;
    j["frame"] = options.frame;
    j["roi"] = {roi.x, roi.y, roi.width, roi.height};
    j["num_points"] = truth.num_points;
    j["slope_deg"] = truth.slope_deg;
    j["roughness_rms_m"] = truth.roughness_rms_m;
    j["roughness_max_m"] = truth.roughness_max_m;
    j["max_rock_height_m"] = truth.max_rock_height_m;
    j["hazard_height_m"] = truth.hazard_height_m;
    out << j.dump(2) << "\n";
    return kExitOk;
  }
  out << std::fixed << std::setprecision(3) << "truth of frame " << options.frame << " ROI (x "
      << roi.x << ", y " << roi.y << ", " << roi.width << " x " << roi.height << " px)\n"
      << "  points:            " << truth.num_points << "\n"
      << "  slope:             " << truth.slope_deg << " deg\n"
      << "  roughness RMS:     " << truth.roughness_rms_m << " m\n"
      << "  roughness max:     " << truth.roughness_max_m << " m\n"
      << "  tallest rock:      " << truth.max_rock_height_m << " m\n"
      << "  hazard height:     " << truth.hazard_height_m << " m\n";
  return kExitOk;
}

namespace {

// synth: --out, the preset and every override.
Command AddSynthCommand(CLI::App& app) {
  const auto options = std::make_shared<SynthCommandOptions>();
  CLI::App* synth_app = app.add_subcommand(
      "synth", "Generate a synthetic lunar dataset with ground truth (docs/synthetic-scenes.md)");
  synth_app->add_option("--out", options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  synth_app->add_option("--preset", options->preset,
                        "novac-lateral, novac-forward, novac-boresight, truck, aircraft or helicopter")
      ->capture_default_str();
  synth_app->add_option("--terrain", options->terrain,
                        "mare, cratered, rocky, flank or boulders (default: the preset's)");
  AddSeedOption(synth_app, &options->seed, "Random seed: same seed, same bytes");
  synth_app->add_option("--threads", options->threads,
                        "Worker threads (0: every core this process may use); output does not depend on it")
      ->check(NonNegativeWhole())
      ->capture_default_str();
  synth_app->add_option("--image-size", options->image_size_px,
                        "Square imager side in pixels (default 1024; 2048 variant)")
      ->check(NonNegativeWhole());
  synth_app->add_option("--camera-model", options->camera_model_file,
                        "A .cameramodel to use instead of the default camera");
  synth_app->add_option(
      "--set", options->overrides,
      "Override any parameter: key=value (e.g. render.sun_elevation_deg=15, terrain.rock_k=0.01)");
  synth_app->add_option("--fault", options->faults,
                        "A sensor fault NAME[=M] on the pair hdabench run takes, the truth left as the\n"
                        "scene's (repeatable, applied in order; hdabench faults --list, docs/faults.md)");
  synth_app->add_option("--frames", options->frames,
                        "Frames to render: all, pair (the pair hdabench run takes), pair+next (and the frame\n"
                        "after it, for the dropped-frame fault) or a list such as 0,6 or 0-6; the other frames\n"
                        "keep their times, navigation and LRF, without an image")
      ->capture_default_str();
  synth_app->add_flag("--quiet", options->quiet, "No progress lines");
  return {synth_app, [options] { return RunSynth(*options, std::cout, std::cerr); }};
}

// What `truth` parses into: its options and the --roi text.
struct TruthArgs {
  TruthCommandOptions options;
  std::string roi_text;
};

// truth: DATASET, --frame, --roi and --json.
Command AddTruthCommand(CLI::App& app) {
  const auto args = std::make_shared<TruthArgs>();
  CLI::App* truth_app = app.add_subcommand(
      "truth", "True slope, roughness and hazard height of an ROI of a dataset with truth");
  truth_app->add_option("DATASET", args->options.dataset_dir, "Dataset folder")->required();
  truth_app->add_option("--frame", args->options.frame, "Frame index")->capture_default_str();
  truth_app->add_option("--roi", args->roi_text, "x,y,w,h in pixels")->required();
  truth_app->add_flag("--json", args->options.json, "Print JSON instead of a table");
  return {truth_app, [args] {
            const std::vector<int> roi = ParseIntList(args->roi_text, 4, "--roi", "x,y,w,h");
            std::copy(roi.begin(), roi.end(), args->options.roi);
            return RunTruth(args->options, std::cout, std::cerr);
          }};
}

}  // namespace

// What `chessboard` parses into.
struct ChessboardArgs {
  std::string out_dir;
  std::string preset = "novac-lateral";
  std::string camera_model_file;
  std::string board_text = "9x6";
  std::string region_text = "0,1,0,1";
  synth::ChessboardBoard board;
  synth::ChessboardViewsOptions views;
  bool quiet = false;
};

// Renders the views and writes them with the camera they were seen through.
int RunChessboard(ChessboardArgs& args, std::ostream& out, std::ostream& err) {
  std::error_code ec;
  if (fs::exists(args.out_dir, ec) && (!fs::is_directory(args.out_dir, ec) || !fs::is_empty(args.out_dir, ec))) {
    err << "hdabench chessboard: " << args.out_dir << " already exists and is not an empty folder; choose a new --out\n";
    return kExitUsage;
  }
  std::optional<calib::CameraModel> camera;
  if (!ParseBoardSize(args.board_text, &args.board.corners_x, &args.board.corners_y)) {
    err << "hdabench chessboard: --board " << args.board_text << ": expected WxH, inner corners per row x rows\n";
    return kExitUsage;
  }
  try {
    const std::vector<double> region = ParseNumberList(args.region_text, 4, "--region", "x0,x1,y0,y1");
    args.views.region_x0 = region[0];
    args.views.region_x1 = region[1];
    args.views.region_y0 = region[2];
    args.views.region_y1 = region[3];
    if (args.camera_model_file.empty()) {
      const synth::SynthOptions preset = synth::SynthPreset(args.preset);
      camera.emplace(synth::DefaultSynthCamera(preset.image_size_px, preset.horizontal_fov_deg));
    }
    ThrowIfInvalid("chessboard: ", args.board.Validate());
    ThrowIfInvalid("chessboard: ", args.views.Validate());
  } catch (const InputError& e) {
    err << "hdabench chessboard: " << e.what() << "\n";
    return kExitUsage;
  }
  try {
    if (!camera) camera.emplace(calib::CameraModel::Load(args.camera_model_file));
    if (!args.quiet) {
      err << "hdabench chessboard: rendering " << args.views.views << " views through " << camera->LensModelName()
          << " " << camera->WidthPx() << " x " << camera->HeightPx() << "\n";
    }
    const std::vector<synth::ChessboardView> views = synth::RenderChessboardViews(*camera, args.board, args.views);
    synth::WriteChessboardViews(views, args.out_dir, "board-");
    camera->Save((fs::path(args.out_dir) / "true.cameramodel").string());
  } catch (const InputError& e) {
    err << "hdabench chessboard: " << e.what() << "\n";
    return kExitInput;
  }
  out << "wrote " << args.views.views << " views to " << args.out_dir
      << " (board-NN.png, truth.csv, poses.csv, true.cameramodel); calibrate them with hdabench calibrate "
      << args.out_dir << "/board-*.png --board " << args.board.corners_x << "x" << args.board.corners_y
      << " --spacing " << util::ShortestText(args.board.spacing_m) << "\n";
  return kExitOk;
}

// chessboard: synthetic chessboard views through a camera, for calibrate.
Command AddChessboardCommand(CLI::App& app) {
  const auto args = std::make_shared<ChessboardArgs>();
  CLI::App* c = app.add_subcommand(
      "chessboard",
      "Render chessboard views through a camera (default: a preset's synthetic camera) for calibrate\n"
      "(docs/calibration.md)");
  c->add_option("--out", args->out_dir, "Folder to create (must not exist, or be empty)")->required();
  c->add_option("--preset", args->preset, "The preset whose default camera sees the board")->capture_default_str();
  c->add_option("--camera-model", args->camera_model_file, "A .cameramodel to see the board through instead");
  c->add_option("--board", args->board_text, "Inner corners per row x rows")->capture_default_str();
  c->add_option("--spacing", args->board.spacing_m, "Distance between neighbouring corners, metres")
      ->capture_default_str();
  c->add_option("--views", args->views.views, "Number of views")->capture_default_str();
  AddSeedOption(c, &args->views.seed, "Seed of the poses and the noise: same seed, same bytes");
  c->add_option("--coverage", args->views.coverage,
                "How far toward the imager's corners and edges the boards reach, (0, 1]: 1 the whole\n"
                "imager, less a poorer set")
      ->capture_default_str();
  c->add_option("--region", args->region_text,
                "The part of the imager the boards stay in, x0,x1,y0,y1 as fractions of its width and\n"
                "height (y from the top); the rest sees no board")
      ->capture_default_str();
  c->add_option("--noise", args->views.noise_sigma, "Gaussian noise, grey levels")->capture_default_str();
  c->add_option("--blur-px", args->views.blur_sigma_px, "Gaussian blur of the optics, pixels")->capture_default_str();
  c->add_option("--threads", args->views.threads, "Render workers (0: every core); output does not depend on it")
      ->check(NonNegativeWhole())
      ->capture_default_str();
  c->add_flag("--quiet", args->quiet, "No progress lines");
  return {c, [args] { return RunChessboard(*args, std::cout, std::cerr); }};
}

// synth, then truth and chessboard.
std::vector<Command> AddSynthCommands(CLI::App& app) {
  return {AddSynthCommand(app), AddTruthCommand(app), AddChessboardCommand(app)};
}

}  // namespace hdabench::tools
