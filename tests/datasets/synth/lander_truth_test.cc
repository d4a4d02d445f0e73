// The lander truth (datasets/synth/lander_truth.h) on constructed surfaces
// whose answers are worked out by hand in each test's comment.
#include "datasets/synth/lander_truth.h"

#include <cmath>
#include <functional>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "tools/util/error.h"

namespace hdabench::datasets::synth {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A 20 m x 20 m surface centred on the origin, cells every `spacing` m, with
// heights z(x, y).
SurfaceGrid MakeSurface(const std::function<double(double, double)>& z, double spacing = 0.05) {
  SurfaceGrid s;
  s.spacing_m = spacing;
  s.origin_in_local_m = Eigen::Vector2d(-10.0, 10.0);
  const int n = static_cast<int>(std::lround(20.0 / spacing)) + 1;
  s.height_m = cv::Mat(n, n, CV_32FC1);
  for (int r = 0; r < n; ++r) {
    for (int c = 0; c < n; ++c) {
      s.height_m.at<float>(r, c) = static_cast<float>(z(-10.0 + c * spacing, 10.0 - r * spacing));
    }
  }
  return s;
}

// Four pads on a 4 m circle, each on the cell under its centre (pydem's
// "square" lander with a point pad).
LanderGeometry FourPointPads() {
  LanderGeometry lander;
  lander.legs = 4;
  lander.footprint_diameter_m = 4.0;
  lander.pad_diameter_m = 0.0;
  return lander;
}

TEST(LanderTruth, TheDefaultGeometryIsValidAndBadFieldsAreNamed) {
  EXPECT_TRUE(LanderGeometry().Validate().empty());
  LanderGeometry bad;
  bad.legs = 2;
  bad.body_clearance_m = 0.0;
  const std::vector<std::string> errors = bad.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("lander.legs"), std::string::npos);
  EXPECT_NE(errors[1].find("lander.body_clearance_m"), std::string::npos);
}

// A plane rising 12 deg toward the east. Every pad's highest point is its
// disk's uphill edge, 0.25 m east of its centre, so every contact is lifted
// by the same 0.25 tan 12 deg: the landing plane is parallel to the ground,
// 12 deg at every yaw (unsafe: over 10), and the ground under the body lies
// below it (clearance 0). At 8 deg: 8 deg, safe. On the 0.05 m grid a pad's
// highest cell centre lies up to a cell short of its uphill edge, so a
// contact may sit up to 0.05 tan 12 deg = 0.011 m low: over the 3.5 m
// between pads, up to 0.2 deg of tilt; 0.05 deg is allowed.
TEST(LanderTruth, APlaneIsUnsafeAtTwelveDegreesAndSafeAtEight) {
  for (const double slope : {12.0, 8.0}) {
    SCOPED_TRACE(slope);
    const SurfaceGrid s = MakeSurface([&](double x, double) { return std::tan(slope * kDeg) * x; });
    const LandingVerdict v = EvaluateLanding(s, Eigen::Vector2d(0.5, -1.0), LanderGeometry());
    ASSERT_TRUE(v.defined) << v.why;
    EXPECT_NEAR(v.slope_deg, slope, 0.05);
    EXPECT_NEAR(v.clearance_m, 0.0, 1e-3);
    EXPECT_EQ(v.unsafe_by_slope, slope > 10.0);
    EXPECT_FALSE(v.unsafe_by_clearance);
    EXPECT_EQ(v.safe, slope < 10.0);
  }
}

