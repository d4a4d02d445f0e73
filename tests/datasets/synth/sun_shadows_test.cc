// Tests of the terrain's shadow heights (TerrainShadows) against shadow rays
// cast through the same surface (SceneRaycaster::Occluded).
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "datasets/synth/noise.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/render.h"
#include "datasets/synth/scene.h"
#include "datasets/synth/sun_shadows.h"
#include "tests/support/test_support.h"
#include "tools/util/error.h"

namespace hdabench::datasets::synth {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// A scene of width x height nodes at `spacing_m`, node (0, 0) at (0, 0), the
// heights from z(column, row).
Scene GridScene(int width, int height, double spacing_m, const std::function<double(int, int)>& z) {
  Scene scene;
  scene.dem.width = width;
  scene.dem.height = height;
  scene.dem.spacing_m = spacing_m;
  scene.dem.height_m.resize(static_cast<size_t>(width) * height);
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) scene.dem.height_m[static_cast<size_t>(r) * width + c] = static_cast<float>(z(c, r));
  }
  return scene;
}

struct Agreement {
  int points = 0;
  int shadowed = 0;  // by the shadow rays
  int disagree = 0;
};

// Random points on the surface, raised as the renderer raises them, each
// asked of both.
Agreement Compare(const Scene& scene, const Eigen::Vector3d& sun, std::uint64_t seed, int points) {
  const SceneRaycaster raycaster(scene);
  const TerrainShadows shadows(scene.dem, sun);
  Agreement agreement;
  const Heightfield& dem = scene.dem;
  for (int i = 0; i < points; ++i) {
    const double x = dem.MinXM() + (dem.MaxXM() - dem.MinXM()) * HashUniform(seed, static_cast<std::uint64_t>(i), 1);
    const double y = dem.MinYM() + (dem.MaxYM() - dem.MinYM()) * HashUniform(seed, static_cast<std::uint64_t>(i), 2);
    double z;
    Eigen::Vector3d normal;
    if (!dem.HeightAt(x, y, &z) || !dem.NormalAt(x, y, &normal)) continue;
    const Eigen::Vector3d start = Eigen::Vector3d(x, y, z) + SceneRaycaster::kShadowRayOffsetM * normal;
    const bool ray = raycaster.Occluded(start, sun, kInfinity);
    ++agreement.points;
    agreement.shadowed += ray ? 1 : 0;
    agreement.disagree += ray != shadows.Hidden(start) ? 1 : 0;
  }
  return agreement;
}

TEST(TerrainShadows, AgreeWithShadowRaysOnARoughSurface) {
  const std::uint64_t seed = testing_support::CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  // Random heights of +-0.03 m on 0.15 m cells on a hill: at a low sun about
  // a third of the surface is in cast shadow, as on a default scene, most of
  // it cast within a few cells.
  const Scene scene = GridScene(120, 110, 0.15, [&](int c, int r) {
    return 0.06 * HashUniform(seed, static_cast<std::uint64_t>(r * 1000 + c), 3) +
           2.0 * std::exp(-((c - 60) * (c - 60) + (r - 55) * (r - 55)) / 400.0);
  });
  // Along the grid, nearly along it, and across it, at several sun heights.
  for (const double azimuth_deg : {90.0, 0.0, 93.0, 225.0, 301.0}) {
    for (const double elevation_deg : {5.0, 9.0, 30.0}) {
      SCOPED_TRACE("sun azimuth " + std::to_string(azimuth_deg) + ", elevation " + std::to_string(elevation_deg));
      const Agreement agreement = Compare(scene, SunDirectionInLocal(azimuth_deg, elevation_deg), seed, 4000);
      ASSERT_GT(agreement.points, 3500);
      if (elevation_deg < 10.0) {
        EXPECT_GT(agreement.shadowed, agreement.points / 10);
      }
      // Measured: at most 1.9 % (a sun across the grid at 5 deg), 0.6 % along
      // it; the points that disagree have their shadow cast from beyond the
      // exact steps, its edge placed by S linear between two nodes.
      EXPECT_LE(agreement.disagree, agreement.points * 3 / 100)
          << agreement.disagree << " of " << agreement.points << " points disagree (" << agreement.shadowed
          << " in shadow by the rays)";
    }
  }
}

TEST(TerrainShadows, ExactForAWallAlongTheGrid) {
  // A wall 1 m high along the rows at columns 30-31 (x = 3.0-3.1 m): with the
  // sun along the grid the nodes' shadow heights are exact, and the same
  // along the wall, so every point agrees with its shadow ray, however far
  // the shadow reaches.
  const Scene wall = GridScene(60, 40, 0.1, [](int c, int) { return c >= 30 && c <= 31 ? 1.0 : 0.0; });
  for (const double elevation_deg : {5.0, 20.0, 60.0}) {
    const Agreement agreement = Compare(wall, SunDirectionInLocal(90.0, elevation_deg), 7, 3000);
    EXPECT_GT(agreement.shadowed, 0);
    EXPECT_EQ(agreement.disagree, 0) << "elevation " << elevation_deg;
  }
}

TEST(TerrainShadows, NoShadowOutsideTheDemOrUnderAnOverheadSun) {
  const Scene scene = GridScene(20, 20, 0.5, [](int c, int) { return c == 10 ? 5.0 : 0.0; });
  const TerrainShadows low_sun(scene.dem, SunDirectionInLocal(90.0, 5.0));
  EXPECT_TRUE(low_sun.Hidden(Eigen::Vector3d(4.0, -4.0, 0.01)));     // just west of the wall
  EXPECT_FALSE(low_sun.Hidden(Eigen::Vector3d(6.0, -4.0, 0.01)));    // east of it, toward the sun
  EXPECT_FALSE(low_sun.Hidden(Eigen::Vector3d(-1.0, -4.0, 0.01)));   // off the DEM
  EXPECT_FALSE(low_sun.Hidden(Eigen::Vector3d(4.0, -4.0, 100.0)));   // high above it
  const TerrainShadows overhead(scene.dem, Eigen::Vector3d::UnitZ());
  EXPECT_FALSE(overhead.Hidden(Eigen::Vector3d(4.0, -4.0, 0.01)));
  Scene tiny = GridScene(1, 1, 0.5, [](int, int) { return 0.0; });
  const TerrainShadows none(tiny.dem, SunDirectionInLocal(90.0, 5.0));
  EXPECT_FALSE(none.Hidden(Eigen::Vector3d(0.0, 0.0, -1.0)));
}

TEST(TerrainShadows, RenderFrameRefusesShadowsOfAnotherSun) {
  const Scene scene = GridScene(20, 20, 0.5, [](int, int) { return 0.0; });
  const SceneRaycaster raycaster(scene);
  const CameraRays rays(calib::CameraModel("LENSMODEL_PINHOLE", {20.0, 20.0, 7.5, 7.5}, 16, 16));
  RenderOptions options;
  const TerrainShadows other_sun(scene.dem, SunDirectionInLocal(options.sun_azimuth_deg + 10.0, 9.0));
  const Eigen::Quaterniond down(0.0, 1.0, 0.0, 0.0);
  const Rigid3d cam_from_local(down, -(down * Eigen::Vector3d(4.5, -4.5, 20.0)));
  EXPECT_THROW(RenderFrame(raycaster, scene, rays, cam_from_local, options, 1, {}, &other_sun), InputError);
}

}  // namespace
}  // namespace hdabench::datasets::synth
