#include "hda/geometry.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tests/support/test_support.h"
#include "tools/util/angles.h"
#include "tools/util/random_vectors.h"

namespace hdabench::hda {
namespace {

using util::kPi;
using util::kDegToRad;
using util::kRadToDeg;

using testing_support::CurrentTestSeed;
using testing_support::RandomRotation;
using testing_support::RandomVector;


// cam_from_local of an OpenCV camera at `center_in_local` looking at `target`
// with local z (ENU) up: x right, y down in the image.
Rigid3d LookAt(const Eigen::Vector3d& center_in_local, const Eigen::Vector3d& target_in_local) {
  const Eigen::Vector3d z = (target_in_local - center_in_local).normalized();
  const Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ()).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d cam_from_local_rotation;
  cam_from_local_rotation.row(0) = x;
  cam_from_local_rotation.row(1) = y;
  cam_from_local_rotation.row(2) = z;
  const Eigen::Quaterniond rotation(cam_from_local_rotation);
  return Rigid3d(rotation, -(rotation * center_in_local));
}

// Unit bearing b moved by an angle of about |noise| rad in its tangent plane.
Eigen::Vector3d PerturbBearing(const Eigen::Vector3d& b, double sigma_rad, std::mt19937_64* rng) {
  std::normal_distribution<double> normal(0.0, sigma_rad);
  const Eigen::Vector3d e1 = b.unitOrthogonal();
  const Eigen::Vector3d e2 = b.cross(e1);
  const double a1 = normal(*rng), a2 = normal(*rng);
  return (b + a1 * e1 + a2 * e2).normalized();
}

// Points of a grid of side `size_m` (count x count) on the plane through the
// origin whose normal is `normal`, in local.
std::vector<Eigen::Vector3d> PlaneGrid(const Eigen::Vector3d& normal, double size_m, int count) {
  const Eigen::Vector3d u = normal.unitOrthogonal();
  const Eigen::Vector3d v = normal.cross(u);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < count; ++i) {
    for (int j = 0; j < count; ++j) {
      const double a = size_m * (static_cast<double>(i) / (count - 1) - 0.5);
      const double b = size_m * (static_cast<double>(j) / (count - 1) - 0.5);
      points.push_back(a * u + b * v);
    }
  }
  return points;
}

// Normal of a plane tilted by slope_deg about the local x axis.
Eigen::Vector3d TiltedNormal(double slope_deg) {
  return Eigen::Vector3d(0.0, -std::sin(slope_deg * kDegToRad), std::cos(slope_deg * kDegToRad));
}

double StdDev(const std::vector<double>& values) {
  double mean = 0.0;
  for (const double v : values) mean += v;
  mean /= static_cast<double>(values.size());
  double sum = 0.0;
  for (const double v : values) sum += (v - mean) * (v - mean);
  return std::sqrt(sum / static_cast<double>(values.size() - 1));
}

// ---------------------------------------------------------------------------
// Triangulation

TEST(TriangulationOptionsValidate, DefaultsValidAndBadValueNamed) {
  TriangulationOptions options;
  EXPECT_TRUE(options.Validate().empty());
  options.min_parallax_deg = 0.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "min_parallax_deg = 0: expected in (0, 90)");
}

TEST(TriangulateMidpoint, RecoversRandomPointsAt570m) {
  std::mt19937_64 rng(CurrentTestSeed());
  const TriangulationOptions options;
  for (int trial = 0; trial < 100; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()) + " trial " + std::to_string(trial));
    // A point 570 m away within about 30 deg of the optical axis, seen from a
    // second camera anywhere within 60 m with any attitude.
    const Eigen::Vector3d direction =
        (Eigen::Vector3d::UnitZ() + RandomVector(&rng, 0.5)).normalized();
    const Eigen::Vector3d point_in_cam1 = 570.0 * direction;
    Eigen::Vector3d center2_in_cam1 = RandomVector(&rng, 60.0);
    if (center2_in_cam1.norm() < 20.0) center2_in_cam1 = center2_in_cam1.normalized() * 20.0;
    const Eigen::Quaterniond rotation = RandomRotation(&rng);
    const Rigid3d cam2_from_cam1(rotation, -(rotation * center2_in_cam1));
    const Eigen::Vector3d bearing1 = point_in_cam1.normalized();
    const Eigen::Vector3d bearing2 = (cam2_from_cam1 * point_in_cam1).normalized();
    Eigen::Vector3d estimate;
    double parallax_deg = -1.0;
    const TriangulationStatus status =
        TriangulateMidpoint(bearing1, bearing2, cam2_from_cam1, options, &estimate, &parallax_deg);
    if (status == TriangulationStatus::kParallelRays) {
      // The baseline happened to lie along the line of sight: check it says so.
      EXPECT_LT(parallax_deg, options.min_parallax_deg);
      continue;
    }
    ASSERT_EQ(status, TriangulationStatus::kOk) << ToString(status);
    // Exact bearings: only rounding remains (1e-6 m is ~1e-9 of the range).
    EXPECT_LT((estimate - point_in_cam1).norm(), 1e-6);
    const double expected_parallax_deg =
        std::atan2(point_in_cam1.cross(point_in_cam1 - center2_in_cam1).norm(),
                   point_in_cam1.dot(point_in_cam1 - center2_in_cam1)) *
        kRadToDeg;
    EXPECT_NEAR(parallax_deg, expected_parallax_deg, 1e-9);
  }
}

