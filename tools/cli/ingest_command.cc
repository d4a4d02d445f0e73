// `hdabench ingest stereolunar`: convert a StereoLunar nadir pair
// (datasets/stereolunar.h, docs/stereolunar.md) and write it as a dataset;
// `hdabench ingest field`: a field campaign's log (datasets/field_log.h,
// docs/field-ingest.md); `hdabench export field`: a dataset as such a log.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "tools/util/text.h"
#include "tools/cli/command_support.h"
#include "datasets/dataset.h"
#include "datasets/field_log.h"
#include "datasets/planar_target.h"
#include "datasets/stereolunar.h"
#include "tools/cli/command_line.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace {

// kExitOk when `dir` does not exist or is an empty folder; otherwise says so
// and returns kExitUsage.
int RequireNewFolder(const std::string& dir, const std::string& command, std::ostream& err) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(dir, ec) && (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec))) {
    err << command << dir << ": exists and is not an empty folder; choose a new folder\n";
    return kExitUsage;
  }
  return kExitOk;
}

// What was written must load cleanly; anything else is a bug in the bench
// (kExitInternal, the problems printed).
int CheckWrittenDataset(const std::string& dir, const std::string& command, std::ostream& err) {
  const datasets::DatasetLoadResult check = datasets::LoadDataset(dir);
  if (check.Ok()) return kExitOk;
  err << command << "internal error: the written dataset has " << check.problems.size() << " problem(s):\n";
  for (const datasets::Problem& problem : check.problems) err << problem.ToString() << "\n";
  return kExitInternal;
}

}  // namespace

