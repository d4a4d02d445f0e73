#include "datasets/synth/raycast.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hdabench::datasets::synth {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// Slack on the barycentric-like footprint tests, in cell units: a ray through a
// shared edge or corner must hit one of the cells around it despite rounding.
constexpr double kFootprintSlack = 1e-9;
// Slack on the height-range pruning, metres: block ranges are exact node
// heights, the ray's height at a t is rounded.
constexpr double kHeightSlackM = 1e-6;

// floor(x) as an int, for x within the range of int: what
// static_cast<int>(std::floor(x)) gives, without the call to floor() that
// baseline x86-64 makes of it.
inline int FloorToInt(double x) {
  const int truncated = static_cast<int>(x);
  return x < truncated ? truncated - 1 : truncated;
}

// The t-range where z0 + dz * t lies in [z_lo, z_hi], intersected with
// [*t_in, *t_out]; false when empty. `inv_dz` is 1 / dz.
bool ClipToHeightRange(double z0, double dz, double inv_dz, double z_lo, double z_hi, double* t_in,
                       double* t_out) {
  if (dz == 0.0) return z0 >= z_lo && z0 <= z_hi && *t_in <= *t_out;
  const double inv = inv_dz;
  double ta = (z_lo - z0) * inv;
  double tb = (z_hi - z0) * inv;
  if (ta > tb) std::swap(ta, tb);
  *t_in = std::max(*t_in, ta);
  *t_out = std::min(*t_out, tb);
  return *t_in <= *t_out;
}

// The t-range where the ray's (u, v) lies in [0, u_max] x [0, v_max].
bool ClipToBox(double u0, double du, double v0, double dv, double u_max, double v_max, double* t_in,
               double* t_out) {
  const auto clip = [&](double p0, double dp, double p_max) {
    if (dp == 0.0) return p0 >= 0.0 && p0 <= p_max;
    const double inv = 1.0 / dp;
    double ta = (0.0 - p0) * inv;
    double tb = (p_max - p0) * inv;
    if (ta > tb) std::swap(ta, tb);
    *t_in = std::max(*t_in, ta);
    *t_out = std::min(*t_out, tb);
    return true;
  };
  if (!clip(u0, du, u_max) || !clip(v0, dv, v_max)) return false;
  return *t_in <= *t_out;
}

}  // namespace

// A ray in DEM-cell units: u(t) = u0 + du * t along columns (x), v(t) = v0 +
// dv * t along rows (-y), z(t) = z0 + dz * t in metres; t in metres.
struct SceneRaycaster::RayState {
  Eigen::Vector3d origin;
  Eigen::Vector3d direction;
  double u0, v0, z0;
  double du, dv, dz;
  double inv_du, inv_dv;  // infinite for a zero component
  double inv_dz;          // 1 / dz (infinite for zero; ClipToHeightRange does not use it then)
  double t_max;           // hits beyond are ignored
};

// 2-D DDA over a grid of square elements of side `size` (cell units) in the
// element range [c_lo, c_hi] x [r_lo, r_hi], for t in [t_in, t_out]. Calls
// visit(r, c, t_a, t_b) in ray order with the element's t-range (clipped to
// [t_in, t_out]); stops early when visit returns true and then returns true.
// `inv_size` is 1 / size when that is exact (a power of two), else 0: a
// position is then divided by size, as multiplying by a rounded inverse could
// put it in another element.
template <typename Visit>
static bool WalkGrid(double u0, double v0, double du, double dv, double inv_du, double inv_dv,
                     double size, double inv_size, int c_lo, int c_hi, int r_lo, int r_hi, double t_in,
                     double t_out, Visit&& visit) {
  // The starting element comes from the position at t_in, clamped into range:
  // t_in is on the range's boundary when the range was entered there.
  const double u_in = u0 + du * t_in;
  const double v_in = v0 + dv * t_in;
  const double u_elements = inv_size != 0.0 ? u_in * inv_size : u_in / size;
  const double v_elements = inv_size != 0.0 ? v_in * inv_size : v_in / size;
  int c = std::clamp(FloorToInt(u_elements), c_lo, c_hi);
  int r = std::clamp(FloorToInt(v_elements), r_lo, r_hi);
  const int step_c = du > 0.0 ? 1 : -1;
  const int step_r = dv > 0.0 ? 1 : -1;
  double t_next_c = du == 0.0 ? kInf : ((c + (du > 0.0 ? 1 : 0)) * size - u0) * inv_du;
  double t_next_r = dv == 0.0 ? kInf : ((r + (dv > 0.0 ? 1 : 0)) * size - v0) * inv_dv;
  const double dt_c = du == 0.0 ? kInf : size * std::abs(inv_du);
  const double dt_r = dv == 0.0 ? kInf : size * std::abs(inv_dv);
  double t = t_in;
  for (;;) {
    const double t_exit = std::min({t_next_c, t_next_r, t_out});
    if (visit(r, c, t, std::max(t, t_exit))) return true;
    if (t_exit >= t_out) return false;
    if (t_next_c < t_next_r) {
      c += step_c;
      t = t_next_c;
      t_next_c += dt_c;
      if (c < c_lo || c > c_hi) return false;
    } else {
      r += step_r;
      t = t_next_r;
      t_next_r += dt_r;
      if (r < r_lo || r > r_hi) return false;
    }
  }
}

