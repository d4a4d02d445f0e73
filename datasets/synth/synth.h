// Synthetic HDA datasets: terrain, rendering, trajectory presets, navigation
// and LRF with errors, and ground truth, assembled into a datasets::Dataset
// (docs/synthetic-scenes.md describes every parameter and its default).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "datasets/dataset.h"
#include "datasets/synth/render.h"
#include "datasets/synth/scene.h"
#include "datasets/synth/terrain.h"

namespace hdabench::datasets::synth {

// How the description of every dataset synth makes begins ("hdabench
// synthetic scene: preset ..."): what tells a scene the bench can make again
// (demo replaces only such a dataset).
inline constexpr char kSyntheticSceneDescription[] = "hdabench synthetic scene:";

enum class Motion {
  kLateral,    // constant altitude and attitude, moving sideways (across the line of sight)
  kBoresight,  // along the optical axis toward the ILS (glide slope): poorly observable
  kForward,    // constant altitude and attitude, level flight toward the ILS (north): the paper's approach
  kVertical,   // straight up at constant attitude: the truck campaign's motorized lift
};

enum class Attitude {
  kFixed,  // constant attitude: the camera keeps its pitch (every preset)
  kTrack,  // the body turns so that the optical axis points at the ILS at every instant (a camera
           // that keeps the site in the middle of its view, as the third-party oblique pairs do)
};

struct SynthOptions {
  std::string preset = "novac-lateral";  // the preset these values came from (recorded in the dataset)
  std::string terrain = "cratered";      // TerrainPreset name: mare, cratered, rocky, flank, boulders

  // Camera: the default is a square imager with mild OPENCV8 distortion.
  int image_size_px = 1024;              // imager side, pixels (the 2048 variant: 2048)
  double horizontal_fov_deg = 30.0;      // full field of view across the imager, degrees
  std::string camera_model_file;         // a .cameramodel to use instead of the default camera
  std::optional<calib::CameraModel> camera_model;  // a model already read: used instead of both

  // Trajectory, in the local frame (ENU) with the ILS at the origin. The vehicle
  // starts south of the ILS, flies with body x pointing north, and the camera
  // looks off_nadir_deg from nadir toward the north (toward the ILS).
  Motion motion = Motion::kLateral;
  Attitude attitude = Attitude::kFixed;
  double altitude_m = 400.0;             // camera height above the ILS at the start, metres
  double standoff_m = 400.0;             // horizontal distance south of the ILS at the start, metres
  double off_nadir_deg = 45.0;           // optical axis from nadir toward body x, degrees
  double speed_mps = 13.0;               // speed along the motion direction, m/s
  double collection_s = 5.0;             // image collection window, seconds
  double frame_rate_hz = 2.5;            // frames per second in the window

  // Terrain sampling.
  double dem_spacing_m = 0.0;            // DEM node spacing, metres; 0: half the ground footprint of a centre pixel
  double terrain_scale = 1.0;            // lengths of the terrain preset times this (truck: small scale)

  // Sensors: navigation as measured = truth + errors (IMU-like on the relative pose).
  double nav_rate_hz = 50.0;             // navigation samples per second
  double lrf_rate_hz = 20.0;             // LRF samples per second
  double nav_velocity_bias_mps = 0.05;   // constant velocity error (random direction), m/s: position drift
  double nav_position_noise_m = 0.02;    // white position noise per sample, 1 sigma, metres
  double nav_attitude_drift_deg_per_s = 0.002;  // gyro-bias-like attitude drift (random axis), deg/s
  double nav_attitude_noise_deg = 0.005; // white attitude noise per sample, 1 sigma, degrees
  double lrf_noise_m = 0.10;             // LRF range noise, 1 sigma, metres
  double lrf_bias_m = 0.0;               // LRF range bias, metres

  // The frames that get an image, chosen from the dataset before any is
  // rendered (its frame times, navigation and LRF are complete; no frame has
  // an image yet, every frame has its image path). Empty function: every
  // frame. The other frames keep their times, with no image and no truth
  // points; the navigation, the LRF, the DEM and the rocks are the same
  // whichever frames are rendered, and so is each rendered frame's image.
  std::function<std::vector<int>(const Dataset&)> frames_to_render;

  RenderOptions render;                  // sun, photometry, exposure, noise, bit depth
  int threads = 1;                       // worker threads for terrain and rendering (output does not depend on it)

  // Every violated constraint, one message each; empty when usable.
  std::vector<std::string> Validate() const;
};

// The default camera of the synthetic scenes: a square imager of
// image_size_px with the horizontal field of view given, LENSMODEL_OPENCV8
// with mild barrel distortion (about 1.5 px at the corners of a 1024 imager).
calib::CameraModel DefaultSynthCamera(int image_size_px, double horizontal_fov_deg);

// The named presets: novac-lateral (default), novac-forward, novac-boresight, truck, aircraft,
// helicopter.
// Throws InputError for an unknown name, listing the valid ones.
SynthOptions SynthPreset(const std::string& name);
std::vector<std::string> SynthPresetNames();

// Sets one option by name (as in docs/synthetic-scenes.md, e.g. "speed_mps",
// "render.sun_elevation_deg", "terrain.rock_k"): `terrain_options` receives the
// terrain.* fields. Throws InputError naming the key or the value when unknown
// or unparsable.
void ApplyOverride(const std::string& key, const std::string& value, SynthOptions* options,
                   TerrainOptions* terrain_options);

// Multiplies every length of a terrain preset by `scale` (relief, wavelengths,
// crater and rock diameters) and rescales the power-law densities so a scene
// looks the same at the new scale: N'(>=D) = k s^(-r-2) D^r per square metre.
void ScaleTerrain(double scale, TerrainOptions* terrain);

// Progress of GenerateSynthDataset: a stage name and the fraction done in it.
using SynthProgress = std::function<void(const std::string& stage, double fraction)>;

struct SynthSummary {
  int frames = 0;
  std::vector<int> rendered_frames;  // the frames with an image
  int rocks = 0;
  int craters = 0;
  double dem_spacing_m = 0.0;
  int dem_width = 0;
  int dem_height = 0;
  double terrain_s = 0.0;
  double render_s = 0.0;           // every rendered frame
  double pair_baseline_m = 0.0;          // true baseline between frames pair_frames
  std::pair<int, int> pair_frames{0, 0}; // the pair whose true baseline is closest to 30 m (scaled for truck/aircraft by range)
  std::string Summary() const;           // one line
};

// Generates the dataset in memory: the scene, every frame rendered, truth
// points, DEM, rocks and true navigation, measured navigation and LRF.
// `terrain_options` is the terrain preset after overrides; its extent is set
// here from the cameras' footprint. Deterministic for a seed, whatever
// `options.threads`. Throws InputError for invalid options or geometry (a
// camera that sees no terrain, a footprint too large for the DEM spacing).
Dataset GenerateSynthDataset(const SynthOptions& options, const TerrainOptions& terrain_options,
                             std::uint64_t seed, const SynthProgress& progress = {},
                             SynthSummary* summary = nullptr);

}  // namespace hdabench::datasets::synth