TEST(TriangulateMidpoint, ParallelRaysAreReported) {
  const TriangulationOptions options;
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-10.0, 0.0, 0.0));
  Eigen::Vector3d point(7.0, 7.0, 7.0);
  double parallax_deg = -1.0;
  EXPECT_EQ(TriangulateMidpoint(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(),
                                cam2_from_cam1, options, &point, &parallax_deg),
            TriangulationStatus::kParallelRays);
  EXPECT_EQ(parallax_deg, 0.0);
  EXPECT_EQ(point, Eigen::Vector3d(7.0, 7.0, 7.0));  // untouched
  // A point 1e5 m away seen over a 10 m baseline: parallax 0.0057 deg.
  const Eigen::Vector3d far_point(0.0, 0.0, 1e5);
  EXPECT_EQ(TriangulateMidpoint(far_point.normalized(), (cam2_from_cam1 * far_point).normalized(),
                                cam2_from_cam1, options, &point, &parallax_deg),
            TriangulationStatus::kParallelRays);
  EXPECT_NEAR(parallax_deg, std::atan(10.0 / 1e5) * kRadToDeg, 1e-9);
  // Anti-parallel rays have no unique closest points either.
  EXPECT_EQ(TriangulateMidpoint(Eigen::Vector3d::UnitZ(), -Eigen::Vector3d::UnitZ(),
                                cam2_from_cam1, options, &point, nullptr),
            TriangulationStatus::kParallelRays);
}

TEST(TriangulateMidpoint, PointBehindCameraIsReported) {
  const TriangulationOptions options;
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-50.0, 0.0, 0.0));
  const Eigen::Vector3d point_in_cam1(10.0, -5.0, 570.0);
  const Eigen::Vector3d bearing1 = point_in_cam1.normalized();
  const Eigen::Vector3d bearing2 = (cam2_from_cam1 * point_in_cam1).normalized();
  Eigen::Vector3d point;
  // Both rays reversed: they meet at the mirrored point, behind both cameras.
  EXPECT_EQ(TriangulateMidpoint(-bearing1, -bearing2, cam2_from_cam1, options, &point, nullptr),
            TriangulationStatus::kBehindCamera);
  // Only ray 1 reversed: the closest points lie behind camera 1.
  EXPECT_EQ(TriangulateMidpoint(-bearing1, bearing2, cam2_from_cam1, options, &point, nullptr),
            TriangulationStatus::kBehindCamera);
  // Only ray 2 reversed.
  EXPECT_EQ(TriangulateMidpoint(bearing1, -bearing2, cam2_from_cam1, options, &point, nullptr),
            TriangulationStatus::kBehindCamera);
}

TEST(TriangulateMidpoint, NonFiniteInputIsReported) {
  const TriangulationOptions options;
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-50.0, 0.0, 0.0));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Eigen::Vector3d good(0.0, 0.0, 1.0);
  Eigen::Vector3d point;
  double parallax_deg = -1.0;
  EXPECT_EQ(TriangulateMidpoint(Eigen::Vector3d(nan, 0.0, 1.0), good, cam2_from_cam1, options,
                                &point, &parallax_deg),
            TriangulationStatus::kNonFinite);
  EXPECT_EQ(parallax_deg, -1.0);  // not written
  EXPECT_EQ(TriangulateMidpoint(good, Eigen::Vector3d(0.0, nan, 1.0), cam2_from_cam1, options,
                                &point, nullptr),
            TriangulationStatus::kNonFinite);
  Rigid3d bad_pose = cam2_from_cam1;
  bad_pose.translation.x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(TriangulateMidpoint(good, good, bad_pose, options, &point, nullptr),
            TriangulationStatus::kNonFinite);
  // An invalid Unproject result is the zero vector.
  EXPECT_EQ(TriangulateMidpoint(Eigen::Vector3d::Zero(), good, cam2_from_cam1, options, &point,
                                nullptr),
            TriangulationStatus::kNonFinite);
}

// ---------------------------------------------------------------------------
// Epipolar consistency

struct EpipolarScene {
  double focal_px = 1500.0;
  Rigid3d cam2_from_cam1;
  Eigen::Vector3d point_in_cam1;
};

// Camera 2 40 m to the side and 10 m forward, rotated 3 deg; the point near
// the centre of both images.
EpipolarScene MakeEpipolarScene() {
  EpipolarScene scene;
  const Eigen::Quaterniond rotation(Eigen::AngleAxisd(3.0 * kDegToRad, Eigen::Vector3d::UnitY()));
  const Eigen::Vector3d center2_in_cam1(40.0, 3.0, 10.0);
  scene.cam2_from_cam1 = Rigid3d(rotation, -(rotation * center2_in_cam1));
  scene.point_in_cam1 = Eigen::Vector3d(12.0, -4.0, 570.0);
  return scene;
}

