#include "reference/direct/plane_direct.h"

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/text.h"
#include "tests/reference/textured_plane_scene.h"

namespace hdabench::reference {
namespace {

using textured_plane::AngleDeg;
using textured_plane::Camera;
using textured_plane::Render;
using textured_plane::Scene;

DirectPlaneImages ExactImages(const Scene& scene) {
  return PrepareDirectPlaneImages(Render(scene, Rigid3d(), 0.0, 1), Render(scene, scene.cam2_from_cam1, 0.0, 2));
}

DirectPlaneResult Fit(const Scene& scene, double sigma_dn, const cv::Rect& box,
                      const Eigen::Vector3d& start = Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0),
                      const DirectPlaneOptions& options = DirectPlaneOptions()) {
  const DirectPlaneImages images =
      PrepareDirectPlaneImages(Render(scene, Rigid3d(), sigma_dn, 1), Render(scene, scene.cam2_from_cam1, sigma_dn, 2));
  return FitPlaneDirect(images, Camera(), box, scene.cam2_from_cam1, start, scene.up, options);
}

// The slope's uncertainty the parallax alone leaves a square box of side w
// px whose N pixels are each located along the epipolar line to
// precision_px: a least-squares plane's disparity gradient is then
// uncertain by precision_px sqrt(12 / N) / w per pixel, and a slope of
// tangent t changes the disparity d = f B / Z by d t / f per pixel, so
// sigma = precision_px sqrt(12 / N) f / (w d) radians (to first order).
// It is taken on the fit's starting plane: level, 90 m from camera 1.
double ParallaxSigmaRad(double baseline_m, int side_px, double precision_px) {
  const double disparity_px = textured_plane::kFocalPx * baseline_m / 90.0;
  const double n = static_cast<double>(side_px) * side_px;
  return precision_px * std::sqrt(12.0 / n) * textured_plane::kFocalPx / (side_px * disparity_px);
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
  // The 5 m baseline's parallax would give a slope (0.1 deg at 1/16 px per
  // pixel): the cause is the texture.
  const double precision_px = DirectPlaneOptions().parallax_precision_px;
  EXPECT_NEAR(fit.parallax_slope_sigma_deg * util::kDegToRad / ParallaxSigmaRad(5.0, 48, precision_px), 1.0,
              0.05);
  EXPECT_LT(fit.parallax_slope_sigma_deg, DirectPlaneOptions().max_slope_sigma_deg);
}

// A hundredth of the baseline (0.4 px of disparity, corners still moving
// far more than convergence_px between the plane and infinity): the noisy
// fit's own sigma is far over the bound, and the parallax alone leaves the
// slope about 10 deg uncertain at 1/16 px per pixel, so no texture would
// have given one: the ROI is low parallax, not no texture. The attribution
// follows parallax_precision_px: at a hundredth of it the geometry would
// allow a slope, and the texture is blamed.
TEST(FitPlaneDirect, APairWhoseParallaxLeavesNoSlopeIsLowParallaxNotNoTexture) {
  Scene scene;
  scene.cam2_from_cam1.translation = Eigen::Vector3d(-0.05, 0.0, 0.0);
  const cv::Rect box(104, 104, 48, 48);
  const DirectPlaneOptions options;
  const DirectPlaneResult fit = Fit(scene, 1.0, box, Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), options);
  EXPECT_EQ(fit.status, DirectPlaneStatus::kLowParallax) << fit.reason;
  EXPECT_NE(fit.reason.find("the nav pose's parallax (baseline 0.05 m)"), std::string::npos) << fit.reason;
  EXPECT_NE(fit.reason.find("the fit: "), std::string::npos) << fit.reason;
  EXPECT_NEAR(fit.parallax_slope_sigma_deg * util::kDegToRad / ParallaxSigmaRad(0.05, 48, options.parallax_precision_px),
              1.0, 0.05);
  EXPECT_GT(fit.parallax_slope_sigma_deg, options.max_slope_sigma_deg);
  EXPECT_TRUE(fit.points_in_cam1.empty());
  EXPECT_TRUE(std::isfinite(fit.slope_deg));

