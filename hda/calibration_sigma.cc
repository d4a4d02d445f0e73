#include "hda/calibration_sigma.h"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::hda {

namespace {

void RequireModesOfCamera(const calib::CameraModel& camera, const calib::IntrinsicsModes& modes) {
  if (modes.lensmodel != camera.LensModelName() || modes.intrinsics != camera.Intrinsics()) {
    throw InputError("the calibration modes of " + modes.model + " (" + modes.lensmodel +
                     ") are not about the camera the method runs with (" + camera.LensModelName() +
                     "): other lens model or intrinsics");
  }
  for (size_t k = 0; k < modes.modes.size(); ++k) {
    const calib::IntrinsicsMode& mode = modes.modes[k];
    if (mode.intrinsics_delta.size() != camera.Intrinsics().size()) {
      throw InputError(modes.model + ": calibration mode " + std::to_string(k + 1) + " has " +
                       std::to_string(mode.intrinsics_delta.size()) + " intrinsics, the camera " +
                       std::to_string(camera.Intrinsics().size()));
    }
  }
}

}  // namespace

HdaInput InputInTurnedFrame(const HdaInput& input, const Eigen::Vector3d& rotation_rad) {
  const double angle = rotation_rad.norm();
  const Eigen::Quaterniond turn =
      angle > 0.0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation_rad / angle)) : Eigen::Quaterniond::Identity();
  const Rigid3d perturbed_from_nominal(turn, Eigen::Vector3d::Zero());
  HdaInput turned = input;
  turned.local_from_cam1 = input.local_from_cam1 * perturbed_from_nominal.Inverse();
  turned.cam2_from_cam1 = perturbed_from_nominal * input.cam2_from_cam1 * perturbed_from_nominal.Inverse();
  turned.lrf_origin_in_cam1_m = turn * input.lrf_origin_in_cam1_m;
  turned.lrf_beam_in_cam1 = turn * input.lrf_beam_in_cam1;
  return turned;
}

CalibrationSigma SiteCalibrationSigma(const HdaInput& input, const calib::CameraModel& camera,
                                      const HdaOptions& options, const calib::IntrinsicsModes& modes,
                                      const cv::Rect& box1_px, const std::vector<cv::Point2d>& points1_px,
                                      const std::vector<cv::Point2d>& points2_px, double match_window_px) {
  RequireModesOfCamera(camera, modes);
  CalibrationSigma sigma;
  const RoiResult nominal =
      EvaluateMatchedSite(input, camera, options, box1_px, points1_px, points2_px, match_window_px);
  if (!nominal.has_fit) {
    sigma.why = "no plane with the nominal camera: " + nominal.reason;
    return sigma;
  }
  sigma.nominal_slope_deg = nominal.slope_deg;
  sigma.points = nominal.counts.depth_inliers;
  const Eigen::Vector3d n0 = nominal.normal_in_local.normalized();
  const Eigen::Vector3d up = -input.gravity_in_local_mps2.normalized();

  // Per mode, the normal's change for one sigma (central differences).
  std::vector<Eigen::Vector3d> moves;
  for (size_t k = 0; k < modes.modes.size(); ++k) {
    const calib::IntrinsicsMode& mode = modes.modes[k];
    Eigen::Vector3d normals[2];
    for (int side = 0; side < 2; ++side) {
      const double step = side == 0 ? kCalibrationModeStep : -kCalibrationModeStep;
      std::vector<double> intrinsics = camera.Intrinsics();
      for (size_t i = 0; i < intrinsics.size(); ++i) intrinsics[i] += step * mode.intrinsics_delta[i];
      const calib::CameraModel perturbed(camera.LensModelName(), intrinsics, camera.WidthPx(), camera.HeightPx(),
                                         camera.RtCamRef(), modes.model);
      const RoiResult moved = EvaluateMatchedSite(InputInTurnedFrame(input, step * mode.rotation_rad), perturbed, options,
                                                  box1_px, points1_px, points2_px, match_window_px);
      if (!moved.has_fit || moved.counts.depth_inliers != nominal.counts.depth_inliers) {
        sigma.why = "calibration mode " + std::to_string(k + 1) + " at " + util::FixedText(step, 1) +
                    " sigma " +
                    (moved.has_fit ? "changes the fit's points (" + std::to_string(nominal.counts.depth_inliers) +
                                         " -> " + std::to_string(moved.counts.depth_inliers) + ")"
                                   : "leaves no plane: " + moved.reason);
        return sigma;
      }
      Eigen::Vector3d n = moved.normal_in_local.normalized();
      if (n.dot(n0) < 0.0) n = -n;
      normals[side] = n;
    }
    moves.push_back((normals[0] - normals[1]) / (2.0 * kCalibrationModeStep));
  }

  double tilt2 = 0.0;
  for (const Eigen::Vector3d& m : moves) tilt2 += m.squaredNorm();
  // slope = acos(n . up), so d slope = -(dn . up) / sin(slope) = -dn . dip,
  // dip the unit vector of up's part in the plane (dn is in the plane).
  const Eigen::Vector3d along = up - up.dot(n0) * n0;
  double slope2 = 0.0;
  if (along.norm() < 1e-6) {
    slope2 = tilt2 / 2.0;
  } else {
    const Eigen::Vector3d dip = along.normalized();
    for (const Eigen::Vector3d& m : moves) slope2 += std::pow(m.dot(dip), 2);
  }
  sigma.available = true;
  sigma.slope_deg = std::sqrt(slope2) * util::kRadToDeg;
  sigma.tilt_deg = std::sqrt(tilt2) * util::kRadToDeg;
  return sigma;
}

double CombinedSlopeSigmaDeg(double method_sigma_deg, double calibration_sigma_deg) {
  if (!std::isfinite(calibration_sigma_deg)) return method_sigma_deg;
  return std::hypot(method_sigma_deg, calibration_sigma_deg);
}

}  // namespace hdabench::hda
