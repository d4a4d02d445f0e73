// Calibration of a stand-in camera (or a pair of cameras) from chessboard
// images, with mrcal, and the bench's own judgement of the result.
//
// Steps (docs/calibration.md):
//  1. Each image is read and searched for the board (calib/chessboard.h). An
//     image that cannot be read, has no board, or differs in size from the
//     camera's first image is rejected with the reason; the rest are used.
//  2. Fewer than `min_views` usable views for a camera stops the calibration
//     (InputError) before anything runs: no model is written.
//  3. The corners go to mrcal's corners.vnl under names mrcal's globs can pair
//     (cam0-NNN.ext, cam1-NNN.ext: NNN is the image's position in its list, so
//     the i-th images of the two lists are one moment for a pair).
//  4. `mrcal-calibrate-cameras` runs through Debian's python3 with the lens
//     model, the board and a focal-length seed (OpenCV's
//     cv::initCameraMatrix2D on the same corners, unless given).
//  5. The analysis (calib/calibration_analysis.h): residuals, outliers,
//     coverage, projection uncertainty in the HDA band, the slope error the
//     calibration alone would cause at the HDA geometry, and the OpenCV
//     cross-check.
//  6. Each model must load through the bench's own reader (CameraModel::Load)
//     before it is moved into the output folder; a calibration that fails
//     before that leaves no .cameramodel in it. Should the analysis then fail,
//     the models move to out_dir/unanalysed/: kept, but not where a judged
//     model would be.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "calib/calibration_analysis.h"
#include "calib/chessboard.h"

namespace hdabench::calib {

struct CalibrateOptions {
  // Images of camera 0, in order. For a pair, `pair_images` holds camera 1's,
  // the i-th of each list taken at the same moment.
  std::vector<std::string> images;
  std::vector<std::string> pair_images;
  ChessboardSpec board;
  // A full mrcal lens model name (e.g. LENSMODEL_OPENCV8 or
  // LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100).
  std::string lensmodel = "LENSMODEL_OPENCV8";
  CornerDetector detector = CornerDetector::kAuto;
  // Initial focal length in pixels for mrcal's solve; 0: estimated from the
  // corners (cv::initCameraMatrix2D).
  double focal_px = 0.0;
  // Fewest views with the whole board, per camera, to attempt a calibration.
  // A lens model with 12 intrinsics seen in fewer than 5 board poses is
  // barely constrained, whatever the residuals say.
  int min_views = 5;
  // Output folder: created; must not exist or be empty.
  std::string out_dir;
  // The interpreter mrcal's tools run under, and mrcal-calibrate-cameras (a
  // path, or a name looked up on PATH).
  std::string python = "/usr/bin/python3";
  std::string mrcal_calibrate = "mrcal-calibrate-cameras";
  // Wall-time limit of mrcal-calibrate-cameras, seconds (> 0).
  double mrcal_timeout_s = 900.0;
  AnalysisOptions analysis;
  // How good the calibration must be (docs/calibration.md, "How good must the
  // calibration be?"): its slope term may be at most `slope_share` (in
  // (0, 1]) of the flight method's own slope sigma, `method_slope_sigma_deg`
  // (> 0; 0: not given, and the requirement is stated per degree of it).
  double slope_share = 0.1;
  double method_slope_sigma_deg = 0.0;
  // Called with one line per step (may be empty: no progress).
  std::function<void(const std::string&)> progress;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// What happened to one input image.
struct ImageUse {
  std::string path;        // as given
  std::string name;        // the name in corners.vnl and mrcal's model (cam0-001.png)
  int camera = 0;          // 0, or 1 for the pair's images
  bool used = false;       // the board was found and the view went to mrcal
  std::string reason;      // why not, when not used
  std::string detector;    // "opencv" or "mrgingham" when the board was found
  int width_px = 0;        // image size (0 when unreadable)
  int height_px = 0;
};

// What one camera's calibration must reach at the HDA geometry. The slope
// term grows in proportion to the projection uncertainty (first order), so
// the HDA band's median projection uncertainty may be at most
// band_median_px * share * S / slope_rms_deg for a method sigma S.
struct CalibrationRequirement {
  bool available = false;          // the analysis gave both figures
  double share = 0.1;
  double band_median_px = 0.0;     // mrcal's, worst direction, over the band
  double slope_rms_deg = 0.0;      // the slope Monte Carlo's RMS
  double allowed_px_per_deg = 0.0; // the allowed band median per degree of the method's sigma
  double method_sigma_deg = 0.0;   // 0: not given
  double allowed_px = 0.0;         // with method_sigma_deg
};

// The requirement of one camera's analysis (not available without its
// uncertainty or slope figure).
CalibrationRequirement RequirementOf(const CameraAnalysis& camera, double share, double method_sigma_deg);

struct CalibrateResult {
  std::vector<ImageUse> images;
  // One per camera: out_dir/camera-N.cameramodel.
  std::vector<std::string> model_paths;
  int imager_width_px = 0;
  int imager_height_px = 0;
  double focal_seed_px = 0.0;
  // mrcal-calibrate-cameras's own figures, as it printed them (per coordinate,
  // not per corner; see the analysis for per-corner figures); NaN when its
  // output had no such line.
  double mrcal_rms_px = 0.0;
  double mrcal_worst_px = 0.0;
  CalibrationAnalysis analysis;
  std::vector<CalibrationRequirement> requirements;  // one per camera of the analysis
  double detection_s = 0.0;
  double mrcal_s = 0.0;
  double analysis_s = 0.0;
  std::string summary_json;      // out_dir/calibration.json
  std::string summary_markdown;  // out_dir/summary.md
};

// Runs the whole calibration. Throws InputError for unusable options or
// inputs (too few usable views included: the message lists every image and
// why it was rejected) and ExternalError when mrcal's tool or the analysis
// fails (the message names the log). Detections, corners.vnl and logs stay in
// out_dir after a failure; out_dir/camera-N.cameramodel only appear when
// everything succeeded.
CalibrateResult Calibrate(const CalibrateOptions& options);

// One line per finding for a person deciding whether the calibration is good
// enough for the HDA (docs/calibration.md, "Verdict"): residual RMS against
// 0.5 px per corner, corners over the whole HDA band, and the slope error the
// calibration alone causes at the HDA geometry (p90 at most 0.1 deg: not the
// limit; at most 0.5 deg: noticeable; above: the calibration limits the slope).
std::vector<std::string> CalibrationVerdict(const CalibrateResult& result);

// The summary a person reads (summary.md), from a result.
std::string CalibrationSummaryMarkdown(const CalibrateOptions& options, const CalibrateResult& result);

}  // namespace hdabench::calib
