// The renderer's camera model (RenderOptions::AntiAliasing::kCamera): the
// scene integrated over each pixel's light-sensitive area, blurred by the
// optics, then the sensor. See render.h for the design and
// docs/synthetic-scenes.md for its parameters and measured behaviour.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "datasets/synth/optics.h"
#include "datasets/synth/render_internal.h"
#include "tools/util/parallel_for.h"

namespace hdabench::datasets::synth::internal {

namespace {

constexpr std::int32_t kNoSurface = -2;  // the ray hits nothing
constexpr std::int32_t kTerrain = -1;    // rocks are >= 0

// Side of the square of the same area as a lattice cell (1/2 px^2), pixels.
const double kCellPx = std::sqrt(0.5);

// The sampling lattice: the pixel centres (sub-lattice A) and the pixel
// corners (sub-lattice B), a square lattice turned by 45 deg with spacing
// 1/sqrt(2) px, over the imager grown by margin_px on each side (the pixel
// response reaches beyond the pixel). A point's cell is the diamond
// |dx| + |dy| <= 1/2 around it. A(i, j) is at image position (i - margin,
// j - margin); B(i, j) at (i - margin - 1/2, j - margin - 1/2). The diagonal
// neighbours of A(i, j) are B(i, j), B(i + 1, j), B(i, j + 1), B(i + 1, j + 1).
struct SubLattice {
  SubLattice(int cols_in, int rows_in, double offset_px)
      : cols(cols_in),
        rows(rows_in),
        offset(offset_px),
        radiance(static_cast<size_t>(cols_in) * rows_in, 0.0f),
        lit_direct(static_cast<size_t>(cols_in) * rows_in, 0.0f),
        ambient(static_cast<size_t>(cols_in) * rows_in, 0.0f),
        surface(static_cast<size_t>(cols_in) * rows_in, kNoSurface),
        blocked(static_cast<size_t>(cols_in) * rows_in, 0),
        split(static_cast<size_t>(cols_in) * rows_in, 0) {}
  double X(int i) const { return i + offset; }
  double Y(int j) const { return j + offset; }
  size_t Index(int i, int j) const { return static_cast<size_t>(j) * cols + i; }

