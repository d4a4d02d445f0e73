// Navigation interpolation and the pose helpers of Dataset, against poses
// computed by hand or constructed so that the answer is known.
#include <cmath>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "datasets/dataset.h"
#include "datasets/example.h"
#include "datasets/navigation.h"
#include "tests/support/constructed_pair.h"
#include "tests/support/test_support.h"
#include "tools/util/angles.h"

namespace hdabench::datasets {
namespace {

using util::kPi;

using testing_support::CurrentTestSeed;


NavSample Sample(double time_s, const Eigen::Quaterniond& rotation,
                 const Eigen::Vector3d& position) {
  NavSample sample;
  sample.time_s = time_s;
  sample.local_from_body = Rigid3d(rotation, position);
  return sample;
}

Eigen::Quaterniond Yaw(double angle_rad) {
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitZ()));
}

// Angle of the rotation taking a to b, radians.
double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return RotationAngleRad(b * a.conjugate());
}

Dataset EmptyDataset() {
  return Dataset(calib::CameraModel("LENSMODEL_PINHOLE", {500.0, 500.0, 127.5, 127.5}, 256, 256));
}

TEST(InterpolateLocalFromBody, MidpointOfNinetyDegreeYawIsFortyFive) {
  const std::vector<NavSample> nav = {
      Sample(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 0.0)),
      Sample(2.0, Yaw(kPi / 2.0), Eigen::Vector3d(10.0, -4.0, 2.0))};
  const Rigid3d mid = InterpolateLocalFromBody(nav, 1.0);
  EXPECT_LT(AngleBetween(mid.rotation, Yaw(kPi / 4.0)), 1e-15);
  EXPECT_LT((mid.translation - Eigen::Vector3d(5.0, -2.0, 1.0)).norm(), 1e-15);
  const Rigid3d quarter = InterpolateLocalFromBody(nav, 0.5);
  EXPECT_LT(AngleBetween(quarter.rotation, Yaw(kPi / 8.0)), 1e-15);
  EXPECT_LT((quarter.translation - Eigen::Vector3d(2.5, -1.0, 0.5)).norm(), 1e-15);
  // A body x axis rotated by 45 degrees of yaw points north-east.
  const Eigen::Vector3d forward = mid.rotation * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(forward.x(), std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(forward.y(), std::sqrt(0.5), 1e-15);
}

TEST(InterpolateLocalFromBody, TakesTheShorterArcWhenQuaternionSignFlips) {
  Eigen::Quaterniond flipped = Yaw(kPi / 2.0);
  flipped.coeffs() = -flipped.coeffs();  // same attitude, other hemisphere
  const std::vector<NavSample> nav = {
      Sample(10.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()),
      Sample(12.0, flipped, Eigen::Vector3d::Zero())};
  EXPECT_LT(AngleBetween(InterpolateLocalFromBody(nav, 11.0).rotation, Yaw(kPi / 4.0)), 1e-15);
}

TEST(InterpolateLocalFromBody, ReturnsSamplesAtTheirOwnTimes) {
  const std::vector<NavSample> nav = {
      Sample(0.0, Yaw(0.1), Eigen::Vector3d(1.0, 2.0, 3.0)),
      Sample(0.02, Yaw(0.2), Eigen::Vector3d(4.0, 5.0, 6.0)),
      Sample(0.04, Yaw(0.3), Eigen::Vector3d(7.0, 8.0, 9.0))};
  for (const NavSample& sample : nav) {
    const Rigid3d pose = InterpolateLocalFromBody(nav, sample.time_s);
    EXPECT_EQ(pose.translation, sample.local_from_body.translation);
    EXPECT_EQ(pose.rotation.coeffs(), sample.local_from_body.rotation.coeffs());
  }
}

TEST(InterpolateLocalFromBody, OutsideTheSpanThrowsWithTheSpan) {
  const std::vector<NavSample> nav = {
      Sample(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()),
      Sample(2.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero())};
  try {
    InterpolateLocalFromBody(nav, 3.0);
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(), "time 3 s is outside the navigation span [0, 2] s");
  }
  EXPECT_THROW(InterpolateLocalFromBody(nav, -1e-9), std::out_of_range);
  EXPECT_THROW(InterpolateLocalFromBody(nav, std::nan("")), std::out_of_range);
  EXPECT_THROW(InterpolateLocalFromBody({}, 0.0), std::out_of_range);
}

