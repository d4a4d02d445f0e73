#include "reference/ceres/ceres_refine.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "hda/geometry.h"
#include "tests/support/test_support.h"
#include "tools/util/angles.h"
#include "tools/util/random_vectors.h"

namespace hdabench::reference {
namespace {

using util::kPi;
using util::kDegToRad;
using util::kRadToDeg;

using testing_support::CurrentTestSeed;


// The HDA geometry of the NOVA-C paper: a 1024 x 1024 pinhole of focal
// 1900 px, ground at about 565 m slant range seen obliquely, camera 2 after a
// 31 m lateral move (along cam1's x) with a little re-pointing.
constexpr double kFocalPx = 1900.0;
constexpr double kCentrePx = 511.5;
constexpr double kRangeM = 565.0;
constexpr double kBaselineM = 31.0;
constexpr double kNavPositionSigmaM = 0.3;
constexpr double kNavAttitudeSigmaDeg = 0.05;

Eigen::Vector3d Unproject(const Eigen::Vector2d& pixel) {
  return Eigen::Vector3d((pixel.x() - kCentrePx) / kFocalPx, (pixel.y() - kCentrePx) / kFocalPx, 1.0)
      .normalized();
}
Eigen::Vector2d Project(const Eigen::Vector3d& point) {
  return Eigen::Vector2d(kFocalPx * point.x() / point.z() + kCentrePx,
                         kFocalPx * point.y() / point.z() + kCentrePx);
}

Eigen::Quaterniond SmallRotation(const Eigen::Vector3d& rotation_vector_rad) {
  const double angle = rotation_vector_rad.norm();
  if (angle == 0.0) return Eigen::Quaterniond::Identity();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation_vector_rad / angle));
}

double RotationErrorRad(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b);
}