// Bearing2 of the point moved by offset_px across the epipolar line in image 2.
Eigen::Vector3d OffsetBearing2(const EpipolarScene& scene, double offset_px) {
  const Eigen::Vector3d p2 = scene.cam2_from_cam1 * scene.point_in_cam1;
  const Eigen::Vector3d x1 = scene.point_in_cam1 / scene.point_in_cam1.z();
  const Eigen::Vector3d x2 = p2 / p2.z();
  const Eigen::Vector3d& t = scene.cam2_from_cam1.translation;
  const Eigen::Vector3d line2 = t.cross(scene.cam2_from_cam1.rotation * x1);  // E x1
  const Eigen::Vector2d across = line2.head<2>().normalized();
  Eigen::Vector3d moved = x2;
  moved.head<2>() += (offset_px / scene.focal_px) * across;
  return moved.normalized();
}

TEST(EpipolarAngleRad, ZeroForConsistentCorrespondences) {
  std::mt19937_64 rng(CurrentTestSeed());
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()) + " trial " + std::to_string(trial));
    const Eigen::Quaterniond rotation = RandomRotation(&rng);
    const Rigid3d cam2_from_cam1(rotation, RandomVector(&rng, 50.0));
    const Eigen::Vector3d point = RandomVector(&rng, 600.0);
    EXPECT_LT(EpipolarAngleRad(point.normalized(), (cam2_from_cam1 * point).normalized(),
                               cam2_from_cam1),
              1e-12);
  }
}

TEST(EpipolarAngleRad, GrowsWithInjectedPixelOffset) {
  const EpipolarScene scene = MakeEpipolarScene();
  const Eigen::Vector3d bearing1 = scene.point_in_cam1.normalized();
  EXPECT_LT(EpipolarAngleRad(bearing1, OffsetBearing2(scene, 0.0), scene.cam2_from_cam1), 1e-12);
  double previous = 0.0;
  for (const double offset_px : {0.5, 1.0, 2.0, 5.0}) {
    const double angle = EpipolarAngleRad(bearing1, OffsetBearing2(scene, offset_px),
                                          scene.cam2_from_cam1);
    // Near the image centre an offset across the line is an angle of offset / f
    // (to within the 1e-4 cos^2 factor of the off-axis position, and the
    // epipolar plane's tilt to the image, below 2 % here).
    EXPECT_NEAR(angle, offset_px / scene.focal_px, 0.02 * offset_px / scene.focal_px)
        << "offset " << offset_px << " px";
    EXPECT_GT(angle, previous);
    previous = angle;
  }
}

TEST(EpipolarAngleRad, DegenerateGeometryHasAFiniteAnswer) {
  const Eigen::Vector3d b(0.1, 0.2, 1.0);
  // Pure rotation: b2 must be R b1.
  const Rigid3d rotation_only(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX())), Eigen::Vector3d::Zero());
  EXPECT_LT(EpipolarAngleRad(b, (rotation_only.rotation * b).normalized(), rotation_only), 1e-12);
  const Eigen::Vector3d r_b = (rotation_only.rotation * b).normalized();
  EXPECT_NEAR(EpipolarAngleRad(b, Eigen::AngleAxisd(0.01, r_b.unitOrthogonal()) * r_b,
                               rotation_only),
              0.01, 1e-12);
  // Bearing1 along the baseline: b2 must lie on the baseline's line.
  const Rigid3d forward(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.0, 0.0, -20.0));
  EXPECT_LT(EpipolarAngleRad(Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ(), forward), 1e-12);
  EXPECT_NEAR(EpipolarAngleRad(Eigen::Vector3d::UnitZ(), Eigen::Vector3d(0.0, std::tan(0.02), 1.0),
                               forward),
              0.02, 1e-12);
  // Bad input: rejected by any threshold.
  EXPECT_EQ(EpipolarAngleRad(Eigen::Vector3d::Zero(), b, forward),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(EpipolarAngleRad(Eigen::Vector3d(std::nan(""), 0.0, 1.0), b, forward),
            std::numeric_limits<double>::infinity());
}

