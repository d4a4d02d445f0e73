#include "hda/calibration_sigma.h"

#include <cmath>
#include <limits>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tools/util/angles.h"
#include "tools/util/error.h"

// A namespace of its own: the sanitizer tree's unity build joins this file
// with the other hda tests, whose helpers have the same names.
namespace hdabench::hda::calibration_sigma_test {
namespace {

using util::kDegToRad;
using util::kRadToDeg;

constexpr int kSizePx = 512;
constexpr double kFocalPx = 1000.0;
constexpr double kHeightM = 200.0;
constexpr double kBaselineM = 200.0 * 30.0 / 566.0;  // east, the paper's baseline-to-range ratio

calib::CameraModel Pinhole() {
  const double c = (kSizePx - 1) / 2.0;
  return calib::CameraModel("LENSMODEL_PINHOLE", {kFocalPx, kFocalPx, c, c}, kSizePx, kSizePx);
}

// Camera 1 at kHeightM above the local origin looking straight down (x east,
// y south, z down), camera 2 kBaselineM east of it with the same attitude;
// the ground is the plane through the origin tilted by slope_deg toward
// north. The matches are the exact projections of the ground seen at a grid
// of image-1 pixels in the box.
struct Site {
  HdaInput input;
  cv::Rect box;
  std::vector<cv::Point2d> points1, points2;
};

Site MakeSite(double slope_deg) {
  Site site;
  Eigen::Matrix3d local_r_cam;
  local_r_cam << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  const Eigen::Vector3d centre(0.0, 0.0, kHeightM);
  site.input.local_from_cam1 = Rigid3d(Eigen::Quaterniond(local_r_cam), centre);
  site.input.cam2_from_cam1 = Rigid3d(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-kBaselineM, 0.0, 0.0));
  site.input.lrf_range_m = kHeightM;
  const double s = slope_deg * kDegToRad;
  const Eigen::Vector3d normal(0.0, std::sin(s), std::cos(s));
  site.box = cv::Rect(224, 224, 64, 64);
  const double c = (kSizePx - 1) / 2.0;
  for (int j = 0; j < 10; ++j) {
    for (int i = 0; i < 10; ++i) {
      const Eigen::Vector2d q1(site.box.x + 3.0 + 6.5 * i, site.box.y + 3.0 + 6.5 * j);
      const Eigen::Vector3d ray = local_r_cam * Eigen::Vector3d((q1.x() - c) / kFocalPx, (q1.y() - c) / kFocalPx, 1.0);
      const Eigen::Vector3d ground = centre + ray * (-normal.dot(centre) / normal.dot(ray));
      const Eigen::Vector3d in_cam2 = site.input.cam2_from_cam1 * (local_r_cam.transpose() * (ground - centre));
      site.points1.emplace_back(q1.x(), q1.y());
      site.points2.emplace_back(kFocalPx * in_cam2.x() / in_cam2.z() + c, kFocalPx * in_cam2.y() / in_cam2.z() + c);
    }
  }
  return site;
}

calib::IntrinsicsModes ModesOf(const calib::CameraModel& camera, std::vector<calib::IntrinsicsMode> modes) {
  calib::IntrinsicsModes m;
  m.model = "<constructed>";
  m.lensmodel = camera.LensModelName();
  m.intrinsics = camera.Intrinsics();
  m.modes = std::move(modes);
  return m;
}

CalibrationSigma SigmaOf(const Site& site, const calib::IntrinsicsModes& modes) {
  return SiteCalibrationSigma(site.input, Pinhole(), HdaOptions(), modes, site.box, site.points1, site.points2, 0.0);
}

// A focal length known to sigma_f: the nav baseline fixes the lateral
// positions, so a focal length f (1 + e) stretches every depth by 1 + e and
// the plane's tan(slope) with it: d slope / d e = sin(slope) cos(slope), so
// sigma_slope = sin cos sigma_f / f (radians); the tilt is along the dip
// alone, so its sigma is the same.
TEST(SiteCalibrationSigma, AnUncertainFocalLengthGivesTheSlopeSigmaWorkedOutByHand) {
  const double sigma_f_px = 1.0;
  calib::IntrinsicsMode focal;
  focal.intrinsics_delta = {sigma_f_px, sigma_f_px, 0.0, 0.0};
  for (const double slope_deg : {3.0, 6.0, 9.0}) {
    SCOPED_TRACE(slope_deg);
    const Site site = MakeSite(slope_deg);
    const CalibrationSigma sigma = SigmaOf(site, ModesOf(Pinhole(), {focal}));
    ASSERT_TRUE(sigma.available) << sigma.why;
    EXPECT_NEAR(sigma.nominal_slope_deg, slope_deg, 1e-6);
    EXPECT_EQ(sigma.points, 100);
    const double s = slope_deg * kDegToRad;
    const double by_hand_deg = std::sin(s) * std::cos(s) * sigma_f_px / kFocalPx * kRadToDeg;
    EXPECT_NEAR(sigma.slope_deg, by_hand_deg, 0.01 * by_hand_deg);
    EXPECT_NEAR(sigma.tilt_deg, by_hand_deg, 0.01 * by_hand_deg);
  }
}

// Independent modes add in quadrature.
TEST(SiteCalibrationSigma, IndependentModesAddInQuadrature) {
  const Site site = MakeSite(6.0);
  calib::IntrinsicsMode fx, fy;
  fx.intrinsics_delta = {1.0, 1.0, 0.0, 0.0};
  fy.intrinsics_delta = {2.0, 2.0, 0.0, 0.0};
  const double one = SigmaOf(site, ModesOf(Pinhole(), {fx})).slope_deg;
  const double two = SigmaOf(site, ModesOf(Pinhole(), {fy})).slope_deg;
  const double both = SigmaOf(site, ModesOf(Pinhole(), {fx, fy})).slope_deg;
  EXPECT_NEAR(two, 2.0 * one, 1e-3 * one);
  EXPECT_NEAR(both, std::hypot(one, two), 1e-3 * both);
}

// Bearings turned by R (the pixels re-projected after turning their rays)
// and the inputs seen from the turned frame give the nominal site exactly:
// how a mode's implied rotation is taken out. Left in, the same turn tilts
// the site.
TEST(InputInTurnedFrame, TakesOutATurnOfEveryBearing) {
  const Site site = MakeSite(6.0);
  const double c = (kSizePx - 1) / 2.0;
  const RoiResult nominal =
      EvaluateMatchedSite(site.input, Pinhole(), HdaOptions(), site.box, site.points1, site.points2, 0.0);
  ASSERT_TRUE(nominal.has_fit) << nominal.reason;
  for (const Eigen::Vector3d& r : {Eigen::Vector3d(0.0, 1e-3, 0.0), Eigen::Vector3d(2e-3, -1e-3, 5e-4)}) {
    SCOPED_TRACE(r.transpose());
    const Eigen::Matrix3d turn = Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
    std::vector<cv::Point2d> turned1, turned2;
    for (size_t k = 0; k < site.points1.size(); ++k) {
      for (int image = 0; image < 2; ++image) {
        const cv::Point2d q = image == 0 ? site.points1[k] : site.points2[k];
        const Eigen::Vector3d v = turn * Eigen::Vector3d((q.x - c) / kFocalPx, (q.y - c) / kFocalPx, 1.0);
        (image == 0 ? turned1 : turned2).emplace_back(kFocalPx * v.x() / v.z() + c, kFocalPx * v.y() / v.z() + c);
      }
    }
    const RoiResult taken_out = EvaluateMatchedSite(InputInTurnedFrame(site.input, r), Pinhole(), HdaOptions(),
                                                    site.box, turned1, turned2, 0.0);
    ASSERT_TRUE(taken_out.has_fit) << taken_out.reason;
    EXPECT_LT((taken_out.normal_in_local - nominal.normal_in_local).norm(), 1e-9);
    const RoiResult left_in =
        EvaluateMatchedSite(site.input, Pinhole(), HdaOptions(), site.box, turned1, turned2, 0.0);
    EXPECT_GT((left_in.normal_in_local - nominal.normal_in_local).norm(), 0.5 * r.norm());
  }
}

// A principal point known to sigma_c: both images' rays move alike in x/z,
// so the disparities and depths stay, and the points shear along x by
// -sigma_c Z / f: a plane sloped across the baseline (toward north) keeps
// its normal (the mode carries no rotation).
TEST(SiteCalibrationSigma, AnUncertainPrincipalPointLeavesASlopeAcrossTheBaseline) {
  calib::IntrinsicsMode shift;
  shift.intrinsics_delta = {0.0, 0.0, 1.0, 0.0};
  const CalibrationSigma sigma = SigmaOf(MakeSite(6.0), ModesOf(Pinhole(), {shift}));
  ASSERT_TRUE(sigma.available) << sigma.why;
  EXPECT_LT(sigma.tilt_deg, 1e-9);
}

TEST(SiteCalibrationSigma, NoModesNoSigmaAndModesOfAnotherCameraAreRefused) {
  const Site site = MakeSite(6.0);
  const CalibrationSigma none = SigmaOf(site, ModesOf(Pinhole(), {}));
  ASSERT_TRUE(none.available) << none.why;
  EXPECT_EQ(none.slope_deg, 0.0);
  calib::IntrinsicsModes other = ModesOf(Pinhole(), {});
  other.intrinsics[0] += 1.0;
  EXPECT_THROW(SigmaOf(site, other), InputError);
  calib::IntrinsicsMode short_mode;
  short_mode.intrinsics_delta = {1.0};
  EXPECT_THROW(SigmaOf(site, ModesOf(Pinhole(), {short_mode})), InputError);
}

TEST(SiteCalibrationSigma, ASiteWithTooFewMatchesHasNoSigmaAndSaysWhy) {
  Site site = MakeSite(6.0);
  site.points1.resize(2);
  site.points2.resize(2);
  const CalibrationSigma sigma = SigmaOf(site, ModesOf(Pinhole(), {}));
  EXPECT_FALSE(sigma.available);
  EXPECT_NE(sigma.why.find("no plane with the nominal camera"), std::string::npos) << sigma.why;
}

TEST(CombinedSlopeSigmaDeg, AddsInQuadratureAndKeepsTheMethodsAloneWithoutATerm) {
  EXPECT_DOUBLE_EQ(CombinedSlopeSigmaDeg(0.3, 0.4), 0.5);
  EXPECT_EQ(CombinedSlopeSigmaDeg(0.3, std::numeric_limits<double>::quiet_NaN()), 0.3);
}

}  // namespace
}  // namespace hdabench::hda::calibration_sigma_test
