// `hdabench calibrate` and `hdabench calib-diff` (calib/calibrate.h,
// calib/calibration_analysis.h, docs/calibration.md).
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
#include <nlohmann/json.hpp>

#include "calib/calibrate.h"
#include "calib/calibration_analysis.h"
#include "calib/camera_model.h"
#include "hda/calibration_sigma.h"
#include "reference/flight/calibration_check.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/text.h"

namespace hdabench::tools {

namespace {

// The calibration's slope figure through the flight method's own steps.
calib::HdaTiltFunction HdaTiltOfTheFlightMethod() {
  return [](const calib::CameraModel& truth, const calib::CameraModel& believed, const Eigen::Vector3d& rotation_rad,
            const calib::HdaGeometry& geometry) {
    return reference::HdaGeometryTiltDeg(reference::MakeHdaGeometrySite(truth, geometry), believed, rotation_rad);
  };
}

}  // namespace

int RunCalibrate(const CalibrateCommandOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench calibrate: ";
  calib::CalibrateOptions calibrate;
  if (!ParseBoardSize(options.board, &calibrate.board.width, &calibrate.board.height) ||
      calibrate.board.width < 2 || calibrate.board.height < 2) {
    err << command << "--board '" << options.board
        << "': expected inner corners per row x rows, e.g. 9x6 (each at least 2)\n";
    return kExitUsage;
  }
  calibrate.board.spacing = options.spacing;
  calibrate.images = options.images;
  calibrate.pair_images = options.pair_images;
  calibrate.lensmodel = options.lensmodel;
  calibrate.focal_px = options.focal_px;
  calibrate.min_views = options.min_views;
  calibrate.out_dir = options.out_dir;
  calibrate.analysis.hda.range_m = options.hda_range_m;
  calibrate.analysis.hda.baseline_m = options.hda_baseline_m;
  calibrate.analysis.hda.site_m = options.hda_site_m;
  calibrate.analysis.slope_samples = options.slope_samples;
  calibrate.analysis.hda_tilt_deg = HdaTiltOfTheFlightMethod();
  calibrate.slope_share = options.slope_share;
  calibrate.method_slope_sigma_deg = options.method_sigma_deg;
  calibrate.analysis.seed = options.seed;
  try {
    calibrate.detector = calib::ParseCornerDetector(options.detector);
  } catch (const InputError& e) {
    err << command << "--detector: " << e.what() << "\n";
    return kExitUsage;
  }
  // Flag values are checked before any image is read: a bad flag is a usage error.
  std::vector<std::string> problems = calibrate.Validate();
  for (const std::string& p : calibrate.analysis.Validate()) problems.push_back(p);
  if (!problems.empty()) {
    for (const std::string& p : problems) err << command << p << "\n";
    return kExitUsage;
  }
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::exists(options.out_dir, ec) &&
      (!fs::is_directory(options.out_dir, ec) || !fs::is_empty(options.out_dir, ec))) {
    err << command << options.out_dir << ": exists and is not an empty folder; choose a new folder\n";
    return kExitUsage;
  }
  if (!options.quiet) {
    calibrate.progress = [&err](const std::string& line) { err << "calibrate: " << line << "\n"; };
  }
  return WithExitCodes(command, err, [&] {
    const calib::CalibrateResult result = calib::Calibrate(calibrate);
    out << calib::CalibrationSummaryMarkdown(calibrate, result);
    out << "\nwrote " << result.model_paths.size() << " model(s) and the summary to "
        << options.out_dir << " (detection " << util::FixedText(result.detection_s, 1) << " s, mrcal "
        << util::FixedText(result.mrcal_s, 1) << " s, analysis " << util::FixedText(result.analysis_s, 1)
        << " s)\n";
  });
}

