// A constructed pair with a known plane for the direct estimators' tests
// (plane-nav, dense-nav): band-limited texture on a tilted plane seen by a
// pinhole camera from two positions, point-sampled and so exact.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "tools/util/angles.h"

namespace hdabench::reference::textured_plane {

// A constructed pair with a known plane: a pinhole camera (focal 800 px,
// 256 x 256) looking straight down from 100 m at a plane tilted 2.1 deg,
// camera 2 moved 5 m sideways (2.9 deg of parallax, as NOVA-C's 31 m at
// 566 m). The plane carries a band-limited texture (sinusoids of periods 0.7
// to 5 m, at least 5.6 px in the image), so point-sampled images are exact.
constexpr int kSizePx = 256;
constexpr double kFocalPx = 800.0;

inline calib::CameraModel Camera() {
  const double c = 0.5 * (kSizePx - 1);
  return calib::CameraModel("LENSMODEL_PINHOLE", {kFocalPx, kFocalPx, c, c}, kSizePx, kSizePx);
}

struct Scene {
  Eigen::Vector3d plane = Eigen::Vector3d(0.03, -0.02, 1.0) / 100.0;  // p . X = 1 in camera 1
  Rigid3d cam2_from_cam1 = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-5.0, 0.0, 0.0));
  Eigen::Vector3d up = Eigen::Vector3d(0.0, 0.0, -1.0);  // the camera looks down
  bool textured = true;
};

// The texture at a point of the plane (in-plane coordinates from two axes
// orthogonal to its normal).
inline double Texture(const Scene& scene, const Eigen::Vector3d& x) {
  const Eigen::Vector3d n = scene.plane.normalized();
  const Eigen::Vector3d e1 = n.cross(Eigen::Vector3d::UnitY()).normalized();
  const Eigen::Vector3d e2 = n.cross(e1);
  const double s = x.dot(e1), t = x.dot(e2);
  if (!scene.textured) return 100.0;
  static const double waves[][4] = {  // cycles per metre along s and t, amplitude DN, phase
      {0.21, 0.05, 14, 0.3},  {-0.11, 0.37, 12, 1.1}, {0.52, -0.31, 10, 2.0}, {0.08, 0.74, 9, 0.7},
      {0.95, 0.22, 8, 2.9},   {-0.61, -0.83, 7, 1.6}, {1.12, -0.45, 6, 0.2},  {0.33, 1.21, 6, 2.4},
      {-1.18, 0.57, 5, 1.3},  {1.31, 0.61, 5, 0.9}};
  double value = 100.0;
  for (const auto& w : waves) value += w[2] * std::sin(2.0 * util::kPi * (w[0] * s + w[1] * t) + w[3]);
  return value;
}

// Image of camera 1 (cam_from_cam1 identity) or 2, point-sampled, with
// Gaussian noise of sigma_dn (seeded).
inline cv::Mat Render(const Scene& scene, const Rigid3d& cam_from_cam1, double sigma_dn, unsigned seed) {
  const calib::CameraModel camera = Camera();
  std::vector<Eigen::Vector2d> pixels;
  for (int r = 0; r < kSizePx; ++r) {
    for (int c = 0; c < kSizePx; ++c) pixels.emplace_back(c, r);
  }
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  camera.Unproject(pixels, &bearings, &valid);
  const Rigid3d cam1_from_cam = cam_from_cam1.Inverse();
  const Eigen::Vector3d centre = cam1_from_cam.translation;
  std::mt19937 random(seed);
  std::normal_distribution<double> noise(0.0, sigma_dn);
  cv::Mat image(kSizePx, kSizePx, CV_32F);
  for (size_t k = 0; k < pixels.size(); ++k) {
    const Eigen::Vector3d direction = cam1_from_cam.rotation * bearings[k];
    const double lambda = (1.0 - scene.plane.dot(centre)) / scene.plane.dot(direction);
    const double value = Texture(scene, centre + lambda * direction) + (sigma_dn > 0 ? noise(random) : 0.0);
    image.at<float>(static_cast<int>(pixels[k].y()), static_cast<int>(pixels[k].x())) = static_cast<float>(value);
  }
  return image;
}

inline double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b))) * util::kRadToDeg;
}

}  // namespace hdabench::reference::textured_plane
