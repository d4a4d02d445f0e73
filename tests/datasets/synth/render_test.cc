// Tests of the ray caster and the renderer on hand-made scenes (flat, tilted
// or noise heightfields with chosen rocks), independent of the terrain
// generator.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "tools/util/error.h"
#include "calib/rigid3.h"
#include "datasets/synth/imagery_check.h"
#include "datasets/synth/noise.h"
#include "datasets/synth/optics.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/render.h"
#include "datasets/synth/scene.h"
#include "tests/support/test_support.h"
#include "tools/util/angles.h"

namespace hdabench::datasets::synth {
namespace {

using util::kPi;


// A heightfield of width x height nodes with node (0, 0) at (origin_x, origin_y)
// and heights from `z(x, y)`; uniform albedo unless changed.
Scene MakeScene(int width, int height, double spacing_m, double origin_x_m, double origin_y_m,
                const std::function<double(double, double)>& z) {
  Scene scene;
  Heightfield& dem = scene.dem;
  dem.width = width;
  dem.height = height;
  dem.spacing_m = spacing_m;
  dem.origin_x_m = origin_x_m;
  dem.origin_y_m = origin_y_m;
  dem.height_m.resize(static_cast<size_t>(width) * height);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      dem.height_m[static_cast<size_t>(r) * width + c] =
          static_cast<float>(z(origin_x_m + c * spacing_m, origin_y_m - r * spacing_m));
    }
  }
  scene.albedo.mean = 0.12;
  scene.albedo.relative_variation = 0.0;
  return scene;
}

// A camera looking straight down from `centre_in_local`, image x = east,
// image y = south (north up in the image).
Rigid3d NadirCamFromLocal(const Eigen::Vector3d& centre_in_local) {
  // Rotation by 180 deg about x: cam x = east, cam y = south, cam z = down.
  const Eigen::Quaterniond cam_from_local_rotation(0.0, 1.0, 0.0, 0.0);
  return Rigid3d(cam_from_local_rotation, -(cam_from_local_rotation * centre_in_local));
}

calib::CameraModel Pinhole(int size_px, double focal_px) {
  return calib::CameraModel("LENSMODEL_PINHOLE", {focal_px, focal_px, (size_px - 1) / 2.0, (size_px - 1) / 2.0},
                            size_px, size_px);
}

RenderOptions NoiselessOptions() {
  RenderOptions options;
  options.shot_noise = false;
  options.read_noise_dn = 0.0;
  return options;
}

// Reference intersection: every triangle of the DEM (Moller-Trumbore), the
// nearest with t > 0; -1 when none.
double BruteForceTerrain(const Heightfield& dem, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction) {
  const auto node = [&](int r, int c) {
    return Eigen::Vector3d(dem.origin_x_m + c * dem.spacing_m, dem.origin_y_m - r * dem.spacing_m, dem.At(r, c));
  };
  const auto triangle = [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
    const Eigen::Vector3d e1 = b - a;
    const Eigen::Vector3d e2 = c - a;
    const Eigen::Vector3d p = direction.cross(e2);
    const double det = e1.dot(p);
    if (std::abs(det) < 1e-15) return -1.0;
    const Eigen::Vector3d s = origin - a;
    const double u = s.dot(p) / det;
    const Eigen::Vector3d q = s.cross(e1);
    const double v = direction.dot(q) / det;
    if (u < 0.0 || v < 0.0 || u + v > 1.0) return -1.0;
    const double t = e2.dot(q) / det;
    return t > 0.0 ? t : -1.0;
  };
  double best = -1.0;
  for (int r = 0; r + 1 < dem.height; ++r) {
    for (int c = 0; c + 1 < dem.width; ++c) {
      for (const double t : {triangle(node(r, c), node(r + 1, c + 1), node(r, c + 1)),
                             triangle(node(r, c), node(r + 1, c + 1), node(r + 1, c))}) {
        if (t > 0.0 && (best < 0.0 || t < best)) best = t;
      }
    }
  }
  return best;
}

// Reference rock intersection: every sphere's entry point that lies above the
// ground; -1 when none.
double BruteForceRocks(const Scene& scene, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                       int* index) {
  double best = -1.0;
  for (size_t k = 0; k < scene.rocks.size(); ++k) {
    const Rock& rock = scene.rocks[k];
    const Eigen::Vector3d offset = origin - rock.center_in_local_m;
    const double b = direction.dot(offset);
    const double disc = b * b - (offset.squaredNorm() - rock.radius_m * rock.radius_m);
    if (disc < 0.0) continue;
    const double t = -b - std::sqrt(disc);
    if (t <= 0.0) continue;
    const Eigen::Vector3d p = origin + t * direction;
    double ground;
    if (!scene.dem.HeightAt(p.x(), p.y(), &ground) || p.z() < ground) continue;
    if (best < 0.0 || t < best) {
      best = t;
      *index = static_cast<int>(k);
    }
  }
  return best;
}

// A random unit direction pointing down at least `min_down` (z <= -min_down).
Eigen::Vector3d RandomDownDirection(std::uint64_t seed, std::uint64_t i, double min_down) {
  const double z = -(min_down + (1.0 - min_down) * HashUniform(seed, i, 10));
  const double azimuth = 2.0 * kPi * HashUniform(seed, i, 11);
  const double horizontal = std::sqrt(1.0 - z * z);
  return Eigen::Vector3d(horizontal * std::cos(azimuth), horizontal * std::sin(azimuth), z);
}