namespace {

// calib-diff in slope terms: at calibrate's HDA geometry (a 10 m site at
// 570 m, 30 m baseline, the band's centre), the tilt of the plane the flight
// method's steps fit with B (its implied rotation from A taken out) when A is
// the lens, and A's calibration sigma there when A holds its calibration.
// Added to the diff's JSON as "hda_slope"; returns the line to print.
std::string SlopeDifferenceAtHdaGeometry(const std::string& path_a, const calib::CameraModel& a,
                                         const calib::CameraModel& b, const calib::ProjectionDiff& diff) {
  const calib::HdaGeometry geometry;
  const reference::HdaGeometrySite site = reference::MakeHdaGeometrySite(a, geometry);
  const double tilt_deg = reference::HdaGeometryTiltDeg(site, b, diff.rotation_rad);
  nlohmann::ordered_json slope = {{"range_m", geometry.range_m},
                                  {"baseline_m", geometry.baseline_m},
                                  {"site_m", geometry.site_m},
                                  {"tilt_deg", std::isfinite(tilt_deg) ? nlohmann::ordered_json(tilt_deg)
                                                                       : nlohmann::ordered_json(nullptr)}};
  std::ostringstream line;
  line << "  at the HDA geometry (a " << util::ShortestText(geometry.site_m) << " m site at "
       << util::ShortestText(geometry.range_m) << " m, " << util::ShortestText(geometry.baseline_m)
       << " m baseline, the band's centre), B tilts the flight method's plane by "
       << (std::isfinite(tilt_deg) ? util::FixedText(tilt_deg, 4) + " deg" : std::string("- (no plane)"))
       << " against A";
  if (calib::ModelHasOptimizationInputs(path_a)) {
    const calib::IntrinsicsModes modes = calib::ComputeIntrinsicsModes(path_a);
    const hda::CalibrationSigma sigma = hda::SiteCalibrationSigma(site.input, a, hda::HdaOptions(), modes,
                                                                  site.box1_px, site.points1_px, site.points2_px, 0.0);
    if (sigma.available) {
      slope["a_calibration_tilt_sigma_deg"] = sigma.tilt_deg;
      line << "; A's calibration sigma there " << util::FixedText(sigma.tilt_deg, 4) << " deg";
      if (std::isfinite(tilt_deg) && sigma.tilt_deg > 0.0) {
        slope["sigmas"] = tilt_deg / sigma.tilt_deg;
        line << ": " << util::FixedText(tilt_deg / sigma.tilt_deg, 2) << " sigma"
             << (tilt_deg <= 2.0 * sigma.tilt_deg ? ", within what A could tell"
                                                  : ", beyond what A could tell: the slopes change");
      }
    } else {
      slope["a_calibration_tilt_sigma_deg"] = nullptr;
      line << "; A's calibration sigma: none (" << sigma.why << ")";
    }
  } else {
    slope["a_calibration_tilt_sigma_deg"] = nullptr;
    line << "; A holds no optimization_inputs: no calibration sigma to compare with";
  }
  std::string bytes, error;
  if (!util::ReadFileBytes(diff.json_path, &bytes, &error)) throw InputError(diff.json_path + ": " + error);
  nlohmann::ordered_json record = nlohmann::ordered_json::parse(bytes);
  record["hda_slope"] = slope;
  util::WriteFileAtomically(diff.json_path, record.dump(2) + "\n");
  return line.str();
}

}  // namespace

