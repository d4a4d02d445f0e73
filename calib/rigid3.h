// Rigid transform b_from_a: p_in_b = rotation * p_in_a + translation
// (docs/conventions.md, "Transforms and points").
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hdabench {

struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();  // unit, Hamilton
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();         // origin of a in b, metres

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& r, const Eigen::Vector3d& t) : rotation(r), translation(t) {}

  Eigen::Vector3d operator*(const Eigen::Vector3d& point_in_a) const {
    return rotation * point_in_a + translation;
  }
  // c_from_a = c_from_b * b_from_a.
  Rigid3d operator*(const Rigid3d& b_from_a) const {
    return Rigid3d(rotation * b_from_a.rotation, rotation * b_from_a.translation + translation);
  }
  // a_from_b.
  Rigid3d Inverse() const {
    const Eigen::Quaterniond r_inv = rotation.conjugate();
    return Rigid3d(r_inv, -(r_inv * translation));
  }
  Eigen::Matrix3d RotationMatrix() const { return rotation.toRotationMatrix(); }
  // Every coefficient of the rotation and the translation is finite.
  bool AllFinite() const { return rotation.coeffs().allFinite() && translation.allFinite(); }
};

}  // namespace hdabench