double AngleRad(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

struct Scene {
  Rigid3d true_cam2_from_cam1;
  std::vector<Eigen::Vector3d> true_points_in_cam1;
  CeresRefineInput input;  // observed bearings, nav pose, initial (triangulated) points
};

struct SceneSpec {
  double pixel_sigma_px = 0.25;
  double nav_position_error_sigma_m = 0.0;   // drawn per axis
  double nav_attitude_error_sigma_deg = 0.0;  // drawn per axis
  double outlier_fraction = 0.0;              // gross mismatches appended, 15-40 px off in image 2
  int patches_per_side = 3;                   // patches on a grid across the image
  int points_per_patch = 60;
};

// Points on rough 10 m patches of a tilted ground plane at about kRangeM,
// patch centres spread across image 1. Bearings are pixels (true projection +
// Gaussian noise) unprojected through the pinhole; the initial points are the
// flight's midpoint triangulation with the nav pose.
Scene MakeScene(const SceneSpec& spec, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Scene scene;
  // Camera 2's centre in cam1 and its re-pointing.
  const Eigen::Vector3d centre2_in_cam1(kBaselineM, 1.5, -2.0);
  const Eigen::Quaterniond rotation = SmallRotation(Eigen::Vector3d(0.3, -0.8, 0.2) * kDegToRad);
  scene.true_cam2_from_cam1 = Rigid3d(rotation, -(rotation * centre2_in_cam1));

  // Ground plane through (0, 0, kRangeM), tilted 30 deg about x (oblique view:
  // the range grows toward the bottom of the image).
  const double tilt = 30.0 * kDegToRad;
  const Eigen::Vector3d normal_in_cam1(0.0, -std::sin(tilt), -std::cos(tilt));
  const Eigen::Vector3d origin(0.0, 0.0, kRangeM);
  const Eigen::Vector3d u = normal_in_cam1.unitOrthogonal();
  const Eigen::Vector3d v = normal_in_cam1.cross(u);

  for (int pi = 0; pi < spec.patches_per_side; ++pi) {
    for (int pj = 0; pj < spec.patches_per_side; ++pj) {
      const double span = spec.patches_per_side > 1 ? 700.0 : 0.0;
      const double step = spec.patches_per_side > 1 ? span / (spec.patches_per_side - 1) : 0.0;
      const Eigen::Vector2d centre_px(kCentrePx - span / 2 + step * pi,
                                      kCentrePx - span / 2 + step * pj);
      const Eigen::Vector3d ray = Unproject(centre_px);
      const Eigen::Vector3d centre = ray * (normal_in_cam1.dot(origin) / normal_in_cam1.dot(ray));
      for (int k = 0; k < spec.points_per_patch; ++k) {
        // A rough patch: +-5 m in the plane, relief of about 0.5 m plus a bump.
        const double a = 5.0 * uniform(rng), b = 5.0 * uniform(rng);
        const double relief = 0.5 * normal(rng) + 2.0 * std::exp(-(a * a + b * b) / 8.0);
        scene.true_points_in_cam1.push_back(centre + a * u + b * v - relief * normal_in_cam1);
      }
    }
  }

  // Nav pose: the truth with errors drawn from the stated sigmas.
  Rigid3d nav = scene.true_cam2_from_cam1;
  const Eigen::Vector3d attitude_error = util::DrawVector3(normal, rng);
  const Eigen::Vector3d position_error = util::DrawVector3(normal, rng);
  nav.rotation =
      SmallRotation(attitude_error * spec.nav_attitude_error_sigma_deg * kDegToRad) * nav.rotation;
  nav.translation += position_error * spec.nav_position_error_sigma_m;
  scene.input.nav_cam2_from_cam1 = nav;
  scene.input.focal_px = kFocalPx;

  const hda::TriangulationOptions triangulation;
  auto add_match = [&](const Eigen::Vector3d& b1, const Eigen::Vector3d& b2,
                       const Eigen::Vector3d& truth) {
    Eigen::Vector3d point;
    if (hda::TriangulateMidpoint(b1, b2, nav, triangulation, &point, nullptr) !=
        hda::TriangulationStatus::kOk) {
      return false;
    }
    scene.input.bearings1_in_cam1.push_back(b1);
    scene.input.bearings2_in_cam2.push_back(b2);
    scene.input.points_in_cam1_m.push_back(point);
    scene.true_points_in_cam1.push_back(truth);
    return true;
  };
  const std::vector<Eigen::Vector3d> truths = std::move(scene.true_points_in_cam1);
  scene.true_points_in_cam1.clear();
  for (const Eigen::Vector3d& truth : truths) {
    const Eigen::Vector2d p1 = Project(truth) + spec.pixel_sigma_px * util::DrawVector2(normal, rng);
    const Eigen::Vector2d p2 =
        Project(scene.true_cam2_from_cam1 * truth) + spec.pixel_sigma_px * util::DrawVector2(normal, rng);
    add_match(Unproject(p1), Unproject(p2), truth);
  }
  // Gross mismatches: a ground point seen in image 1, matched 15-40 px away in
  // image 2, appended after the good matches.
  const int outliers = static_cast<int>(std::lround(spec.outlier_fraction * static_cast<double>(truths.size())));
  for (int k = 0; k < outliers; ++k) {
    const Eigen::Vector3d& truth = truths[static_cast<size_t>(k * 7) % truths.size()];
    const double angle = kPi * uniform(rng);
    const double offset = 15.0 + 12.5 * (1.0 + uniform(rng));
    const Eigen::Vector2d p1 = Project(truth);
    const Eigen::Vector2d p2 = Project(scene.true_cam2_from_cam1 * truth) +
                               offset * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    add_match(Unproject(p1), Unproject(p2), truth);
  }
  return scene;
}

CeresRefineOptions Options(double pixel_sigma_px) {
  CeresRefineOptions options;
  options.pixel_sigma_px = pixel_sigma_px;
  options.nav_position_sigma_m = kNavPositionSigmaM;
  options.nav_attitude_sigma_deg = kNavAttitudeSigmaDeg;
  return options;
}

bool AllFinite(const CeresRefineResult& result) {
  if (!result.cam2_from_cam1.rotation.coeffs().allFinite()) return false;
  if (!result.cam2_from_cam1.translation.allFinite()) return false;
  for (const Eigen::Vector3d& p : result.points_in_cam1_m) {
    if (!p.allFinite()) return false;
  }
  for (const double rms : result.reprojection_rms_px) {
    if (std::isnan(rms)) return false;
  }
  const RefineCost costs[2] = {result.initial_cost, result.final_cost};
  for (const RefineCost& c : costs) {
    if (!std::isfinite(c.total) || !std::isfinite(c.reprojection) || !std::isfinite(c.prior)) {
      return false;
    }
  }
  return std::isfinite(result.wall_s);
}

// Every deterministic field, as bytes.
std::string Bytes(const CeresRefineResult& result) {
  std::string bytes;
  auto add = [&bytes](const void* data, size_t size) {
    bytes.append(static_cast<const char*>(data), size);
  };
  add(&result.status, sizeof(result.status));
  bytes += result.failure;
  add(result.cam2_from_cam1.rotation.coeffs().data(), 4 * sizeof(double));
  add(result.cam2_from_cam1.translation.data(), 3 * sizeof(double));
  for (const Eigen::Vector3d& p : result.points_in_cam1_m) add(p.data(), 3 * sizeof(double));
  for (const double rms : result.reprojection_rms_px) add(&rms, sizeof(rms));
  add(&result.excluded, sizeof(result.excluded));
  const RefineCost costs[2] = {result.initial_cost, result.final_cost};
  for (const RefineCost& c : costs) {
    add(&c.total, sizeof(double));
    add(&c.reprojection, sizeof(double));
    add(&c.prior, sizeof(double));
  }
  add(&result.iterations, sizeof(result.iterations));
  return bytes;
}

double MedianPointErrorM(const std::vector<Eigen::Vector3d>& points,
                         const std::vector<Eigen::Vector3d>& truth, size_t count) {
  std::vector<double> errors;
  for (size_t i = 0; i < count; ++i) errors.push_back((points[i] - truth[i]).norm());
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  return errors[errors.size() / 2];
}

// ---------------------------------------------------------------------------
// Options and input checks

TEST(CeresRefine, DefaultOptionsAreValid) {
  EXPECT_TRUE(CeresRefineOptions().Validate().empty());
}

TEST(CeresRefine, ValidateListsEveryViolation) {
  CeresRefineOptions options;
  options.pixel_sigma_px = 0.0;
  options.loss_scale_px = std::numeric_limits<double>::quiet_NaN();
  options.nav_position_sigma_m = -1.0;
  options.nav_attitude_sigma_deg = std::numeric_limits<double>::infinity();
  options.min_points = 0;
  options.max_iterations = 0;
  options.function_tolerance = -1.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 7u);
  EXPECT_NE(errors[0].find("pixel_sigma_px = 0"), std::string::npos) << errors[0];
  EXPECT_NE(errors[6].find("function_tolerance = -1"), std::string::npos) << errors[6];
}

