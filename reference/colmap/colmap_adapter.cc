#include "reference/colmap/colmap_adapter.h"

#include <cmath>

#include "calib/pixel_convention.h"

namespace hdabench::reference {

using calib::PixelOrigin;

bool IsValidColmapPose(const std::array<double, 7>& qvec_tvec) {
  for (double v : qvec_tvec) {
    if (!std::isfinite(v)) return false;
  }
  const double norm2 = qvec_tvec[0] * qvec_tvec[0] + qvec_tvec[1] * qvec_tvec[1] +
                       qvec_tvec[2] * qvec_tvec[2] + qvec_tvec[3] * qvec_tvec[3];
  return norm2 > 1e-12;
}

Rigid3d CamFromWorldFromColmap(const std::array<double, 7>& qvec_tvec) {
  Eigen::Quaterniond q(qvec_tvec[0], qvec_tvec[1], qvec_tvec[2], qvec_tvec[3]);
  q.normalize();
  return Rigid3d(q, Eigen::Vector3d(qvec_tvec[4], qvec_tvec[5], qvec_tvec[6]));
}

std::array<double, 7> ColmapFromCamFromWorld(const Rigid3d& cam_from_world) {
  Eigen::Quaterniond q = cam_from_world.rotation.normalized();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d& t = cam_from_world.translation;
  return {q.w(), q.x(), q.y(), q.z(), t.x(), t.y(), t.z()};
}

Eigen::Vector2d PixelToColmap(const Eigen::Vector2d& pixel) {
  return calib::ConvertPixel(pixel, PixelOrigin::kCenterOfTopLeftPixelIsZero,
                             PixelOrigin::kTopLeftCornerIsZero);
}

Eigen::Vector2d PixelFromColmap(const Eigen::Vector2d& colmap_pixel) {
  return calib::ConvertPixel(colmap_pixel, PixelOrigin::kTopLeftCornerIsZero,
                             PixelOrigin::kCenterOfTopLeftPixelIsZero);
}

}  // namespace hdabench::reference
