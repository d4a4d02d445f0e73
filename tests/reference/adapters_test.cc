#include <random>

#include <gtest/gtest.h>
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/triangulation/methods.hpp>

#include "reference/colmap/colmap_adapter.h"
#include "reference/opengv/opengv_adapter.h"
#include "tools/util/random_vectors.h"

namespace hdabench::reference {
namespace {

double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

// A relative pose with a real rotation and a 30 m baseline, as in NOVA-C's HDA.
Rigid3d TrueCam2FromCam1() {
  const Eigen::Quaterniond r(Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1.0, -0.3).normalized()));
  return Rigid3d(r, Eigen::Vector3d(-29.0, 2.0, 7.0));
}

TEST(OpenGvAdapter, OpenGvTriangulationWithConvertedPoseRecoversThePoints) {
  const Rigid3d cam2_from_cam1 = TrueCam2FromCam1();
  std::mt19937_64 rng(0x5eed0001);
  std::uniform_real_distribution<double> lateral(-40.0, 40.0);
  std::uniform_real_distribution<double> depth(450.0, 650.0);
  opengv::bearingVectors_t bearings1;
  opengv::bearingVectors_t bearings2;
  std::vector<Eigen::Vector3d> points_in_cam1;
  for (int i = 0; i < 20; ++i) {
    const Eigen::Vector3d p1 = util::DrawVector3(lateral, lateral, depth, rng);
    points_in_cam1.push_back(p1);
    bearings1.push_back(p1.normalized());
    bearings2.push_back((cam2_from_cam1 * p1).normalized());
  }
  const opengv::transformation_t t12 = OpenGvFromCam2FromCam1(cam2_from_cam1);
  opengv::relative_pose::CentralRelativeAdapter adapter(bearings1, bearings2, t12.col(3),
                                                        t12.block<3, 3>(0, 0));
  for (size_t i = 0; i < points_in_cam1.size(); ++i) {
    // OpenGV's triangulation returns the point in frame 1 given X1 = R12 X2 + t12.
    const Eigen::Vector3d p = opengv::triangulation::triangulate(adapter, i);
    EXPECT_LT((p - points_in_cam1[i]).norm(), 1e-6) << "point " << i;
  }
}

TEST(OpenGvAdapter, UnitTranslationIsScaledToTheBaseline) {
  const Rigid3d truth = TrueCam2FromCam1();
  opengv::transformation_t t12 = OpenGvFromCam2FromCam1(truth);
  const double baseline_m = t12.col(3).norm();
  t12.col(3) /= baseline_m;  // what a solver returns: unit norm
  const Rigid3d back = Cam2FromCam1FromOpenGv(t12, baseline_m);
  EXPECT_LT(AngleBetween(back.rotation, truth.rotation), 1e-12);
  EXPECT_LT((back.translation - truth.translation).norm(), 1e-9);
}

TEST(ColmapAdapter, PoseRoundTripAndRelativePose) {
  const Rigid3d cam1_from_world(Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitX())),
                                Eigen::Vector3d(1, 2, 3));
  const Rigid3d cam2_from_world = TrueCam2FromCam1() * cam1_from_world;
  const std::array<double, 7> line1 = ColmapFromCamFromWorld(cam1_from_world);
  // COLMAP writes w first: a rotation of 0.7 rad about x is (cos 0.35, sin 0.35, 0, 0).
  EXPECT_NEAR(line1[0], std::cos(0.35), 1e-15);
  EXPECT_NEAR(line1[1], std::sin(0.35), 1e-15);
  EXPECT_EQ(line1[4], 1.0);
  ASSERT_TRUE(IsValidColmapPose(line1));
  const Rigid3d back1 = CamFromWorldFromColmap(line1);
  const Rigid3d back2 = CamFromWorldFromColmap(ColmapFromCamFromWorld(cam2_from_world));
  // x2 = R x1 + t in COLMAP is cam2_from_cam1 = cam2_from_world * world_from_cam1.
  const Rigid3d relative = back2 * back1.Inverse();
  EXPECT_LT(AngleBetween(relative.rotation, TrueCam2FromCam1().rotation), 1e-12);
  EXPECT_LT((relative.translation - TrueCam2FromCam1().translation).norm(), 1e-9);
  // A negative-w quaternion is the same rotation; COLMAP's line uses w >= 0.
  Rigid3d flipped = cam1_from_world;
  flipped.rotation.coeffs() *= -1.0;
  EXPECT_GE(ColmapFromCamFromWorld(flipped)[0], 0.0);
}

TEST(ColmapAdapter, RejectsUnusablePoseLines) {
  EXPECT_FALSE(IsValidColmapPose({0, 0, 0, 0, 1, 2, 3}));
  EXPECT_FALSE(IsValidColmapPose({1, 0, 0, 0, std::nan(""), 2, 3}));
  EXPECT_TRUE(IsValidColmapPose({2, 0, 0, 0, 1, 2, 3}));
}

TEST(ColmapAdapter, PixelsShiftByHalfAPixel) {
  EXPECT_EQ(PixelToColmap(Eigen::Vector2d(0, 0)), Eigen::Vector2d(0.5, 0.5));
  EXPECT_EQ(PixelFromColmap(Eigen::Vector2d(0.5, 1023.5)), Eigen::Vector2d(0, 1023));
}

}  // namespace
}  // namespace hdabench::reference
