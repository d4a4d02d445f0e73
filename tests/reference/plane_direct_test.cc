#include "reference/direct/plane_direct.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/angles.h"
#include "tools/util/error.h"

namespace hdabench::reference {
namespace {

// A constructed pair with a known plane: a pinhole camera (focal 800 px,
// 256 x 256) looking straight down from 100 m at a plane tilted 2.1 deg,
// camera 2 moved 5 m sideways (2.9 deg of parallax, as NOVA-C's 31 m at
// 566 m). The plane carries a band-limited texture (sinusoids of periods 0.7
// to 5 m, at least 5.6 px in the image), so point-sampled images are exact.
constexpr int kSizePx = 256;
constexpr double kFocalPx = 800.0;

calib::CameraModel Camera() {
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
double Texture(const Scene& scene, const Eigen::Vector3d& x) {
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
cv::Mat Render(const Scene& scene, const Rigid3d& cam_from_cam1, double sigma_dn, unsigned seed) {
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

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b))) * util::kRadToDeg;
}

DirectPlaneResult Fit(const Scene& scene, double sigma_dn, const cv::Rect& box,
                      const Eigen::Vector3d& start = Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0)) {
  const DirectPlaneImages images =
      PrepareDirectPlaneImages(Render(scene, Rigid3d(), sigma_dn, 1), Render(scene, scene.cam2_from_cam1, sigma_dn, 2));
  return FitPlaneDirect(images, Camera(), box, scene.cam2_from_cam1, start, scene.up, DirectPlaneOptions());
}

// Without noise the plane comes back to a hundredth of a degree, from a
// level start 10 % too far (the search, then Gauss-Newton).
TEST(FitPlaneDirect, RecoversTheTiltedPlaneOfExactImages) {
  const Scene scene;
  const DirectPlaneResult fit = Fit(scene, 0.0, cv::Rect(104, 104, 48, 48));
  ASSERT_EQ(fit.status, DirectPlaneStatus::kOk) << fit.reason;
  EXPECT_TRUE(fit.converged) << fit.reason;
  EXPECT_LT(AngleDeg(fit.plane_in_cam1, scene.plane), 0.01) << fit.reason;
  EXPECT_NEAR(fit.plane_in_cam1.norm(), scene.plane.norm(), 1e-4 * scene.plane.norm());
  const double true_slope = std::acos(scene.plane.normalized().dot(-scene.up)) * util::kRadToDeg;
  EXPECT_NEAR(fit.slope_deg, true_slope, 0.01);
  EXPECT_NEAR(fit.gain, 1.0, 1e-3);
  EXPECT_EQ(fit.points_in_cam1.size(), 48u * 48u);
}

// With 1 DN of noise per image (about the sensor noise of the default
// scenes' shadows) the tilt error stays within 3 of the fit's own predicted
// sigmas; the sigma is that of an estimate worth having (under half a degree
// for a 48 px ROI whose slope moves its far side by 0.01 px per degree), and
// the same inputs give the same numbers.
TEST(FitPlaneDirect, NoisyImagesStayWithinThePredictedSigma) {
  const Scene scene;
  const DirectPlaneResult fit = Fit(scene, 1.0, cv::Rect(104, 104, 48, 48));
  ASSERT_EQ(fit.status, DirectPlaneStatus::kOk) << fit.reason;
  EXPECT_GT(fit.slope_sigma_deg, 0.0);
  EXPECT_LT(fit.slope_sigma_deg, 0.5);
  EXPECT_LE(AngleDeg(fit.plane_in_cam1, scene.plane), 3.0 * fit.slope_sigma_deg) << fit.reason;
  EXPECT_NEAR(fit.robust_sigma_dn, std::sqrt(2.0), 0.3);  // both images' noise
  const DirectPlaneResult again = Fit(scene, 1.0, cv::Rect(104, 104, 48, 48));
  EXPECT_EQ(again.plane_in_cam1, fit.plane_in_cam1);
  EXPECT_EQ(again.slope_sigma_deg, fit.slope_sigma_deg);
}

TEST(FitPlaneDirect, AnUntexturedRoiIsNoTextureNeverANumber) {
  Scene scene;
  scene.textured = false;
  const DirectPlaneResult fit = Fit(scene, 0.0, cv::Rect(104, 104, 48, 48));
  EXPECT_EQ(fit.status, DirectPlaneStatus::kNoTexture) << fit.reason;
  EXPECT_STREQ(ToString(fit.status), "no texture");
  EXPECT_FALSE(fit.reason.empty());
  EXPECT_TRUE(std::isfinite(fit.slope_deg));
}

// Camera 2 sees the scene 40 px further left: a box at the left edge of
// image 1 is not in image 2.
TEST(FitPlaneDirect, ARoiOutsideImage2IsOutsideOverlap) {
  const Scene scene;
  const DirectPlaneResult fit = Fit(scene, 0.0, cv::Rect(0, 104, 32, 32));
  EXPECT_EQ(fit.status, DirectPlaneStatus::kOutsideOverlap) << fit.reason;
  EXPECT_STREQ(ToString(fit.status), "outside overlap");
  EXPECT_NE(fit.reason.find("pixels project into image 2"), std::string::npos) << fit.reason;
}

TEST(FitPlaneDirect, BadInputsAreInputErrors) {
  const Scene scene;
  const DirectPlaneImages images = PrepareDirectPlaneImages(Render(scene, Rigid3d(), 0.0, 1),
                                                            Render(scene, scene.cam2_from_cam1, 0.0, 2));
  DirectPlaneOptions options;
  options.max_iterations = 0;
  EXPECT_THROW(FitPlaneDirect(images, Camera(), cv::Rect(0, 0, 8, 8), scene.cam2_from_cam1, scene.plane, scene.up,
                              options),
               InputError);
  EXPECT_THROW(FitPlaneDirect(images, Camera(), cv::Rect(250, 0, 8, 8), scene.cam2_from_cam1, scene.plane, scene.up,
                              DirectPlaneOptions()),
               InputError);
  EXPECT_THROW(PrepareDirectPlaneImages(cv::Mat(), images.image1), InputError);
  EXPECT_THROW(PrepareDirectPlaneImages(images.image1, cv::Mat(10, 10, CV_32F, cv::Scalar(0))), InputError);
  // A start behind the camera is a status, not a throw.
  const DirectPlaneResult behind = FitPlaneDirect(images, Camera(), cv::Rect(104, 104, 48, 48), scene.cam2_from_cam1,
                                                  -scene.plane, scene.up, DirectPlaneOptions());
  EXPECT_EQ(behind.status, DirectPlaneStatus::kDiverged);
  EXPECT_FALSE(behind.reason.empty());
}

}  // namespace
}  // namespace hdabench::reference
