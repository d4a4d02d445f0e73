// What a mrcal calibration is worth for the HDA: reprojection residuals,
// imager coverage, mrcal's projection uncertainty over the HDA band, the slope
// error the calibration's uncertainty alone would cause at the HDA geometry, an
// OpenCV cross-check, and the projection difference between two calibrations.
//
// The work is done by calib/calibration_analysis.py, compiled into the library
// and run with Debian's /usr/bin/python3 (which sees python3-mrcal, numpy,
// OpenCV and matplotlib) through util::PythonScript, with a time limit and a
// clean matplotlib configuration. The script writes a JSON record (format
// "hdabench-calibration-analysis" or "hdabench-calibration-diff", version 1)
// that is read back here; the same inputs and options give the same bytes.
//
// Pixels follow mrcal (centre of the top-left pixel at (0,0)); every pixel
// figure is in pixels of the model's imager, angles in degrees. Projection
// uncertainties are mrcal's worst-direction standard deviation (1 sigma) of
// the projection of a direction at infinity. A "band" figure is taken over the
// HDA band (HdaGeometry). Paths to figures and models are the output folder
// joined with the path the JSON records (relative to the JSON's folder).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/intrinsics_modes.h"

namespace hdabench::calib {

// The HDA viewing geometry the analysis evaluates the calibration for.
struct HdaGeometry {
  double range_m = 570.0;    // slant range from the camera to the site centre, metres, > 0
  double baseline_m = 30.0;  // distance between the two camera positions, metres, > 0;
                             // perpendicular to the line of sight, along image x
  double site_m = 10.0;      // side of the square site, metres, > 0; the site is
                             // perpendicular to the line of sight through the band centre
  // The HDA band as fractions of the imager: x of the width (0 = left edge,
  // 1 = right edge), y of the height (0 = top edge). 0 <= x0 < x1 <= 1, same in y.
  double band_x0 = 0.25;
  double band_x1 = 0.75;
  double band_y0 = 0.40;
  double band_y1 = 0.80;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

class CameraModel;

// The tilt, degrees, of the plane the flight method's steps fit to the HDA
// site of `geometry` seen through the lens `truth`, with the camera model
// `believed` and its frame turned by `rotation_rad` (the implied rotation
// from the truth's frame): reference::HdaGeometryTiltDeg, which calib cannot
// call itself (it sits below the flight method). NaN when no plane is fitted.
using HdaTiltFunction = std::function<double(const CameraModel& truth, const CameraModel& believed,
                                             const Eigen::Vector3d& rotation_rad, const HdaGeometry& geometry)>;

struct AnalysisOptions {
  std::string python = "/usr/bin/python3";  // interpreter that sees Debian's mrcal, cv2, matplotlib
  double timeout_s = 900.0;                 // wall-time limit of the script, seconds, > 0
  HdaGeometry hda;
  int slope_samples = 30;  // Monte Carlo re-solves, >= 0 (0: no slope error)
  std::uint64_t seed = 1;  // seed of the Monte Carlo noise (numpy)
  // The slope error of each re-solve; without it the slope figure is left
  // out and its section says why (hdabench calibrate always gives it).
  HdaTiltFunction hda_tilt_deg;

