// Synthetic scenes for the tests that need real images: the novac-lateral
// preset with exact navigation (measured = true poses, exact LRF), so that a
// method's errors are its own.
#pragma once

#include <filesystem>

#include "datasets/dataset.h"
#include "datasets/synth/synth.h"
#include "datasets/synth/terrain.h"
#include "tests/support/test_support.h"

namespace hdabench::testing_support {

// novac-lateral with every navigation and LRF error set to zero, generated on
// two threads (the output does not depend on it).
inline datasets::synth::SynthOptions ExactNavLateralPreset() {
  datasets::synth::SynthOptions options = datasets::synth::SynthPreset("novac-lateral");
  options.nav_velocity_bias_mps = 0.0;
  options.nav_position_noise_m = 0.0;
  options.nav_attitude_drift_deg_per_s = 0.0;
  options.nav_attitude_noise_deg = 0.0;
  options.lrf_noise_m = 0.0;
  options.threads = 2;
  return options;
}

// The terrain preset of `options`, scaled as `hdabench synth` scales it.
inline datasets::synth::TerrainOptions TerrainOf(const datasets::synth::SynthOptions& options) {
  datasets::synth::TerrainOptions terrain = datasets::synth::TerrainPreset(options.terrain);
  datasets::synth::ScaleTerrain(options.terrain_scale, &terrain);
  return terrain;
}

// The default novac-lateral scene (1024 x 1024, or the imager given) with
// exact navigation over the paper's 2.4 s window (frames 0..6, the pair 0-6
// about 31 m apart, the only frames rendered), made once into `folder` (a
// test binary's HDABENCH_TEST_TMP) and shared (CachedDataset). Returns the
// dataset folder.
inline std::filesystem::path CachedExactNavLateralScene(const std::filesystem::path& folder,
                                                        int image_size_px = 1024) {
  const std::string name =
      image_size_px == 1024 ? "ExactNavLateral" : "ExactNavLateral" + std::to_string(image_size_px) + "px";
  return CachedDataset(folder, name, [image_size_px](const std::filesystem::path& out) {
    datasets::synth::SynthOptions options = ExactNavLateralPreset();
    options.image_size_px = image_size_px;
    options.collection_s = 2.4;
    options.frames_to_render = [](const datasets::Dataset&) { return std::vector<int>{0, 6}; };
    datasets::WriteDataset(datasets::synth::GenerateSynthDataset(options, TerrainOf(options), 1),
                           out.string());
  });
}

}  // namespace hdabench::testing_support