TEST(SampsonErrorPx, ZeroWhenConsistentAndAboutOffsetOverRootTwo) {
  const EpipolarScene scene = MakeEpipolarScene();
  const Eigen::Vector3d bearing1 = scene.point_in_cam1.normalized();
  EXPECT_LT(SampsonErrorPx(bearing1, OffsetBearing2(scene, 0.0), scene.cam2_from_cam1,
                           scene.focal_px),
            1e-9);
  for (const double offset_px : {0.5, 2.0}) {
    // Both images' epipolar gradients are alike (small rotation, point near
    // the centres), so the distance is spread evenly: offset / sqrt(2).
    EXPECT_NEAR(SampsonErrorPx(bearing1, OffsetBearing2(scene, offset_px), scene.cam2_from_cam1,
                               scene.focal_px),
                offset_px / std::sqrt(2.0), 0.03 * offset_px);
  }
  EXPECT_EQ(SampsonErrorPx(-bearing1, OffsetBearing2(scene, 0.0), scene.cam2_from_cam1,
                           scene.focal_px),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(SampsonErrorPx(bearing1, OffsetBearing2(scene, 0.0), scene.cam2_from_cam1, 0.0),
            std::numeric_limits<double>::infinity());
}

// ---------------------------------------------------------------------------
// Plane fit

const Eigen::Vector3d kLunarGravity(0.0, 0.0, -1.62);

TEST(FitPlane, TiltedNoisyPlaneGivesSlopeAndRoughness) {
  std::mt19937_64 rng(CurrentTestSeed());
  SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()));
  const double slope_deg = 7.0;
  const double noise_m = 0.05;  // per axis
  const double size_m = 10.0;
  const int count = 30;
  std::normal_distribution<double> noise(0.0, noise_m);
  std::vector<Eigen::Vector3d> points = PlaneGrid(TiltedNormal(slope_deg), size_m, count);
  const Eigen::Vector3d offset_m(100.0, -50.0, 3.0);  // away from the origin
  for (Eigen::Vector3d& p : points) {
    const double dx = noise(rng), dy = noise(rng), dz = noise(rng);
    p += offset_m + Eigen::Vector3d(dx, dy, dz);
  }
  const PlaneFitResult fit = FitPlane(points, kLunarGravity, 10);
  ASSERT_EQ(fit.status, PlaneFitStatus::kOk) << ToString(fit.status);
  EXPECT_EQ(fit.num_points, count * count);
  EXPECT_GT(fit.normal_in_local.z(), 0.0);
  // Tilt std for N points on a grid of side L: sqrt(12 / N) * sigma / L rad =
  // 0.033 deg here; 5 sigma.
  const double tilt_sigma_deg = std::sqrt(12.0 / (count * count)) * noise_m / size_m * kRadToDeg;
  EXPECT_NEAR(fit.slope_deg, slope_deg, 5.0 * tilt_sigma_deg);
  // RMS of N normal residuals estimates sigma with relative std 1/sqrt(2N) = 2.4 %.
  EXPECT_NEAR(fit.roughness_rms_m, noise_m, 0.1 * noise_m);
  // The largest of 900 |N(0, sigma)| lies in about 2.8 to 4.5 sigma.
  EXPECT_GT(fit.roughness_max_m, 2.5 * noise_m);
  EXPECT_LT(fit.roughness_max_m, 5.0 * noise_m);
  EXPECT_NEAR(fit.centroid_in_local_m.x(), 100.0, 0.01);
}

TEST(FitPlane, ExactPlaneMatchesTruthDefinitions) {
  // A 4-point patch with one point 0.2 m above the plane z = 0: hand-computed
  // TLS values (the truth's definitions in datasets/synth/truth.h).
  const std::vector<Eigen::Vector3d> points = {
      {0.0, 0.0, 0.0}, {10.0, 0.0, 0.0}, {0.0, 10.0, 0.0}, {10.0, 10.0, 0.0}};
  const PlaneFitResult flat = FitPlane(points, kLunarGravity, 3);
  ASSERT_EQ(flat.status, PlaneFitStatus::kOk);
  EXPECT_NEAR(flat.slope_deg, 0.0, 1e-12);
  EXPECT_NEAR(flat.roughness_rms_m, 0.0, 1e-12);
  EXPECT_NEAR((flat.normal_in_local - Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  EXPECT_NEAR((flat.centroid_in_local_m - Eigen::Vector3d(5.0, 5.0, 0.0)).norm(), 0.0, 1e-12);
  // Gravity reversed: the normal follows up.
  const PlaneFitResult flipped = FitPlane(points, -kLunarGravity, 3);
  ASSERT_EQ(flipped.status, PlaneFitStatus::kOk);
  EXPECT_NEAR((flipped.normal_in_local + Eigen::Vector3d::UnitZ()).norm(), 0.0, 1e-12);
  // Symmetric bump on a diagonal pair: the plane stays level at z = 0.05 and
  // every residual is 0.05 m.
  std::vector<Eigen::Vector3d> bumped = points;
  bumped[0].z() = 0.1;
  bumped[3].z() = 0.1;
  const PlaneFitResult fit = FitPlane(bumped, kLunarGravity, 3);
  ASSERT_EQ(fit.status, PlaneFitStatus::kOk);
  EXPECT_NEAR(fit.slope_deg, 0.0, 1e-9);
  EXPECT_NEAR(fit.roughness_rms_m, 0.05, 1e-12);
  EXPECT_NEAR(fit.roughness_max_m, 0.05, 1e-12);
}

TEST(FitPlane, TiltedLocalFrameUsesGravityNotZ) {
  std::mt19937_64 rng(CurrentTestSeed());
  SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()));
  const std::vector<Eigen::Vector3d> points = PlaneGrid(TiltedNormal(7.0), 10.0, 5);
  for (int trial = 0; trial < 20; ++trial) {
    // The same scene in a local frame rotated arbitrarily (e.g. Moon-centred).
    const Eigen::Quaterniond rotation = RandomRotation(&rng);
    std::vector<Eigen::Vector3d> rotated;
    for (const Eigen::Vector3d& p : points) rotated.push_back(rotation * p);
    const PlaneFitResult fit = FitPlane(rotated, rotation * kLunarGravity, 3);
    ASSERT_EQ(fit.status, PlaneFitStatus::kOk);
    EXPECT_NEAR(fit.slope_deg, 7.0, 1e-9) << "trial " << trial;
    EXPECT_GT(fit.normal_in_local.dot(rotation * Eigen::Vector3d::UnitZ()), 0.0);
  }
}