SceneRaycaster::SceneRaycaster(const Scene& scene) : scene_(scene) {
  const Heightfield& dem = scene.dem;
  if (dem.width < 2 || dem.height < 2 || !(dem.spacing_m > 0.0) ||
      dem.height_m.size() != static_cast<size_t>(dem.width) * static_cast<size_t>(dem.height)) {
    return;
  }
  valid_ = true;
  cells_x_ = dem.width - 1;
  cells_y_ = dem.height - 1;

  // Level 0: blocks of kBlock x kBlock cells, from the node heights (a block's
  // cells reach one node past its last cell).
  Level level0;
  level0.cells_per_block = kBlock;
  level0.cols = (cells_x_ + kBlock - 1) / kBlock;
  level0.rows = (cells_y_ + kBlock - 1) / kBlock;
  level0.min_z_m.assign(static_cast<size_t>(level0.cols) * level0.rows,
                        std::numeric_limits<float>::infinity());
  level0.max_z_m.assign(level0.min_z_m.size(), -std::numeric_limits<float>::infinity());
  for (int r = 0; r < dem.height; ++r) {
    // Node row r belongs to the blocks whose cells touch it: rows of cells r-1 and r.
    const int block_r_first = std::max(0, (r - 1) / kBlock);
    const int block_r_last = std::min(level0.rows - 1, r / kBlock);
    for (int c = 0; c < dem.width; ++c) {
      const float z = dem.At(r, c);
      const int block_c_first = std::max(0, (c - 1) / kBlock);
      const int block_c_last = std::min(level0.cols - 1, c / kBlock);
      for (int br = block_r_first; br <= block_r_last; ++br) {
        for (int bc = block_c_first; bc <= block_c_last; ++bc) {
          const size_t i = static_cast<size_t>(br) * level0.cols + bc;
          level0.min_z_m[i] = std::min(level0.min_z_m[i], z);
          level0.max_z_m[i] = std::max(level0.max_z_m[i], z);
        }
      }
    }
  }
  levels_.push_back(std::move(level0));
  while (std::max(levels_.back().cols, levels_.back().rows) > kBlock) {
    const Level& child = levels_.back();
    Level parent;
    parent.cells_per_block = child.cells_per_block * kBlock;
    parent.cols = (child.cols + kBlock - 1) / kBlock;
    parent.rows = (child.rows + kBlock - 1) / kBlock;
    parent.min_z_m.assign(static_cast<size_t>(parent.cols) * parent.rows,
                          std::numeric_limits<float>::infinity());
    parent.max_z_m.assign(parent.min_z_m.size(), -std::numeric_limits<float>::infinity());
    for (int r = 0; r < child.rows; ++r) {
      for (int c = 0; c < child.cols; ++c) {
        const size_t from = static_cast<size_t>(r) * child.cols + c;
        const size_t to = static_cast<size_t>(r / kBlock) * parent.cols + c / kBlock;
        parent.min_z_m[to] = std::min(parent.min_z_m[to], child.min_z_m[from]);
        parent.max_z_m[to] = std::max(parent.max_z_m[to], child.max_z_m[from]);
      }
    }
    levels_.push_back(std::move(parent));
  }
  const Level& top_level = levels_.back();
  terrain_min_z_m_ = *std::min_element(top_level.min_z_m.begin(), top_level.min_z_m.end());
  terrain_max_z_m_ = *std::max_element(top_level.max_z_m.begin(), top_level.max_z_m.end());

  // Rock grid: square cells sized for about two rocks per cell on average,
  // never finer than 2 DEM cells nor coarser than 256.
  const std::vector<Rock>& rocks = scene.rocks;
  rocks_max_z_m_ = terrain_max_z_m_;
  if (rocks.empty()) return;
  const double area_cells = static_cast<double>(cells_x_) * cells_y_;
  rock_cell_cells_ = std::clamp(std::sqrt(2.0 * area_cells / static_cast<double>(rocks.size())), 2.0, 256.0);
  rock_cols_ = static_cast<int>(std::ceil(cells_x_ / rock_cell_cells_));
  rock_rows_ = static_cast<int>(std::ceil(cells_y_ / rock_cell_cells_));
  const size_t num_cells = static_cast<size_t>(rock_cols_) * rock_rows_;
  rock_cells_.assign(num_cells, RockCell{std::numeric_limits<float>::infinity(),
                                         -std::numeric_limits<float>::infinity()});
  // The grid cells a rock's xy bounding square covers; false when none.
  const auto cell_range = [&](const Rock& rock, int* c_lo, int* c_hi, int* r_lo, int* r_hi) {
    const double r_cells = rock.radius_m / dem.spacing_m;
    const double u = (rock.center_in_local_m.x() - dem.origin_x_m) / dem.spacing_m;
    const double v = (dem.origin_y_m - rock.center_in_local_m.y()) / dem.spacing_m;
    if (!(rock.radius_m > 0.0) || !std::isfinite(u) || !std::isfinite(v) ||
        !std::isfinite(rock.center_in_local_m.z()) || u + r_cells < 0.0 || v + r_cells < 0.0 ||
        u - r_cells > cells_x_ || v - r_cells > cells_y_) {
      return false;
    }
    *c_lo = std::clamp(static_cast<int>(std::floor((u - r_cells) / rock_cell_cells_)), 0, rock_cols_ - 1);
    *c_hi = std::clamp(static_cast<int>(std::floor((u + r_cells) / rock_cell_cells_)), 0, rock_cols_ - 1);
    *r_lo = std::clamp(static_cast<int>(std::floor((v - r_cells) / rock_cell_cells_)), 0, rock_rows_ - 1);
    *r_hi = std::clamp(static_cast<int>(std::floor((v + r_cells) / rock_cell_cells_)), 0, rock_rows_ - 1);
    return true;
  };
  std::vector<std::uint32_t> counts(num_cells + 1, 0);
  for (const Rock& rock : rocks) {
    int c_lo, c_hi, r_lo, r_hi;
    if (!cell_range(rock, &c_lo, &c_hi, &r_lo, &r_hi)) continue;
    for (int r = r_lo; r <= r_hi; ++r) {
      for (int c = c_lo; c <= c_hi; ++c) ++counts[static_cast<size_t>(r) * rock_cols_ + c];
    }
  }
  rock_cell_offsets_.assign(num_cells + 1, 0);
  for (size_t i = 0; i < num_cells; ++i) rock_cell_offsets_[i + 1] = rock_cell_offsets_[i] + counts[i];
  rock_cell_indices_.resize(rock_cell_offsets_.back());
  std::vector<std::uint32_t> fill(rock_cell_offsets_.begin(), rock_cell_offsets_.end() - 1);
  for (size_t k = 0; k < rocks.size(); ++k) {
    const Rock& rock = rocks[k];
    int c_lo, c_hi, r_lo, r_hi;
    if (!cell_range(rock, &c_lo, &c_hi, &r_lo, &r_hi)) continue;
    const auto bottom = static_cast<float>(rock.center_in_local_m.z() - rock.radius_m);
    const auto top = static_cast<float>(rock.center_in_local_m.z() + rock.radius_m);
    rocks_max_z_m_ = std::max(rocks_max_z_m_, static_cast<double>(top));
    for (int r = r_lo; r <= r_hi; ++r) {
      for (int c = c_lo; c <= c_hi; ++c) {
        const size_t i = static_cast<size_t>(r) * rock_cols_ + c;
        rock_cell_indices_[fill[i]++] = static_cast<std::uint32_t>(k);
        rock_cells_[i].min_z_m = std::min(rock_cells_[i].min_z_m, bottom);
        rock_cells_[i].max_z_m = std::max(rock_cells_[i].max_z_m, top);
      }
    }
  }
}

