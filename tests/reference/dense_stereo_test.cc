#include "reference/direct/dense_stereo.h"

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Eigenvalues>
#include <gtest/gtest.h>

#include "tests/reference/textured_plane_scene.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"

namespace hdabench::reference {
namespace {

using textured_plane::AngleDeg;
using textured_plane::Camera;
using textured_plane::Render;
using textured_plane::Scene;

// The scene's plane (100 m below, 2.1 deg) seen by camera 2 5 m to the side:
// 40 px of disparity; level ground through the plane's point below camera 1
// starts the search.
Eigen::Vector3d LevelGround(const Scene& scene) {
  const double distance = 1.0 / scene.plane.dot(Eigen::Vector3d::UnitZ());
  return -scene.up / distance;
}

DenseStereoResult Dense(const Scene& scene, double sigma_dn, const Rigid3d& nav_cam2_from_cam1,
                        const DenseStereoOptions& options = DenseStereoOptions()) {
  return RunDenseStereo(Render(scene, Rigid3d(), sigma_dn, 1), Render(scene, scene.cam2_from_cam1, sigma_dn, 2),
                        Camera(), nav_cam2_from_cam1, LevelGround(scene), options);
}

// The plane through the points whose image-1 pixels fall in `box`, by least
// squares on the normal (the smallest eigenvector of their scatter).
Eigen::Vector3d PlaneNormal(const DenseStereoResult& dense, const cv::Rect& box, int* count) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> points;
  for (size_t k = 0; k < dense.points_in_cam1.size(); ++k) {
    const Eigen::Vector2d& q = dense.pixels1[k];
    if (q.x() < box.x || q.y() < box.y || q.x() >= box.x + box.width || q.y() >= box.y + box.height) continue;
    points.push_back(dense.points_in_cam1[k]);
    mean += points.back();
  }
  *count = static_cast<int>(points.size());
  if (points.empty()) return Eigen::Vector3d::Zero();
  mean /= static_cast<double>(points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - mean) * (p - mean).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(scatter);
  return eigen.eigenvectors().col(0);
}

// Exact images and the exact pose: a point for nearly every pixel of the
// overlap, and the plane of a 96 x 96 px ROI (12 m) back within 0.03 deg
// (0.007 measured). A tilt of 0.03 deg moves the ROI's far side by 0.002 px
// of disparity: the bound holds only with an interpolant whose error does
// not depend on the sub-pixel position (the cubic spline; Keys' cubic
// convolution gave 0.2 deg here, SGBM's parabola alone 1.3 deg).
TEST(RunDenseStereo, RecoversTheTiltedPlaneOfExactImages) {
  const Scene scene;
  const DenseStereoResult dense = Dense(scene, 0.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  EXPECT_NEAR(dense.rectification.baseline_m, 5.0, 1e-9);
  EXPECT_GT(dense.valid_pixels, 0.7 * dense.field_pixels) << dense.reason;
  EXPECT_LT(dense.row_shift_max_px, 0.02) << dense.reason;
  int count = 0;
  const Eigen::Vector3d normal = PlaneNormal(dense, cv::Rect(80, 80, 96, 96), &count);
  EXPECT_GT(count, 0.9 * 96 * 96);
  EXPECT_LT(AngleDeg(normal, scene.plane), 0.03);
  // The points lie on the plane: within 0.1 % of the 100 m distance.
  int on_plane = 0;
  for (const Eigen::Vector3d& p : dense.points_in_cam1) on_plane += std::abs(scene.plane.dot(p) - 1.0) < 1e-3;
  EXPECT_GT(on_plane, 0.95 * dense.valid_pixels);
}

// 1 DN of noise per image: each pixel's disparity is noisy (its 5 x 5
// window's), but a 96 x 96 px ROI averages 9216 of them. The bound, 0.5 deg:
// at 1 DN against gradients of about 10 DN/px the window gives a disparity
// sigma near 0.03 px, about 0.075 m of distance at 100 m; over 12 m with
// ~370 independent windows that is 0.075 / (12 * sqrt(370 / 12)) rad = 0.06
// deg, and the bound leaves room for the windows' correlation.
TEST(RunDenseStereo, NoisyImagesStillGiveThePlaneAndTheSameBytesTwice) {
  const Scene scene;
  const DenseStereoResult dense = Dense(scene, 1.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  int count = 0;
  const Eigen::Vector3d normal = PlaneNormal(dense, cv::Rect(80, 80, 96, 96), &count);
  EXPECT_GT(count, 0.9 * 96 * 96);
  EXPECT_LT(AngleDeg(normal, scene.plane), 0.5);
  const DenseStereoResult again = Dense(scene, 1.0, scene.cam2_from_cam1);
  ASSERT_EQ(again.points_in_cam1.size(), dense.points_in_cam1.size());
  EXPECT_EQ(again.points_in_cam1, dense.points_in_cam1);
  EXPECT_EQ(again.pixels1, dense.pixels1);
}

// The navigation's relative rotation off by 0.03 deg about the baseline puts
// image 2's matches 0.42 px off their rows (0.03 deg at 800 px per radian);
// the row correction finds the offset and the plane comes back as with the
// exact pose. Without it the one-dimensional matcher is wrong by degrees.
TEST(RunDenseStereo, CorrectsTheRowsOfAnErroneousNavRotation) {
  const Scene scene;
  const Rigid3d nav(Eigen::Quaterniond(Eigen::AngleAxisd(0.03 * util::kDegToRad, Eigen::Vector3d::UnitX())) *
                        scene.cam2_from_cam1.rotation,
                    scene.cam2_from_cam1.translation);
  const DenseStereoResult dense = Dense(scene, 0.0, nav);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  EXPECT_NEAR(dense.row_shift_max_px, 0.03 * util::kDegToRad * 800.0, 0.1) << dense.reason;
  int count = 0;
  EXPECT_LT(AngleDeg(PlaneNormal(dense, cv::Rect(80, 80, 96, 96), &count), scene.plane), 0.2);
  EXPECT_GT(count, 0.9 * 96 * 96);

  DenseStereoOptions uncorrected;
  uncorrected.correct_rows = false;
  const DenseStereoResult raw = Dense(scene, 0.0, nav, uncorrected);
  EXPECT_EQ(raw.row_shift_matches, 0);
  EXPECT_GT(AngleDeg(PlaneNormal(raw, cv::Rect(80, 80, 96, 96), &count), scene.plane), 0.5);
  EXPECT_GT(count, 0.5 * 96 * 96);
}

// A nav rotation error about the view axis (0.1 deg) turns image 2 about its
// centre: the rows' offset grows along them, 0.00175 px per px, which the
// correction's slope in u must take up (measured where Rectify applies it,
// at image 2's columns). Its offset across the rows is a disparity error no
// matcher can see: the plane is not asserted.
TEST(RunDenseStereo, CorrectsRowsThatTurnWithANavRoll) {
  const Scene scene;
  const double roll = 0.1 * util::kDegToRad;
  const Rigid3d nav(Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ())) *
                        scene.cam2_from_cam1.rotation,
                    scene.cam2_from_cam1.translation);
  const DenseStereoResult dense = Dense(scene, 0.0, nav);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  EXPECT_GT(dense.row_shift_matches, 50);
  EXPECT_NEAR(std::abs(dense.rectification.row_shift(1)), roll, 0.1 * roll) << dense.rectification.row_shift;
  EXPECT_LT(std::abs(dense.rectification.row_shift(2)), 0.1 * roll) << dense.rectification.row_shift;
}

TEST(RunDenseStereo, AnUntexturedPairHasNoDisparitiesNeverANumber) {
  Scene scene;
  scene.textured = false;
  const DenseStereoResult dense = Dense(scene, 0.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  EXPECT_LT(dense.valid_pixels, 0.01 * dense.field_pixels) << dense.reason;
  for (const Eigen::Vector3d& p : dense.points_in_cam1) EXPECT_TRUE(p.allFinite());
}

// Motion along the boresight puts the epipole at the image centre; 5 deg off
// it, the epipole is still in the image (whose half-width is 9 deg) and no
// pixel is within 60 deg of a view perpendicular to the baseline. No motion
// at all has no baseline, and one so short that the level ground's disparity
// is under SGBM's step is too short. Each is a status with its reason.
TEST(RunDenseStereo, MotionAlongTheBoresightOrNoneIsNotRectifiable) {
  const Scene scene;
  const Rigid3d forward(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, -5.0));
  const DenseStereoResult along = Dense(scene, 0.0, forward);
  EXPECT_EQ(along.status, DenseStereoStatus::kNotRectifiable);
  EXPECT_STREQ(ToString(along.status), "not rectifiable");
  EXPECT_NE(along.reason.find("the epipole is the image centre"), std::string::npos) << along.reason;
  EXPECT_TRUE(along.points_in_cam1.empty());
  const double off = 5.0 * util::kDegToRad;
  const Rigid3d nearly(Eigen::Quaterniond::Identity(), -5.0 * Eigen::Vector3d(std::sin(off), 0.0, std::cos(off)));
  const DenseStereoResult oblique = Dense(scene, 0.0, nearly);
  EXPECT_EQ(oblique.status, DenseStereoStatus::kNotRectifiable);
  EXPECT_NE(oblique.reason.find("no part of image 1 is within 60 deg"), std::string::npos) << oblique.reason;
  const DenseStereoResult still = Dense(scene, 0.0, Rigid3d());
  EXPECT_EQ(still.status, DenseStereoStatus::kNotRectifiable);
  EXPECT_NE(still.reason.find("no baseline"), std::string::npos) << still.reason;
  // Rounding errors of a pose composition are a baseline too short, whatever
  // their direction (it was "the epipole is the image centre").
  const DenseStereoResult rounded = Dense(scene, 0.0, Rigid3d(Eigen::Quaterniond::Identity(),
                                                              Eigen::Vector3d(1e-13, 0.0, -3e-12)));
  EXPECT_EQ(rounded.status, DenseStereoStatus::kNotRectifiable);
  EXPECT_NE(rounded.reason.find("baseline too short"), std::string::npos) << rounded.reason;
  EXPECT_NE(rounded.reason.find("under the matcher's 1/16 px step"), std::string::npos) << rounded.reason;
}

// Camera 2 sees the scene 40 px further left: a box at image 1's left edge
// is not in image 2, a central one is.
TEST(DenseOverlapFraction, ABoxAtTheEdgeIsOutsideTheOverlap) {
  const Scene scene;
  const DenseStereoResult dense = Dense(scene, 0.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk);
  EXPECT_LT(DenseOverlapFraction(dense, Camera(), scene.cam2_from_cam1, cv::Rect(0, 104, 32, 32), 5), 0.1);
  EXPECT_DOUBLE_EQ(DenseOverlapFraction(dense, Camera(), scene.cam2_from_cam1, cv::Rect(104, 104, 32, 32), 5), 1.0);
}

// The slope uncertainty the disparity step leaves an ROI: on the scene's
// pair (level ground 40 px of disparity), a 96 x 96 px box of 9216 points has
// tan(sigma) = sqrt(12 / 9216) 800 / (16 x 96 x 40) (0.027 deg). The tangent
// grows as the nav baseline shrinks (a hundredth of it: 100 times) and as the
// square root of the points' count falls, and sigma is infinite where the
// pair is not rectifiable or the ROI has no points.
TEST(DenseSlopeSigmaDeg, FollowsTheDisparityStepTheBaselineAndThePoints) {
  const Scene scene;
  const cv::Rect box(80, 80, 96, 96);
  const DenseStereoResult dense = Dense(scene, 0.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  const auto tangent = [&box](const DenseStereoResult& d, int points) {
    return std::tan(DenseSlopeSigmaDeg(d, Camera(), box, points) * util::kDegToRad);
  };
  const double expected = std::sqrt(12.0 / 9216.0) * 800.0 / (16.0 * 96.0 * 40.0);
  EXPECT_NEAR(tangent(dense, 9216), expected, 0.05 * expected);
  EXPECT_NEAR(tangent(dense, 9216 / 4), 2.0 * tangent(dense, 9216), 1e-9 * expected);

  Rigid3d short_baseline = scene.cam2_from_cam1;
  short_baseline.translation *= 0.01;
  const DenseStereoResult short_pair = Dense(scene, 0.0, short_baseline);
  ASSERT_EQ(short_pair.status, DenseStereoStatus::kOk) << short_pair.reason;
  EXPECT_NEAR(tangent(short_pair, 9216) / tangent(dense, 9216), 100.0, 1e-6);
  // 2.7 deg: within the 3 deg bound; with 144 points (8 times the tangent), 20.6 deg: past it.
  const double bound_deg = DenseStereoOptions().max_slope_sigma_deg;
  EXPECT_LT(DenseSlopeSigmaDeg(short_pair, Camera(), box, 9216), bound_deg);
  EXPECT_GT(DenseSlopeSigmaDeg(short_pair, Camera(), box, 144), bound_deg);

  Rigid3d no_baseline = scene.cam2_from_cam1;
  no_baseline.translation.setZero();
  const DenseStereoResult none = Dense(scene, 0.0, no_baseline);
  ASSERT_EQ(none.status, DenseStereoStatus::kNotRectifiable);
  EXPECT_EQ(DenseSlopeSigmaDeg(none, Camera(), box, 9216), std::numeric_limits<double>::infinity());
  EXPECT_EQ(DenseSlopeSigmaDeg(dense, Camera(), box, 0), std::numeric_limits<double>::infinity());
}

// An ROI whose centre looks above the level ground's horizon (ground higher
// than the camera, ahead of an oblique one) has no level-ground disparity;
// its slope's uncertainty then comes from the median disparity of its own
// points. Here the level plane is mirrored to the camera's other side (100 m
// above it), so that every ray of the image looks above its horizon, and the
// ROI's points (the plane, 40 px of disparity) give the tangent the level
// ground gave.
TEST(DenseSlopeSigmaDeg, AboveTheLevelGroundsHorizonTheRoisOwnPointsGiveTheDisparity) {
  const Scene scene;
  const cv::Rect box(80, 80, 96, 96);
  const DenseStereoResult dense = Dense(scene, 0.0, scene.cam2_from_cam1);
  ASSERT_EQ(dense.status, DenseStereoStatus::kOk) << dense.reason;
  std::vector<Eigen::Vector3d> in_box;
  for (size_t k = 0; k < dense.points_in_cam1.size(); ++k) {
    const Eigen::Vector2d& q = dense.pixels1[k];
    if (q.x() >= box.x - 0.5 && q.x() < box.x + box.width - 0.5 && q.y() >= box.y - 0.5 &&
        q.y() < box.y + box.height - 0.5) {
      in_box.push_back(dense.points_in_cam1[k]);
    }
  }
  ASSERT_GT(in_box.size(), 1000u);
  const double level_deg = DenseSlopeSigmaDeg(dense, Camera(), box, 9216, in_box);
  EXPECT_EQ(level_deg, DenseSlopeSigmaDeg(dense, Camera(), box, 9216)) << "the level ground's disparity comes first";

  DenseStereoResult above = dense;
  above.rectification.level_plane_in_cam1 = -dense.rectification.level_plane_in_cam1;
  EXPECT_EQ(DenseSlopeSigmaDeg(above, Camera(), box, 9216), std::numeric_limits<double>::infinity());
  const double own_deg = DenseSlopeSigmaDeg(above, Camera(), box, 9216, in_box);
  EXPECT_NEAR(std::tan(own_deg * util::kDegToRad) / std::tan(level_deg * util::kDegToRad), 1.0, 0.02);
  // Points behind the rectified frame give no disparity either.
  std::vector<Eigen::Vector3d> behind = in_box;
  for (Eigen::Vector3d& p : behind) p = -p;
  EXPECT_EQ(DenseSlopeSigmaDeg(above, Camera(), box, 9216, behind), std::numeric_limits<double>::infinity());
}

TEST(RunDenseStereo, BadInputsAreInputErrors) {
  const Scene scene;
  const cv::Mat image = Render(scene, Rigid3d(), 0.0, 1);
  DenseStereoOptions options;
  options.block_size_px = 4;
  EXPECT_THROW(RunDenseStereo(image, image, Camera(), scene.cam2_from_cam1, LevelGround(scene), options), InputError);
  EXPECT_THROW(RunDenseStereo(cv::Mat(), image, Camera(), scene.cam2_from_cam1, LevelGround(scene),
                              DenseStereoOptions()),
               InputError);
  EXPECT_THROW(RunDenseStereo(image, cv::Mat(10, 10, CV_32F, cv::Scalar(0)), Camera(), scene.cam2_from_cam1,
                              LevelGround(scene), DenseStereoOptions()),
               InputError);
  EXPECT_THROW(RunDenseStereo(image, cv::Mat(image.size(), CV_32FC3), Camera(), scene.cam2_from_cam1,
                              LevelGround(scene), DenseStereoOptions()),
               InputError);
}

}  // namespace
}  // namespace hdabench::reference
