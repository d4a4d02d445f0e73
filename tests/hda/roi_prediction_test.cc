#include "hda/roi_prediction.h"

#include <cmath>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tools/util/angles.h"
#include "tests/support/cameras.h"

namespace hdabench::hda {
namespace {

using util::kPi;

constexpr double kFocalPx = 1000.0;
constexpr double kRangeM = 566.0;

using testing_support::Pinhole1000;  // f = kFocalPx

// Camera 2 displaced by position_in_cam1 (metres) with the same attitude.
Rigid3d Translated(const Eigen::Vector3d& position_in_cam1) {
  return Rigid3d(Eigen::Quaterniond::Identity(), -position_in_cam1);
}

// A 64 x 64 ROI whose centre pixel-edge coordinate is the principal point.
Roi CentreRoi() { return Roi{4, cv::Rect(480, 480, 64, 64), 100.0, 2.0}; }

PredictionOptions NoMargin() {
  PredictionOptions options;
  options.nav_position_sigma_m = 0;
  options.nav_attitude_sigma_deg = 0;
  options.range_sigma_m = 0;
  options.min_margin_px = 0;
  return options;
}

TEST(PredictionOptionsValidate, DefaultsAreValidAndBadFieldsAreNamed) {
  PredictionOptions options;
  EXPECT_TRUE(options.Validate().empty());
  options.sigma_multiplier = 0;
  options.min_margin_px = -1;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "sigma_multiplier = 0: expected > 0");
  EXPECT_EQ(errors[1], "min_margin_px = -1: expected >= 0");
}

TEST(PredictRoi, IdentityPoseWithoutMarginGivesTheSameBox) {
  const PredictedRoi predicted = PredictRoi(CentreRoi(), Pinhole1000(), Rigid3d(), kRangeM, NoMargin());
  EXPECT_EQ(predicted.status, PredictionStatus::kOk);
  EXPECT_EQ(predicted.id, 4);
  EXPECT_EQ(predicted.box_px, CentreRoi().box_px);
  EXPECT_EQ(predicted.margin_px, 0.0);
  EXPECT_FALSE(predicted.clipped);
}

TEST(PredictRoi, LateralTranslationShiftsByFocalTimesBaselineOverRange) {
  // Camera 2 is 30 m to the right (+x of camera 1) at 566 m from the ground
  // plane: the ground moves left by f * 30 / 566 = 53.0035 px.
  const double baseline_m = 30.0;
  PredictionOptions options;  // 1 m, 0.1 deg, 1 m, 3 sigma, 8 px minimum: a margin over the minimum
  options.nav_position_sigma_m = 1.0;
  options.nav_attitude_sigma_deg = 0.1;
  options.range_sigma_m = 1.0;
  const PredictedRoi predicted = PredictRoi(CentreRoi(), Pinhole1000(),
                                            Translated({baseline_m, 0, 0}), kRangeM, options);
  ASSERT_EQ(predicted.status, PredictionStatus::kOk);
  const double shift_px = kFocalPx * baseline_m / kRangeM;
  EXPECT_NEAR(predicted.projected_edges_px.x, 479.5 - shift_px, 1e-6);
  EXPECT_NEAR(predicted.projected_edges_px.y, 479.5, 1e-6);
  EXPECT_NEAR(predicted.projected_edges_px.width, 64.0, 1e-6);
  EXPECT_NEAR(predicted.projected_edges_px.height, 64.0, 1e-6);

  // Margin formula: the centre point is (-30, 0, 566) in camera 2, at
  // d = |(30, 566)|; the pinhole's scale there is f / cos^2 (across the ray in
  // x) and f / cos (in y), the larger being f * (1 + (30 / 566)^2).
  const double d = std::hypot(baseline_m, kRangeM);
  const double scale_px_per_rad = kFocalPx * (1.0 + (baseline_m / kRangeM) * (baseline_m / kRangeM));
  const double angle_rad = 1.0 / d + 0.1 * kPi / 180.0 + 1.0 * baseline_m / (d * d);
  const double expected_margin_px = 3.0 * scale_px_per_rad * angle_rad;  // about 10.84 px
  EXPECT_NEAR(predicted.margin_px, expected_margin_px, 1e-4);
  EXPECT_GT(predicted.margin_px, 8.0);

  // Pixels whose centres are inside the enlarged box.
  const double u0 = 479.5 - shift_px - expected_margin_px, u1 = u0 + 64.0 + 2 * expected_margin_px;
  const double v0 = 479.5 - expected_margin_px, v1 = v0 + 64.0 + 2 * expected_margin_px;
  const int x0 = static_cast<int>(std::ceil(u0)), x1 = static_cast<int>(std::floor(u1));
  const int y0 = static_cast<int>(std::ceil(v0)), y1 = static_cast<int>(std::floor(v1));
  EXPECT_EQ(predicted.box_px, cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1));
  EXPECT_EQ(predicted.box_px, cv::Rect(416, 469, 86, 86));
  EXPECT_FALSE(predicted.clipped);
}