TEST(CeresRefine, InvalidOptionsThrowInputErrorNamingTheField) {
  const Scene scene = MakeScene(SceneSpec(), CurrentTestSeed());
  CeresRefineOptions options = Options(0.25);
  options.loss_scale_px = -2.0;
  try {
    RefineTwoView(scene.input, options);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("loss_scale_px = -2"), std::string::npos)
        << error.what();
  }
}

void ExpectInvalid(const CeresRefineInput& input, const std::string& expected_text) {
  const CeresRefineResult result = RefineTwoView(input, Options(0.25));
  EXPECT_EQ(result.status, CeresRefineStatus::kInvalidInput);
  EXPECT_FALSE(result.ok);
  EXPECT_NE(result.failure.find(expected_text), std::string::npos) << result.failure;
  EXPECT_EQ(result.failure.find('\n'), std::string::npos);
  EXPECT_TRUE(result.points_in_cam1_m.empty());
  EXPECT_TRUE(AllFinite(result)) << result.failure;
}

TEST(CeresRefine, BadInputGivesAStatusNotACrash) {
  const Scene scene = MakeScene(SceneSpec(), CurrentTestSeed());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  {
    CeresRefineInput input = scene.input;
    input.bearings2_in_cam2.pop_back();
    ExpectInvalid(input, "sizes differ");
  }
  {
    CeresRefineInput input = scene.input;
    input.points_in_cam1_m.push_back(Eigen::Vector3d(0, 0, 500));
    ExpectInvalid(input, "sizes differ");
  }
  {
    CeresRefineInput input = scene.input;
    input.bearings1_in_cam1[17].y() = nan;
    ExpectInvalid(input, "bearing1[17]");
  }
  {
    CeresRefineInput input = scene.input;
    input.bearings2_in_cam2[3] = Eigen::Vector3d(0.0, std::numeric_limits<double>::infinity(), 1.0);
    ExpectInvalid(input, "bearing2[3]");
  }
  {
    CeresRefineInput input = scene.input;
    input.bearings2_in_cam2[4] = Eigen::Vector3d::Zero();
    ExpectInvalid(input, "bearing2[4]");
  }
  {
    CeresRefineInput input = scene.input;
    input.points_in_cam1_m[9].z() = nan;
    ExpectInvalid(input, "point[9]");
  }
  {
    CeresRefineInput input = scene.input;
    input.focal_px = 0.0;
    ExpectInvalid(input, "focal_px");
  }
  {
    CeresRefineInput input = scene.input;
    input.nav_cam2_from_cam1.translation.x() = nan;
    ExpectInvalid(input, "nav cam2_from_cam1 is not finite");
  }
  {
    CeresRefineInput input = scene.input;
    input.nav_cam2_from_cam1.rotation.coeffs() *= 1.1;
    ExpectInvalid(input, "unit quaternion");
  }
  {
    CeresRefineInput input = scene.input;
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
    covariance(2, 2) = -1.0;
    input.nav_covariance = covariance;
    ExpectInvalid(input, "not positive definite");
  }
  {
    CeresRefineInput input = scene.input;
    Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Identity();
    covariance(0, 5) = 0.5;
    input.nav_covariance = covariance;
    ExpectInvalid(input, "not symmetric");
  }
}