// Exact intersection with the two triangles of cell (row, col): the nearest
// with 0 < t <= ray.t_max whose point lies on the triangle's footprint.
bool SceneRaycaster::CellHit(const RayState& ray, int row, int col, double* t_hit) const {
  const Heightfield& dem = scene_.dem;
  const double h00 = dem.At(row, col);
  const double h01 = dem.At(row, col + 1);
  const double h10 = dem.At(row + 1, col);
  const double h11 = dem.At(row + 1, col + 1);
  // Cell-local coordinates: uu along columns, vv along rows, both in [0, 1].
  const double uu0 = ray.u0 - col;
  const double vv0 = ray.v0 - row;
  bool found = false;
  double best = ray.t_max;
  // Plane z = h00 + a * uu + b * vv of each triangle. Upper-right (uu >= vv)
  // holds node (r, c+1); lower-left (uu <= vv) holds (r+1, c).
  const double coefficients[2][2] = {{h01 - h00, h11 - h01}, {h11 - h10, h10 - h00}};
  for (int k = 0; k < 2; ++k) {
    const double a = coefficients[k][0];
    const double b = coefficients[k][1];
    const double den = ray.dz - a * ray.du - b * ray.dv;
    if (den == 0.0) continue;  // parallel to the plane
    const double t = (h00 + a * uu0 + b * vv0 - ray.z0) / den;
    if (!(t > 0.0 && t <= best)) continue;
    const double uu = uu0 + ray.du * t;
    const double vv = vv0 + ray.dv * t;
    if (uu < -kFootprintSlack || uu > 1.0 + kFootprintSlack || vv < -kFootprintSlack ||
        vv > 1.0 + kFootprintSlack) {
      continue;
    }
    const double side = k == 0 ? uu - vv : vv - uu;
    if (side < -kFootprintSlack) continue;
    best = t;
    found = true;
  }
  if (found) *t_hit = best;
  return found;
}