// The 8 deg plane with a 0.6 m square block under the body, its top h above
// the ground (h = 0.4 m and 0.2 m). The landing plane lies 0.25 tan 8 deg =
// 0.0351 m above the ground (the pads' uphill edges), so the block's top is
// h - 0.0351 m above it vertically, (h - 0.0351) cos 8 deg along its normal:
// 0.3614 m for 0.4 (over 0.30: unsafe by clearance) and 0.1633 m for 0.2
// (safe). The slope stays 8 deg. A contact may sit up to 0.05 tan 8 deg =
// 0.007 m low on the 0.05 m grid (see above): 0.005 m is allowed.
TEST(LanderTruth, ABlockUnderTheBodyIsUnsafeAtFortyCentimetresAndSafeAtTwenty) {
  for (const double h : {0.4, 0.2}) {
    SCOPED_TRACE(h);
    const SurfaceGrid s = MakeSurface([&](double x, double y) {
      const double ground = std::tan(8.0 * kDeg) * x;
      return std::abs(x) <= 0.3 && std::abs(y) <= 0.3 ? ground + h : ground;
    });
    const LandingVerdict v = EvaluateLanding(s, Eigen::Vector2d(0.0, 0.0), LanderGeometry());
    ASSERT_TRUE(v.defined) << v.why;
    const double expected = (h - 0.25 * std::tan(8.0 * kDeg)) * std::cos(8.0 * kDeg);
    // The block's top follows the ground, so its gap to the plane is the
    // same over the whole block.
    EXPECT_NEAR(v.clearance_m, expected, 5e-3);
    EXPECT_NEAR(v.slope_deg, 8.0, 0.05);
    EXPECT_FALSE(v.unsafe_by_slope);
    EXPECT_EQ(v.unsafe_by_clearance, h > 0.3);
    EXPECT_EQ(v.safe, h < 0.3);
  }
}

// Level ground and a 0.3 m block (0.2 m square) under the east pad of a
// four-pad lander at yaw 0: pads A (2, 0, 0.3), B (0, 2, 0), C (-2, 0, 0),
// D (0, -2, 0). The plane through B, C, D is z = 0 and leaves A above it; the
// one through A, B, D (z = 0.15 x - 0.3) leaves C above it. The lander rests
// on A and C and rocks onto B or D: the plane through A, B, C is
// z = 0.15 + 0.075 x - 0.075 y (D at 0 below its 0.3), and the one through
// A, C, D is its mirror. Slope atan(0.075 sqrt 2) = 6.0548 deg. At yaw 45 the
// pads miss the block: level. The worst yaw is 0; a lander that chooses its
// yaw lands level.
TEST(LanderTruth, ARockUnderOnePadLiftsItAndTiltsThePlane) {
  const SurfaceGrid s = MakeSurface([](double x, double y) {
    return std::abs(x - 2.0) <= 0.1 && std::abs(y) <= 0.1 ? 0.3 : 0.0;
  });
  LanderGeometry lander = FourPointPads();
  const LandingAtYaw at0 = EvaluateLandingAtYaw(s, Eigen::Vector2d(0.0, 0.0), 0.0, lander);
  ASSERT_TRUE(at0.defined);
  EXPECT_NEAR(at0.slope_deg, std::atan(0.075 * std::sqrt(2.0)) / kDeg, 1e-3);
  EXPECT_LT(at0.clearance_m, 0.02);  // the block's cells inside the polygon next to A
  EXPECT_FALSE(at0.unsafe_by_slope);
  const LandingAtYaw at45 = EvaluateLandingAtYaw(s, Eigen::Vector2d(0.0, 0.0), 45.0, lander);
  ASSERT_TRUE(at45.defined);
  EXPECT_NEAR(at45.slope_deg, 0.0, 1e-6);

  const LandingVerdict worst = EvaluateLanding(s, Eigen::Vector2d(0.0, 0.0), lander);
  EXPECT_NEAR(worst.slope_deg, at0.slope_deg, 1e-9);
  EXPECT_EQ(worst.yaw_deg, 0.0);
  lander.chooses_yaw = true;
  const LandingVerdict best = EvaluateLanding(s, Eigen::Vector2d(0.0, 0.0), lander);
  EXPECT_NEAR(best.slope_deg, 0.0, 1e-6);
  EXPECT_TRUE(best.safe);
}