int RunCalibDiff(const CalibDiffCommandOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench calib-diff: ";
  calib::DiffOptions diff;
  diff.gridn = options.gridn;
  diff.with_uncertainty_of_a = options.with_uncertainty;
  const std::vector<std::string> problems = diff.Validate();
  if (!problems.empty()) {
    for (const std::string& p : problems) err << command << p << "\n";
    return kExitUsage;
  }
  // Both must be models the bench itself can use; they are read before the
  // output folder is made, so a refused diff leaves nothing behind.
  std::optional<calib::CameraModel> a;
  std::optional<calib::CameraModel> b;
  if (const int code = WithExitCodes(command, err,
                                     [&] {
                                       a.emplace(calib::CameraModel::Load(options.model_a));
                                       b.emplace(calib::CameraModel::Load(options.model_b));
                                     });
      code != kExitOk) {
    return code;
  }
  if (a->WidthPx() != b->WidthPx() || a->HeightPx() != b->HeightPx()) {
    err << command << options.model_b << ": imager " << b->WidthPx() << " x " << b->HeightPx() << " differs from "
        << options.model_a << ": " << a->WidthPx() << " x " << a->HeightPx()
        << "; the projection difference needs equal imager sizes\n";
    return kExitInput;
  }
  // A grid finer than A's pixels adds nothing but memory (mrcal holds every point).
  if (options.gridn > a->WidthPx()) {
    err << command << "--gridn " << options.gridn << ": more grid points across than the " << a->WidthPx()
        << " pixels of " << options.model_a << "'s imager\n";
    return kExitUsage;
  }
  namespace fs = std::filesystem;
  const fs::path dir(options.out_dir);
  std::error_code ec;
  const NewFolders made_here(dir);
  fs::create_directories(dir, ec);
  std::error_code kind_error;
  if (ec || !fs::is_directory(dir, kind_error)) {
    err << command << "--out " << options.out_dir << ": cannot create the output folder: "
        << (fs::exists(dir, kind_error) ? std::string("it exists and is not a folder") : ec.message()) << "\n";
    return kExitInput;
  }
  const int code = WithExitCodes(command, err, [&] {
    const calib::ProjectionDiff result = calib::DiffCalibrations(
        options.model_a, options.model_b, (dir / "calib-diff.json").string(),
        (dir / "calib-diff.png").string(), diff);
    out << "projection difference " << options.model_a << " -> " << options.model_b << " ("
        << a->LensModelName() << " -> " << b->LensModelName() << ", " << a->WidthPx() << " x "
        << a->HeightPx() << " px, " << result.points << " grid points, implied rotation "
        << util::FixedText(result.rotation_deg, 4) << " deg taken out):\n"
        << "  median " << util::FixedText(result.median_px, 3) << " px, p90 " << util::FixedText(result.p90_px, 3)
        << " px, max " << util::FixedText(result.max_px, 3) << " px\n";
    if (result.uncertainty_of_a) {
      const calib::DiffUncertainty& u = *result.uncertainty_of_a;
      out << "  A's projection uncertainty (1 sigma): median " << util::FixedText(u.median_px, 3) << " px, max "
          << util::FixedText(u.max_px, 3) << " px; difference within 1/2/3 sigma at "
          << util::FixedText(100 * u.within_1_sigma, 0) << " / " << util::FixedText(100 * u.within_2_sigma, 0) << " / "
          << util::FixedText(100 * u.within_3_sigma, 0) << " % of the grid\n";
    }
    out << SlopeDifferenceAtHdaGeometry(options.model_a, *a, *b, result) << "\n";
    out << "wrote " << result.json_path << " and " << result.heatmap_png << "\n";
  });
  if (code != kExitOk) made_here.Remove();
  return code;
}

