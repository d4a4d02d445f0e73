// Ray casting against a synthetic Scene: the triangulated heightfield and the
// rocks standing on it. Frames follow docs/conventions.md: local = ENU, z up,
// metres.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "datasets/synth/scene.h"

namespace hdabench::datasets::synth {

// The nearest surface a ray meets.
struct RayHit {
  double distance_m = 0.0;  // along the unit direction, from the ray origin
  Eigen::Vector3d point_in_local_m = Eigen::Vector3d::Zero();
  // Unit surface normal at the hit. Terrain: the upward normal of the hit
  // triangle (as Heightfield::NormalAt). Rock: the outward sphere normal.
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();
  double albedo = 0.0;   // normal albedo at the hit: AlbedoField::At or Rock::albedo
  int rock_index = -1;   // index into Scene::rocks; -1 = terrain
};

// Exact ray intersection with a Scene.
//
// Terrain: the same surface as Heightfield::HeightAt, i.e. two triangles per
// cell split along the diagonal (r, c) -> (r+1, c+1). Triangles are found
// through a min/max-height pyramid over blocks of kBlock x kBlock cells per
// level (a "max mipmap" with branching factor kBlock): each level is walked
// with a 2-D DDA restricted to the part of the ray whose height lies inside the
// block's [min, max] height range, and only blocks the ray can touch are
// descended into; the cells found are intersected exactly (plane of each
// triangle, then an inside test on the triangle's footprint).
//
// Rocks: spheres; a point of a sphere counts as a surface only where it is at
// or above the terrain under it (the buried part is hidden). A ray that enters
// a sphere above ground therefore hits the rock first; a ray that enters it
// below ground has already hit the terrain. Rocks are found through a uniform
// 2-D grid over the xy bounds of the spheres, walked with the same DDA and
// pruned by the height range of the rocks in each grid cell.
//
// The scene is the DEM's xy extent: a ray that leaves it misses, and terrain or
// rock points outside it are never hit.
//
// Lifetime: the raycaster keeps a reference to `scene`; the scene must outlive
// it and must not change while it exists (the pyramid and the rock grid are
// built from it in the constructor). All const member functions are
// thread-safe.
class SceneRaycaster {
 public:
  // Builds the height pyramid and the rock grid: O(DEM nodes + rocks).
  // A DEM with fewer than 2 x 2 nodes or a non-positive spacing gives a
  // raycaster that never hits anything.
  explicit SceneRaycaster(const Scene& scene);

  // Nearest hit of the ray origin + t * unit_direction with 0 < t <=
  // max_distance_m (terrain or rock). Returns false, leaving *hit untouched,
  // when there is none. `unit_direction_in_local` must have unit norm (the
  // distance is measured in its units).
  bool Intersect(const Eigen::Vector3d& origin_in_local, const Eigen::Vector3d& unit_direction_in_local,
                 double max_distance_m, RayHit* hit) const;

  // The same without the albedo (hit->albedo is set to 0): evaluating the
  // regolith albedo field costs about as much as the intersection itself.
  bool IntersectGeometry(const Eigen::Vector3d& origin_in_local, const Eigen::Vector3d& unit_direction_in_local,
                         double max_distance_m, RayHit* hit) const;

  // Whether anything lies on the ray for 0 < t <= max_distance_m (any hit, not
  // the nearest: cheaper). For shadow rays, start at the lit point moved by
  // kShadowRayOffsetM along its surface normal so that the surface the ray
  // leaves is not hit again through rounding ("shadow acne").
  bool Occluded(const Eigen::Vector3d& origin_in_local, const Eigen::Vector3d& unit_direction_in_local,
                double max_distance_m) const;
  // The same for the rocks alone (the renderer takes the terrain's part from
  // TerrainShadows).
  bool OccludedByRocks(const Eigen::Vector3d& origin_in_local, const Eigen::Vector3d& unit_direction_in_local,
                       double max_distance_m) const;

  const Scene& GetScene() const { return scene_; }

  // Offset of a shadow ray's origin along the surface normal, metres. Hit
  // points are accurate to ~1e-12 m relative to scene coordinates of a few km;
  // 0.1 mm is far above that and far below any feature the renderer resolves.
  static constexpr double kShadowRayOffsetM = 1e-4;
  // Cells per block side at each pyramid level.
  static constexpr int kBlock = 4;

 private:
  struct Level {
    int cols = 0;                 // blocks along x
    int rows = 0;                 // blocks along y
    int cells_per_block = 1;      // kBlock^level, in DEM cells
    std::vector<float> min_z_m;   // rows * cols
    std::vector<float> max_z_m;
  };
  struct RockCell {
    float min_z_m = 0.0f;  // lowest visible rock point in the cell (terrain min under the rocks)
    float max_z_m = 0.0f;  // highest rock top in the cell
  };
  struct RayState;

  bool IntersectImpl(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double max_distance_m,
                     bool with_albedo, RayHit* hit) const;
  bool MakeRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction, double t_max,
               RayState* ray) const;
  bool TerrainHit(const RayState& ray, double* t_hit, int* cell_row, int* cell_col) const;
  bool TerrainLevel(const RayState& ray, int level, int block_row, int block_col, double t_in,
                    double t_out, double* t_hit, int* cell_row, int* cell_col) const;
  bool CellHit(const RayState& ray, int row, int col, double* t_hit) const;
  bool RockHit(const RayState& ray, double t_max, bool any_hit, double* t_hit, int* rock_index) const;
  bool RockSurfaceHit(const RayState& ray, const Rock& rock, double t_max, double* t_hit) const;

  const Scene& scene_;
  bool valid_ = false;
  int cells_x_ = 0;  // DEM cells along x (width - 1)
  int cells_y_ = 0;  // DEM cells along y (height - 1)
  double terrain_min_z_m_ = 0.0;
  double terrain_max_z_m_ = 0.0;
  std::vector<Level> levels_;  // levels_[0]: blocks of kBlock cells; last: a single block or a few

  // Rock grid in DEM-cell units: cell (r, c) covers DEM cells
  // [c * rock_cell_cells_, (c + 1) * rock_cell_cells_) along x, same along y.
  double rock_cell_cells_ = 1.0;
  int rock_cols_ = 0;
  int rock_rows_ = 0;
  double rocks_max_z_m_ = 0.0;
  std::vector<RockCell> rock_cells_;
  std::vector<std::uint32_t> rock_cell_offsets_;  // CSR: rock_rows_ * rock_cols_ + 1
  std::vector<std::uint32_t> rock_cell_indices_;
};

}  // namespace hdabench::datasets::synth