int RunIngestStereoLunar(const IngestStereoLunarOptions& options, std::ostream& out,
                         std::ostream& err) {
  const std::string command = "hdabench ingest stereolunar: ";
  const std::string& dir = options.out_dir;
  if (const int code = RequireNewFolder(dir, command, err); code != kExitOk) return code;
  if (options.sun < 0) {
    err << command << "--sun " << options.sun << ": expected 0, 1 or 2\n";
    return kExitUsage;
  }
  // Empty: the frames' .npz, else the default cameras.txt.
  const std::string cameras = options.cameras_file;
  try {
    const datasets::Dataset dataset =
        datasets::ConvertStereoLunarPair(options.pair_dir, cameras, options.sun);
    datasets::WriteDataset(dataset, dir);
    if (const int code = CheckWrittenDataset(dir, command, err); code != kExitOk) return code;
    out << "wrote dataset '" << dataset.name << "' to " << dir << ": 2 frames ("
        << dataset.camera.WidthPx() << " x " << dataset.camera.HeightPx() << " px), baseline "
        << dataset.BaselineM(0, 1) << " m, LRF range " << dataset.lrf.front().range_m
        << " m, truth points and navigation\n";
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  return kExitOk;
}

int RunIngestField(const IngestFieldOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench ingest field: ";
  const std::string& dir = options.out_dir;
  if (const int code = RequireNewFolder(dir, command, err); code != kExitOk) return code;
  try {
    datasets::FieldIngestReport report;
    const datasets::Dataset dataset = datasets::IngestFieldLog(options.log_file, &report);
    datasets::WriteDataset(dataset, dir);
    if (const int code = CheckWrittenDataset(dir, command, err); code != kExitOk) return code;
    for (const std::string& line : report.lines) out << "  " << line << "\n";
    const int last = static_cast<int>(dataset.frames.size()) - 1;
    out << "wrote dataset '" << dataset.name << "' to " << dir << ": " << report.frames_kept << " of "
        << report.frames_found << " frames (" << dataset.camera.WidthPx() << " x "
        << dataset.camera.HeightPx() << " px) over " << dataset.frames[static_cast<size_t>(last)].time_s -
                                                          dataset.frames.front().time_s
        << " s, first to last baseline " << dataset.BaselineM(0, last) << " m, ";
    if (dataset.lrf.empty()) {
      out << "no LRF (the flight method takes the range from the navigation)";
    } else {
      out << "LRF range at the first " << dataset.LrfRangeAt(dataset.frames.front().time_s) << " m";
    }
    out << ", no truth\n";
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  return kExitOk;
}

int RunIngestTarget(const IngestTargetOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench ingest target: ";
  calib::ChessboardSpec board;
  if (!ParseBoardSize(options.board, &board.width, &board.height) || board.width < 2 || board.height < 2) {
    err << command << "--board '" << options.board
        << "': expected inner corners per row x rows, e.g. 9x6 (each at least 2)\n";
    return kExitUsage;
  }
  board.spacing = options.spacing;
  if (!(options.spacing > 0.0) || !std::isfinite(options.spacing)) {
    err << command << "--spacing " << options.spacing << ": expected a positive length\n";
    return kExitUsage;
  }
  calib::CornerDetector detector = calib::CornerDetector::kAuto;
  try {
    detector = calib::ParseCornerDetector(options.detector);
  } catch (const InputError& e) {
    err << command << "--detector: " << e.what() << "\n";
    return kExitUsage;
  }
  const std::string& dir = options.out_dir;
  if (const int code = RequireNewFolder(dir, command, err); code != kExitOk) return code;
  return WithExitCodes(command, err, [&] {
    const calib::CameraModel camera1 = calib::CameraModel::Load(options.camera1);
    const calib::CameraModel camera2 =
        options.camera2.empty() ? camera1 : calib::CameraModel::Load(options.camera2);
    const datasets::PlanarTargetPair pair = datasets::MakePlanarTargetPair(
        options.image1, camera1, options.image2, camera2, board, detector, options.name);
    for (int i = 0; i < 2; ++i) {
      const datasets::PlanarTargetView& view = pair.view[i];
      out << "  image " << i + 1 << " " << view.image_path << ": PnP reprojection RMS "
          << util::FixedText(view.reprojection_rms_px, 3) << " px (max "
          << util::FixedText(view.reprojection_max_px, 3) << "), range " << util::FixedText(view.range_m, 3)
          << " along the axis, board tilted " << util::FixedText(view.tilt_deg, 1) << " deg to it\n";
    }
    if (pair.has_calibrated_extrinsics) {
      out << "  PnP relative pose against the models' extrinsics: rotation "
          << util::FixedText(pair.extrinsics_rotation_diff_deg, 3) << " deg, translation "
          << util::FixedText(pair.extrinsics_translation_diff, 4) << "\n";
    }
    datasets::WriteDataset(pair.dataset, dir);
    if (const int code = CheckWrittenDataset(dir, command, err); code != kExitOk) return code;
    out << "wrote dataset '" << pair.dataset.name << "' to " << dir << ": 2 frames ("
        << camera1.WidthPx() << " x " << camera1.HeightPx() << " px), baseline "
        << util::FixedText(pair.dataset.BaselineM(0, 1), 4) << ", truth: the board's plane\n";
    const cv::Rect& box = pair.board_box_px;
    out << "the board as one ROI: hdabench run " << dir << " --roi " << box.x << "," << box.y << ","
        << box.width << "," << box.height << " --out DIR\n";
    return kExitOk;
  });
}

int RunExportField(const ExportFieldOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench export field: ";
  datasets::Geodetic origin;
  {
    // An empty item (a trailing comma) is refused as any other.
    std::vector<double> values;
    for (const std::string_view item : util::SplitAtCommas(options.origin_text)) {
      double v = 0.0;
      values.push_back(util::ParseDouble(item, &v) == util::ParseStatus::kOk ? v : std::nan(""));
    }
    // Heights from 100 km below the ellipsoid to 1000 km above it: beyond
    // them the local frame's round trip through WGS84 loses the positions, or
    // the log's heights pass the 1e7 m that ingest field takes.
    if (values.size() != 3 || !std::isfinite(values[0]) || !std::isfinite(values[1]) || !std::isfinite(values[2]) ||
        std::abs(values[0]) > 90.0 || std::abs(values[1]) > 180.0 || values[2] < -1e5 || values[2] > 1e6) {
      err << command << "--origin '" << options.origin_text
          << "': expected LAT,LON,HEIGHT (degrees in [-90, 90] and [-180, 180], metres in [-1e5, 1e6])\n";
      return kExitUsage;
    }
    origin = {values[0], values[1], values[2]};
  }
  if (!std::isfinite(options.clock_offset_s)) {
    err << command << "--clock-offset-s: expected a finite number\n";
    return kExitUsage;
  }
  // Not among the dataset's files, nor over another command's results.
  if (const int code = CheckOutputFolder(options.out_dir, options.dataset_dir, "", command, err); code != kExitOk) {
    return code;
  }
  datasets::LoadOptions load;
  load.keep_images = true;
  const std::optional<datasets::Dataset> dataset =
      LoadDatasetOrReport(options.dataset_dir, load, "export field", err);
  if (!dataset) return kExitInput;
  try {
    datasets::WriteFieldLog(*dataset, options.out_dir, origin, options.clock_offset_s);
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  out << "wrote the field log of '" << dataset->name << "' to " << options.out_dir << ": "
      << dataset->frames.size() << " images, " << dataset->nav.size() << " navigation and "
      << dataset->lrf.size() << " LRF samples (log.json; hdabench ingest field reads it back)\n";
  return kExitOk;
}

// ingest: stereolunar (PAIR_DIR, --out, --sun, --cameras), field (LOG, --out) and
// target (IMAGE1, IMAGE2, the cameras, the board, --out);
// export: field (DATASET, --out, --origin, --clock-offset-s).
std::vector<Command> AddIngestCommands(CLI::App& app) {
  CLI::App* ingest = app.add_subcommand("ingest", "Convert outside data into a dataset");
  ingest->require_subcommand(1);
  const auto options = std::make_shared<IngestStereoLunarOptions>();
  CLI::App* stereolunar = ingest->add_subcommand(
      "stereolunar",
      "Convert one sun position of a StereoLunar nadir pair (docs/stereolunar.md) into a dataset");
  stereolunar->add_option("PAIR_DIR", options->pair_dir, "Pair folder (im_NNNNN.jpg and .exr)")
      ->required();
  stereolunar->add_option("--out", options->out_dir,
                          "Folder to create (must not exist, or be empty)")
      ->required();
  stereolunar->add_option("--sun", options->sun, "Sun position, 0-based (0, 1 or 2)")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  stereolunar->add_option(
      "--cameras", options->cameras_file,
      "cameras.txt instead of the frames' .npz (default: each frame's im_NNNNN.npz, as the dataset\n"
      "ships; without them PAIR_DIR/cameras.txt, else PAIR_DIR/../cameras.txt)");
  Command stereolunar_command{stereolunar,
                             [options] { return RunIngestStereoLunar(*options, std::cout, std::cerr); }};
  const auto field_options = std::make_shared<IngestFieldOptions>();
  CLI::App* field = ingest->add_subcommand(
      "field",
      "Convert a field campaign's log (images, navigation, LRF, camera model, mount; described by\n"
      "one JSON file, docs/field-ingest.md) into a dataset");
  field->add_option("LOG", field_options->log_file, "The field log description (JSON)")->required();
  field->add_option("--out", field_options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  Command field_command{field, [field_options] { return RunIngestField(*field_options, std::cout, std::cerr); }};

  const auto target_options = std::make_shared<IngestTargetOptions>();
  CLI::App* target = ingest->add_subcommand(
      "target",
      "Two images of a chessboard (one camera moved, or a stereo pair) as a dataset: navigation by\n"
      "PnP on each image, truth the board's plane (docs/planar-target.md)");
  target->add_option("IMAGE1", target_options->image1, "First image of the board (frame 0)")->required();
  target->add_option("IMAGE2", target_options->image2, "Second image (frame 1)")->required();
  target->add_option("--camera1", target_options->camera1, "IMAGE1's mrcal .cameramodel")->required();
  target->add_option("--camera2", target_options->camera2,
                     "IMAGE2's .cameramodel (default: --camera1); image 2 is resampled into camera 1's model");
  target->add_option("--board", target_options->board, "Inner corners per row x rows, e.g. 9x6")->required();
  target->add_option("--spacing", target_options->spacing,
                     "Distance between neighbouring corners: the unit of every length in the dataset")
      ->capture_default_str();
  target->add_option("--detector", target_options->detector,
                     "Corner detector: auto (mrgingham for square boards, else OpenCV), opencv, mrgingham")
      ->capture_default_str();
  target->add_option("--name", target_options->name, "Dataset name (default: from the image names)");
  target->add_option("--out", target_options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  Command target_command{target, [target_options] { return RunIngestTarget(*target_options, std::cout, std::cerr); }};

  // export field: the opposite, a dataset as a field log.
  CLI::App* export_app = app.add_subcommand("export", "Write a dataset in an outside format");
  export_app->require_subcommand(1);
  const auto export_options = std::make_shared<ExportFieldOptions>();
  CLI::App* export_field = export_app->add_subcommand(
      "field",
      "Write a dataset as a field log (docs/field-ingest.md) that hdabench ingest field reads back:\n"
      "WGS84 navigation, Euler angles, the clock offset, the LRF log, images named by time");
  export_field->add_option("DATASET", export_options->dataset_dir, "Dataset folder")->required();
  export_field->add_option("--out", export_options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  export_field->add_option("--origin", export_options->origin_text,
                           "WGS84 latitude (deg), longitude (deg), height (m) of the dataset's local origin")
      ->capture_default_str();
  export_field->add_option("--clock-offset-s", export_options->clock_offset_s,
                           "Navigation time minus image time written into the log, seconds")
      ->capture_default_str();
  Command export_command{export_field,
                         [export_options] { return RunExportField(*export_options, std::cout, std::cerr); }};
  return {stereolunar_command, field_command, target_command, export_command};
}

}  // namespace hdabench::tools