TEST(InterpolateLrfRange, IsLinearBetweenSamples) {
  std::vector<LrfSample> lrf(3);
  lrf[0].time_s = 0.0;
  lrf[0].range_m = 100.0;
  lrf[1].time_s = 1.0;
  lrf[1].range_m = 110.0;
  lrf[2].time_s = 3.0;
  lrf[2].range_m = 90.0;
  EXPECT_DOUBLE_EQ(InterpolateLrfRange(lrf, 0.25), 102.5);
  EXPECT_DOUBLE_EQ(InterpolateLrfRange(lrf, 2.0), 100.0);
  EXPECT_EQ(InterpolateLrfRange(lrf, 3.0), 90.0);
  try {
    InterpolateLrfRange(lrf, 3.5);
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(), "time 3.5 s is outside the LRF span [0, 3] s");
  }
}

TEST(CamFromLocal, FollowsTheConventionOnAHandCase) {
  // Body level at 100 m above the origin, camera = body (identity mount, which
  // points the camera z axis along local z: fine for a convention check).
  Dataset dataset = EmptyDataset();
  dataset.nav = {Sample(0.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, 100.0)),
                 Sample(1.0, Eigen::Quaterniond::Identity(), Eigen::Vector3d(10.0, 0.0, 100.0))};
  FrameRecord frame;
  frame.time_s = 0.5;
  dataset.frames = {frame};
  const Rigid3d cam_from_local = dataset.CamFromLocal(0);
  EXPECT_LT((cam_from_local * Eigen::Vector3d::Zero() - Eigen::Vector3d(-5.0, 0.0, -100.0)).norm(),
            1e-12);
  EXPECT_LT((dataset.CameraCenterInLocal(0) - Eigen::Vector3d(5.0, 0.0, 100.0)).norm(), 1e-12);
  EXPECT_THROW(dataset.CamFromLocal(1), std::out_of_range);
  EXPECT_THROW(dataset.CamFromLocal(-1), std::out_of_range);
}

// Relative pose against truth built so that cam2_from_cam1 is known: pick the
// mount, cam1_from_local and cam2_from_cam1, then derive the navigation
// local_from_body(t_i) = inverse(cam_i_from_local) * cam_from_body.
TEST(Cam2FromCam1, MatchesConstructedTruth) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const testing_support::ConstructedPair pair = testing_support::DrawConstructedPair(&rng);
    const Rigid3d& cam2_from_cam1 = pair.cam2_from_cam1;
    Dataset dataset = testing_support::TwoFrameDataset(pair);
    dataset.nav = pair.Navigation();

    const Rigid3d estimate = dataset.Cam2FromCam1(0, 1);
    EXPECT_LT(AngleBetween(estimate.rotation, cam2_from_cam1.rotation), 1e-12);
    EXPECT_LT((estimate.translation - cam2_from_cam1.translation).norm(), 1e-9);
    // Baseline = |centre2 - centre1|, which is |t of cam2_from_cam1| seen from cam 1.
    EXPECT_NEAR(dataset.BaselineM(0, 1), cam2_from_cam1.Inverse().translation.norm(), 1e-9);
    // The reverse pair is the inverse.
    const Rigid3d reverse = dataset.Cam2FromCam1(1, 0);
    EXPECT_LT(AngleBetween(reverse.rotation, cam2_from_cam1.rotation.conjugate()), 1e-12);
  }
}