TEST(SceneRaycaster, MatchesBruteForceOnNoiseHeightfield) {
  const std::uint64_t seed = testing_support::CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  // 23 x 17 nodes of independent random heights in [-1, 1] m at 0.5 m: steep,
  // rough, with many self-occlusions.
  Scene scene = MakeScene(23, 17, 0.5, -5.0, 4.0, [](double, double) { return 0.0; });
  for (size_t i = 0; i < scene.dem.height_m.size(); ++i) {
    scene.dem.height_m[i] = static_cast<float>(2.0 * HashUniform(seed, i, 1) - 1.0);
  }
  const SceneRaycaster raycaster(scene);
  int hits = 0;
  for (std::uint64_t i = 0; i < 3000; ++i) {
    SCOPED_TRACE("ray " + std::to_string(i));
    // Origins over and around the DEM, directions from steep to grazing.
    const Eigen::Vector3d origin(-8.0 + 17.0 * HashUniform(seed, i, 2), -8.0 + 16.0 * HashUniform(seed, i, 3),
                                 -0.5 + 6.0 * HashUniform(seed, i, 4));
    const Eigen::Vector3d direction = RandomDownDirection(seed, i, 0.02);
    RayHit hit;
    const bool found = raycaster.Intersect(origin, direction, 100.0, &hit);
    const double reference = BruteForceTerrain(scene.dem, origin, direction);
    ASSERT_EQ(found, reference > 0.0) << "reference t " << reference;
    EXPECT_EQ(raycaster.Occluded(origin, direction, 100.0), found);
    if (!found) continue;
    ++hits;
    EXPECT_NEAR(hit.distance_m, reference, 1e-9);
    EXPECT_EQ(hit.rock_index, -1);
    double ground;
    ASSERT_TRUE(scene.dem.HeightAt(hit.point_in_local_m.x(), hit.point_in_local_m.y(), &ground));
    EXPECT_LT(std::abs(hit.point_in_local_m.z() - ground), 1e-6);
    Eigen::Vector3d normal;
    ASSERT_TRUE(scene.dem.NormalAt(hit.point_in_local_m.x(), hit.point_in_local_m.y(), &normal));
    // On a shared edge the two triangles differ; away from it they agree.
    EXPECT_GT(hit.normal_in_local.dot(normal), 1.0 - 1e-9);
    // A shorter max distance excludes the hit.
    EXPECT_FALSE(raycaster.Occluded(origin, direction, hit.distance_m * (1.0 - 1e-9) - 1e-12));
  }
  EXPECT_GT(hits, 500);  // the test exercises hits, not just misses
}

TEST(SceneRaycaster, MatchesBruteForceWithRocks) {
  const std::uint64_t seed = testing_support::CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  // A gently tilted plane with 300 rocks of 0.1-2 m radius, buried between a
  // quarter and three quarters of their diameter.
  Scene scene = MakeScene(81, 61, 0.25, -10.0, 7.5, [](double x, double y) { return 0.1 * x - 0.05 * y; });
  for (std::uint64_t k = 0; k < 300; ++k) {
    Rock rock;
    rock.radius_m = 0.1 + 0.9 * HashUniform(seed, k, 20) * HashUniform(seed, k, 21);
    const double x = -10.0 + 20.0 * HashUniform(seed, k, 22);
    const double y = -7.5 + 15.0 * HashUniform(seed, k, 23);
    const double protrusion = rock.radius_m * (0.5 + HashUniform(seed, k, 24));
    double ground;
    ASSERT_TRUE(scene.dem.HeightAt(x, y, &ground));
    rock.center_in_local_m = Eigen::Vector3d(x, y, ground + protrusion - rock.radius_m);
    rock.height_above_ground_m = protrusion;
    rock.albedo = 0.2f;
    scene.rocks.push_back(rock);
  }
  const SceneRaycaster raycaster(scene);
  int rock_hits = 0;
  for (std::uint64_t i = 0; i < 3000; ++i) {
    SCOPED_TRACE("ray " + std::to_string(i));
    const Eigen::Vector3d origin(-12.0 + 24.0 * HashUniform(seed, i, 2), -9.0 + 18.0 * HashUniform(seed, i, 3),
                                 3.0 + 5.0 * HashUniform(seed, i, 4));
    const Eigen::Vector3d direction = RandomDownDirection(seed, i, 0.05);
    int reference_rock = -1;
    const double terrain_t = BruteForceTerrain(scene.dem, origin, direction);
    const double rock_t = BruteForceRocks(scene, origin, direction, &reference_rock);
    RayHit hit;
    const bool found = raycaster.Intersect(origin, direction, 1000.0, &hit);
    ASSERT_EQ(found, terrain_t > 0.0 || rock_t > 0.0);
    if (!found) continue;
    const bool rock_first = rock_t > 0.0 && (terrain_t < 0.0 || rock_t < terrain_t);
    if (rock_first) {
      ++rock_hits;
      EXPECT_EQ(hit.rock_index, reference_rock);
      EXPECT_NEAR(hit.distance_m, rock_t, 1e-9);
      EXPECT_FLOAT_EQ(static_cast<float>(hit.albedo), 0.2f);
    } else {
      EXPECT_EQ(hit.rock_index, -1);
      EXPECT_NEAR(hit.distance_m, terrain_t, 1e-9);
    }
  }
  EXPECT_GT(rock_hits, 100);
}