// A ridge along x, z = -0.2 |y|, under a four-pad lander. Yaw 0: pads A
// (2, 0, 0) and C (-2, 0, 0) on the crest, B (0, 2) and D (0, -2) at -0.4.
// The plane through A, B, C is z = -0.2 y (D below it at 0.4) and the
// mirror through A, C, D; the one through A, B, D (z = 0.2 x - 0.4) leaves C
// above it. Slope atan 0.2 = 11.31 deg: unsafe. Yaw 45: every pad at
// |y| = 1.41 (the cell under it at 1.40), height -0.28: level, and the crest
// 0.28 m above the plane: under 0.30, safe. So the worst yaw is unsafe by
// slope, and a lander that chooses its yaw is safe (at 45 deg or at a yaw
// further inside the limits).
TEST(LanderTruth, OnARidgeTheYawDecides) {
  const SurfaceGrid s = MakeSurface([](double, double y) { return -0.2 * std::abs(y); });
  LanderGeometry lander = FourPointPads();
  const LandingAtYaw at0 = EvaluateLandingAtYaw(s, Eigen::Vector2d(0.0, 0.0), 0.0, lander);
  ASSERT_TRUE(at0.defined);
  EXPECT_NEAR(at0.slope_deg, std::atan(0.2) / kDeg, 1e-3);
  EXPECT_NEAR(at0.clearance_m, 0.0, 1e-6);
  const LandingAtYaw at45 = EvaluateLandingAtYaw(s, Eigen::Vector2d(0.0, 0.0), 45.0, lander);
  ASSERT_TRUE(at45.defined);
  EXPECT_NEAR(at45.slope_deg, 0.0, 1e-6);
  EXPECT_NEAR(at45.clearance_m, 0.28, 1e-3);
  EXPECT_TRUE(at45.Safe());

  const LandingVerdict worst = EvaluateLanding(s, Eigen::Vector2d(0.0, 0.0), lander);
  EXPECT_TRUE(worst.unsafe_by_slope);
  EXPECT_FALSE(worst.safe);
  EXPECT_NEAR(worst.slope_deg, std::atan(0.2) / kDeg, 1e-3);
  lander.chooses_yaw = true;
  const LandingVerdict best = EvaluateLanding(s, Eigen::Vector2d(0.0, 0.0), lander);
  EXPECT_TRUE(best.safe);
  EXPECT_GT(best.yaw_deg, 0.0);
  EXPECT_LE(best.clearance_m, at45.clearance_m);
}

// A site whose footprint leaves the grid has no verdict; the safety map
// marks the grid's border so, and a level surface safe elsewhere.
TEST(LanderTruth, AFootprintOffTheGridHasNoVerdict) {
  const SurfaceGrid s = MakeSurface([](double, double) { return 0.0; }, 0.25);
  const LandingVerdict v = EvaluateLanding(s, Eigen::Vector2d(9.0, 0.0), LanderGeometry());
  EXPECT_FALSE(v.defined);
  EXPECT_FALSE(v.safe);
  EXPECT_NE(v.why.find("leaves the truth DEM"), std::string::npos);
  const cv::Mat map = SafetyMap(s, LanderGeometry(), 4);
  EXPECT_EQ(map.at<unsigned char>(0, 0), 0);
  EXPECT_EQ(map.at<unsigned char>(map.rows / 2, map.cols / 2), 1);
}

// The safety map decides each cell with shortcuts (a bound on the
// clearance, the first unsafe yaw); its classes are those of the full
// evaluation at the same cells, on rough ground with blocks of every height
// around the clearance and slopes across the limit, for a lander that cannot
// choose its yaw and for one that can.
TEST(LanderTruth, TheSafetyMapAgreesWithTheFullEvaluation) {
  const SurfaceGrid s = MakeSurface(
      [](double x, double y) {
        // Slopes from 3 to 17 deg across y, with ripples.
        const double ground = (0.05 + 0.125 * (y + 10.0) / 20.0) * x + 0.04 * std::sin(1.7 * x) * std::cos(2.3 * y);
        // Blocks 0.6 m wide, 0.1-0.55 m high, on a 4.5 m lattice, east of x = 0 only.
        const double bx = std::remainder(x, 4.5), by = std::remainder(y, 4.5);
        const double h = 0.1 + 0.05 * std::fmod(std::abs(std::floor(x / 4.5) * 3 + std::floor(y / 4.5) * 7), 10.0);
        return x > 0.0 && std::abs(bx) < 0.3 && std::abs(by) < 0.3 ? ground + h : ground;
      },
      0.1);
  for (const bool chooses : {false, true}) {
    SCOPED_TRACE(chooses);
    LanderGeometry lander;
    lander.chooses_yaw = chooses;
    const LanderOnSurface on(s, lander);
    const int stride = 3;
    const cv::Mat map = on.SafetyMap(stride, 2);
    int counts[4] = {0, 0, 0, 0};
    for (int r = 0; r < map.rows; ++r) {
      for (int c = 0; c < map.cols; ++c) {
        const Eigen::Vector2d centre(s.origin_in_local_m.x() + c * stride * s.spacing_m,
                                     s.origin_in_local_m.y() - r * stride * s.spacing_m);
        const LandingVerdict v = on.Evaluate(centre);
        const int expected = !v.defined ? 0 : v.safe ? 1 : (v.unsafe_by_slope ? 3 : 2);
        ASSERT_EQ(map.at<unsigned char>(r, c), expected) << r << "," << c;
        ++counts[expected];
      }
    }
    // Every class occurs, so each shortcut was taken somewhere.
    for (int k = 0; k < 4; ++k) EXPECT_GT(counts[k], 0) << k;
  }
}

