#include "reference/opengv/opengv_adapter.h"

namespace hdabench::reference {

Rigid3d Cam2FromCam1FromOpenGv(const opengv::transformation_t& transformation_12,
                               double baseline_m) {
  const Eigen::Matrix3d r12 = transformation_12.block<3, 3>(0, 0);
  Eigen::Vector3d t12 = transformation_12.col(3);
  const double norm = t12.norm();
  if (norm > 0.0) t12 *= baseline_m / norm;
  const Rigid3d cam1_from_cam2(Eigen::Quaterniond(r12).normalized(), t12);
  return cam1_from_cam2.Inverse();
}

opengv::transformation_t OpenGvFromCam2FromCam1(const Rigid3d& cam2_from_cam1) {
  const Rigid3d cam1_from_cam2 = cam2_from_cam1.Inverse();
  opengv::transformation_t transformation_12;
  transformation_12.block<3, 3>(0, 0) = cam1_from_cam2.RotationMatrix();
  transformation_12.col(3) = cam1_from_cam2.translation;
  return transformation_12;
}

}  // namespace hdabench::reference