TEST(SceneRaycaster, RaysLeavingTheDemMiss) {
  const Scene scene = MakeScene(11, 11, 1.0, 0.0, 10.0, [](double, double) { return 0.0; });
  const SceneRaycaster raycaster(scene);
  RayHit hit;
  // Up, away, and outside the extent.
  EXPECT_FALSE(raycaster.Intersect({5, 5, 1}, {0, 0, 1}, 100.0, &hit));
  EXPECT_FALSE(raycaster.Intersect({-1, 5, 1}, {0, 0, -1}, 100.0, &hit));
  EXPECT_FALSE(raycaster.Intersect({5, 5, 1}, Eigen::Vector3d(1, 0, 0.001).normalized(), 100.0, &hit));
  EXPECT_FALSE(raycaster.Intersect({5, 5, 1}, {0, 0, -1}, 0.5, &hit));  // beyond max distance
  EXPECT_FALSE(raycaster.Intersect({5, 5, std::nan("")}, {0, 0, -1}, 100.0, &hit));
  ASSERT_TRUE(raycaster.Intersect({5, 5, 1}, {0, 0, -1}, 100.0, &hit));
  EXPECT_NEAR(hit.distance_m, 1.0, 1e-12);
  // A degenerate DEM never hits.
  Scene empty;
  const SceneRaycaster none(empty);
  EXPECT_FALSE(none.Intersect({0, 0, 1}, {0, 0, -1}, 100.0, &hit));
}