  std::vector<std::string> Validate() const;
};

// ---------------------------------------------------------------- the analysis

struct ImageResiduals {
  std::string image;               // mrcal's imagepaths entry, or "observation N" without one
  int observation = 0;             // index of the board observation in the solve
  int corners = 0;                 // corners the detector found
  int inliers = 0;                 // corners the solve used
  int outliers = 0;                // found corners mrcal's outlier rejection threw out
  std::optional<double> rms_px;    // sqrt(mean(dx^2 + dy^2)) over the inliers; none without any
  std::optional<double> worst_px;  // largest inlier residual; none without inliers
};

struct ResidualSummary {
  double rms_px = 0;     // sqrt(mean(dx^2 + dy^2)) over the camera's inlier corners (per corner)
  double worst_px = 0;   // largest inlier residual
  double median_px = 0;  // median inlier residual
  double noise_stdev_px = 0;  // stdev of the inlier residual coordinates (the noise level)
  // mrcal-calibrate-cameras' printed "RMS error": sqrt(mean(x^2)) over the whole
  // measurement vector of the joint solve, i.e. per coordinate (x and y apart),
  // outliers counted as 0, regularization included; about rms_px / sqrt(2).
  double mrcal_rms_px = 0;
  int inliers = 0;
  int outliers = 0;      // found corners mrcal rejected
  int detected = 0;      // corners found: inliers + outliers
  int board_points = 0;  // board corners over the camera's images (found or not)
  std::vector<ImageResiduals> images;
};

struct CoverageSummary {
  int cells_x = 10;  // the imager is cut into cells_x x cells_y cells
  int cells_y = 10;
  double share = 0;                      // [0,1]: share of cells holding at least one inlier corner
  int band_cells = 0;                    // cells overlapping the HDA band by a positive area
  double band_share = 0;                 // [0,1]: share of those holding at least one inlier corner
  std::vector<std::vector<int>> counts;  // inlier corners per cell, [row][column], row 0 at the top
  std::string figure;                    // PNG: the imager with every corner, the band outlined
};

// mrcal's worst-direction projection stdev at infinity, pixels.
struct UncertaintySummary {
  double band_median_px = 0;  // over a 16 x 12 grid covering the band
  double band_max_px = 0;
  double band_centre_px = 0;    // at the band's centre
  double imager_centre_px = 0;  // at the imager's centre
  double imager_median_px = 0;  // over a 60-wide grid over the whole imager
  double imager_max_px = 0;
  std::string figure;  // PNG heat map over the imager, the band outlined
};

// The spread of the projection at the band centre over the Monte Carlo samples.
struct ProjectionSpread {
  std::optional<double> rms_px;  // RMS of the 2-D offsets
  std::optional<double>
      worst_direction_stdev_px;  // sqrt of the larger eigenvalue of their 2nd moment
};

// The slope error the calibration's uncertainty alone causes at the HDA
// geometry: the calibration is re-solved `samples` times with its inlier
// corners perturbed by Gaussian noise of its own residual level; the implied
// rotation between the nominal and each re-solved camera frame is fitted and
// taken out (the mount alignment is calibrated separately); the flight
// method's own steps (AnalysisOptions::hda_tilt_deg: nav rejection,
// triangulation with the known relative pose, its plane fit) fit the HDA
// site, a 10 x 10 grid projected exactly through the nominal model, with the
// re-solved model; the figure is the angle to the site's true normal.
struct SlopeErrorSummary {
  std::string error;  // why there is no result (e.g. 0 samples asked for); empty when done
  int samples = 0;    // re-solves asked for
  int ok = 0;         // re-solves that gave a slope error
  int failed = 0;     // re-solves that failed (counted, never fatal)
  std::vector<std::string> failures;  // up to 5 distinct failure messages
  std::optional<double> rms_deg;      // RMS slope error over the samples, degrees
  std::optional<double> median_deg;
  std::optional<double> p90_deg;
  std::optional<double> max_deg;
  std::optional<double>
      nominal_deg;  // the same machinery with the nominal model: its own error floor
  std::optional<double> rotation_fit_median_deg;  // median size of the taken-out rotation
  std::optional<double> noise_stdev_px;           // noise added per corner coordinate
  // At the band centre: after the fitted rotation (what the slope error sees),
  // and after the board-pose rotation (mrcal's convention: the like-for-like
  // check of mrcal's analytic stdev, mrcal_band_centre_stdev_px).
  ProjectionSpread fitted_rotation_spread;
  ProjectionSpread board_rotation_spread;
  std::optional<double> mrcal_band_centre_stdev_px;
  std::optional<double> convergence_deg;  // angle between the two lines of sight to the site
};

// A projection difference over the imager after the implied-rotation fit.
struct ProjectionDiffSummary {
  double median_px = 0;
  double p90_px = 0;
  double max_px = 0;
  std::optional<double> band_median_px;  // over the grid points inside the band
  std::optional<double> band_max_px;
  double rotation_deg = 0;  // size of the fitted rotation
  int grid_width = 0;       // grid points across and down the imager
  int grid_height = 0;
};

// cv2.calibrateCamera (CALIB_RATIONAL_MODEL) on every detected corner of the
// camera's images in the solve, against the mrcal model.
struct OpenCvCrossCheck {
  std::string model;  // the LENSMODEL_OPENCV8 model written from OpenCV's result
  int images = 0;
  int corners = 0;
  double rms_px = 0;           // OpenCV's own figure, over every corner it got
  double rms_inliers_px = 0;   // the same over mrcal's inliers only
  ProjectionDiffSummary diff;  // mrcal model vs OpenCV's
  std::string figure;          // PNG heat map of that difference
  // OpenCV again on mrcal's inliers only: separates the outliers' effect from
  // the solvers' (none when too few images keep 6 inliers).
  std::optional<double> inliers_only_rms_px;
  std::optional<ProjectionDiffSummary> inliers_only_diff;
};

struct CameraAnalysis {
  int index = 0;            // position in the list of models; names the files (camera-N)
  std::string model;        // the model's path as given
  int icam_intrinsics = 0;  // the camera's index in its solve
  std::string lensmodel;
  int width_px = 0;
  int height_px = 0;
  std::array<double, 4> band_px{};  // the HDA band in pixels: x0, x1, y0, y1
  ResidualSummary residuals;
  CoverageSummary coverage;
  std::optional<UncertaintySummary> uncertainty;  // none when mrcal cannot compute it
  std::string uncertainty_error;                  // why not; empty otherwise
  SlopeErrorSummary slope;
  std::optional<OpenCvCrossCheck> opencv;  // none when OpenCV failed
  std::string opencv_error;                // why; empty otherwise
};

// Pose of camera `camera` relative to camera `relative_to` (0), from the models'
// extrinsics; only meaningful, and only given, when both come from one solve.
struct RelativePose {
  int camera = 0;
  int relative_to = 0;
  bool same_solve = false;
  std::optional<double> baseline;  // board units (the object spacing's unit)
  std::optional<double> rotation_deg;
  std::optional<std::array<double, 3>> translation;  // camera's centre in relative_to's frame
};

struct CalibrationAnalysis {
  std::vector<CameraAnalysis> cameras;
  std::vector<RelativePose> relative_poses;  // cameras 1.. relative to camera 0
  std::string json_path;                     // out_dir/analysis.json
  std::string log_path;                      // out_dir/logs/analysis.log
  double wall_s = 0;                        // wall time of the script
};

// Analyses the models written by mrcal-calibrate-cameras (each must hold its
// optimization_inputs). Writes out_dir/analysis.json (atomically; an older
// one is removed first, so a failed run leaves none), out_dir/figures/*.png
// (coverage-camera-N, uncertainty-camera-N, opencv-diff-camera-N),
// out_dir/opencv/camera-N.cameramodel and the script's output in
// out_dir/logs/analysis.log. Relative model paths are taken from the caller's
// working folder.
// Throws InputError for invalid options, a missing model file or one the
// script finds unusable (no optimization_inputs, not a model: its message,
// naming the file); ExternalError naming the interpreter, what failed, the log
// and its last line when python cannot run, the script fails or times out, or
// its JSON is unusable.
CalibrationAnalysis AnalyseCalibration(const std::vector<std::string>& models,
                                       const std::string& out_dir,
                                       const AnalysisOptions& options = {});

// ---------------------------------------------------------------- two calibrations

struct DiffOptions {
  std::string python = "/usr/bin/python3";
  double timeout_s = 300.0;  // wall-time limit, seconds, > 0
  int gridn = 60;            // grid points across the imager (>= 2); rows keep cells square
  // Adds model A's projection uncertainty on the same grid and the share of
  // grid points whose difference is within 1, 2 and 3 times it. A must hold
  // its optimization_inputs.
  bool with_uncertainty_of_a = false;