TEST(FitPlane, DegenerateAndBadInputAreReported) {
  // Collinear points (and a line with 1e-8 m of cross-line jitter, still a line).
  const std::vector<Eigen::Vector3d> line = {
      {0.0, 0.0, 0.0}, {1.0, 1.0, 0.1}, {2.0, 2.0, 0.2}, {3.0, 3.0, 0.3}};
  EXPECT_EQ(FitPlane(line, kLunarGravity, 3).status, PlaneFitStatus::kDegenerate);
  std::vector<Eigen::Vector3d> almost_line = line;
  almost_line[1].x() += 1e-8;
  EXPECT_EQ(FitPlane(almost_line, kLunarGravity, 3).status, PlaneFitStatus::kDegenerate);
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1.0, 2.0, 3.0));
  EXPECT_EQ(FitPlane(same, kLunarGravity, 3).status, PlaneFitStatus::kDegenerate);
  // Too few: 2 points, whatever min_points says; or fewer than min_points.
  const PlaneFitResult two = FitPlane({{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}}, kLunarGravity, 0);
  EXPECT_EQ(two.status, PlaneFitStatus::kTooFewPoints);
  EXPECT_EQ(two.num_points, 2);
  EXPECT_EQ(FitPlane(line, kLunarGravity, 10).status, PlaneFitStatus::kTooFewPoints);
  // Non-finite point, zero gravity.
  std::vector<Eigen::Vector3d> with_nan = PlaneGrid(Eigen::Vector3d::UnitZ(), 1.0, 3);
  EXPECT_EQ(FitPlane(with_nan, Eigen::Vector3d::Zero(), 3).status, PlaneFitStatus::kInvalidInput);
  with_nan[4].y() = std::nan("");
  EXPECT_EQ(FitPlane(with_nan, kLunarGravity, 3).status, PlaneFitStatus::kInvalidInput);
}

// ---------------------------------------------------------------------------
// Predicted slope uncertainty

// The paper's geometry: camera 1 400 m above and 400 m downrange of the site
// (45 deg off nadir, slant range 566 m), camera 2 about 5 s later, 40 m
// closer and 30 m to the side; a 10 m site sloping 7 deg, 20 x 20 points.
// The Monte Carlo tests use 0.05 px of matching noise (depth sigma ~0.5 m):
// inside the first-order regime of the prediction (see geometry.h; at 0.3 px
// the TLS fit itself turns nonlinear).
struct SlopeScene {
  Rigid3d cam1_from_local = LookAt(Eigen::Vector3d(0.0, -400.0, 400.0), Eigen::Vector3d::Zero());
  Rigid3d cam2_from_local = LookAt(Eigen::Vector3d(30.0, -370.0, 375.0), Eigen::Vector3d::Zero());
  std::vector<Eigen::Vector3d> points_in_local = PlaneGrid(TiltedNormal(7.0), 10.0, 20);

  Rigid3d Cam2FromCam1() const { return cam2_from_local * cam1_from_local.Inverse(); }
  std::vector<Eigen::Vector3d> PointsInCam1() const {
    std::vector<Eigen::Vector3d> points;
    for (const Eigen::Vector3d& p : points_in_local) points.push_back(cam1_from_local * p);
    return points;
  }
  Eigen::Vector3d UpInCam1() const { return cam1_from_local.rotation * Eigen::Vector3d::UnitZ(); }
};

// Slopes of `trials` simulated reconstructions: bearings with angular noise,
// triangulation with a nav pose whose translation has baseline_sigma_m of
// noise per axis, and a cam1 attitude error of attitude_sigma_rad per axis.
std::vector<double> SimulateSlopesDeg(const SlopeScene& scene, double sigma_angle_rad,
                                      double baseline_sigma_m, double attitude_sigma_rad,
                                      int trials, std::mt19937_64* rng) {
  const Rigid3d cam2_from_cam1 = scene.Cam2FromCam1();
  const Rigid3d local_from_cam1 = scene.cam1_from_local.Inverse();
  const std::vector<Eigen::Vector3d> points_in_cam1 = scene.PointsInCam1();
  std::normal_distribution<double> baseline_noise(0.0, baseline_sigma_m);
  std::normal_distribution<double> attitude_noise(0.0, attitude_sigma_rad);
  const TriangulationOptions options;
  std::vector<double> slopes_deg;
  for (int trial = 0; trial < trials; ++trial) {
    Rigid3d nav_cam2_from_cam1 = cam2_from_cam1;
    nav_cam2_from_cam1.translation += util::DrawVector3(baseline_noise, *rng);
    const Eigen::Vector3d attitude_error = util::DrawVector3(attitude_noise, *rng);
    const Eigen::Quaterniond attitude_rotation =
        attitude_error.norm() > 0.0
            ? Eigen::Quaterniond(Eigen::AngleAxisd(attitude_error.norm(), attitude_error.normalized()))
            : Eigen::Quaterniond::Identity();
    std::vector<Eigen::Vector3d> estimated_in_local;
    for (const Eigen::Vector3d& p : points_in_cam1) {
      const Eigen::Vector3d b1 = PerturbBearing(p.normalized(), sigma_angle_rad, rng);
      const Eigen::Vector3d b2 = PerturbBearing((cam2_from_cam1 * p).normalized(), sigma_angle_rad, rng);
      Eigen::Vector3d estimate;
      EXPECT_EQ(TriangulateMidpoint(b1, b2, nav_cam2_from_cam1, options, &estimate, nullptr),
                TriangulationStatus::kOk);
      estimated_in_local.push_back(attitude_rotation * (local_from_cam1.rotation * estimate) +
                                   local_from_cam1.translation);
    }
    const PlaneFitResult fit = FitPlane(estimated_in_local, kLunarGravity, 3);
    EXPECT_EQ(fit.status, PlaneFitStatus::kOk);
    slopes_deg.push_back(fit.slope_deg);
  }
  return slopes_deg;
}