bool SceneRaycaster::TerrainLevel(const RayState& ray, int level, int block_row, int block_col,
                                  double t_in, double t_out, double* t_hit, int* cell_row,
                                  int* cell_col) const {
  // The children of block (block_row, block_col) of level `level`, or of the
  // whole DEM when level == size(levels_), walked in ray order.
  const int num_levels = static_cast<int>(levels_.size());
  const int child = level - 1;  // -1: DEM cells
  int child_cols, child_rows;
  double child_size;
  if (child >= 0) {
    child_cols = levels_[child].cols;
    child_rows = levels_[child].rows;
    child_size = levels_[child].cells_per_block;
  } else {
    child_cols = cells_x_;
    child_rows = cells_y_;
    child_size = 1.0;
  }
  int c_lo = 0, c_hi = child_cols - 1, r_lo = 0, r_hi = child_rows - 1;
  if (level < num_levels) {
    c_lo = block_col * kBlock;
    r_lo = block_row * kBlock;
    c_hi = std::min(c_hi, c_lo + kBlock - 1);
    r_hi = std::min(r_hi, r_lo + kBlock - 1);
  }
  // Block sides are powers of kBlock (4): their inverses are exact.
  return WalkGrid(ray.u0, ray.v0, ray.du, ray.dv, ray.inv_du, ray.inv_dv, child_size, 1.0 / child_size, c_lo,
                  c_hi, r_lo, r_hi, t_in, t_out, [&](int r, int c, double t_a, double t_b) {
                    if (child < 0) {
                      double t;
                      if (!CellHit(ray, r, c, &t)) return false;
                      *t_hit = t;
                      *cell_row = r;
                      *cell_col = c;
                      return true;
                    }
                    const Level& lv = levels_[child];
                    const size_t i = static_cast<size_t>(r) * lv.cols + c;
                    double a = t_a, b = t_b;
                    if (!ClipToHeightRange(ray.z0, ray.dz, ray.inv_dz, double{lv.min_z_m[i]} - kHeightSlackM,
                                           double{lv.max_z_m[i]} + kHeightSlackM, &a, &b)) {
                      return false;
                    }
                    return TerrainLevel(ray, child, r, c, a, b, t_hit, cell_row, cell_col);
                  });
}

