#include "reference/opengv/two_view_models.h"

#include <cmath>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tests/support/test_support.h"
#include "tools/util/angles.h"

namespace hdabench::reference {
namespace {

using util::kDegToRad;

// Exact matches of 60 points 40-80 m deep seen from two cameras 10 m apart,
// the second turned by 4 degrees (OpenGV's convention: X1 = R12 X2 + t12).
struct ExactPair {
  std::vector<Eigen::Vector3d> bearings1;
  std::vector<Eigen::Vector3d> bearings2;
  EpipolarPose truth;
};

ExactPair MakeExactPair(std::uint64_t seed, double relief_m) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> lateral(-20.0, 20.0);
  std::uniform_real_distribution<double> depth(60.0 - relief_m, 60.0 + relief_m);
  ExactPair pair;
  pair.truth.r12 =
      Eigen::AngleAxisd(4.0 * kDegToRad, Eigen::Vector3d(0.2, 1.0, -0.3).normalized()).toRotationMatrix();
  const Eigen::Vector3d t12(10.0, 1.0, -1.5);
  pair.truth.t12 = t12.normalized();
  for (int i = 0; i < 60; ++i) {
    const Eigen::Vector3d x1(lateral(rng), lateral(rng), relief_m > 0 ? depth(rng) : 60.0);
    const Eigen::Vector3d x2 = pair.truth.r12.transpose() * (x1 - t12);
    pair.bearings1.push_back(x1.normalized());
    pair.bearings2.push_back(x2.normalized());
  }
  return pair;
}

double AngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a * b.transpose()).angle() / kDegToRad;
}

// From a start 1 degree off in rotation and 3 degrees in direction, the
// refinement lands on the exact pose (the Sampson distances of exact matches
// are zero there).
TEST(TwoViewModels, SampsonRefinementRecoversAnExactPose) {
  const ExactPair pair = MakeExactPair(testing_support::CurrentTestSeed(), 20.0);
  const TangentMatches matches = ToTangentPlanes(pair.bearings1, pair.bearings2);
  ASSERT_TRUE(matches.valid);
  ASSERT_EQ(matches.u1.size(), pair.bearings1.size());
  for (const double d : EpipolarSampsonPx(matches, pair.truth, 1000.0)) EXPECT_NEAR(d, 0.0, 1e-9);

  EpipolarPose pose;
  pose.r12 = pair.truth.r12 *
             Eigen::AngleAxisd(1.0 * kDegToRad, Eigen::Vector3d(1.0, 0.5, 0.2).normalized())
                 .toRotationMatrix();
  pose.t12 = (Eigen::AngleAxisd(3.0 * kDegToRad, Eigen::Vector3d::UnitY()) * pair.truth.t12);
  std::vector<size_t> all(matches.u1.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  ASSERT_TRUE(RefineEpipolarPose(matches, all, 1000.0, &pose));
  EXPECT_LT(AngleDeg(pose.r12, pair.truth.r12), 1e-6);
  const double direction_deg =
      std::atan2(pose.t12.cross(pair.truth.t12).norm(), std::abs(pose.t12.dot(pair.truth.t12))) /
      kDegToRad;
  EXPECT_LT(direction_deg, 1e-6);

  // Fewer than 5 matches: nothing to refine, the pose is left alone.
  EpipolarPose untouched = pose;
  EXPECT_FALSE(RefineEpipolarPose(matches, {0, 1, 2, 3}, 1000.0, &untouched));
  EXPECT_EQ(untouched.r12, pose.r12);
}

// Exact matches of a plane: the homography's Sampson distances vanish and it
// wins; of a volume: they do not, and the general model wins. The general
// model is fitted from a start off the truth.
TEST(TwoViewModels, GricPicksThePlaneOnlyWhenTheMatchesLieOnOne) {
  for (const double relief_m : {0.0, 20.0}) {
    SCOPED_TRACE(relief_m);
    const ExactPair pair = MakeExactPair(testing_support::CurrentTestSeed(), relief_m);
    const TangentMatches matches = ToTangentPlanes(pair.bearings1, pair.bearings2);
    const HomographyModel homography = FitHomographyModel(matches, 1000.0, 3, 3.0);
    ASSERT_TRUE(homography.valid);
    EpipolarPose start = pair.truth;
    start.r12 = start.r12 * Eigen::AngleAxisd(0.2 * kDegToRad, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const GeneralModel general = FitGeneralModel(matches, start, 1000.0);
    const ModelSelection selection = SelectTwoViewModel(general.sampson_px, homography.sampson_px);
    EXPECT_EQ(selection.num_matches, 60);
    EXPECT_TRUE(std::isfinite(selection.gric_general));
    EXPECT_TRUE(std::isfinite(selection.gric_homography));
    EXPECT_EQ(selection.homography_wins(), relief_m == 0.0)
        << "GRIC homography " << selection.gric_homography << ", general " << selection.gric_general;
  }
}

// No matches, or bearings that cannot be mapped: nothing valid, no crash.
TEST(TwoViewModels, EmptyInputsGiveNoModel) {
  const TangentMatches none = ToTangentPlanes({}, {});
  EXPECT_FALSE(none.valid);
  EXPECT_FALSE(FitHomographyModel(none, 1000.0, 3, 3.0).valid);
  const ModelSelection selection = SelectTwoViewModel({}, {});
  EXPECT_EQ(selection.num_matches, 0);
  EXPECT_TRUE(std::isfinite(selection.gric_general));
}

}  // namespace
}  // namespace hdabench::reference