TEST(CeresRefine, ZeroOrTooFewPointsGiveTooFewPoints) {
  const Scene scene = MakeScene(SceneSpec(), CurrentTestSeed());
  CeresRefineInput empty = scene.input;
  empty.bearings1_in_cam1.clear();
  empty.bearings2_in_cam2.clear();
  empty.points_in_cam1_m.clear();
  const CeresRefineResult none = RefineTwoView(empty, Options(0.25));
  EXPECT_EQ(none.status, CeresRefineStatus::kTooFewPoints);
  EXPECT_NE(none.failure.find("0 usable of 0"), std::string::npos) << none.failure;
  EXPECT_TRUE(none.points_in_cam1_m.empty());
  EXPECT_TRUE(AllFinite(none));

  CeresRefineInput few = scene.input;
  few.bearings1_in_cam1.resize(4);
  few.bearings2_in_cam2.resize(4);
  few.points_in_cam1_m.resize(4);
  const CeresRefineResult four = RefineTwoView(few, Options(0.25));
  EXPECT_EQ(four.status, CeresRefineStatus::kTooFewPoints);
  EXPECT_NE(four.failure.find("need at least 5"), std::string::npos) << four.failure;
  // The initial state comes back.
  ASSERT_EQ(four.points_in_cam1_m.size(), 4u);
  EXPECT_EQ(four.points_in_cam1_m[2], few.points_in_cam1_m[2]);
  EXPECT_EQ(four.cam2_from_cam1.translation, few.nav_cam2_from_cam1.translation);
  EXPECT_EQ(four.reprojection_rms_px.size(), 4u);
  EXPECT_TRUE(AllFinite(four));
}

TEST(CeresRefine, PointsBehindACameraAreExcludedAndReturnedAsGiven) {
  Scene scene = MakeScene(SceneSpec(), CurrentTestSeed());
  const Eigen::Vector3d behind = -scene.input.points_in_cam1_m[5];
  scene.input.points_in_cam1_m[5] = behind;
  const CeresRefineResult result = RefineTwoView(scene.input, Options(0.25));
  EXPECT_EQ(result.status, CeresRefineStatus::kOk) << result.failure;
  EXPECT_EQ(result.excluded, 1);
  EXPECT_EQ(result.points_in_cam1_m[5], behind);
  EXPECT_TRUE(std::isinf(result.reprojection_rms_px[5]));
  EXPECT_TRUE(std::isfinite(result.reprojection_rms_px[6]));
  EXPECT_TRUE(AllFinite(result));
}

// ---------------------------------------------------------------------------
// Behaviour on the HDA geometry

// (3) Exact nav and exact pixels: the start is the optimum, nothing moves.
TEST(CeresRefine, ExactNavAndPixelsMoveNothing) {
  SceneSpec spec;
  spec.pixel_sigma_px = 0.0;
  const Scene scene = MakeScene(spec, CurrentTestSeed());
  const CeresRefineResult result = RefineTwoView(scene.input, Options(0.25));
  ASSERT_EQ(result.status, CeresRefineStatus::kOk) << result.failure;
  const Rigid3d& truth = scene.true_cam2_from_cam1;
  EXPECT_LE((result.cam2_from_cam1.translation - truth.translation).norm(),
            1e-9 * truth.translation.norm());
  EXPECT_LE(RotationErrorRad(result.cam2_from_cam1.rotation, truth.rotation), 1e-9);
  for (size_t i = 0; i < result.points_in_cam1_m.size(); ++i) {
    ASSERT_LE((result.points_in_cam1_m[i] - scene.true_points_in_cam1[i]).norm(),
              1e-9 * scene.true_points_in_cam1[i].norm())
        << i;
    ASSERT_LE(result.reprojection_rms_px[i], 1e-6) << i;
  }
  EXPECT_LE(result.final_cost.total, 1e-12);
}