// The pads' highest ground is cv::dilate's with the pad's disk and the edge
// replicated, to the float: random grids, radii from none to wider than the
// grid, whole and fractional, on grids with fewer rows than columns and more.
TEST(LanderTruth, TheDiskMaximumIsDilationByTheDisk) {
  cv::RNG rng(7);
  for (const cv::Size size : {cv::Size(37, 23), cv::Size(9, 41), cv::Size(1, 5)}) {
    cv::Mat z(size, CV_32FC1);
    rng.fill(z, cv::RNG::UNIFORM, -5.0, 5.0);
    for (const double radius : {0.0, 0.7, 1.0, 2.5, 3.0, 6.49, 11.2, 30.0}) {
      SCOPED_TRACE(std::to_string(size.width) + " x " + std::to_string(size.height) + ", radius " +
                   std::to_string(radius));
      const int reach = static_cast<int>(std::floor(radius));
      cv::Mat disk(2 * reach + 1, 2 * reach + 1, CV_8UC1, cv::Scalar(0));
      for (int r = -reach; r <= reach; ++r) {
        for (int c = -reach; c <= reach; ++c) {
          if (r * r + c * c <= radius * radius + 1e-9) disk.at<unsigned char>(r + reach, c + reach) = 1;
        }
      }
      cv::Mat expected;
      cv::dilate(z, expected, disk, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
      const cv::Mat got = DiskMaximum(z, radius);
      ASSERT_EQ(got.type(), CV_32FC1);
      EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0);
    }
  }
  EXPECT_THROW(DiskMaximum(cv::Mat(), 1.0), InputError);
  EXPECT_THROW(DiskMaximum(cv::Mat(3, 3, CV_32FC1, cv::Scalar(0)), -1.0), InputError);
  EXPECT_THROW(DiskMaximum(cv::Mat(3, 3, CV_8UC1, cv::Scalar(0)), 1.0), InputError);
}


// A rock's sphere is drawn onto the DEM: its top where its centre is, even
// when the rock is smaller than a cell.
TEST(LanderTruth, TheSurfaceCarriesTheRocks) {
  Truth truth;
  TruthDem dem;
  dem.spacing_m = 0.5;
  dem.origin_in_local_m = Eigen::Vector2d(-5.0, 5.0);
  dem.height_in_local_m = cv::Mat(21, 21, CV_32FC1, cv::Scalar(0.0f));
  truth.dem = dem;
  TruthRock big;
  big.center_in_local_m = Eigen::Vector3d(0.0, 0.0, -0.3);  // 2 m sphere: top at 0.7
  big.diameter_m = 2.0;
  big.height_above_ground_m = 0.7;
  TruthRock small;
  small.center_in_local_m = Eigen::Vector3d(2.1, -2.9, 0.0);  // 0.2 m sphere between cells: top at 0.1
  small.diameter_m = 0.2;
  small.height_above_ground_m = 0.1;
  truth.rocks = {big, small};
  const SurfaceGrid s = SurfaceOfTruth(truth);
  EXPECT_FLOAT_EQ(s.height_m.at<float>(10, 10), 0.7f);
  // (0.5, 0): -0.3 + sqrt(1 - 0.25) = 0.5660.
  EXPECT_NEAR(s.height_m.at<float>(10, 11), -0.3 + std::sqrt(0.75), 1e-6);
  // (1, 0): on the sphere's rim, below the ground: the ground.
  EXPECT_FLOAT_EQ(s.height_m.at<float>(10, 12), 0.0f);
  // Cell under (2.1, -2.9): column 14 (x = 2.0), row 16 (y = -3.0).
  EXPECT_FLOAT_EQ(s.height_m.at<float>(16, 14), 0.1f);
  EXPECT_FLOAT_EQ(s.height_m.at<float>(0, 0), 0.0f);
}

}  // namespace
}  // namespace hdabench::datasets::synth