TEST(PredictRoi, SmallMarginIsRaisedToTheMinimum) {
  PredictionOptions options = NoMargin();
  options.min_margin_px = 8;
  const PredictedRoi predicted = PredictRoi(CentreRoi(), Pinhole1000(), Rigid3d(), kRangeM, options);
  EXPECT_EQ(predicted.margin_px, 8.0);
  EXPECT_EQ(predicted.box_px, cv::Rect(472, 472, 80, 80));
}

TEST(PredictRoi, BoxAtTheBorderIsClipped) {
  const Roi roi{1, cv::Rect(0, 100, 32, 32), 100.0, 2.0};
  const PredictedRoi predicted =
      PredictRoi(roi, Pinhole1000(), Translated({10.0, 0, 0}), kRangeM, NoMargin());
  ASSERT_EQ(predicted.status, PredictionStatus::kOk);
  EXPECT_TRUE(predicted.clipped);
  // Shift left by 1000 * 10 / 566 = 17.67 px: columns 0 .. 13 remain.
  EXPECT_EQ(predicted.box_px, cv::Rect(0, 100, 14, 32));
}

TEST(PredictRoi, RoiThatLeavesImage2IsOutside) {
  // 600 m to the right: the ground moves 1060 px left, past the margin.
  const PredictedRoi predicted =
      PredictRoi(CentreRoi(), Pinhole1000(), Translated({600.0, 0, 0}), kRangeM, PredictionOptions());
  EXPECT_EQ(predicted.status, PredictionStatus::kOutsideImage2);
  EXPECT_TRUE(predicted.box_px.empty());
  EXPECT_STREQ(PredictionStatusName(predicted.status), "outside image 2");
}

TEST(PredictRoi, GroundBehindCamera2IsReported) {
  // Camera 2 turned 180 degrees about y: the ground is behind it.
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitY())),
                               Eigen::Vector3d::Zero());
  const PredictedRoi predicted =
      PredictRoi(CentreRoi(), Pinhole1000(), cam2_from_cam1, kRangeM, PredictionOptions());
  EXPECT_EQ(predicted.status, PredictionStatus::kBehindCamera);
  EXPECT_TRUE(predicted.box_px.empty());
  EXPECT_STREQ(PredictionStatusName(predicted.status), "behind camera");
}

TEST(PredictRoi, BadGroundDistanceThrowsInputError) {
  try {
    PredictRoi(CentreRoi(), Pinhole1000(), Rigid3d(), 0.0, PredictionOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "PredictRoi: ground_distance_m = 0: expected finite and > 0");
  }
  PredictionOptions bad;
  bad.range_sigma_m = -1;
  try {
    PredictRoi(CentreRoi(), Pinhole1000(), Rigid3d(), kRangeM, bad);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "PredictRoi: invalid PredictionOptions: range_sigma_m = -1: expected >= 0");
  }
}

}  // namespace
}  // namespace hdabench::hda