bool SceneRaycaster::MakeRay(const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                             double t_max, RayState* ray) const {
  if (!valid_ || !origin.allFinite() || !direction.allFinite() || !(t_max > 0.0)) return false;
  const Heightfield& dem = scene_.dem;
  const double inv_spacing = 1.0 / dem.spacing_m;
  ray->origin = origin;
  ray->direction = direction;
  ray->u0 = (origin.x() - dem.origin_x_m) * inv_spacing;
  ray->v0 = (dem.origin_y_m - origin.y()) * inv_spacing;
  ray->z0 = origin.z();
  ray->du = direction.x() * inv_spacing;
  ray->dv = -direction.y() * inv_spacing;
  ray->dz = direction.z();
  ray->inv_du = ray->du == 0.0 ? kInf : 1.0 / ray->du;
  ray->inv_dv = ray->dv == 0.0 ? kInf : 1.0 / ray->dv;
  ray->inv_dz = ray->dz == 0.0 ? kInf : 1.0 / ray->dz;
  ray->t_max = t_max;
  return true;
}

bool SceneRaycaster::TerrainHit(const RayState& ray, double* t_hit, int* cell_row, int* cell_col) const {
  double t0 = 0.0;
  double t1 = ray.t_max;
  if (!ClipToBox(ray.u0, ray.du, ray.v0, ray.dv, cells_x_, cells_y_, &t0, &t1)) return false;
  if (!ClipToHeightRange(ray.z0, ray.dz, ray.inv_dz, terrain_min_z_m_ - kHeightSlackM,
                         terrain_max_z_m_ + kHeightSlackM, &t0, &t1)) {
    return false;
  }
  return TerrainLevel(ray, static_cast<int>(levels_.size()), 0, 0, t0, t1, t_hit, cell_row, cell_col);
}

bool SceneRaycaster::RockSurfaceHit(const RayState& ray, const Rock& rock, double t_max,
                                    double* t_hit) const {
  const Eigen::Vector3d offset = ray.origin - rock.center_in_local_m;
  const double b = ray.direction.dot(offset);
  const double c = offset.squaredNorm() - rock.radius_m * rock.radius_m;
  const double discriminant = b * b - c;
  if (discriminant < 0.0) return false;
  // Only the entry point: a ray that would leave the sphere from inside is
  // either under the ground there or started inside the rock.
  const double t = -b - std::sqrt(discriminant);
  if (!(t > 0.0 && t <= t_max)) return false;
  const Eigen::Vector3d point = ray.origin + t * ray.direction;
  double ground_m;
  if (!scene_.dem.HeightAt(point.x(), point.y(), &ground_m) || point.z() < ground_m) return false;
  *t_hit = t;
  return true;
}

bool SceneRaycaster::RockHit(const RayState& ray, double t_max, bool any_hit, double* t_hit,
                             int* rock_index) const {
  if (rock_cell_indices_.empty()) return false;
  double t0 = 0.0;
  double t1 = t_max;
  // Visible rock points are above the terrain, so above its minimum.
  if (!ClipToBox(ray.u0, ray.du, ray.v0, ray.dv, cells_x_, cells_y_, &t0, &t1) ||
      !ClipToHeightRange(ray.z0, ray.dz, ray.inv_dz, terrain_min_z_m_ - kHeightSlackM,
                         rocks_max_z_m_ + kHeightSlackM, &t0, &t1)) {
    return false;
  }
  double best = t1;
  int best_index = -1;
  WalkGrid(ray.u0, ray.v0, ray.du, ray.dv, ray.inv_du, ray.inv_dv, rock_cell_cells_, /*inv_size=*/0.0, 0,
           rock_cols_ - 1, 0, rock_rows_ - 1, t0, t1, [&](int r, int c, double t_a, double t_b) {
             const size_t i = static_cast<size_t>(r) * rock_cols_ + c;
             double a = t_a, b = t_b;
             const RockCell& cell = rock_cells_[i];
             if (ClipToHeightRange(ray.z0, ray.dz, ray.inv_dz, double{cell.min_z_m} - kHeightSlackM,
                                   double{cell.max_z_m} + kHeightSlackM, &a, &b)) {
               const std::vector<Rock>& rocks = scene_.rocks;
               for (std::uint32_t k = rock_cell_offsets_[i]; k < rock_cell_offsets_[i + 1]; ++k) {
                 const std::uint32_t index = rock_cell_indices_[k];
                 double t;
                 if (!RockSurfaceHit(ray, rocks[index], best, &t)) continue;
                 best = t;
                 best_index = static_cast<int>(index);
                 if (any_hit) return true;
               }
             }
             // Every hit whose point lies over this cell has been seen here, so
             // a hit before the cell's exit is the nearest.
             return best_index >= 0 && best <= t_b;
           });
  if (best_index < 0) return false;
  *t_hit = best;
  *rock_index = best_index;
  return true;
}