TEST(SunDirectionInLocal, AzimuthFromNorthClockwise) {
  EXPECT_LT((SunDirectionInLocal(0.0, 0.0) - Eigen::Vector3d(0, 1, 0)).norm(), 1e-12);
  EXPECT_LT((SunDirectionInLocal(90.0, 0.0) - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((SunDirectionInLocal(123.0, 90.0) - Eigen::Vector3d(0, 0, 1)).norm(), 1e-12);
  const Eigen::Vector3d d = SunDirectionInLocal(200.0, 10.0);
  EXPECT_NEAR(d.norm(), 1.0, 1e-12);
  EXPECT_NEAR(std::asin(d.z()), 10.0 * kPi / 180.0, 1e-12);
}

TEST(LunarLambertReflectance, MatchesTheFormula) {
  // g = 0: L = 1, r = 2 A cos i / (cos i + cos e).
  EXPECT_NEAR(LunarLambertReflectance(0.1, 0.5, 1.0, 0.0), 0.1 * 2.0 * 0.5 / 1.5, 1e-15);
  // g = 60 deg: L = 1 - 1.14 + 0.8712 - 0.31536.
  const double l = 1.0 - 0.019 * 60 + 2.42e-4 * 3600 - 1.46e-6 * 216000;
  EXPECT_NEAR(LunarLambertLimbDarkening(kPi / 3.0), l, 1e-12);
  EXPECT_NEAR(LunarLambertReflectance(0.2, 0.6, 0.8, kPi / 3.0),
              0.2 * (2.0 * l * 0.6 / 1.4 + (1.0 - l) * 0.6), 1e-15);
  // The check values of the cited sources (ISIS LunarLambertMcEwen, the Ames
  // Stereo Pipeline's sfs model coefficients 1 -0.019 0.000242 -0.00000146).
  EXPECT_NEAR(LunarLambertLimbDarkening(0.0), 1.0, 1e-15);
  EXPECT_NEAR(LunarLambertLimbDarkening(kPi / 6.0), 0.6084, 5e-5);
  EXPECT_NEAR(LunarLambertLimbDarkening(kPi / 3.0), 0.4158, 5e-5);
  EXPECT_NEAR(LunarLambertLimbDarkening(kPi / 2.0), 0.1859, 5e-5);
  // Large phase: clamped to pure Lambert; no light from behind.
  EXPECT_EQ(LunarLambertLimbDarkening(kPi * 0.8), 0.0);
  EXPECT_EQ(LunarLambertReflectance(0.2, 0.0, 0.8, 0.5), 0.0);
  EXPECT_EQ(LunarLambertReflectance(0.2, -0.3, 0.8, 0.5), 0.0);
}

// Bilinear interpolation of a CV_32FC3 raster at pixel (x, y); false when a
// corner is NaN or outside.
bool InterpolatePoint(const cv::Mat& points, double x, double y, Eigen::Vector3d* point) {
  const int c = static_cast<int>(std::floor(x));
  const int r = static_cast<int>(std::floor(y));
  if (c < 0 || r < 0 || c + 1 >= points.cols || r + 1 >= points.rows) return false;
  const double fx = x - c;
  const double fy = y - r;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int dr = 0; dr < 2; ++dr) {
    for (int dc = 0; dc < 2; ++dc) {
      const cv::Vec3f& p = points.at<cv::Vec3f>(r + dr, c + dc);
      if (!std::isfinite(p[0])) return false;
      const double w = (dc ? fx : 1.0 - fx) * (dr ? fy : 1.0 - fy);
      sum += w * Eigen::Vector3d(p[0], p[1], p[2]);
    }
  }
  *point = sum;
  return true;
}

TEST(RenderFrame, TruthPointsAgreeBetweenTwoPoses) {
  const std::uint64_t seed = testing_support::CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  // Gentle undulation (slopes <= ~10 deg: no occlusion from 100 m) with a
  // textured albedo.
  Scene scene = MakeScene(321, 241, 0.5, -70.0, 60.0, [](double x, double y) {
    return 2.0 * std::sin(x / 15.0) * std::cos(y / 20.0) + 0.5 * std::sin(0.3 * x + 0.2 * y);
  });
  scene.albedo.relative_variation = 0.25;
  scene.albedo.seed = seed;
  const SceneRaycaster raycaster(scene);
  const calib::CameraModel camera = Pinhole(200, 300.0);  // GSD 100/300 = 0.33 m at 100 m
  // Frame 1 nadir at x = -15; frame 2 at x = +15, tilted 5 deg about its y axis.
  const Rigid3d cam1_from_local = NadirCamFromLocal({-15.0, 0.0, 100.0});
  Rigid3d cam2_from_local = NadirCamFromLocal({15.0, 2.0, 100.0});
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(5.0 * kPi / 180.0, Eigen::Vector3d::UnitY()));
  cam2_from_local = Rigid3d(tilt, Eigen::Vector3d::Zero()) * cam2_from_local;
  RenderOptions options;
  options.anti_aliasing = RenderOptions::AntiAliasing::kGrid;
  options.samples_per_pixel_axis = 1;
  options.threads = 2;
  const RenderedFrame frame1 = RenderFrame(raycaster, scene, camera, cam1_from_local, options, 1);
  const RenderedFrame frame2 = RenderFrame(raycaster, scene, camera, cam2_from_local, options, 2);

  std::vector<Eigen::Vector3d> points_in_cam2;
  std::vector<Eigen::Vector3d> points_in_local;
  for (int r = 0; r < frame1.points_in_local_m.rows; r += 3) {
    for (int c = 0; c < frame1.points_in_local_m.cols; c += 3) {
      const cv::Vec3f& p = frame1.points_in_local_m.at<cv::Vec3f>(r, c);
      ASSERT_TRUE(std::isfinite(p[0]));  // the whole view is on the DEM
      const Eigen::Vector3d point(p[0], p[1], p[2]);
      // Truth points lie on the surface (float storage: ~1e-5 m at 100 m).
      double ground;
      ASSERT_TRUE(scene.dem.HeightAt(point.x(), point.y(), &ground));
      EXPECT_LT(std::abs(point.z() - ground), 1e-4);
      points_in_local.push_back(point);
      points_in_cam2.push_back(cam2_from_local * point);
    }
  }
  std::vector<Eigen::Vector2d> pixels2;
  std::vector<unsigned char> valid;
  camera.Project(points_in_cam2, &pixels2, &valid);
  const Eigen::Vector3d camera2_in_local = cam2_from_local.Inverse().translation;
  int compared = 0;
  double max_raster_error_m = 0.0;
  for (size_t i = 0; i < pixels2.size(); ++i) {
    if (!valid[i]) continue;
    Eigen::Vector3d interpolated;
    if (!InterpolatePoint(frame2.points_in_local_m, pixels2[i].x(), pixels2[i].y(), &interpolated)) continue;
    ++compared;
    // The ray from camera 2 toward the point meets the surface at that point:
    // no occlusion, exact geometry (float-stored point: 1e-4 m).
    RayHit hit;
    const Eigen::Vector3d direction = (points_in_local[i] - camera2_in_local).normalized();
    ASSERT_TRUE(raycaster.Intersect(camera2_in_local, direction, 1e4, &hit));
    EXPECT_LT((hit.point_in_local_m - points_in_local[i]).norm(), 1e-4);
    // Frame 2's raster, interpolated at the projection, gives the same point.
    // Bilinear interpolation over one pixel footprint (h ~ 0.33 m) of a
    // surface with curvature kappa <= 2/15^2 + 0.5*0.36^2 ~ 0.074 1/m errs by
    // about kappa h^2 / 8 ~ 1 mm; the 0.5 m triangles add kinks of the same
    // order. 1 cm = 0.03 px.
    const double error_m = (interpolated - points_in_local[i]).norm();
    max_raster_error_m = std::max(max_raster_error_m, error_m);
    EXPECT_LT(error_m, 0.01) << "pixel in frame 2 " << pixels2[i].transpose();
  }
  EXPECT_GT(compared, 2000);
  RecordProperty("max_raster_error_m", std::to_string(max_raster_error_m));
}