  DirectPlaneOptions sharper = options;
  sharper.parallax_precision_px = options.parallax_precision_px / 100.0;
  const DirectPlaneResult blamed = Fit(scene, 1.0, box, Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), sharper);
  EXPECT_TRUE(blamed.status == DirectPlaneStatus::kNoTexture || blamed.status == DirectPlaneStatus::kDiverged)
      << ToString(blamed.status) << ": " << blamed.reason;
  EXPECT_LT(blamed.parallax_slope_sigma_deg, options.max_slope_sigma_deg);
  EXPECT_NEAR(blamed.parallax_slope_sigma_deg / fit.parallax_slope_sigma_deg, 0.01, 1e-9);
}

// With a twenty-fifth of that baseline the parallax alone leaves the slope
// uncertain by more than a right angle: the reason says "any angle" rather
// than a number of degrees, and the sigma is still the first-order one.
// With a sixth of it (about 60 deg) the reason gives the degrees.
TEST(FitPlaneDirect, AParallaxThatLeavesEverySlopeOpenSaysAnyAngle) {
  Scene scene;
  scene.cam2_from_cam1.translation = Eigen::Vector3d(-0.002, 0.0, 0.0);
  const cv::Rect box(104, 104, 48, 48);
  const DirectPlaneOptions options;
  // The corners still move by more than convergence_px: the plane is
  // observable in principle, so the fit runs and its failure is attributed.
  ASSERT_GT(textured_plane::kFocalPx * 0.002 / 90.0, options.convergence_px);
  const DirectPlaneResult fit = Fit(scene, 1.0, box, Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), options);
  EXPECT_EQ(fit.status, DirectPlaneStatus::kLowParallax) << fit.reason;
  EXPECT_GE(fit.parallax_slope_sigma_deg, 90.0);
  EXPECT_NEAR(fit.parallax_slope_sigma_deg * util::kDegToRad /
                  ParallaxSigmaRad(0.002, 48, options.parallax_precision_px),
              1.0, 0.05);
  EXPECT_NE(fit.reason.find("leaves the slope uncertain by any angle on the starting plane"), std::string::npos)
      << fit.reason;
  EXPECT_EQ(fit.reason.find(" deg on the starting plane"), std::string::npos) << fit.reason;
  EXPECT_TRUE(fit.points_in_cam1.empty());

  scene.cam2_from_cam1.translation = Eigen::Vector3d(-0.05 / 6.0, 0.0, 0.0);
  const DirectPlaneResult wide = Fit(scene, 1.0, box, Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), options);
  EXPECT_EQ(wide.status, DirectPlaneStatus::kLowParallax) << wide.reason;
  EXPECT_GT(wide.parallax_slope_sigma_deg, 45.0);
  EXPECT_LT(wide.parallax_slope_sigma_deg, 80.0);
  const std::string degrees = util::FixedText(wide.parallax_slope_sigma_deg, 1) + " deg on the starting plane";
  EXPECT_NE(wide.reason.find("leaves the slope uncertain by " + degrees), std::string::npos) << wide.reason;
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

// A fit stopped before it settles (three Gauss-Newton steps from a start
// 10 % too far and level) gives no plane, however small its sigma.
TEST(FitPlaneDirect, AFitThatDoesNotSettleIsDiverged) {
  const Scene scene;
  const DirectPlaneImages images = ExactImages(scene);
  DirectPlaneOptions options;
  options.max_iterations = 3;
  options.search_fraction = 0.0;
  const DirectPlaneResult fit = FitPlaneDirect(images, Camera(), cv::Rect(104, 104, 48, 48), scene.cam2_from_cam1,
                                               Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), scene.up, options);
  EXPECT_FALSE(fit.converged);
  EXPECT_EQ(fit.status, DirectPlaneStatus::kDiverged) << fit.reason;
  EXPECT_NE(fit.reason.find("did not settle"), std::string::npos) << fit.reason;
  EXPECT_TRUE(fit.points_in_cam1.empty());
}

