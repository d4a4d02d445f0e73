// Navigation and LRF samples of a dataset and their interpolation
// (docs/conventions.md, "Transforms and points"; docs/dataset-format.md).
#pragma once

#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::datasets {

// One row of the navigation table.
struct NavSample {
  double time_s = 0.0;
  // Body pose: translation = body origin in local (metres), rotation = attitude
  // (body vectors into local).
  Rigid3d local_from_body;
  // Optional columns; meaningful only when Dataset::nav_has_velocity /
  // nav_has_sigmas say the table has them (zero otherwise).
  Eigen::Vector3d velocity_in_local_mps = Eigen::Vector3d::Zero();
  // 1-sigma position error along local x, y, z, metres.
  Eigen::Vector3d sigma_position_in_local_m = Eigen::Vector3d::Zero();
  // 1-sigma attitude error as a small rotation about body x, y, z, radians:
  // local_from_body_true = local_from_body * Exp(delta_in_body).
  Eigen::Vector3d sigma_attitude_in_body_rad = Eigen::Vector3d::Zero();
};

// One row of the LRF table: a slant range along a boresight.
struct LrfSample {
  double time_s = 0.0;
  double range_m = 0.0;  // > 0
  // Unit direction of the beam in the body frame; the beam starts at
  // Dataset::lrf_origin_in_body_m.
  Eigen::Vector3d boresight_in_body = Eigen::Vector3d::UnitZ();
};

// local_from_body at `time_s`: position interpolated linearly, attitude by
// spherical linear interpolation on the shorter arc (q and -q are the same
// attitude), between the two samples around `time_s`; a sample's own pose at
// its own time. Preconditions: `nav` is non-empty with strictly increasing
// times (LoadDataset guarantees it). Throws std::out_of_range naming the time
// and the span when `time_s` is outside [nav.front().time_s, nav.back().time_s]
// or not finite.
Rigid3d InterpolateLocalFromBody(const std::vector<NavSample>& nav, double time_s);

// Slant range at `time_s`, linear between the two samples around it.
// Same preconditions and failure as InterpolateLocalFromBody.
double InterpolateLrfRange(const std::vector<LrfSample>& lrf, double time_s);

// Rotation angle of a relative rotation, radians in [0, pi].
double RotationAngleRad(const Eigen::Quaterniond& rotation);

}  // namespace hdabench::datasets