// (1) The final cost never exceeds the initial one: exact and noisy nav, with
// and without outliers, every loss, and a run stopped by the iteration limit.
TEST(CeresRefine, FinalCostNeverAboveInitial) {
  const RobustLoss losses[3] = {RobustLoss::kNone, RobustLoss::kHuber, RobustLoss::kCauchy};
  for (int trial = 0; trial < 6; ++trial) {
    SceneSpec spec;
    spec.pixel_sigma_px = trial % 2 == 0 ? 0.2 : 0.3;
    const bool exact_nav = trial < 2;
    spec.nav_position_error_sigma_m = exact_nav ? 0.0 : kNavPositionSigmaM;
    spec.nav_attitude_error_sigma_deg = exact_nav ? 0.0 : kNavAttitudeSigmaDeg;
    spec.outlier_fraction = trial >= 4 ? 0.1 : 0.0;
    const Scene scene = MakeScene(spec, CurrentTestSeed() + static_cast<std::uint64_t>(trial));
    for (const RobustLoss loss : losses) {
      for (const int max_iterations : {1, 100}) {
        CeresRefineOptions options = Options(spec.pixel_sigma_px);
        options.loss = loss;
        options.max_iterations = max_iterations;
        const CeresRefineResult result = RefineTwoView(scene.input, options);
        SCOPED_TRACE("trial " + std::to_string(trial) + ", loss " + ToString(loss) +
                     ", max iterations " + std::to_string(max_iterations));
        EXPECT_TRUE(result.status == CeresRefineStatus::kOk ||
                    result.status == CeresRefineStatus::kNotConverged)
            << ToString(result.status) << ": " << result.failure;
        EXPECT_LE(result.final_cost.total, result.initial_cost.total);
        EXPECT_DOUBLE_EQ(result.final_cost.total,
                         result.final_cost.reprojection + result.final_cost.prior);
        EXPECT_EQ(result.points_in_cam1_m.size(), scene.input.points_in_cam1_m.size());
        EXPECT_TRUE(AllFinite(result));
        // Pixel noise in every trial: the midpoint points are never the optimum.
        EXPECT_LT(result.final_cost.total, result.initial_cost.total);
        EXPECT_LE(result.iterations, max_iterations);
        if (result.status == CeresRefineStatus::kNotConverged) {
          EXPECT_NE(result.failure.find("not converged"), std::string::npos) << result.failure;
          EXPECT_FALSE(result.ok);
        }
        if (max_iterations == 100) {
          EXPECT_EQ(result.status, CeresRefineStatus::kOk) << result.failure;
          EXPECT_TRUE(result.ok);
          EXPECT_TRUE(result.failure.empty());
        }
      }
    }
  }
}