  const int cols;
  const int rows;
  const double offset;                    // image position of point (0, 0), both axes
  std::vector<float> radiance;            // reflectance (I/F, with the fill light) averaged over the cell
  std::vector<float> lit_direct;          // its direct part were the sun not hidden (CellSample)
  std::vector<float> ambient;             // its fill-light part
  std::vector<std::int32_t> surface;      // kNoSurface, kTerrain or a rock index
  std::vector<unsigned char> blocked;     // 1 when the sun is hidden by another surface (cast shadow)
  std::vector<unsigned char> split;       // 1 when the cell is split for a discontinuity
};

struct Lattice {
  Lattice(int width, int height, int margin)
      : margin_px(margin),
        centres(width + 2 * margin, height + 2 * margin, -margin),
        corners(width + 2 * margin + 1, height + 2 * margin + 1, -margin - 0.5) {}
  const int margin_px;
  SubLattice centres;  // A
  SubLattice corners;  // B
};

// What the camera model needs of one ray: the geometry and truth shadow state
// of its hit (the facet, as the truth rasters record it) and the reflectance
// of the scene averaged over the ray's cell.
struct CellSample {
  bool hit = false;
  RayHit ray_hit;                  // point, facet normal, rock index
  unsigned char truth_shadow = 0;  // 255 cast, 128 attached (facet faces away from the sun), 0 lit
  bool blocked = false;            // the sun hidden by another surface (cast shadow)
  double reflectance = 0.0;        // cell-averaged, with the fill light
  double lit_direct = 0.0;         // the direct part were the sun not hidden (0 in attached shadow)
  double ambient = 0.0;            // the fill-light part
};

// Casts the camera ray of `bearing_in_cam` (unit, or zero: nothing) into
// sample->ray_hit; false when it hits nothing.
bool CastCameraRay(const FrameContext& frame, const Eigen::Vector3d& bearing_in_cam, CellSample* sample) {
  if (bearing_in_cam.squaredNorm() == 0.0) return false;
  const Eigen::Vector3d direction = (frame.local_from_cam * bearing_in_cam).normalized();
  sample->hit = frame.raycaster->IntersectGeometry(frame.camera_in_local, direction,
                                                   std::numeric_limits<double>::infinity(), &sample->ray_hit);
  return sample->hit;
}

// Whether another surface hides the sun from `hit` (by `shadow_mode`: a
// shadow ray from just above the facet, or the assumed state).
bool CastShadow(const FrameContext& frame, const RayHit& hit, ShadowMode shadow_mode, std::int64_t* shadow_rays) {
  if (shadow_mode != ShadowMode::kTrace) return shadow_mode == ShadowMode::kAssumeShadowed;
  ++*shadow_rays;
  return SunBlocked(frame, hit);
}

// Shades the hit of `sample` (cast by CastCameraRay along `bearing_in_cam`)
// as the scene averaged over a square cell of cell_px pixels. Terrain: the
// albedo texture and the surface normal low-passed over the cell's ground
// footprint (a Gaussian and a box of the same variance as the cell); rocks
// keep their own normal and albedo.
void ShadeHit(const FrameContext& frame, const Scene& scene, const Eigen::Vector3d& bearing_in_cam,
              double pixel_angle_rad, double cell_px, ShadowMode shadow_mode, std::int64_t* shadow_rays,
              CellSample* sample_out) {
  CellSample& sample = *sample_out;
  const RayHit& hit = sample.ray_hit;
  const Eigen::Vector3d to_camera = -(frame.local_from_cam * bearing_in_cam).normalized();
  // The cell's footprint: cell_px * angle * distance across the ray,
  // stretched by 1 / cos e along the slope; the geometric mean of the two.
  const double cos_emission_facet = hit.normal_in_local.dot(to_camera);
  const double cell_m =
      cell_px * pixel_angle_rad * hit.distance_m / std::sqrt(std::max(cos_emission_facet, 0.1));
  Eigen::Vector3d normal = hit.normal_in_local;
  double albedo = 0.0;
  if (hit.rock_index < 0) {
    const double x = hit.point_in_local_m.x();
    const double y = hit.point_in_local_m.y();
    scene.dem.MeanNormalAt(x, y, 0.5 * cell_m, &normal);
    albedo = scene.albedo.At(x, y, cell_m / std::sqrt(12.0));
  } else {
    albedo = scene.rocks[static_cast<size_t>(hit.rock_index)].albedo;
  }
  const double cos_incidence_facet = hit.normal_in_local.dot(frame.sun_in_local);
  const double cos_incidence = normal.dot(frame.sun_in_local);
  const bool cast = (cos_incidence_facet > 0.0 || cos_incidence > 0.0) &&
                    CastShadow(frame, hit, shadow_mode, shadow_rays);
  sample.truth_shadow = cos_incidence_facet <= 0.0 ? 128 : (cast ? 255 : 0);
  sample.blocked = cast;
  if (cos_incidence > 0.0) {
    const double phase_rad = std::acos(std::clamp(frame.sun_in_local.dot(to_camera), -1.0, 1.0));
    sample.lit_direct = LunarLambertReflectance(albedo, cos_incidence, normal.dot(to_camera), phase_rad);
  }
  sample.ambient = frame.ambient_reflectance * albedo;
  sample.reflectance = (cast ? 0.0 : sample.lit_direct) + sample.ambient;
}

// Casts the ray of `bearing_in_cam` (unit, or zero: nothing) and shades it
// for its cell (ShadeHit).
CellSample ShadeCell(const FrameContext& frame, const Scene& scene, const Eigen::Vector3d& bearing_in_cam,
                     double pixel_angle_rad, double cell_px, ShadowMode shadow_mode, std::int64_t* shadow_rays) {
  CellSample sample;
  if (CastCameraRay(frame, bearing_in_cam, &sample)) {
    ShadeHit(frame, scene, bearing_in_cam, pixel_angle_rad, cell_px, shadow_mode, shadow_rays, &sample);
  }
  return sample;
}

// The shadow mode of a ray through image point (x, y): from the truth shadow
// mask of the 4 x 4 pixel centres around it.
ShadowMode ShadowModeAt(const cv::Mat& shadow_mask, double x_px, double y_px) {
  const int col = static_cast<int>(std::floor(x_px));
  const int row = static_cast<int>(std::floor(y_px));
  return ShadowModeOfBox(shadow_mask, row - 1, row + 2, col - 1, col + 2);
}

// Where a ray from `origin` along unit `direction` meets the terrain near
// hit->point_in_local_m, a point of the surface whose triangle's normal is
// hit->normal_in_local: the ray meets that plane, the point found there is
// brought onto the surface (straight up or down) with its own triangle's
// plane, and so on, until the point lies on the plane it was found on: the
// ray's intersection with that triangle. Without a surface in front of it
// (as when the rays around it meet the same terrain), that is the ray's hit.
// False when the steps do not settle in kSettleSteps, or the ray meets a
// plane edge-on or from behind.
constexpr int kSettleSteps = 4;
bool SettleOnTerrain(const Heightfield& dem, const Eigen::Vector3d& origin, const Eigen::Vector3d& direction,
                     RayHit* hit) {
  for (int step = 0; step < kSettleSteps; ++step) {
    const double approach = hit->normal_in_local.dot(direction);
    const double offset = hit->normal_in_local.dot(hit->point_in_local_m - origin);
    if (!(approach < 0.0) || !(offset < 0.0)) return false;
    const Eigen::Vector3d point = origin + (offset / approach) * direction;
    double ground_m;
    Eigen::Vector3d normal;
    if (!dem.HeightAt(point.x(), point.y(), &ground_m) || !dem.NormalAt(point.x(), point.y(), &normal)) return false;
    const bool settled = normal == hit->normal_in_local && std::abs(point.z() - ground_m) <= 1e-9;
    hit->point_in_local_m = Eigen::Vector3d(point.x(), point.y(), ground_m);
    hit->normal_in_local = normal;
    if (settled) {
      hit->distance_m = offset / approach;
      return true;
    }
  }
  return false;
}

// Per-row counters, each written by the worker of that row only.
struct RowCounters {
  explicit RowCounters(int rows)
      : camera_rays(static_cast<size_t>(rows), 0), shadow_rays(static_cast<size_t>(rows), 0),
        split_cells(static_cast<size_t>(rows), 0) {}
  std::vector<std::int64_t> camera_rays;
  std::vector<std::int64_t> shadow_rays;
  std::vector<std::int64_t> split_cells;
};

void Record(const CellSample& sample, size_t index, SubLattice* lattice) {
  lattice->radiance[index] = static_cast<float>(sample.reflectance);
  lattice->lit_direct[index] = static_cast<float>(sample.lit_direct);
  lattice->ambient[index] = static_cast<float>(sample.ambient);
  lattice->surface[index] = sample.hit ? (sample.ray_hit.rock_index >= 0 ? sample.ray_hit.rock_index : kTerrain)
                                       : kNoSurface;
  lattice->blocked[index] = sample.blocked ? 1 : 0;
}

// Pass 1: the pixel centres, each with its own shadow ray: the truth rasters
// and the in-image points of sub-lattice A.
void TraceCentres(const FrameContext& context, const Scene& scene, const CameraRays& rays, int threads,
                  const FrameProgress& progress, Lattice* lattice, RowCounters* counters, RenderedFrame* frame) {
  const int width = rays.WidthPx();
  const int height = rays.HeightPx();
  const int margin = lattice->margin_px;
  util::ParallelFor(
      "render rows", height, threads,
      [&](int row) {
        std::int64_t row_shadow_rays = 0;
        auto* points = frame->points_in_local_m.ptr<cv::Vec3f>(row);
        auto* mask = frame->shadow_mask.ptr<unsigned char>(row);
        auto* rock = frame->rock_index.ptr<std::int32_t>(row);
        for (int col = 0; col < width; ++col) {
          double pixel_angle_rad = 0.0;
          rays.BearingAt(col, row, &pixel_angle_rad);
          // The truth ray: the exact unprojection of the centre.
          const CellSample sample = ShadeCell(context, scene, rays.CentreBearing(row, col), pixel_angle_rad, kCellPx,
                                              ShadowMode::kTrace, &row_shadow_rays);
          if (sample.hit) {
            const Eigen::Vector3f p = sample.ray_hit.point_in_local_m.cast<float>();
            points[col] = cv::Vec3f(p.x(), p.y(), p.z());
          } else {
            const float nan = std::numeric_limits<float>::quiet_NaN();
            points[col] = cv::Vec3f(nan, nan, nan);
          }
          mask[col] = sample.truth_shadow;
          rock[col] = sample.hit ? sample.ray_hit.rock_index : -1;
          Record(sample, lattice->centres.Index(col + margin, row + margin), &lattice->centres);
        }
        counters->camera_rays[static_cast<size_t>(row + margin)] += width;
        counters->shadow_rays[static_cast<size_t>(row + margin)] += row_shadow_rays;
      },
      [&](int rows_done) {
        if (progress && rows_done % 16 == 0) progress(0.3 * rows_done / height);
      });
}

// Pass 2: the corners and the margin's centres; shadow rays only where the
// pixel centres around a point disagree (pass 1 is complete). Row j covers
// B row j and A row j (when it exists).
void TraceLattice(const FrameContext& context, const Scene& scene, const CameraRays& rays, int threads,
                  const cv::Mat& shadow_mask, const FrameProgress& progress, Lattice* lattice,
                  RowCounters* counters) {
  const int width = rays.WidthPx();
  const int height = rays.HeightPx();
  const int margin = lattice->margin_px;
  const auto trace = [&](SubLattice* sub, int i, int j, std::int64_t* row_shadow_rays) {
    const double x = sub->X(i);
    const double y = sub->Y(j);
    double pixel_angle_rad = 0.0;
    const Eigen::Vector3d bearing = rays.BearingAt(x, y, &pixel_angle_rad);
    Record(ShadeCell(context, scene, bearing, pixel_angle_rad, kCellPx, ShadowModeAt(shadow_mask, x, y),
                     row_shadow_rays),
           sub->Index(i, j), sub);
  };
  const int rows = lattice->corners.rows;
  util::ParallelFor(
      "render rows", rows, threads,
      [&](int j) {
        std::int64_t row_camera_rays = 0;
        std::int64_t row_shadow_rays = 0;
        for (int i = 0; i < lattice->corners.cols; ++i, ++row_camera_rays) {
          trace(&lattice->corners, i, j, &row_shadow_rays);
        }
        if (j < lattice->centres.rows) {
          const bool image_row = j >= margin && j < height + margin;
          for (int i = 0; i < lattice->centres.cols; ++i) {
            if (image_row && i >= margin && i < width + margin) continue;  // pass 1's
            trace(&lattice->centres, i, j, &row_shadow_rays);
            ++row_camera_rays;
          }
        }
        counters->camera_rays[static_cast<size_t>(j)] += row_camera_rays;
        counters->shadow_rays[static_cast<size_t>(j)] += row_shadow_rays;
      },
      [&](int rows_done) {
        if (progress && rows_done % 16 == 0) progress(0.3 + 0.4 * rows_done / rows);
      });
}

// How a cell's point and a neighbour's differ: kSurfaceEdge when they see
// another surface (terrain, a rock, another rock, nothing), kShadowEdge when
// they see terrain both and another cast-shadow state.
constexpr unsigned char kNoEdge = 0;
constexpr unsigned char kSurfaceEdge = 1;
constexpr unsigned char kShadowEdge = 2;

unsigned char EdgeBetween(const SubLattice& a, size_t ia, const SubLattice& b, size_t ib) {
  if (a.surface[ia] != b.surface[ib]) return kSurfaceEdge;
  if (a.blocked[ia] != b.blocked[ib]) return a.surface[ia] == kTerrain ? kShadowEdge : kSurfaceEdge;
  return kNoEdge;
}

// Pass 3: marks the cells with a discontinuity toward one of their four
// diagonal neighbours, kSurfaceEdge over kShadowEdge (reads pass 2's values
// only; row j writes the marks of A row j and B row j).
void MarkSplitCells(const RenderOptions& options, Lattice* lattice) {
  SubLattice& a = lattice->centres;
  SubLattice& b = lattice->corners;
  util::ParallelFor("render rows", b.rows, options.threads, [&](int j) {
    if (j < a.rows) {
      for (int i = 0; i < a.cols; ++i) {
        const size_t index = a.Index(i, j);
        unsigned char edge = kNoEdge;
        for (const size_t neighbour : {b.Index(i, j), b.Index(i + 1, j), b.Index(i, j + 1), b.Index(i + 1, j + 1)}) {
          edge = std::max(edge, EdgeBetween(a, index, b, neighbour));
        }
        a.split[index] = edge;
      }
    }
    for (int i = 0; i < b.cols; ++i) {
      const size_t index = b.Index(i, j);
      unsigned char edge = kNoEdge;
      for (int dj = -1; dj <= 0; ++dj) {
        for (int di = -1; di <= 0; ++di) {
          const int ai = i + di;
          const int aj = j + dj;
          if (ai < 0 || aj < 0 || ai >= a.cols || aj >= a.rows) continue;
          edge = std::max(edge, EdgeBetween(b, index, a, a.Index(ai, aj)));
        }
      }
      b.split[index] = edge;
    }
  });
}

// Pass 4: each marked cell becomes the mean of m x m rays over its diamond
// (a grid along its diagonals); row j writes A row j and B row j. A ray that
// meets the terrain where the cell's own point did keeps the cell's
// low-passed shading (its albedo and normal are the cell's average already)
// with its own cast-shadow state; any other ray is shaded for its sub-cell.
// A cell split for a shadow edge alone (it and its neighbours see terrain)
// casts one camera ray, its own point's: each sub-ray is settled on the
// terrain from that hit (SettleOnTerrain), cast only where it does not
// settle, and asks the sun from its own point.
void SplitCells(const FrameContext& context, const Scene& scene, const CameraRays& rays,
                const RenderOptions& options, const cv::Mat& shadow_mask, const FrameProgress& progress,
                Lattice* lattice, RowCounters* counters) {
  const int m = options.adaptive_samples_per_cell_axis;
  const double sub_cell_px = kCellPx / m;
  const auto split_row = [&](SubLattice* sub, int j, std::int64_t* camera_rays, std::int64_t* shadow_rays,
                             std::int64_t* split_cells) {
    for (int i = 0; i < sub->cols; ++i) {
      const size_t index = sub->Index(i, j);
      if (!sub->split[index]) continue;
      ++*split_cells;
      const double lit_direct = sub->lit_direct[index];
      const double ambient = sub->ambient[index];
      // Sub-ray k: its bearing and shadow mode; traced(k): its reflectance
      // from its own camera ray.
      const auto sub_ray = [&](int k, double* pixel_angle_rad, ShadowMode* shadow_mode) {
        const double u = (k % m + 0.5) / m - 0.5;  // along (1, 1) / 2
        const double v = (k / m + 0.5) / m - 0.5;  // along (1, -1) / 2
        const double x = sub->X(i) + 0.5 * (u + v);
        const double y = sub->Y(j) + 0.5 * (u - v);
        *shadow_mode = ShadowModeAt(shadow_mask, x, y);
        return rays.BearingAt(x, y, pixel_angle_rad);
      };
      const auto traced = [&](int k) {
        double pixel_angle_rad = 0.0;
        ShadowMode shadow_mode;
        const Eigen::Vector3d bearing = sub_ray(k, &pixel_angle_rad, &shadow_mode);
        ++*camera_rays;
        CellSample sample;
        if (!CastCameraRay(context, bearing, &sample)) return 0.0;  // nothing: no light
        if (sub->surface[index] == kTerrain && sample.ray_hit.rock_index < 0) {
          const bool cast = lit_direct > 0.0 && CastShadow(context, sample.ray_hit, shadow_mode, shadow_rays);
          return (cast ? 0.0 : lit_direct) + ambient;
        }
        ShadeHit(context, scene, bearing, pixel_angle_rad, sub_cell_px, shadow_mode, shadow_rays, &sample);
        return sample.reflectance;
      };
      // A shadow edge's sub-rays, each settled on the terrain from the cell's
      // own point (SettleOnTerrain) instead of cast; false, *sum untouched,
      // when that point's ray does not meet the terrain.
      const auto on_facet = [&](double* sum) {
        double pixel_angle_rad = 0.0;
        CellSample own;
        ++*camera_rays;
        if (!CastCameraRay(context, rays.BearingAt(sub->X(i), sub->Y(j), &pixel_angle_rad), &own) ||
            own.ray_hit.rock_index >= 0) {
          return false;
        }
        for (int k = 0; k < m * m; ++k) {
          ShadowMode shadow_mode;
          const Eigen::Vector3d direction =
              (context.local_from_cam * sub_ray(k, &pixel_angle_rad, &shadow_mode)).normalized();
          RayHit hit = own.ray_hit;
          if (!SettleOnTerrain(scene.dem, context.camera_in_local, direction, &hit)) {
            *sum += traced(k);
            continue;
          }
          const bool cast = CastShadow(context, hit, shadow_mode, shadow_rays);
          *sum += (cast ? 0.0 : lit_direct) + ambient;
        }
        return true;
      };
      double sum = 0.0;
      if (sub->split[index] == kShadowEdge && lit_direct <= 0.0) {
        sum = m * m * ambient;  // no direct light to hide
      } else if (sub->split[index] != kShadowEdge || !on_facet(&sum)) {
        for (int k = 0; k < m * m; ++k) sum += traced(k);
      }
      sub->radiance[index] = static_cast<float>(sum / (m * m));
    }
  };
  const int rows = lattice->corners.rows;
  util::ParallelFor(
      "render rows", rows, options.threads,
      [&](int j) {
        std::int64_t camera_rays = 0, shadow_rays = 0, split_cells = 0;
        split_row(&lattice->corners, j, &camera_rays, &shadow_rays, &split_cells);
        if (j < lattice->centres.rows) split_row(&lattice->centres, j, &camera_rays, &shadow_rays, &split_cells);
        counters->camera_rays[static_cast<size_t>(j)] += camera_rays;
        counters->shadow_rays[static_cast<size_t>(j)] += shadow_rays;
        counters->split_cells[static_cast<size_t>(j)] += split_cells;
      },
      [&](int rows_done) {
        if (progress && rows_done % 16 == 0) progress(0.7 + 0.2 * rows_done / rows);
      });
}

// The pixel response as the lattice applies it: the aperture, and the
// optics' Gaussian narrowed by the variance of a cell (1/24 px^2 per axis),
// which the cell filter of every point adds back.
PixelResponse1d LatticeResponse(const RenderOptions& options) {
  const double psf_sigma_px = options.PsfSigmaPx();
  PixelResponse1d response;
  response.aperture_px = std::sqrt(options.fill_factor);
  response.sigma_px = std::sqrt(std::max(0.0, psf_sigma_px * psf_sigma_px - kCellPx * kCellPx / 12.0));
  return response;
}

// Lattice points each side of a pixel centre the response reaches.
int LatticeTaps(const RenderOptions& options) {
  return static_cast<int>(std::ceil(LatticeResponse(options).SupportRadiusPx() + 0.5));
}

// Pass 5: the pixel response, then the sensor. Each sub-lattice is a square
// grid of spacing 1 px, so its part is separable: the 1-D response density at
// the points' offsets (integers for A, half-integers for B) along x into a
// rows x width buffer, then along y; the two parts are added and normalised
// by the weights' total.
void FormPixels(const RenderOptions& options, const Lattice& lattice, int taps, std::uint64_t noise_seed,
                const FrameProgress& progress, RenderedFrame* frame) {
  const int width = frame->image.cols;
  const int height = frame->image.rows;
  const int margin = lattice.margin_px;
  const PixelResponse1d response = LatticeResponse(options);
  // Density of the response at t: its edge-spread difference over a tiny interval.
  const auto density = [&](double t) { return response.CellWeight(t, 1e-3) / 1e-3; };
  std::vector<double> weights_a(static_cast<size_t>(2 * taps + 1));  // offsets t, t = -taps..taps
  std::vector<double> weights_b(static_cast<size_t>(2 * taps + 2));  // offsets u - 1/2, u = -taps..taps+1
  double sum_a = 0.0, sum_b = 0.0;
  for (int t = -taps; t <= taps; ++t) sum_a += weights_a[static_cast<size_t>(t + taps)] = density(t);
  for (int u = -taps; u <= taps + 1; ++u) sum_b += weights_b[static_cast<size_t>(u + taps)] = density(u - 0.5);
  const double norm = sum_a * sum_a + sum_b * sum_b;
  // Along x: A rows at the A columns of each pixel, B rows likewise.
  const auto filter_x = [&](const SubLattice& sub, const std::vector<double>& weights, std::vector<double>* out) {
    out->assign(static_cast<size_t>(sub.rows) * width, 0.0);
    util::ParallelFor("render rows", sub.rows, options.threads, [&](int j) {
      const float* row = &sub.radiance[sub.Index(0, j)];
      for (int col = 0; col < width; ++col) {
        const int first = col + margin - taps;
        double sum = 0.0;
        for (size_t k = 0; k < weights.size(); ++k) sum += weights[k] * double{row[first + static_cast<int>(k)]};
        (*out)[static_cast<size_t>(j) * width + col] = sum;
      }
    });
  };
  std::vector<double> a_x, b_x;
  filter_x(lattice.centres, weights_a, &a_x);
  filter_x(lattice.corners, weights_b, &b_x);
  const double max_dn = options.bit_depth == 8 ? 255.0 : 65535.0;
  util::ParallelFor(
      "render rows", height, options.threads,
      [&](int row) {
        const int first = row + margin - taps;
        for (int col = 0; col < width; ++col) {
          double sum = 0.0;
          for (size_t k = 0; k < weights_a.size(); ++k) {
            sum += weights_a[k] * a_x[static_cast<size_t>(first + static_cast<int>(k)) * width + col];
          }
          for (size_t k = 0; k < weights_b.size(); ++k) {
            sum += weights_b[k] * b_x[static_cast<size_t>(first + static_cast<int>(k)) * width + col];
          }
          const std::uint64_t pixel_index =
              static_cast<std::uint64_t>(row) * static_cast<std::uint64_t>(width) + static_cast<std::uint64_t>(col);
          const double dn =
              SensorDn(options, frame->dn_per_reflectance * sum / norm, noise_seed, pixel_index, max_dn);
          if (options.bit_depth == 8) {
            frame->image.ptr<std::uint8_t>(row)[col] = static_cast<std::uint8_t>(dn);
          } else {
            frame->image.ptr<std::uint16_t>(row)[col] = static_cast<std::uint16_t>(dn);
          }
        }
      },
      [&](int rows_done) {
        if (progress && rows_done % 16 == 0) progress(0.9 + 0.1 * rows_done / height);
      });
}

}  // namespace

void RenderCameraModel(const FrameContext& context, const Scene& scene, const CameraRays& rays,
                       const RenderOptions& options, std::uint64_t noise_seed, const FrameProgress& progress,
                       RenderedFrame* frame) {
  const int taps = LatticeTaps(options);
  Lattice lattice(rays.WidthPx(), rays.HeightPx(), taps);
  RowCounters counters(lattice.corners.rows);
  TraceCentres(context, scene, rays, options.threads, progress, &lattice, &counters, frame);
  TraceLattice(context, scene, rays, options.threads, frame->shadow_mask, progress, &lattice, &counters);
  if (options.adaptive_samples_per_cell_axis > 1) {
    MarkSplitCells(options, &lattice);
    SplitCells(context, scene, rays, options, frame->shadow_mask, progress, &lattice, &counters);
  }
  FormPixels(options, lattice, taps, noise_seed, progress, frame);
  for (size_t j = 0; j < counters.camera_rays.size(); ++j) {
    frame->stats.camera_rays += counters.camera_rays[j];
    frame->stats.shadow_rays += counters.shadow_rays[j];
    frame->stats.split_cells += counters.split_cells[j];
  }
}

}  // namespace hdabench::datasets::synth::internal