  std::vector<std::string> Validate() const;
};

struct DiffUncertainty {
  double median_px = 0;  // A's worst-direction stdev over the grid
  double max_px = 0;
  int points = 0;             // grid points with a finite difference and stdev
  double within_1_sigma = 0;  // [0,1]: share of those with |diff| <= 1 stdev
  double within_2_sigma = 0;
  double within_3_sigma = 0;
};

struct ProjectionDiff {
  double median_px = 0;  // |projection difference| A -> B over the grid
  double p90_px = 0;
  double max_px = 0;
  double rotation_deg = 0;  // size of the implied rotation the fit took out
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();  // the rotation itself (Rodrigues, A's frame -> B's)
  int grid_width = 0;
  int grid_height = 0;
  int points = 0;  // grid points with a finite difference
  // How the rotation was fitted: weighted by the models' uncertainties where
  // they have optimization_inputs, else over a central circle.
  std::string rotation_fit;
  std::optional<DiffUncertainty> uncertainty_of_a;  // with DiffOptions::with_uncertainty_of_a
  std::string json_path;
  std::string heatmap_png;
  std::string log_path;  // out_json with the extension .log
};

// Projection difference A -> B at infinity after the implied-rotation fit
// (mrcal.projection_diff), written to out_json (atomically) and heatmap_png.
// Throws InputError for invalid options, a missing model, different imager
// sizes or (with_uncertainty_of_a) an A without optimization_inputs;
// ExternalError as AnalyseCalibration.
ProjectionDiff DiffCalibrations(const std::string& a, const std::string& b,
                                const std::string& out_json, const std::string& heatmap_png,
                                const DiffOptions& options = {});

// ---------------------------------------------------------------- the calibration's modes

struct ModesOptions {
  std::string python = "/usr/bin/python3";
  double timeout_s = 300.0;  // wall-time limit, seconds, > 0