TEST(RenderFrame, FlatPatchHasTheModelBrightness) {
  Scene scene = MakeScene(121, 121, 1.0, -60.0, 60.0, [](double, double) { return 3.0; });
  const SceneRaycaster raycaster(scene);
  const calib::CameraModel camera = Pinhole(64, 80.0);
  const Eigen::Vector3d centre(4.0, -3.0, 53.0);
  const Rigid3d cam_from_local = NadirCamFromLocal(centre);
  RenderOptions options = NoiselessOptions();
  options.sun_azimuth_deg = 135.0;
  options.sun_elevation_deg = 25.0;
  options.dn_per_reflectance = 900.0;
  const Eigen::Vector3d sun = SunDirectionInLocal(135.0, 25.0);
  for (const int bit_depth : {8, 16}) {
    options.bit_depth = bit_depth;
    const RenderedFrame frame = RenderFrame(raycaster, scene, camera, cam_from_local, options, 7);
    ASSERT_EQ(frame.image.type(), bit_depth == 8 ? CV_8UC1 : CV_16UC1);
    double min_dn = 1e9, max_dn = 0.0;
    for (int r = 0; r < frame.image.rows; ++r) {
      for (int c = 0; c < frame.image.cols; ++c) {
        const cv::Vec3f& p = frame.points_in_local_m.at<cv::Vec3f>(r, c);
        const Eigen::Vector3d to_camera = (centre - Eigen::Vector3d(p[0], p[1], p[2])).normalized();
        const double expected = 900.0 * LunarLambertReflectance(0.12, sun.z(), to_camera.z(),
                                                                std::acos(sun.dot(to_camera)));
        const double dn = bit_depth == 8 ? frame.image.at<std::uint8_t>(r, c) : frame.image.at<std::uint16_t>(r, c);
        // Rounding (0.5 DN); the 2 x 2 samples of a pixel see the same flat
        // surface from directions within 0.5 px, a second-order change
        // (<< 1e-3 DN here).
        EXPECT_LE(std::abs(dn - expected), 0.5 + 1e-3) << "pixel " << c << "," << r;
        EXPECT_EQ(frame.shadow_mask.at<std::uint8_t>(r, c), 0);
        min_dn = std::min(min_dn, dn);
        max_dn = std::max(max_dn, dn);
      }
    }
    EXPECT_GT(max_dn - min_dn, 1.0);  // the geometry changes across the view
  }
  // Auto-exposure: a flat patch of the mean albedo seen along the optical axis
  // gets target_mean_dn. The central 2 x 2 pixels straddle the axis.
  options.bit_depth = 8;
  options.dn_per_reflectance = 0.0;
  const RenderedFrame frame = RenderFrame(raycaster, scene, camera, cam_from_local, options, 7);
  EXPECT_NEAR(frame.dn_per_reflectance, ExposureFor(options, 0.12, Eigen::Vector3d::UnitZ()), 1e-9);
  for (int r = 31; r <= 32; ++r) {
    for (int c = 31; c <= 32; ++c) EXPECT_NEAR(frame.image.at<std::uint8_t>(r, c), 110.0, 1.0);
  }
}

TEST(RenderFrame, HemisphereShadowHasTheGeometricLength) {
  // A rock of 1 m diameter with its centre at ground level (a hemisphere) on
  // flat ground; the sun 10 deg above the eastern horizon. The boundary of the
  // shadow is made by sun rays tangent to the sphere: a ray at elevation e
  // passing at distance R from the centre C meets the ground plane through C
  // at horizontal distance d with d sin(e) = R. So the tip, straight down-sun
  // (west) of C, is R / sin(e) = 2.879 m from C, and at a distance s along the
  // down-sun axis the shadow's half-width is R sqrt(1 - (s sin(e) / R)^2)
  // (the sphere's shadow is an ellipse with semi-axes R / sin(e) and R).
  const double radius_m = 0.5;
  const double elevation_deg = 10.0;
  const double sin_e = std::sin(elevation_deg * kPi / 180.0);
  Scene scene = MakeScene(49, 49, 0.25, -6.0, 6.0, [](double, double) { return 0.0; });
  Rock rock;
  rock.center_in_local_m = Eigen::Vector3d(0.0, 0.0, 0.0);
  rock.radius_m = radius_m;
  rock.height_above_ground_m = radius_m;
  scene.rocks.push_back(rock);
  const SceneRaycaster raycaster(scene);
  // Nadir view from 20 m, 1 cm ground sample distance, centred down-sun.
  const double gsd_m = 0.01;
  const calib::CameraModel camera = Pinhole(512, 20.0 / gsd_m);
  RenderOptions options = NoiselessOptions();
  options.sun_azimuth_deg = 90.0;
  options.sun_elevation_deg = elevation_deg;
  options.anti_aliasing = RenderOptions::AntiAliasing::kGrid;
  options.samples_per_pixel_axis = 1;
  const RenderedFrame frame = RenderFrame(raycaster, scene, camera, NadirCamFromLocal({-1.5, 0.0, 20.0}), options, 3);
  double tip_m = 0.0;              // furthest down-sun shadowed ground point
  double half_width_m = 0.0;       // widest shadowed ground point at s = 1.5 m
  int shadowed_ground = 0;
  for (int r = 0; r < frame.image.rows; ++r) {
    for (int c = 0; c < frame.image.cols; ++c) {
      const cv::Vec3f& p = frame.points_in_local_m.at<cv::Vec3f>(r, c);
      const bool ground = frame.rock_index.at<std::int32_t>(r, c) == -1;
      if (frame.shadow_mask.at<std::uint8_t>(r, c) != 255 || !ground) continue;
      ++shadowed_ground;
      EXPECT_LT(p[0], 0.0f);  // no shadow up-sun
      tip_m = std::max(tip_m, -static_cast<double>(p[0]));
      if (std::abs(static_cast<double>(p[0]) + 1.5) < gsd_m) half_width_m = std::max(half_width_m, std::abs(static_cast<double>(p[1])));
    }
  }
  EXPECT_GT(shadowed_ground, 1000);
  // Within 2 pixels of the geometric value (the last shadowed pixel centre is
  // up to one pixel short of the boundary).
  EXPECT_NEAR(tip_m, radius_m / sin_e, 2.0 * gsd_m);
  EXPECT_NEAR(half_width_m, radius_m * std::sqrt(1.0 - std::pow(1.5 * sin_e / radius_m, 2)), 2.0 * gsd_m);
  // The rock's western half faces away from the sun: attached shadow.
  const int rock_row = 256, rock_col = 256 + static_cast<int>(std::lround(1.2 / gsd_m));  // x = -0.3
  EXPECT_EQ(frame.rock_index.at<std::int32_t>(rock_row, rock_col), 0);
  EXPECT_EQ(frame.shadow_mask.at<std::uint8_t>(rock_row, rock_col), 128);
  EXPECT_EQ(frame.image.at<std::uint8_t>(rock_row, rock_col), 0);
}

