// The check of a run's calibration term against the calibration itself: the
// calibration re-solved from perturbed corners (calib::ResolveCalibration),
// the flight method run with each re-solved camera model (its implied
// rotation taken out, as the prediction takes it out), and each ROI's slope
// spread over the re-solves set beside its predicted calibration sigma
// (docs/calibration.md, "Checking the calibration term").
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "calib/calibration_analysis.h"
#include "datasets/dataset.h"
#include "hda/pipeline.h"
#include "reference/flight/flight_run.h"

namespace hdabench::reference {

struct CalibrationCheckRoi {
  int id = 0;
  double predicted_slope_deg = 0.0;  // CalibrationTerm: the prediction
  double predicted_tilt_deg = 0.0;
  // The site's own matches, held fixed, with each re-solved model (the
  // prediction's setting): RMS over the re-solves of the slope's change and
  // of the angle between the normals; how many re-solves kept the fit's points.
  double fixed_slope_rms_deg = 0.0;
  double fixed_tilt_rms_deg = 0.0;
  int fixed_samples = 0;
  // The whole method again on the ROI (matching included) with each
  // re-solved model: RMS of the slope's change against a run with the
  // nominal model on the same ROIs; how many re-solves gave the ROI a slope.
  double rerun_slope_rms_deg = 0.0;
  int rerun_samples = 0;
};

// The spread over predicted ratio of one column, over the ROIs that have both.
struct RatioStats {
  int rois = 0;
  double median = 0.0;
  double p10 = 0.0;
  double p90 = 0.0;
};

struct CalibrationCheck {
  std::string model;
  int samples = 0;            // re-solves asked for
  int solved = 0;             // re-solves that solved
  std::uint64_t seed = 0;
  double noise_stdev_px = 0.0;
  std::vector<std::string> failures;
  std::vector<CalibrationCheckRoi> rois;  // the ROIs with a predicted calibration sigma > 0
  RatioStats fixed_slope;     // fixed_slope_rms_deg / predicted_slope_deg
  RatioStats fixed_tilt;      // fixed_tilt_rms_deg / predicted_tilt_deg
  RatioStats rerun_slope;     // rerun_slope_rms_deg / predicted_slope_deg
};

// Checks `run`'s calibration term (which must be available) with `samples`
// re-solves of the dataset's model, seeded by `seed`. `progress`, when
// given, is told after each re-solve's runs. Throws InputError when the run
// has no calibration term (saying why) or its model is not the dataset's,
// and as calib::ResolveCalibration and hda::RunHda do.
CalibrationCheck CheckCalibrationTerm(const datasets::Dataset& dataset, const FlightRun& run, int samples,
                                      std::uint64_t seed,
                                      const std::function<void(int done, int samples)>& progress = {});

// The HDA geometry of calibrate's figures (calib::HdaGeometry) as a site the
// flight method's steps evaluate: a square site of site_m, perpendicular to
// the line of sight through the band's centre at range_m, seen from a
// second position moved by baseline_m across that line along the image's x
// (the same attitude); level ground (gravity along the line of sight), the
// LRF along it. The matches are the exact projections through `truth` of a
// 10 x 10 grid of site points.
struct HdaGeometrySite {
  hda::HdaInput input;
  cv::Rect box1_px;
  std::vector<cv::Point2d> points1_px;
  std::vector<cv::Point2d> points2_px;
  Eigen::Vector3d true_normal_in_local = Eigen::Vector3d::UnitZ();
};
// Throws InputError when the camera cannot unproject the band's centre or
// project the site into both positions.
HdaGeometrySite MakeHdaGeometrySite(const calib::CameraModel& truth, const calib::HdaGeometry& geometry);

// The tilt, degrees, of the plane the flight method's steps fit to the
// site's matches with the camera model `believed`, its frame turned by
// `rotation_rad` (the implied rotation from the truth's frame, which the
// camera's alignment absorbs), against the site's true normal. NaN when the
// steps fit no plane.
double HdaGeometryTiltDeg(const HdaGeometrySite& site, const calib::CameraModel& believed,
                          const Eigen::Vector3d& rotation_rad);

// calibration_check.json: the check's settings, its three ratio summaries and
// one row per ROI (format "hdabench-calibration-check", version 1).
std::string CalibrationCheckJson(const CalibrationCheck& check);

// One line: the ratios' medians and p90s.
std::string CalibrationCheckLine(const CalibrationCheck& check);

}  // namespace hdabench::reference