  std::vector<std::string> Validate() const;
};

// Whether a .cameramodel file holds mrcal's optimization_inputs (the key
// 'optimization_inputs' of its dictionary), which the modes need. False for a
// file that cannot be read.
bool ModelHasOptimizationInputs(const std::string& path);

// The calibration's uncertainty as independent modes of the intrinsics
// (calib/intrinsics_modes.h), from the model's optimization_inputs: mrcal's
// propagation of the corner noise through the solve gives the intrinsics'
// covariance; the rotation each change implies (fitted over the imager,
// weighted as the slope Monte Carlo's fit is) is carried with it; the modes
// are the covariance's directions ordered by how far they move projections
// once that rotation is out, every imager point counting alike, kept until
// 99.9 % of that variance (at most 40). Runs the script in a temporary folder.
// Throws InputError for invalid options, a missing model or one without
// optimization_inputs (naming the file); ExternalError as AnalyseCalibration.
IntrinsicsModes ComputeIntrinsicsModes(const std::string& model, const ModesOptions& options = {});

// The calibration re-solved from perturbed corners, as the slope Monte Carlo
// of AnalyseCalibration does it (Gaussian noise of the solve's residual
// level on every inlier corner, outlier rejection off, each solve started
// from the nominal optimum): each re-solved camera's intrinsics and the
// implied rotation from the nominal camera frame (mrcal's rotation fit over
// the imager at infinity, weighted 1/stdev^4 by the nominal projection
// uncertainty: the fit IntrinsicsModes linearises). The check of the
// predicted calibration sigmas (reference/flight: CheckCalibrationTerm).
struct ResolvedIntrinsics {
  std::vector<double> intrinsics;
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();  // Rodrigues, nominal -> re-solved frame
};
struct ResolvedCalibration {
  std::string model;
  std::string lensmodel;
  std::vector<double> intrinsics;            // the nominal ones
  double noise_stdev_px = 0.0;               // the corner noise drawn
  std::vector<ResolvedIntrinsics> solved;    // the samples that solved, in draw order
  int failed = 0;                            // samples whose re-solve or rotation fit failed
  std::vector<std::string> failures;         // the first few distinct reasons
};

// `samples` >= 1 re-solves with numpy's generator seeded by `seed`. Throws as
// ComputeIntrinsicsModes does, and InputError for samples < 1.
ResolvedCalibration ResolveCalibration(const std::string& model, int samples, std::uint64_t seed,
                                       const ModesOptions& options = {});

// The analysis script's text (calib/calibration_analysis.py), compiled in.
const std::string& CalibrationAnalysisScript();

}  // namespace hdabench::calib