// A fit stopped before it settles whose own sigma is under the bound stays
// "diverged" on a pair whose parallax, judged with a coarse matcher's 1/4
// px, would leave the slope over it: the fit's pixels pinned the plane, so
// the geometry is not what failed (the parallax is then not judged).
TEST(FitPlaneDirect, AFitThatDoesNotSettleWithASigmaUnderTheBoundIsNotBlamedOnTheParallax) {
  Scene scene;
  scene.cam2_from_cam1.translation = Eigen::Vector3d(-0.15, 0.0, 0.0);
  const DirectPlaneImages images = ExactImages(scene);
  DirectPlaneOptions options;
  options.max_iterations = 1;
  options.search_fraction = 0.0;
  options.parallax_precision_px = 0.25;
  ASSERT_GT(ParallaxSigmaRad(0.15, 48, options.parallax_precision_px) * util::kRadToDeg,
            2.0 * options.max_slope_sigma_deg);
  const DirectPlaneResult fit = FitPlaneDirect(images, Camera(), cv::Rect(104, 104, 48, 48), scene.cam2_from_cam1,
                                               Eigen::Vector3d(0.0, 0.0, 1.0 / 90.0), scene.up, options);
  EXPECT_FALSE(fit.converged);
  EXPECT_EQ(fit.status, DirectPlaneStatus::kDiverged) << fit.reason;
  EXPECT_GT(fit.slope_sigma_deg, 0.0);
  EXPECT_LE(fit.slope_sigma_deg, options.max_slope_sigma_deg);
  EXPECT_NE(fit.reason.find("did not settle"), std::string::npos) << fit.reason;
  EXPECT_EQ(fit.parallax_slope_sigma_deg, 0.0);
  EXPECT_TRUE(fit.points_in_cam1.empty());
}

// With a tenth or three hundredths of a millimetre of baseline (the corners
// still move by 9e-4 and 2.7e-4 px, over convergence_px) and 1 DN of noise
// (the tests' seeded generator), the Gauss-Newton steps
// follow the noise until every step puts the ROI behind a camera: the fit
// ends "diverged", with no sigma of its own, and the parallax takes the
// blame as it does for a fit that found no texture.
TEST(FitPlaneDirect, AFitThatDivergesWhereTheParallaxLeavesAnySlopeIsLowParallax) {
  for (const double baseline_m : {1e-4, 3e-5}) {
    Scene scene;
    scene.cam2_from_cam1.translation = Eigen::Vector3d(-baseline_m, 0.0, 0.0);
    const DirectPlaneResult fit = Fit(scene, 1.0, cv::Rect(104, 104, 48, 48));
    EXPECT_EQ(fit.status, DirectPlaneStatus::kLowParallax) << fit.reason;
    EXPECT_NE(fit.reason.find("the fit: every step puts the ROI behind a camera"), std::string::npos)
        << fit.reason;
    EXPECT_NE(fit.reason.find("uncertain by any angle"), std::string::npos) << fit.reason;
    EXPECT_EQ(fit.slope_sigma_deg, 0.0);
    EXPECT_TRUE(std::isfinite(fit.parallax_slope_sigma_deg));
    EXPECT_GT(fit.parallax_slope_sigma_deg, 90.0);
    EXPECT_TRUE(fit.points_in_cam1.empty());
  }
}

// Without a baseline every plane maps the ROI alike: the plane is not
// observable, which is said as such (it was "diverged" or "no texture", by
// how the singular solve ended). Rounding errors of a pose are no baseline.
TEST(FitPlaneDirect, APairWithoutBaselineIsLowParallaxNotDivergedOrUntextured) {
  const Scene scene;
  const DirectPlaneImages images = ExactImages(scene);
  for (const Eigen::Vector3d& t : {Eigen::Vector3d::Zero().eval(), Eigen::Vector3d(2e-12, -1e-12, 3e-12)}) {
    const Rigid3d still(scene.cam2_from_cam1.rotation, t);
    const DirectPlaneResult fit = FitPlaneDirect(images, Camera(), cv::Rect(104, 104, 48, 48), still, scene.plane,
                                                 scene.up, DirectPlaneOptions());
    EXPECT_EQ(fit.status, DirectPlaneStatus::kLowParallax) << fit.reason;
    EXPECT_STREQ(ToString(fit.status), "low parallax");
    EXPECT_NE(fit.reason.find("the plane is not observable"), std::string::npos) << fit.reason;
    EXPECT_TRUE(fit.points_in_cam1.empty());
    EXPECT_TRUE(std::isfinite(fit.slope_deg));
  }
}

TEST(FitPlaneDirect, BadInputsAreInputErrors) {
  const Scene scene;
  const DirectPlaneImages images = ExactImages(scene);
  DirectPlaneOptions options;
  options.max_iterations = 0;
  EXPECT_THROW(FitPlaneDirect(images, Camera(), cv::Rect(0, 0, 8, 8), scene.cam2_from_cam1, scene.plane, scene.up,
                              options),
               InputError);
  options = DirectPlaneOptions();
  options.parallax_precision_px = 0.0;
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