bool SceneRaycaster::Intersect(const Eigen::Vector3d& origin_in_local,
                               const Eigen::Vector3d& unit_direction_in_local, double max_distance_m,
                               RayHit* hit) const {
  return IntersectImpl(origin_in_local, unit_direction_in_local, max_distance_m, true, hit);
}

bool SceneRaycaster::IntersectGeometry(const Eigen::Vector3d& origin_in_local,
                                       const Eigen::Vector3d& unit_direction_in_local, double max_distance_m,
                                       RayHit* hit) const {
  return IntersectImpl(origin_in_local, unit_direction_in_local, max_distance_m, false, hit);
}

bool SceneRaycaster::IntersectImpl(const Eigen::Vector3d& origin_in_local,
                                   const Eigen::Vector3d& unit_direction_in_local, double max_distance_m,
                                   bool with_albedo, RayHit* hit) const {
  RayState ray;
  if (!MakeRay(origin_in_local, unit_direction_in_local, max_distance_m, &ray)) return false;
  double t_terrain = 0.0;
  int row = 0, col = 0;
  const bool terrain = TerrainHit(ray, &t_terrain, &row, &col);
  double t_rock = 0.0;
  int rock_index = -1;
  const bool rock = RockHit(ray, terrain ? t_terrain : ray.t_max, false, &t_rock, &rock_index);
  if (rock && (!terrain || t_rock < t_terrain)) {
    const Rock& r = scene_.rocks[static_cast<size_t>(rock_index)];
    hit->distance_m = t_rock;
    hit->point_in_local_m = ray.origin + t_rock * ray.direction;
    hit->normal_in_local = (hit->point_in_local_m - r.center_in_local_m) / r.radius_m;
    hit->normal_in_local.normalize();
    hit->albedo = with_albedo ? double{r.albedo} : 0.0;
    hit->rock_index = rock_index;
    return true;
  }
  if (!terrain) return false;
  const Heightfield& dem = scene_.dem;
  hit->distance_m = t_terrain;
  hit->point_in_local_m = ray.origin + t_terrain * ray.direction;
  // The hit triangle's plane z = h00 + a * uu + b * vv, uu = (x - x_c) / s,
  // vv = (y_r - y) / s: upward normal ~ (-a / s, b / s, 1).
  const double uu = ray.u0 - col + ray.du * t_terrain;
  const double vv = ray.v0 - row + ray.dv * t_terrain;
  const double h00 = dem.At(row, col);
  const double h01 = dem.At(row, col + 1);
  const double h10 = dem.At(row + 1, col);
  const double h11 = dem.At(row + 1, col + 1);
  const double a = uu >= vv ? h01 - h00 : h11 - h10;
  const double b = uu >= vv ? h11 - h01 : h10 - h00;
  hit->normal_in_local = Eigen::Vector3d(-a / dem.spacing_m, b / dem.spacing_m, 1.0).normalized();
  hit->albedo = with_albedo ? scene_.albedo.At(hit->point_in_local_m.x(), hit->point_in_local_m.y()) : 0.0;
  hit->rock_index = -1;
  return true;
}

bool SceneRaycaster::Occluded(const Eigen::Vector3d& origin_in_local,
                              const Eigen::Vector3d& unit_direction_in_local, double max_distance_m) const {
  RayState ray;
  if (!MakeRay(origin_in_local, unit_direction_in_local, max_distance_m, &ray)) return false;
  double t;
  int rock_index, row, col;
  return RockHit(ray, ray.t_max, true, &t, &rock_index) || TerrainHit(ray, &t, &row, &col);
}

bool SceneRaycaster::OccludedByRocks(const Eigen::Vector3d& origin_in_local,
                                     const Eigen::Vector3d& unit_direction_in_local, double max_distance_m) const {
  RayState ray;
  if (!MakeRay(origin_in_local, unit_direction_in_local, max_distance_m, &ray)) return false;
  double t;
  int rock_index;
  return RockHit(ray, ray.t_max, true, &t, &rock_index);
}

}  // namespace hdabench::datasets::synth
