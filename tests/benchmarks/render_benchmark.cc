// Speed of the synthetic renderer on a realistic scene: a 700 x 600 m fractal
// DEM at 0.25 m (2801 x 2401 = 6.7 M nodes) with 100k partly buried rocks,
// seen by a 1024 x 1024 camera (mild OPENCV8 distortion, 30 deg field of view)
// from 400 m altitude, 45 deg off nadir, under a 9 deg sun, with 2 x 2
// anti-aliasing and shadows. The scene is hand-made (not the terrain
// generator) so the figure measures the renderer alone.
#include <cmath>
#include <cstdint>
#include <memory>

#include <benchmark/benchmark.h>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "datasets/synth/noise.h"
#include "datasets/synth/raycast.h"
#include "datasets/synth/render.h"
#include "datasets/synth/scene.h"
#include "datasets/synth/sun_shadows.h"
#include "tools/util/angles.h"

namespace hdabench::datasets::synth {
namespace {

using util::kPi;

constexpr int kImageSizePx = 1024;

struct BenchScene {
  Scene scene;
  std::unique_ptr<SceneRaycaster> raycaster;
  std::unique_ptr<calib::CameraModel> camera;
  Rigid3d cam_from_local;
};

const BenchScene& GetBenchScene() {
  static const BenchScene* bench = [] {
    auto* b = new BenchScene;
    const std::uint64_t seed = 20240222;
    Heightfield& dem = b->scene.dem;
    dem.width = 2801;
    dem.height = 2401;
    dem.spacing_m = 0.25;
    dem.origin_x_m = -350.0;
    dem.origin_y_m = 300.0;
    dem.height_m.resize(static_cast<size_t>(dem.width) * dem.height);
    // Fractal relief, +-15 m over 256 m down to 0.5 m wavelengths.
    for (int r = 0; r < dem.height; ++r) {
      for (int c = 0; c < dem.width; ++c) {
        const double x = dem.origin_x_m + c * dem.spacing_m;
        const double y = dem.origin_y_m - r * dem.spacing_m;
        dem.height_m[static_cast<size_t>(r) * dem.width + c] =
            static_cast<float>(15.0 * FractalNoise(seed, x, y, 0.5, 256.0, 0.8));
      }
    }
    b->scene.albedo.mean = 0.12;
    b->scene.albedo.relative_variation = 0.25;
    // 100k rocks, diameters 0.2-3 m from a steep power law, 30-70% buried.
    for (std::uint64_t k = 0; k < 100000; ++k) {
      Rock rock;
      const double d_m = 0.2 * std::pow(1.0 - HashUniform(seed, k, 1) * (1.0 - std::pow(15.0, -2.5)), -1.0 / 2.5);
      rock.radius_m = d_m / 2.0;
      const double x = -349.0 + 698.0 * HashUniform(seed, k, 2);
      const double y = -299.0 + 598.0 * HashUniform(seed, k, 3);
      double ground_m = 0.0;
      dem.HeightAt(x, y, &ground_m);
      const double protrusion_m = d_m * (0.3 + 0.4 * HashUniform(seed, k, 4));
      rock.center_in_local_m = Eigen::Vector3d(x, y, ground_m + protrusion_m - rock.radius_m);
      rock.height_above_ground_m = protrusion_m;
      rock.albedo = 0.15f;
      b->scene.rocks.push_back(rock);
    }
    b->raycaster = std::make_unique<SceneRaycaster>(b->scene);
    const double focal_px = (kImageSizePx / 2.0) / std::tan(15.0 * kPi / 180.0);
    b->camera = std::make_unique<calib::CameraModel>(
        "LENSMODEL_OPENCV8",
        std::vector<double>{focal_px, focal_px, 511.5, 511.5, -0.02, 0.004, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0},
        kImageSizePx, kImageSizePx);
    // Camera 400 m south of and 400 m above the origin, looking north 45 deg
    // below the horizon: cam x = east, cam z = optical axis.
    const Eigen::Vector3d axis = Eigen::Vector3d(0.0, 1.0, -1.0).normalized();
    const Eigen::Vector3d right(1.0, 0.0, 0.0);
    Eigen::Matrix3d local_from_cam;
    local_from_cam.col(0) = right;
    local_from_cam.col(1) = axis.cross(right);
    local_from_cam.col(2) = axis;
    const Eigen::Quaterniond cam_from_local_rotation(local_from_cam.transpose());
    const Eigen::Vector3d centre(0.0, -400.0, 400.0);
    b->cam_from_local = Rigid3d(cam_from_local_rotation, -(cam_from_local_rotation * centre));
    return b;
  }();
  return *bench;
}

// One frame, bearings and the terrain's shadow heights built beforehand (as
// for a sequence); Arg = threads.
// The default pixel formation (the camera model), and point sampling
// (quincunx) for comparison.
void RenderFrame1024(benchmark::State& state, RenderOptions::AntiAliasing anti_aliasing) {
  const BenchScene& bench = GetBenchScene();
  RenderOptions options;
  options.anti_aliasing = anti_aliasing;
  options.threads = static_cast<int>(state.range(0));
  const CameraRays rays(*bench.camera, options.threads);
  const TerrainShadows shadows(bench.scene.dem,
                               SunDirectionInLocal(options.sun_azimuth_deg, options.sun_elevation_deg));
  std::uint64_t seed = 0;
  RenderStats stats;
  for (auto _ : state) {
    const RenderedFrame frame =
        RenderFrame(*bench.raycaster, bench.scene, rays, bench.cam_from_local, options, ++seed, {}, &shadows);
    stats = frame.stats;
    benchmark::DoNotOptimize(frame.image.data);
  }
  state.counters["camera_rays"] = static_cast<double>(stats.camera_rays);
  state.counters["shadow_rays"] = static_cast<double>(stats.shadow_rays);
  state.counters["split_cells"] = static_cast<double>(stats.split_cells);
}
void BM_RenderFrame1024(benchmark::State& state) { RenderFrame1024(state, RenderOptions::AntiAliasing::kCamera); }
void BM_RenderFrame1024Quincunx(benchmark::State& state) {
  RenderFrame1024(state, RenderOptions::AntiAliasing::kQuincunx);
}
BENCHMARK(BM_RenderFrame1024)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_RenderFrame1024Quincunx)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Building the bearings of a 1024 x 1024 camera (1 M libmrcal
// unprojections), once per camera; Arg = threads.
void BM_CameraRays1024(benchmark::State& state) {
  const BenchScene& bench = GetBenchScene();
  for (auto _ : state) {
    const CameraRays rays(*bench.camera, static_cast<int>(state.range(0)));
    benchmark::DoNotOptimize(&rays);
  }
}
BENCHMARK(BM_CameraRays1024)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// Building the raycaster's pyramid and rock grid over the 6.7 M-node DEM.
void BM_SceneRaycasterBuild(benchmark::State& state) {
  const BenchScene& bench = GetBenchScene();
  for (auto _ : state) {
    const SceneRaycaster raycaster(bench.scene);
    benchmark::DoNotOptimize(&raycaster);
  }
}
BENCHMARK(BM_SceneRaycasterBuild)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace hdabench::datasets::synth