// (2) With noisy nav the refined relative pose is closer to the truth.
// What the images observe: the relative rotation and the direction of the
// baseline (five degrees of freedom), never the baseline's length, which comes
// from the prior alone: the length error is asserted to stay what the nav's
// was. How well the rest is observed depends on the spread of the points: one
// 10 m patch (about one degree of the field) fixes little more than the offset
// of the epipolar lines across the baseline (measured over 20 trials with 60
// points: rotation RMS 0.093 -> 0.082 deg, baseline direction 0.87 -> 0.82
// deg, the rotation about the optical axis not improved), so this test uses
// nine patches across the image, with range varying over the oblique ground:
// then all three rotation axes and the baseline direction are observed.
// Asserted over 20 trials: the RMS rotation error, the RMS rotation about the
// optical axis and the RMS baseline direction error drop well below the nav's,
// and the rotation improves in most trials.
TEST(CeresRefine, NoisyNavPoseIsImproved) {
  constexpr int kTrials = 20;
  double rotation_before = 0.0, rotation_after = 0.0;            // sum of squares, deg^2
  double direction_before = 0.0, direction_after = 0.0;          // sum of squares, deg^2
  double length_before = 0.0, length_after = 0.0;                // sum of squares, m^2
  double points_before = 0.0, points_after = 0.0;                // sum of medians, m
  Eigen::Vector3d axis_before = Eigen::Vector3d::Zero(), axis_after = Eigen::Vector3d::Zero();
  int improved_rotation = 0, improved_direction = 0;
  double seconds = 0.0;
  int iterations = 0;
  double initial_cost = 0.0, final_cost = 0.0, final_prior = 0.0;
  for (int trial = 0; trial < kTrials; ++trial) {
    SceneSpec spec;
    spec.pixel_sigma_px = 0.25;
    spec.nav_position_error_sigma_m = kNavPositionSigmaM;
    spec.nav_attitude_error_sigma_deg = kNavAttitudeSigmaDeg;
    const Scene scene = MakeScene(spec, CurrentTestSeed() + static_cast<std::uint64_t>(trial));
    const CeresRefineResult result = RefineTwoView(scene.input, Options(0.25));
    ASSERT_EQ(result.status, CeresRefineStatus::kOk) << result.failure;
    const Rigid3d& truth = scene.true_cam2_from_cam1;
    const Rigid3d& nav = scene.input.nav_cam2_from_cam1;
    const Rigid3d& refined = result.cam2_from_cam1;
    const double rb = RotationErrorRad(nav.rotation, truth.rotation) * kRadToDeg;
    const double ra = RotationErrorRad(refined.rotation, truth.rotation) * kRadToDeg;
    // Baseline direction: the centre of camera 2 in cam1, -R^T t.
    const Eigen::Vector3d c_truth = -(truth.rotation.conjugate() * truth.translation);
    const Eigen::Vector3d c_nav = -(nav.rotation.conjugate() * nav.translation);
    const Eigen::Vector3d c_refined = -(refined.rotation.conjugate() * refined.translation);
    const double db = AngleRad(c_nav, c_truth) * kRadToDeg;
    const double da = AngleRad(c_refined, c_truth) * kRadToDeg;
    rotation_before += rb * rb;
    rotation_after += ra * ra;
    direction_before += db * db;
    direction_after += da * da;
    length_before += std::pow(c_nav.norm() - c_truth.norm(), 2);
    length_after += std::pow(c_refined.norm() - c_truth.norm(), 2);
    const Eigen::Quaterniond e_nav = nav.rotation * truth.rotation.conjugate();
    const Eigen::Quaterniond e_ref = refined.rotation * truth.rotation.conjugate();
    const Eigen::AngleAxisd aa_nav(e_nav), aa_ref(e_ref);
    axis_before += (aa_nav.angle() * aa_nav.axis() * kRadToDeg).cwiseAbs2();
    axis_after += (aa_ref.angle() * aa_ref.axis() * kRadToDeg).cwiseAbs2();
    const size_t n = scene.input.points_in_cam1_m.size();
    points_before += MedianPointErrorM(scene.input.points_in_cam1_m, scene.true_points_in_cam1, n);
    points_after += MedianPointErrorM(result.points_in_cam1_m, scene.true_points_in_cam1, n);
    improved_rotation += ra < rb ? 1 : 0;
    improved_direction += da < db ? 1 : 0;
    seconds += result.wall_s;
    iterations += result.iterations;
    initial_cost += result.initial_cost.total;
    final_cost += result.final_cost.total;
    final_prior += result.final_cost.prior;
    EXPECT_LE(result.final_cost.total, result.initial_cost.total);
  }
  auto root = [](double sum) { return std::sqrt(sum / kTrials); };
  std::printf(
      "[ceres] %d trials: rotation error RMS %.4f -> %.4f deg (per cam axis x %.4f -> %.4f, y %.4f "
      "-> %.4f, z %.4f -> %.4f), baseline direction %.4f -> %.4f deg, baseline length %.3f -> "
      "%.3f m, median point error %.3f -> %.3f m; improved rotation %d/%d, direction %d/%d; "
      "%.1f iterations, %.4f s per solve; mean cost %.1f -> %.1f (prior part %.2f)\n",
      kTrials, root(rotation_before), root(rotation_after), root(axis_before.x()),
      root(axis_after.x()), root(axis_before.y()), root(axis_after.y()), root(axis_before.z()),
      root(axis_after.z()), root(direction_before), root(direction_after), root(length_before),
      root(length_after), points_before / kTrials, points_after / kTrials, improved_rotation,
      kTrials, improved_direction, kTrials, static_cast<double>(iterations) / kTrials,
      seconds / kTrials, initial_cost / kTrials, final_cost / kTrials, final_prior / kTrials);
  EXPECT_LT(root(rotation_after), 0.5 * root(rotation_before));
  EXPECT_LT(root(axis_after.z()), 0.3 * root(axis_before.z()));
  EXPECT_LT(root(direction_after), 0.75 * root(direction_before));
  EXPECT_GE(improved_rotation, 17);
  EXPECT_NEAR(root(length_after), root(length_before), 0.05 * root(length_before));
}