// A small rough scene with rocks for the determinism tests.
Scene RoughScene(std::uint64_t seed) {
  Scene scene = MakeScene(161, 161, 0.25, -20.0, 20.0, [seed](double x, double y) {
    return 2.0 * FractalNoise(seed, x, y, 0.5, 32.0, 0.8);
  });
  scene.albedo.relative_variation = 0.25;
  for (std::uint64_t k = 0; k < 200; ++k) {
    Rock rock;
    rock.radius_m = 0.2 + 0.6 * HashUniform(seed, k, 1);
    const double x = -18.0 + 36.0 * HashUniform(seed, k, 2);
    const double y = -18.0 + 36.0 * HashUniform(seed, k, 3);
    double ground = 0.0;
    scene.dem.HeightAt(x, y, &ground);
    rock.center_in_local_m = Eigen::Vector3d(x, y, ground);
    rock.height_above_ground_m = rock.radius_m;
    scene.rocks.push_back(rock);
  }
  return scene;
}

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size() || !a.isContinuous() || !b.isContinuous()) return false;
  return std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

// The camera and pose of the determinism tests: a distorted lens tilted off nadir.
calib::CameraModel TiltedCamera() {
  return calib::CameraModel("LENSMODEL_OPENCV8", {150, 152, 63.2, 64.1, -0.05, 0.01, 0.001, -0.001, 0, 0, 0, 0},
                            128, 128);
}
Rigid3d TiltedCamFromLocal() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX())), Eigen::Vector3d::Zero()) *
         NadirCamFromLocal({1.0, -2.0, 40.0});
}

TEST(RenderFrame, DeterministicForAnyThreadCount) {
  const std::uint64_t seed = testing_support::CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const Scene scene = RoughScene(seed);
  const SceneRaycaster raycaster(scene);
  const calib::CameraModel camera = TiltedCamera();
  const Rigid3d cam_from_local = TiltedCamFromLocal();
  for (const auto mode : {RenderOptions::AntiAliasing::kCamera, RenderOptions::AntiAliasing::kQuincunx,
                          RenderOptions::AntiAliasing::kGrid}) {
    SCOPED_TRACE("mode " + std::to_string(static_cast<int>(mode)));
    RenderOptions options;
    options.anti_aliasing = mode;
    options.sun_elevation_deg = 8.0;
    options.read_noise_dn = 1.0;
    options.threads = 1;
    const RenderedFrame one = RenderFrame(raycaster, scene, camera, cam_from_local, options, 42);
    options.threads = 2;
    const RenderedFrame two = RenderFrame(raycaster, scene, camera, cam_from_local, options, 42);
    const RenderedFrame again = RenderFrame(raycaster, scene, camera, cam_from_local, options, 42);
    const RenderedFrame other_seed = RenderFrame(raycaster, scene, camera, cam_from_local, options, 43);
    EXPECT_TRUE(SameBytes(one.image, two.image));
    EXPECT_TRUE(SameBytes(one.points_in_local_m, two.points_in_local_m));
    EXPECT_TRUE(SameBytes(one.shadow_mask, two.shadow_mask));
    EXPECT_TRUE(SameBytes(one.rock_index, two.rock_index));
    EXPECT_TRUE(SameBytes(two.image, again.image));
    EXPECT_FALSE(SameBytes(two.image, other_seed.image));
    EXPECT_TRUE(SameBytes(two.points_in_local_m, other_seed.points_in_local_m));  // truth has no noise
    EXPECT_EQ(one.stats.camera_rays, two.stats.camera_rays);
    EXPECT_EQ(one.stats.shadow_rays, two.stats.shadow_rays);
    EXPECT_EQ(one.stats.split_cells, two.stats.split_cells);
    // The scene is rough enough to have cast shadows and rock pixels.
    EXPECT_GT(cv::countNonZero(one.shadow_mask == 255), 50);
    EXPECT_GT(cv::countNonZero(one.rock_index >= 0), 50);
    // Prebuilt bearings give the same frame.
    const CameraRays rays(camera, 2);
    const RenderedFrame prebuilt = RenderFrame(raycaster, scene, rays, cam_from_local, options, 42);
    EXPECT_TRUE(SameBytes(prebuilt.image, two.image));
  }
}

