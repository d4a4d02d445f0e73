// A synthetic lunar scene: the geometry and albedo that the terrain generator
// produces and the renderer, the LRF simulator and the truth functions read.
// Frames follow docs/conventions.md: local = ENU at the ILS, z up.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace hdabench::datasets::synth {

// Terrain heights on a regular grid of nodes in the local x-y plane, north-up
// like datasets::TruthDem: node (r, c) is at
//   x = origin_x_m + c * spacing_m,   y = origin_y_m - r * spacing_m.
// The surface between nodes is two triangles per cell, split along the
// diagonal from node (r, c) to node (r+1, c+1); HeightAt, the renderer and the
// truth all use that same surface, so truth points lie exactly on it.
struct Heightfield {
  int width = 0;           // nodes along x (columns)
  int height = 0;          // nodes along y (rows)
  double origin_x_m = 0;   // x of node (0, 0), local frame
  double origin_y_m = 0;   // y of node (0, 0) (the northern edge)
  double spacing_m = 0.25;
  std::vector<float> height_m;  // row-major, height * width, local z in metres

  float At(int row, int col) const { return height_m[static_cast<size_t>(row) * width + col]; }
  // Height of the triangulated surface at (x, y); false outside the grid.
  bool HeightAt(double x_m, double y_m, double* z_m) const;
  // The same at column coordinate u = (x - origin_x_m) / spacing_m and row
  // coordinate v = (origin_y_m - y) / spacing_m (equal to rounding; cheaper).
  bool HeightAtGrid(double u, double v, double* z_m) const;
  // Upward unit normal of the triangle under (x, y); false outside the grid.
  bool NormalAt(double x_m, double y_m, Eigen::Vector3d* normal) const;
  // Upward unit normal of the surface averaged over a square of side
  // 2 * half_width_m centred on (x, y): from the mean slopes along x and y,
  // (HeightAt(x + h) - HeightAt(x - h)) / 2h and the same along y. The facet
  // normal (NormalAt) when half_width_m <= 0 or a lookup leaves the grid.
  bool MeanNormalAt(double x_m, double y_m, double half_width_m, Eigen::Vector3d* normal) const;
  double MinXM() const { return origin_x_m; }
  double MaxXM() const { return origin_x_m + (width - 1) * spacing_m; }
  double MinYM() const { return origin_y_m - (height - 1) * spacing_m; }
  double MaxYM() const { return origin_y_m; }
};

// The height of a cell's two triangles (split along the diagonal from its
// node (r, c) to (r+1, c+1)) at fractions fu along x and fv along -y of the
// cell, from its corners z00 = (r, c), z01 = (r, c+1), z10 = (r+1, c) and
// z11 = (r+1, c+1).
inline double CellSurfaceHeight(double z00, double z01, double z10, double z11, double fu, double fv) {
  return fu >= fv ? z00 + fu * (z01 - z00) + fv * (z11 - z01) : z00 + fv * (z10 - z00) + fu * (z11 - z10);
}

// A rock: a sphere partly buried in the terrain. What stands above the ground
// is a spherical cap; it blocks light and rays like any other surface.
struct Rock {
  Eigen::Vector3d center_in_local_m = Eigen::Vector3d::Zero();
  double radius_m = 0.0;         // diameter D = 2 * radius_m
  double height_above_ground_m = 0.0;  // top of the cap minus the terrain height under the centre
  float albedo = 0.12f;          // normal albedo of the rock surface
};

// Albedo of the regolith: a deterministic function of position, so that any
// ray hit gets the same value at any resolution.
struct AlbedoField {
  double mean = 0.12;            // mean normal albedo (lunar mare ~0.07-0.12, highlands ~0.2)
  double relative_variation = 0.25;  // peak-to-mean fraction of the fractal variation
  double finest_wavelength_m = 0.5;  // smallest feature of the texture, metres
  double coarsest_wavelength_m = 64.0;
  std::uint64_t seed = 1;
  // A straight albedo edge instead of the texture (the edge-spread check of
  // the renderer): mean * (1 + relative_variation) where
  // edge_normal . (x, y) > edge_offset_m, mean * (1 - relative_variation)
  // on the other side.
  bool edge = false;
  Eigen::Vector2d edge_normal = Eigen::Vector2d::UnitX();  // unit
  double edge_offset_m = 0.0;
  // Albedo at (x, y) in the local frame; always in (0, 1]. filter_sigma_m >
  // 0: the albedo seen through a Gaussian low-pass of that standard deviation
  // on the ground (the renderer's prefilter; FractalNoise's filter for the
  // texture, the exact Gaussian-blurred step for the edge).
  double At(double x_m, double y_m, double filter_sigma_m = 0.0) const;
};

struct Crater {
  Eigen::Vector2d center_in_local_m = Eigen::Vector2d::Zero();
  double diameter_m = 0.0;
  double depth_m = 0.0;          // floor below the pre-impact surface
};

struct Scene {
  Heightfield dem;
  std::vector<Rock> rocks;
  std::vector<Crater> craters;   // what was carved into dem (for the record)
  AlbedoField albedo;
};

}  // namespace hdabench::datasets::synth