// The images leave the scale to the nav baseline: with the baseline 1 % long
// the refined points are 1 % too far, whatever the images say. The range
// finder's range along the optical axis, to level ground through the points
// nearest its beam, brings them back to the range; its note names the
// points and the range it ends at. Bad range-finder inputs are statuses.
TEST(CeresRefine, TheRangeFinderFixesTheScale) {
  SceneSpec spec;
  spec.pixel_sigma_px = 0.25;
  Scene scene = MakeScene(spec, CurrentTestSeed());
  // The nav pose: the true one with the baseline 1 % long; the initial
  // points triangulated with it are 1 % too far.
  const Rigid3d& truth = scene.true_cam2_from_cam1;
  scene.input.nav_cam2_from_cam1 = Rigid3d(truth.rotation, 1.01 * truth.translation);
  for (Eigen::Vector3d& p : scene.input.points_in_cam1_m) p *= 1.01;
  const size_t n = scene.input.points_in_cam1_m.size();
  const CeresRefineResult without = RefineTwoView(scene.input, Options(0.25));
  ASSERT_EQ(without.status, CeresRefineStatus::kOk) << without.failure;
  EXPECT_EQ(without.lrf_points, 0);
  EXPECT_TRUE(without.lrf_note.empty());

  // The scene's ground: the plane through (0, 0, kRangeM), tilted 30 deg
  // about x; the beam along the optical axis meets it at kRangeM.
  CeresRefineInput::Lrf lrf;
  lrf.beam_in_cam1 = Eigen::Vector3d::UnitZ();
  lrf.range_m = kRangeM;
  lrf.range_sigma_m = 0.1;
  lrf.support_radius_m = 20.0;
  lrf.ground_normal_in_cam1 = Eigen::Vector3d(0.0, -std::sin(30.0 * kDegToRad), -std::cos(30.0 * kDegToRad));
  scene.input.lrf = lrf;
  const CeresRefineResult with = RefineTwoView(scene.input, Options(0.25));
  ASSERT_EQ(with.status, CeresRefineStatus::kOk) << with.failure;
  EXPECT_EQ(with.lrf_points, 20);
  EXPECT_NE(with.lrf_note.find("range constraint on 20 points"), std::string::npos) << with.lrf_note;
  const double error_without = MedianPointErrorM(without.points_in_cam1_m, scene.true_points_in_cam1, n);
  const double error_with = MedianPointErrorM(with.points_in_cam1_m, scene.true_points_in_cam1, n);
  std::printf("[ceres] baseline 1 %% long: median point error %.3f m without the range finder, %.3f m with (%s)\n",
              error_without, error_with, with.lrf_note.c_str());
  // 1 % of 565 m is 5.7 m; the patch's relief (0.5 m and a 2 m bump) moves
  // the ground the 20 points stand for by about a metre along the beam.
  EXPECT_GT(error_without, 4.0);
  EXPECT_LT(error_with, 0.3 * error_without);
  const Eigen::Vector3d c_truth = -(truth.rotation.conjugate() * truth.translation);
  const Eigen::Vector3d c_with = -(with.cam2_from_cam1.rotation.conjugate() * with.cam2_from_cam1.translation);
  EXPECT_LT(std::abs(c_with.norm() / c_truth.norm() - 1.0), 0.003) << c_with.norm() << " vs " << c_truth.norm();

  // No point near the beam: no constraint, and the note says why.
  scene.input.lrf->support_radius_m = 1e-3;
  const CeresRefineResult none = RefineTwoView(scene.input, Options(0.25));
  EXPECT_EQ(none.lrf_points, 0);
  EXPECT_NE(none.lrf_note.find("no range constraint"), std::string::npos) << none.lrf_note;
  // A bad range finder is invalid input, named.
  scene.input.lrf->support_radius_m = 20.0;
  scene.input.lrf->range_m = -1.0;
  const CeresRefineResult bad = RefineTwoView(scene.input, Options(0.25));
  EXPECT_EQ(bad.status, CeresRefineStatus::kInvalidInput);
  EXPECT_NE(bad.failure.find("lrf: range_m = -1"), std::string::npos) << bad.failure;
}