TEST(RenderFrame, CameraModelSplitsEdgesAndKeepsTheTruth) {
  const Scene scene = RoughScene(testing_support::CurrentTestSeed());
  const SceneRaycaster raycaster(scene);
  RenderOptions options;
  options.sun_elevation_deg = 8.0;
  const RenderedFrame camera = RenderFrame(raycaster, scene, TiltedCamera(), TiltedCamFromLocal(), options, 42);
  // Shadows and rocks split cells.
  EXPECT_GT(camera.stats.split_cells, 50);
  // The truth is the point-sampling modes' own, bit for bit.
  options.anti_aliasing = RenderOptions::AntiAliasing::kQuincunx;
  const RenderedFrame quincunx = RenderFrame(raycaster, scene, TiltedCamera(), TiltedCamFromLocal(), options, 42);
  EXPECT_EQ(quincunx.stats.split_cells, 0);
  EXPECT_TRUE(SameBytes(camera.points_in_local_m, quincunx.points_in_local_m));
  EXPECT_TRUE(SameBytes(camera.rock_index, quincunx.rock_index));
  EXPECT_TRUE(SameBytes(camera.shadow_mask, quincunx.shadow_mask));
}

TEST(PixelResponse1d, EdgeSpreadAtStatedPoints) {
  // The box alone: linear across the aperture.
  PixelResponse1d box{0.8, 0.0};
  EXPECT_DOUBLE_EQ(box.EdgeSpread(-0.4), 0.0);
  EXPECT_DOUBLE_EQ(box.EdgeSpread(0.0), 0.5);
  EXPECT_DOUBLE_EQ(box.EdgeSpread(0.2), 0.75);
  EXPECT_DOUBLE_EQ(box.EdgeSpread(1.0), 1.0);
  // Box (x) Gaussian against a numerical convolution.
  const PixelResponse1d response{1.0, 0.45};
  for (const double t : {-1.5, -0.7, -0.25, 0.0, 0.3, 0.9, 2.0}) {
    double sum = 0.0;
    const double step = 1e-4;
    for (double s = -0.5 + step / 2; s < 0.5; s += step) sum += 0.5 * std::erfc(-(t - s) / (0.45 * std::sqrt(2.0))) * step;
    EXPECT_NEAR(response.EdgeSpread(t), sum, 1e-7) << "t " << t;
  }
  EXPECT_NEAR(response.EdgeSpread(0.0), 0.5, 1e-15);
  EXPECT_NEAR(response.EdgeSpread(response.SupportRadiusPx()), 1.0, 1e-9);
  // Cells tiling the line carry the whole response.
  double total = 0.0;
  for (int k = -40; k <= 40; ++k) total += response.CellWeight(k * 0.1, 0.1);
  EXPECT_NEAR(total, 1.0, 1e-12);
  // Diffraction: 0.42 lambda N / pitch.
  EXPECT_NEAR(DiffractionSigmaPx(0.6, 5.6, 5.5), 0.42 * 0.6 * 5.6 / 5.5, 1e-15);
  RenderOptions options;
  EXPECT_NEAR(options.PsfSigmaPx(), std::hypot(0.42 * 0.6 * 5.6 / 5.5, 0.4), 1e-15);
}

TEST(FractalNoise, FilteredOctavesFollowTheGaussianTransfer) {
  // No filter: the same value, bit for bit.
  for (int k = 0; k < 50; ++k) {
    const double x = 13.7 * k, y = -4.1 * k;
    EXPECT_EQ(FractalNoise(9, x, y, 0.5, 64.0, 0.5, 0.0), FractalNoise(9, x, y, 0.5, 64.0, 0.5));
  }
  // One octave (finest = coarsest): the value times exp(-2 pi^2 (sigma / wavelength)^2).
  const double expected_factor = std::exp(-2.0 * kPi * kPi * 0.1 * 0.1);
  EXPECT_NEAR(FractalNoise(9, 3.3, 1.2, 1.0, 1.0, 0.5, 0.1), expected_factor * FractalNoise(9, 3.3, 1.2, 1.0, 1.0, 0.5),
              1e-12);
  // A wide filter leaves the mean (0) only.
  EXPECT_EQ(FractalNoise(9, 3.3, 1.2, 0.5, 64.0, 0.5, 1000.0), 0.0);
}

// ValueNoise keeps the lattice values of each layer's last cell per thread.
// Whatever was called before, a value is the one a thread that never called
// it gives: neighbouring points share cells, two seeds alternate on the same
// cell, and layer 40 is past the layers kept.
TEST(ValueNoise, AValueDoesNotDependOnTheCallsBeforeIt) {
  struct Call {
    std::uint64_t seed;
    int layer;
    double x, y;
  };
  std::vector<Call> calls;
  for (int k = 0; k < 60; ++k) {
    const double x = 0.37 * k, y = 2.0 - 0.11 * k;
    calls.push_back({7, k % 3, x, y});
    calls.push_back({8, k % 3, x, y});
    calls.push_back({7, 40, x, y});
  }
  for (const Call& call : calls) {
    double cold = 0.0;
    std::thread([&] { cold = ValueNoise(call.seed, call.layer, call.x, call.y); }).join();
    EXPECT_EQ(ValueNoise(call.seed, call.layer, call.x, call.y), cold) << call.seed << " " << call.layer << " " << call.x;
  }
}

