// The built-in example dataset: a small synthetic HDA run that the bench can
// make on any machine in well under a second, with images consistent with the
// navigation and truth points for every pixel.
//
// Geometry (the NOVA-C HDA case, brief "The flight method"): the vehicle flies
// east at constant altitude and attitude (plus a small attitude wobble) about
// `downrange_m` south of the ILS at the local origin; the camera looks north,
// `off_nadir_deg` off nadir, toward the ILS. The ground is the plane z = 0 with
// a procedural albedo (value noise seeded by `seed`); each pixel is the mean of
// 2 x 2 rays cast through CameraModel::Unproject onto that plane. Truth: the
// point each pixel-centre ray hits, and a flat DEM under the imaged area.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "datasets/dataset.h"

namespace hdabench::datasets {

struct ExampleDatasetOptions {
  std::uint64_t seed = 1;          // albedo texture; same seed, same bytes
  int image_size_px = 256;         // square imager, pixels
  double horizontal_fov_deg = 35.0;  // full field of view across the imager, degrees
  int num_frames = 6;              // images, evenly spaced over duration_s
  double duration_s = 2.4;         // first to last frame, seconds
  double speed_mps = 13.0;         // lateral (east) speed, m/s
  double altitude_m = 400.0;       // body origin above the ground plane, metres
  double downrange_m = 400.0;      // body origin south of the ILS, metres
  double off_nadir_deg = 45.0;     // optical axis from the body z axis toward body x, degrees
  double nav_rate_hz = 50.0;       // navigation samples per second
  double lrf_rate_hz = 20.0;       // LRF samples per second
  double margin_s = 0.1;           // nav and LRF start this long before the first frame and end this long after the last

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// Builds the example in memory (images and truth included), ready for
// WriteDataset. Deterministic: the same options give bit-identical values on
// the same build. Throws InputError naming every field out of range
// (Validate).
Dataset MakeExampleDataset(const ExampleDatasetOptions& options);
Dataset MakeExampleDataset(std::uint64_t seed);

}  // namespace hdabench::datasets