TEST(SlopeSigmaOptionsValidate, DefaultsValidAndBadValuesNamed) {
  SlopeSigmaOptions options;
  EXPECT_TRUE(options.Validate().empty());
  options.focal_px = 0.0;
  options.baseline_sigma_m = -1.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "focal_px = 0: expected > 0");
  EXPECT_EQ(errors[1], "baseline_sigma_m = -1: expected >= 0");
}

TEST(PredictSlopeSigmaDeg, MatchesMonteCarloForPixelNoise) {
  std::mt19937_64 rng(CurrentTestSeed());
  SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()));
  const SlopeScene scene;
  SlopeSigmaOptions options;
  options.pixel_sigma_px = 0.05;
  options.focal_px = 1500.0;
  SlopeSigmaTerms terms;
  const double predicted_deg = PredictSlopeSigmaDeg(options, scene.PointsInCam1(),
                                                    scene.Cam2FromCam1(), scene.UpInCam1(), &terms);
  ASSERT_EQ(terms.status, PlaneFitStatus::kOk);
  EXPECT_EQ(terms.baseline_deg, 0.0);
  EXPECT_EQ(terms.attitude_deg, 0.0);
  EXPECT_NEAR(terms.pixel_deg, predicted_deg, 1e-12);
  const std::vector<double> slopes_deg = SimulateSlopesDeg(
      scene, options.pixel_sigma_px / options.focal_px, 0.0, 0.0, 500, &rng);
  const double empirical_deg = StdDev(slopes_deg);
  const double ratio = empirical_deg / predicted_deg;
  std::printf("[ pixel MC ] predicted %.4f deg, empirical %.4f deg, ratio %.3f\n", predicted_deg,
              empirical_deg, ratio);
  // 500 trials estimate a std to +-3.2 % (1 sigma); the rest is the
  // first-order model. 0.8 - 1.25 is about 6 sigma of sampling noise.
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.25);
}

TEST(PredictSlopeSigmaDeg, MatchesMonteCarloForNavAndPixelNoise) {
  std::mt19937_64 rng(CurrentTestSeed());
  SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()));
  const SlopeScene scene;
  SlopeSigmaOptions options;
  options.pixel_sigma_px = 0.05;
  options.focal_px = 1500.0;
  options.baseline_sigma_m = 1.0;
  options.attitude_sigma_deg = 0.2;
  SlopeSigmaTerms terms;
  const double predicted_deg = PredictSlopeSigmaDeg(options, scene.PointsInCam1(),
                                                    scene.Cam2FromCam1(), scene.UpInCam1(), &terms);
  ASSERT_EQ(terms.status, PlaneFitStatus::kOk);
  EXPECT_NEAR(terms.attitude_deg, 0.2, 1e-9);
  EXPECT_GT(terms.baseline_deg, 0.0);
  EXPECT_NEAR(predicted_deg,
              std::sqrt(terms.pixel_deg * terms.pixel_deg + terms.baseline_deg * terms.baseline_deg +
                        terms.attitude_deg * terms.attitude_deg),
              1e-9);
  const std::vector<double> slopes_deg =
      SimulateSlopesDeg(scene, options.pixel_sigma_px / options.focal_px, options.baseline_sigma_m,
                        options.attitude_sigma_deg * kDegToRad, 500, &rng);
  const double empirical_deg = StdDev(slopes_deg);
  const double ratio = empirical_deg / predicted_deg;
  std::printf(
      "[ nav MC ] predicted %.4f deg (pixel %.4f, baseline %.4f, attitude %.4f), empirical %.4f "
      "deg, ratio %.3f\n",
      predicted_deg, terms.pixel_deg, terms.baseline_deg, terms.attitude_deg, empirical_deg, ratio);
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.25);
}

TEST(PredictSlopeSigmaDeg, ClosedFormOnAFrontoParallelPatch) {
  // Camera 1 looking straight down at a level patch from 570 m, camera 2 40 m
  // to the side: the rays' angular errors across the baseline change the
  // disparity B / Z, so sigma_depth = sqrt(2) Z^2 sigma_a / B (both rays
  // noisy); errors along the other axis make the rays skew and the midpoint
  // moves sideways only. The tilt is then sqrt(12 / N) sigma_depth / L per
  // axis, for the spread of a continuous square; checked to 5 % (the range
  // varies by 0.02 % across the patch).
  const double range_m = 570.0, baseline_m = 40.0, size_m = 10.0;
  const int count = 20;
  const Rigid3d cam1_from_local(
      Eigen::Quaterniond(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitX())),
      Eigen::Vector3d(0.0, 0.0, range_m));
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-baseline_m, 0.0, 0.0));
  std::vector<Eigen::Vector3d> points_in_cam1;
  for (const Eigen::Vector3d& p : PlaneGrid(Eigen::Vector3d::UnitZ(), size_m, count)) {
    points_in_cam1.push_back(cam1_from_local * p);
  }
  SlopeSigmaOptions options;
  const double sigma_a = options.pixel_sigma_px / options.focal_px;
  const double sigma_perp_m = std::sqrt(2.0) * range_m * range_m * sigma_a / baseline_m;
  // Level patch: per-axis RMS tilt.
  const double expected_deg =
      std::sqrt(12.0 / (count * count)) * sigma_perp_m / size_m * kRadToDeg;
  const double predicted_deg = PredictSlopeSigmaDeg(
      options, points_in_cam1, cam2_from_cam1,
      cam1_from_local.rotation * Eigen::Vector3d::UnitZ());
  // The grid's x spread is that of a uniform square with count points per side:
  // (count + 1) / (count - 1) times larger in variance than L^2/12.
  const double grid_factor = std::sqrt((count + 1.0) / (count - 1.0));
  EXPECT_NEAR(predicted_deg, expected_deg / grid_factor, 0.05 * expected_deg);
}