TEST(MakeExampleDataset, HasTheHdaGeometry) {
  const Dataset dataset = MakeExampleDataset(CurrentTestSeed());
  const int last = static_cast<int>(dataset.frames.size()) - 1;
  ASSERT_EQ(last, 5);
  EXPECT_NEAR(dataset.frames[5].time_s - dataset.frames[0].time_s, 2.4, 1e-12);
  // 13 m/s for 2.4 s, plus what the 0.2 degree attitude wobble moves the
  // 0.58 m lever arm: well under a centimetre.
  EXPECT_NEAR(dataset.BaselineM(0, last), 31.2, 0.01);
  // Slant range about 400 * sqrt(2) m at 45 degrees off nadir.
  const double mid_time = 0.5 * (dataset.frames[0].time_s + dataset.frames[5].time_s);
  EXPECT_NEAR(dataset.LrfRangeAt(mid_time), 400.0 * std::sqrt(2.0), 5.0);
  // The optical axis of the middle of the pass meets the ground near the ILS.
  const Rigid3d local_from_cam = dataset.CamFromLocal(2).Inverse();
  const Eigen::Vector3d axis = local_from_cam.rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d center = local_from_cam.translation;
  const Eigen::Vector3d hit = center - center.z() / axis.z() * axis;
  EXPECT_LT(hit.head<2>().norm(), 15.0);
  // 45 degrees off nadir.
  EXPECT_NEAR(std::acos(-axis.z()) * 180.0 / kPi, 45.0, 0.5);
}

// Bilinear sample of an 8-bit image at a sub-pixel position (inside).
double Bilinear(const cv::Mat& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  const double u = x - x0;
  const double v = y - y0;
  auto at = [&](int r, int c) { return static_cast<double>(image.at<unsigned char>(r, c)); };
  return (1 - v) * ((1 - u) * at(y0, x0) + u * at(y0, x0 + 1)) +
         v * ((1 - u) * at(y0 + 1, x0) + u * at(y0 + 1, x0 + 1));
}

double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  double mean_a = 0.0;
  double mean_b = 0.0;
  for (size_t i = 0; i < n; ++i) {
    mean_a += a[i] / static_cast<double>(n);
    mean_b += b[i] / static_cast<double>(n);
  }
  double ab = 0.0;
  double aa = 0.0;
  double bb = 0.0;
  for (size_t i = 0; i < n; ++i) {
    ab += (a[i] - mean_a) * (b[i] - mean_b);
    aa += (a[i] - mean_a) * (a[i] - mean_a);
    bb += (b[i] - mean_b) * (b[i] - mean_b);
  }
  return ab / std::sqrt(aa * bb);
}

// The images agree with the geometry: a pixel of frame 0 and the pixel of
// frame 5 where its truth point projects show the same ground.
TEST(MakeExampleDataset, ImagesAgreeWithPosesAndTruth) {
  const Dataset dataset = MakeExampleDataset(CurrentTestSeed());
  const cv::Mat& image0 = dataset.frames[0].image;
  const cv::Mat& image5 = dataset.frames[5].image;
  const cv::Mat& points0 = dataset.truth.points[0].points_in_local_m;
  const Rigid3d cam5_from_local = dataset.CamFromLocal(5);
  std::vector<Eigen::Vector3d> points_in_cam5;
  std::vector<double> values0;
  for (int row = 8; row < image0.rows - 8; row += 3) {
    for (int col = 8; col < image0.cols - 8; col += 3) {
      const cv::Vec3f p = points0.at<cv::Vec3f>(row, col);
      points_in_cam5.push_back(cam5_from_local * Eigen::Vector3d(p[0], p[1], p[2]));
      values0.push_back(image0.at<unsigned char>(row, col));
    }
  }
  std::vector<Eigen::Vector2d> pixels5;
  std::vector<unsigned char> valid;
  dataset.camera.Project(points_in_cam5, &pixels5, &valid);
  std::vector<double> a;
  std::vector<double> b;
  std::vector<double> shifted;
  for (size_t i = 0; i < pixels5.size(); ++i) {
    const Eigen::Vector2d& q = pixels5[i];
    if (valid[i] == 0 || q.x() < 8 || q.y() < 8 || q.x() > image5.cols - 9 ||
        q.y() > image5.rows - 9) {
      continue;
    }
    a.push_back(values0[i]);
    b.push_back(Bilinear(image5, q.x(), q.y()));
    shifted.push_back(Bilinear(image5, q.x() + 6.0, q.y()));
  }
  ASSERT_GT(a.size(), 3000U);  // the pass keeps most of the scene in view
  EXPECT_GT(Correlation(a, b), 0.9);
  EXPECT_LT(Correlation(a, shifted), 0.7);  // the texture is not flat
}

}  // namespace
}  // namespace hdabench::datasets