// (4) Gross mismatches (10 % of the matches, 15-40 px off in image 2) are
// down-weighted: with a robust loss the pose and the good points stay close
// to the result without them, much closer than with plain least squares.
TEST(CeresRefine, OutliersAreDownWeighted) {
  SceneSpec clean_spec;
  clean_spec.pixel_sigma_px = 0.25;
  clean_spec.nav_position_error_sigma_m = kNavPositionSigmaM;
  clean_spec.nav_attitude_error_sigma_deg = kNavAttitudeSigmaDeg;
  SceneSpec dirty_spec = clean_spec;
  dirty_spec.outlier_fraction = 0.1;
  // The same seed: the same good matches and nav, outliers appended.
  const std::uint64_t seed = CurrentTestSeed();
  const Scene clean = MakeScene(clean_spec, seed);
  const Scene dirty = MakeScene(dirty_spec, seed);
  const size_t good = clean.input.points_in_cam1_m.size();
  ASSERT_GT(dirty.input.points_in_cam1_m.size(), good + good / 20);

  struct Shift {
    double rotation_deg;
    double centre_m;
    double median_point_m;
  };
  auto shift = [&](RobustLoss loss) {
    CeresRefineOptions options = Options(0.25);
    options.loss = loss;
    const CeresRefineResult a = RefineTwoView(clean.input, options);
    const CeresRefineResult b = RefineTwoView(dirty.input, options);
    EXPECT_EQ(a.status, CeresRefineStatus::kOk) << a.failure;
    EXPECT_EQ(b.status, CeresRefineStatus::kOk) << b.failure;
    EXPECT_LE(b.final_cost.total, b.initial_cost.total);
    const Eigen::Vector3d ca = -(a.cam2_from_cam1.rotation.conjugate() * a.cam2_from_cam1.translation);
    const Eigen::Vector3d cb = -(b.cam2_from_cam1.rotation.conjugate() * b.cam2_from_cam1.translation);
    return Shift{RotationErrorRad(a.cam2_from_cam1.rotation, b.cam2_from_cam1.rotation) * kRadToDeg,
                 (ca - cb).norm(), MedianPointErrorM(b.points_in_cam1_m, a.points_in_cam1_m, good)};
  };
  const Shift plain = shift(RobustLoss::kNone);
  const Shift huber = shift(RobustLoss::kHuber);
  const Shift cauchy = shift(RobustLoss::kCauchy);
  std::printf(
      "[ceres] shift of the result by 10%% outliers: none %.4f deg %.3f m points %.3f m; huber "
      "%.4f deg %.3f m points %.3f m; cauchy %.4f deg %.3f m points %.3f m\n",
      plain.rotation_deg, plain.centre_m, plain.median_point_m, huber.rotation_deg, huber.centre_m,
      huber.median_point_m, cauchy.rotation_deg, cauchy.centre_m, cauchy.median_point_m);
  // One point's depth std at 0.25 px: range^2 sigma / (focal baseline), 1.4 m.
  const double depth_sigma_m = kRangeM * kRangeM * (0.25 / kFocalPx) / kBaselineM;
  for (const Shift& robust : {huber, cauchy}) {
    EXPECT_LT(robust.rotation_deg, 0.5 * plain.rotation_deg);
    EXPECT_LT(robust.median_point_m, 0.5 * plain.median_point_m);
    EXPECT_LT(robust.median_point_m, 2.0 * depth_sigma_m);
  }
  EXPECT_LT(cauchy.median_point_m, depth_sigma_m);
}

// (6) Determinism: the same input gives the same bytes, run after run.
TEST(CeresRefine, TwoRunsGiveIdenticalBytes) {
  SceneSpec spec;
  spec.nav_position_error_sigma_m = kNavPositionSigmaM;
  spec.nav_attitude_error_sigma_deg = kNavAttitudeSigmaDeg;
  spec.outlier_fraction = 0.1;
  const Scene scene = MakeScene(spec, CurrentTestSeed());
  const CeresRefineResult first = RefineTwoView(scene.input, Options(0.25));
  const CeresRefineResult second = RefineTwoView(scene.input, Options(0.25));
  ASSERT_EQ(first.status, CeresRefineStatus::kOk) << first.failure;
  EXPECT_GT(first.iterations, 0);
  EXPECT_TRUE(Bytes(first) == Bytes(second));
}

// A covariance equal to the sigmas gives the same result as the sigmas.
TEST(CeresRefine, CovarianceInputMatchesSigmas) {
  SceneSpec spec;
  spec.nav_position_error_sigma_m = kNavPositionSigmaM;
  spec.nav_attitude_error_sigma_deg = kNavAttitudeSigmaDeg;
  Scene scene = MakeScene(spec, CurrentTestSeed());
  const CeresRefineResult from_sigmas = RefineTwoView(scene.input, Options(0.25));
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();
  const double attitude_rad = kNavAttitudeSigmaDeg * kDegToRad;
  covariance.diagonal() << attitude_rad * attitude_rad, attitude_rad * attitude_rad,
      attitude_rad * attitude_rad, kNavPositionSigmaM * kNavPositionSigmaM,
      kNavPositionSigmaM * kNavPositionSigmaM, kNavPositionSigmaM * kNavPositionSigmaM;
  scene.input.nav_covariance = covariance;
  CeresRefineOptions other_sigmas = Options(0.25);
  other_sigmas.nav_position_sigma_m = 5.0;  // ignored: the covariance wins
  const CeresRefineResult from_covariance = RefineTwoView(scene.input, other_sigmas);
  EXPECT_TRUE(Bytes(from_sigmas) == Bytes(from_covariance));

  // A much tighter prior holds the pose at the nav pose.
  scene.input.nav_covariance = covariance * 1e-12;
  const CeresRefineResult held = RefineTwoView(scene.input, Options(0.25));
  ASSERT_EQ(held.status, CeresRefineStatus::kOk) << held.failure;
  EXPECT_LT((held.cam2_from_cam1.translation - scene.input.nav_cam2_from_cam1.translation).norm(),
            1e-3);
}

}  // namespace
}  // namespace hdabench::reference