namespace {

// calibrate: IMAGES, --pair, the board, mrcal's options, --out and the HDA
// geometry of the slope-error figure.
Command AddCalibrateCommand(CLI::App& app) {
  const auto options = std::make_shared<CalibrateCommandOptions>();
  CLI::App* calibrate = app.add_subcommand(
      "calibrate",
      "Calibrate a camera (or a pair) from chessboard images with mrcal, and judge the result\n"
      "(docs/calibration.md)");
  calibrate->add_option("IMAGES", options->images, "Chessboard images of the camera")->required();
  calibrate->add_option("--pair", options->pair_images,
                        "Images of a second camera calibrated together with the first: one per "
                        "image, in the same order");
  calibrate->add_option("--board", options->board,
                        "Inner corners per row x rows, e.g. 9x6 (OpenCV's patternSize)")
      ->required();
  calibrate->add_option("--spacing", options->spacing,
                        "Distance between neighbouring corners (metres, or 1 for squares)")
      ->required();
  calibrate->add_option("--lensmodel", options->lensmodel,
                        "mrcal lens model, e.g. LENSMODEL_OPENCV8 or\n"
                        "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100")
      ->capture_default_str();
  calibrate->add_option("--detector", options->detector,
                        "Corner detector: auto (mrgingham for square boards, else OpenCV), opencv, "
                        "mrgingham")
      ->capture_default_str();
  calibrate->add_option("--focal-px", options->focal_px,
                        "Focal-length seed for mrcal in pixels (0: estimated from the corners)")
      ->capture_default_str();
  calibrate->add_option("--min-views", options->min_views,
                        "Fewest images with the whole board, per camera")
      ->capture_default_str();
  calibrate->add_option("--out", options->out_dir, "Folder to create (must not exist, or be empty)")
      ->required();
  calibrate->add_option("--hda-range-m", options->hda_range_m,
                        "HDA geometry of the slope-error figure: range to the site, m")
      ->capture_default_str();
  calibrate->add_option("--hda-baseline-m", options->hda_baseline_m,
                        "HDA geometry: baseline between the two images, m")
      ->capture_default_str();
  calibrate->add_option("--hda-site-m", options->hda_site_m, "HDA geometry: landing-site side, m")
      ->capture_default_str();
  calibrate->add_option("--method-sigma-deg", options->method_sigma_deg,
                        "The flight method's own slope sigma S (e.g. the median slope_sigma_deg of a run):\n"
                        "the verdict states the projection uncertainty the calibration may have for its\n"
                        "slope term to stay under --slope-share of S (0: stated per degree of S)")
      ->capture_default_str();
  calibrate->add_option("--slope-share", options->slope_share,
                        "The share of the method's slope sigma the calibration's slope term may reach")
      ->capture_default_str();
  calibrate->add_option("--slope-samples", options->slope_samples,
                        "Monte Carlo re-solves behind the slope-error figure")
      ->capture_default_str();
  AddSeedOption(calibrate, &options->seed, "Random seed of mrcal's starting values and of the Monte Carlo noise");
  calibrate->add_flag("--quiet", options->quiet, "No progress lines");
  return {calibrate, [options] { return RunCalibrate(*options, std::cout, std::cerr); }};
}

// calib-diff: models A and B, --out, --gridn and --with-uncertainty.
Command AddCalibDiffCommand(CLI::App& app) {
  const auto options = std::make_shared<CalibDiffCommandOptions>();
  CLI::App* calib_diff = app.add_subcommand(
      "calib-diff", "Projection difference between two calibrations of one camera (median, max, "
                    "heat map)");
  calib_diff->add_option("A", options->model_a, "The reference .cameramodel (e.g. the last one)")
      ->required();
  calib_diff->add_option("B", options->model_b, "The .cameramodel to compare with it")->required();
  calib_diff->add_option("--out", options->out_dir,
                         "Folder for calib-diff.json and calib-diff.png (created if missing)")
      ->required();
  calib_diff->add_option("--gridn", options->gridn, "Grid points across the imager's width")
      ->capture_default_str();
  calib_diff->add_flag("--with-uncertainty", options->with_uncertainty,
                       "Also A's projection uncertainty on the grid, and how much of the "
                       "difference it covers (A must come from a calibration)");
  return {calib_diff, [options] { return RunCalibDiff(*options, std::cout, std::cerr); }};
}

}  // namespace

// calibrate, then calib-diff.
std::vector<Command> AddCalibrateCommands(CLI::App& app) {
  return {AddCalibrateCommand(app), AddCalibDiffCommand(app)};
}

}  // namespace hdabench::tools
