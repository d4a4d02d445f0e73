// The calibration's share of one site's slope uncertainty: how far the
// site's slope and tilt move when the camera model moves by each of the
// calibration's uncertainty modes (calib/intrinsics_modes.h), the site's
// matches held fixed. The site is re-evaluated by the flight method's own
// steps after matching (EvaluateMatchedSite: nav rejection, triangulation
// with the nav pose, the plane fit) with the perturbed intrinsics and with
// the camera frame turned by the mode's implied rotation, which the
// camera-to-lander alignment (calibrated separately) absorbs. Central
// differences over +-kCalibrationModeStep sigma; the modes are independent,
// so their effects add in quadrature.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"
#include "calib/intrinsics_modes.h"
#include "hda/hda_options.h"
#include "hda/pipeline.h"

namespace hdabench::hda {

// The step of the central differences, in sigmas of each mode.
inline constexpr double kCalibrationModeStep = 0.5;

struct CalibrationSigma {
  bool available = false;
  std::string why;           // when not available: the reason, one line
  // 1-sigma of the slope along the dip (on a level site, where the dip is
  // undefined, the per-axis RMS of the tilt), and of the tilt (the RMS of
  // the angle between the perturbed and the nominal normals), degrees.
  double slope_deg = 0.0;
  double tilt_deg = 0.0;
  // The evaluation with the nominal camera, which the perturbed ones are
  // taken against: its slope and the number of points of its fit.
  double nominal_slope_deg = 0.0;
  int points = 0;
};

// The calibration sigma of one site with matches points1_px / points2_px in
// image 1's box box1_px (the surviving matches of a RunHda ROI). `camera`
// must be the model the modes are about (lens model and intrinsics equal).
// Not available, with the reason, when the nominal evaluation or a perturbed
// one gives no fit or a fit on other points (a threshold crossed: the site
// is not in the linear regime of the calibration's uncertainty).
// Throws InputError as EvaluateMatchedSite does, and when the modes do not
// belong to the camera.
CalibrationSigma SiteCalibrationSigma(const HdaInput& input, const calib::CameraModel& camera,
                                      const HdaOptions& options, const calib::IntrinsicsModes& modes,
                                      const cv::Rect& box1_px, const std::vector<cv::Point2d>& points1_px,
                                      const std::vector<cv::Point2d>& points2_px, double match_window_px);

// The inputs as seen from a camera frame turned by `rotation_rad` (Rodrigues,
// nominal -> turned: a direction v of the nominal frame is R v in the turned
// one): the same camera centres and LRF spot, camera 1's attitude, the
// relative pose and the LRF's beam expressed in the turned frames. Matches
// whose bearings are exactly R times the nominal ones give, with these
// inputs, the nominal site.
HdaInput InputInTurnedFrame(const HdaInput& input, const Eigen::Vector3d& rotation_rad);

// The slope sigma a run reports beside the method's own: the two in
// quadrature; the method's alone when the calibration's is not finite.
double CombinedSlopeSigmaDeg(double method_sigma_deg, double calibration_sigma_deg);

}  // namespace hdabench::hda