TEST(SharedWindowFraction, IsTheOverlapOfTwoWindows) {
  // Two 10 px windows 3 px apart across and 5 px down share 7 x 5 of 100 px.
  EXPECT_NEAR(SharedWindowFraction(Eigen::Vector2d(3.0, -5.0), 10.0), 0.35, 1e-12);
  EXPECT_EQ(SharedWindowFraction(Eigen::Vector2d::Zero(), 10.0), 1.0);
  EXPECT_EQ(SharedWindowFraction(Eigen::Vector2d(10.0, 0.0), 10.0), 0.0);
  EXPECT_EQ(SharedWindowFraction(Eigen::Vector2d(0.0, 12.0), 10.0), 0.0);
  // No window: only a match with itself correlates.
  EXPECT_EQ(SharedWindowFraction(Eigen::Vector2d::Zero(), 0.0), 1.0);
  EXPECT_EQ(SharedWindowFraction(Eigen::Vector2d(0.5, 0.0), 0.0), 0.0);
}

TEST(SpreadOfCorrelatedResidualsPx, DividesByWhatCorrelationLeaves) {
  // Independent (far apart or no window): the sample variance, n - 1.
  const std::vector<Eigen::Vector2d> apart = {{0.0, 0.0}, {100.0, 0.0}, {0.0, 100.0}};
  EXPECT_NEAR(SpreadOfCorrelatedResidualsPx(8.0, apart, 25.0), 2.0, 1e-12);
  EXPECT_NEAR(SpreadOfCorrelatedResidualsPx(8.0, apart, 0.0), 2.0, 1e-12);
  // Two matches half a window apart: rho = 0.5, sum_ij rho = 3, divisor
  // 2 - 3 / 2 = 0.5 (where independent ones would give 1).
  const std::vector<Eigen::Vector2d> close = {{0.0, 0.0}, {5.0, 0.0}};
  EXPECT_NEAR(SpreadOfCorrelatedResidualsPx(0.5, close, 10.0), 1.0, 1e-12);
  // Matches on one pixel share all their noise: nothing is left to measure it.
  EXPECT_EQ(SpreadOfCorrelatedResidualsPx(1.0, {{3.0, 3.0}, {3.0, 3.0}}, 10.0), 0.0);
  EXPECT_EQ(SpreadOfCorrelatedResidualsPx(1.0, {{3.0, 3.0}}, 10.0), 0.0);
}

// Slopes of `trials` reconstructions whose bearing errors are box averages,
// over window_px x window_px pixels, of a white noise field on image 1's
// pixel grid (one field per tangent component and image): two matches then
// correlate by exactly SharedWindowFraction of their pixels.
std::vector<double> SimulateWindowedSlopesDeg(const SlopeScene& scene, const std::vector<Eigen::Vector2i>& pixels,
                                              int window_px, double sigma_angle_rad, int trials,
                                              std::mt19937_64* rng) {
  const Rigid3d cam2_from_cam1 = scene.Cam2FromCam1();
  const Rigid3d local_from_cam1 = scene.cam1_from_local.Inverse();
  const std::vector<Eigen::Vector3d> points_in_cam1 = scene.PointsInCam1();
  int width = 0, height = 0;
  for (const Eigen::Vector2i& p : pixels) {
    width = std::max(width, p.x() + window_px);
    height = std::max(height, p.y() + window_px);
  }
  // The field's std makes each window's mean sigma_angle_rad.
  std::normal_distribution<double> white(0.0, sigma_angle_rad * window_px);
  const TriangulationOptions options;
  std::vector<double> slopes_deg;
  for (int trial = 0; trial < trials; ++trial) {
    std::vector<std::vector<double>> fields(4, std::vector<double>(static_cast<size_t>(width) * height));
    for (std::vector<double>& field : fields) {
      for (double& value : field) value = white(*rng);
    }
    const auto window_mean = [&](const std::vector<double>& field, const Eigen::Vector2i& corner) {
      double sum = 0.0;
      for (int y = corner.y(); y < corner.y() + window_px; ++y) {
        for (int x = corner.x(); x < corner.x() + window_px; ++x) sum += field[static_cast<size_t>(y) * width + x];
      }
      return sum / (window_px * window_px);
    };
    std::vector<Eigen::Vector3d> estimated_in_local;
    for (size_t i = 0; i < points_in_cam1.size(); ++i) {
      const Eigen::Vector3d b1 = points_in_cam1[i].normalized();
      const Eigen::Vector3d b2 = (cam2_from_cam1 * points_in_cam1[i]).normalized();
      const Eigen::Vector3d b1_noisy = (b1 + window_mean(fields[0], pixels[i]) * b1.unitOrthogonal() +
                                        window_mean(fields[1], pixels[i]) * b1.cross(b1.unitOrthogonal()))
                                           .normalized();
      const Eigen::Vector3d b2_noisy = (b2 + window_mean(fields[2], pixels[i]) * b2.unitOrthogonal() +
                                        window_mean(fields[3], pixels[i]) * b2.cross(b2.unitOrthogonal()))
                                           .normalized();
      Eigen::Vector3d estimate;
      EXPECT_EQ(TriangulateMidpoint(b1_noisy, b2_noisy, cam2_from_cam1, options, &estimate, nullptr),
                TriangulationStatus::kOk);
      estimated_in_local.push_back(local_from_cam1 * estimate);
    }
    const PlaneFitResult fit = FitPlane(estimated_in_local, kLunarGravity, 3);
    EXPECT_EQ(fit.status, PlaneFitStatus::kOk);
    slopes_deg.push_back(fit.slope_deg);
  }
  return slopes_deg;
}