TEST(Heightfield, MeanNormalOfAPlaneIsItsNormal) {
  const Scene scene = MakeScene(41, 41, 0.5, -10.0, 10.0, [](double x, double y) { return 0.3 * x - 0.1 * y + 2.0; });
  const Eigen::Vector3d plane = Eigen::Vector3d(-0.3, 0.1, 1.0).normalized();
  Eigen::Vector3d normal;
  for (const double half_width : {0.05, 0.4, 2.0}) {
    ASSERT_TRUE(scene.dem.MeanNormalAt(1.3, -2.2, half_width, &normal));
    EXPECT_NEAR((normal - plane).norm(), 0.0, 1e-6) << half_width;
  }
  // Beyond the grid: the facet normal, as near the edge.
  ASSERT_TRUE(scene.dem.MeanNormalAt(9.9, 0.0, 1.0, &normal));
  EXPECT_NEAR((normal - plane).norm(), 0.0, 1e-6);
  EXPECT_FALSE(scene.dem.MeanNormalAt(30.0, 0.0, 1.0, &normal));
}

TEST(RenderFrame, CameraModelEdgeSpreadIsTheConfiguredResponse) {
  RenderOptions options;
  options.anti_aliasing = RenderOptions::AntiAliasing::kCamera;
  // The rendered edge-spread function of a slanted albedo step against the
  // configured response (CheckEdgeSpread): within 1 % of the step for the
  // default optics, a blurrier one and a smaller fill factor.
  const EdgeSpreadCheck check = CheckEdgeSpread(options);
  EXPECT_LT(check.max_error, 0.01);
  EXPECT_GE(check.bins.size(), 55u);
  EXPECT_NEAR(check.width_10_90_px, check.expected_width_10_90_px, 0.03);
  // Diffraction alone (sigma 0.26 px) is sharper than the lattice (0.71 px
  // spacing) resolves exactly: within 3 % (measured 2.7 %).
  options.defocus_sigma_px = 0.0;
  EXPECT_LT(CheckEdgeSpread(options).max_error, 0.03);
  options.defocus_sigma_px = 1.0;
  EXPECT_LT(CheckEdgeSpread(options).max_error, 0.01);
  options.defocus_sigma_px = 0.4;
  options.fill_factor = 0.5;
  EXPECT_LT(CheckEdgeSpread(options).max_error, 0.01);
  // Point sampling is no such camera: the same check fails by far.
  options = RenderOptions();
  options.anti_aliasing = RenderOptions::AntiAliasing::kQuincunx;
  EXPECT_GT(CheckEdgeSpread(options).max_error, 0.1);
}

TEST(RenderOptions, BadValuesGiveExactMessages) {
  EXPECT_TRUE(RenderOptions().Validate().empty());
  RenderOptions options;
  options.sun_elevation_deg = -5.0;
  EXPECT_EQ(options.Validate(), std::vector<std::string>{
                                    "sun_elevation_deg: -5 puts the sun at or below the horizon; expected in (0, 90]"});
  options = RenderOptions();
  options.sun_elevation_deg = std::nan("");
  EXPECT_EQ(options.Validate(),
            std::vector<std::string>{"sun_elevation_deg: nan is not finite; expected in (0, 90]"});
  options = RenderOptions();
  options.bit_depth = 12;
  EXPECT_EQ(options.Validate(), std::vector<std::string>{"bit_depth: 12; expected 8 or 16"});
  options = RenderOptions();
  options.threads = 0;
  EXPECT_EQ(options.Validate(), std::vector<std::string>{"threads: 0; expected >= 1"});
  options = RenderOptions();
  options.samples_per_pixel_axis = 0;
  options.read_noise_dn = -1.0;
  EXPECT_EQ(options.Validate(), (std::vector<std::string>{"samples_per_pixel_axis: 0; expected 1 to 16",
                                                          "read_noise_dn: -1; expected 0 to 65535"}));
  // The sensor noise a dataset may state: synth never writes one its loader refuses.
  options = RenderOptions();
  options.read_noise_dn = 70000.0;
  options.gain_electrons_per_dn = 2e6;
  EXPECT_EQ(options.Validate(), (std::vector<std::string>{"gain_electrons_per_dn: 2e+06; expected > 0 and at most 1e+06",
                                                          "read_noise_dn: 70000; expected 0 to 65535"}));

  // RenderFrame refuses them with every message.
  const Scene scene = MakeScene(3, 3, 1.0, 0.0, 2.0, [](double, double) { return 0.0; });
  const SceneRaycaster raycaster(scene);
  const calib::CameraModel camera = Pinhole(8, 10.0);
  options = RenderOptions();
  options.bit_depth = 12;
  options.threads = 0;
  try {
    RenderFrame(raycaster, scene, camera, NadirCamFromLocal({1, 1, 5}), options, 1);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "invalid render options: bit_depth: 12; expected 8 or 16; threads: 0; expected >= 1");
  }
  // A scene other than the raycaster's.
  const Scene copy = scene;
  EXPECT_THROW(RenderFrame(raycaster, copy, camera, NadirCamFromLocal({1, 1, 5}), RenderOptions(), 1), InputError);
}

}  // namespace
}  // namespace hdabench::datasets::synth
