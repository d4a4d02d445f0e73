// A calibration's uncertainty in a form the bench can propagate without
// mrcal's Python: a few independent modes of the intrinsics, each a change of
// one standard deviation together with the rotation of the camera frame that
// the change implies (docs/calibration.md, "The calibration in each slope's
// error budget"). The covariance of the intrinsics, with what a rotation of
// the camera can hide taken out, is sum_k d_k d_k^T over the modes.
// calib::ComputeIntrinsicsModes (calibration_analysis.h) makes them from a
// model's optimization_inputs.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

namespace hdabench::calib {

struct IntrinsicsMode {
  std::vector<double> intrinsics_delta;             // one sigma, in mrcal's intrinsics order
  // Rodrigues vector, radians: the rotation from the nominal camera frame to
  // the perturbed one that best lines up the two models' projections over
  // the imager (the implied rotation, to first order). A direction v in the
  // nominal frame is R v in the perturbed one.
  Eigen::Vector3d rotation_rad = Eigen::Vector3d::Zero();
  double projection_rms_px = 0.0;                   // RMS move of a projection over the imager, rotation taken out
};

struct IntrinsicsModes {
  std::string model;                  // the .cameramodel they come from
  std::string lensmodel;
  std::vector<double> intrinsics;     // the nominal intrinsics the modes are about
  double noise_stdev_px = 0.0;        // the calibration's corner noise (residual stdev of the solve)
  // mrcal's worst-direction projection stdev at infinity over the imager
  // grid (frames' mean rotation taken out, mrcal's convention), median, and
  // the same from the modes with the fitted rotation taken out.
  double imager_worst_stdev_median_px = 0.0;
  double compensated_worst_stdev_median_px = 0.0;
  double variance_kept = 0.0;         // share of the compensated variance the modes hold
  std::vector<IntrinsicsMode> modes;
};

}  // namespace hdabench::calib