TEST(PredictSlopeSigmaDeg, MatchesMonteCarloForMatchesSharingWindows) {
  // The scene's 20 x 20 points on image-1 pixels 2 px apart, each match from
  // a 9 px window: neighbours share up to 7/9 of a window. Independent
  // errors of the same size would give a far smaller sigma.
  std::mt19937_64 rng(CurrentTestSeed());
  SCOPED_TRACE("seed " + std::to_string(CurrentTestSeed()));
  const SlopeScene scene;
  constexpr int kWindowPx = 9, kSpacingPx = 2, kSide = 20;
  std::vector<Eigen::Vector2i> corners;
  std::vector<Eigen::Vector2d> pixels;
  for (int k = 0; k < kSide * kSide; ++k) {
    // PlaneGrid's order: the first index runs slowest.
    corners.emplace_back((k % kSide) * kSpacingPx, (k / kSide) * kSpacingPx);
    pixels.emplace_back(corners.back().x() + kWindowPx / 2, corners.back().y() + kWindowPx / 2);
  }
  SlopeSigmaOptions options;
  options.pixel_sigma_px = 0.05;
  options.focal_px = 1500.0;
  options.match_window_px = kWindowPx;
  const double predicted_deg = PredictSlopeSigmaDeg(options, scene.PointsInCam1(), scene.Cam2FromCam1(),
                                                    scene.UpInCam1(), nullptr, nullptr, &pixels);
  SlopeSigmaOptions independent = options;
  independent.match_window_px = 0.0;
  const double independent_deg = PredictSlopeSigmaDeg(independent, scene.PointsInCam1(), scene.Cam2FromCam1(),
                                                      scene.UpInCam1(), nullptr, nullptr, &pixels);
  EXPECT_NEAR(independent_deg,
              PredictSlopeSigmaDeg(independent, scene.PointsInCam1(), scene.Cam2FromCam1(), scene.UpInCam1()),
              1e-12);
  const std::vector<double> slopes_deg = SimulateWindowedSlopesDeg(
      scene, corners, kWindowPx, options.pixel_sigma_px / options.focal_px, 400, &rng);
  const double empirical_deg = StdDev(slopes_deg);
  const double ratio = empirical_deg / predicted_deg;
  std::printf("[ windowed MC ] predicted %.4f deg (independent %.4f), empirical %.4f deg, ratio %.3f\n",
              predicted_deg, independent_deg, empirical_deg, ratio);
  EXPECT_GT(predicted_deg, 2.0 * independent_deg);
  // 400 trials estimate a std to +-3.5 % (1 sigma).
  EXPECT_GT(ratio, 0.8);
  EXPECT_LT(ratio, 1.25);
}

TEST(PredictSlopeSigmaDeg, PixelsNotOnePerPointAreInvalid) {
  const SlopeScene scene;
  SlopeSigmaOptions options;
  options.match_window_px = 9.0;
  const std::vector<Eigen::Vector2d> pixels = {{0.0, 0.0}};
  SlopeSigmaTerms terms;
  EXPECT_EQ(PredictSlopeSigmaDeg(options, scene.PointsInCam1(), scene.Cam2FromCam1(), scene.UpInCam1(), &terms,
                                 nullptr, &pixels),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(terms.status, PlaneFitStatus::kInvalidInput);
}

TEST(PredictSlopeSigmaDeg, UnfittablePatchIsInfinite) {
  const SlopeSigmaOptions options;
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-40.0, 0.0, 0.0));
  SlopeSigmaTerms terms;
  EXPECT_EQ(PredictSlopeSigmaDeg(options, {{0.0, 0.0, 570.0}, {1.0, 0.0, 570.0}}, cam2_from_cam1,
                                 -Eigen::Vector3d::UnitZ(), &terms),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(terms.status, PlaneFitStatus::kTooFewPoints);
  EXPECT_EQ(PredictSlopeSigmaDeg(options, {{0.0, 0.0, 570.0}, {1.0, 0.0, 570.0}, {2.0, 0.0, 570.0}},
                                 cam2_from_cam1, -Eigen::Vector3d::UnitZ(), &terms),
            std::numeric_limits<double>::infinity());
  EXPECT_EQ(terms.status, PlaneFitStatus::kDegenerate);
}

}  // namespace
}  // namespace hdabench::hda
