#include "datasets/synth/lander_truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"

namespace hdabench::datasets::synth {

namespace {
// A contact counts as on the plane within this height (metres): the
// surface's heights are floats.
constexpr double kOnPlaneM = 1e-4;
// A square of body cells is passed whole when its bound on the clearance is
// this far under the limit (metres): far above the rounding of the bound and
// of the cells' own heights over the plane, so that no cell the square passes
// would have been over the limit.
constexpr double kTileBoundMarginM = 1e-6;

// Cell coordinates (fractional) of a point of the local x-y plane.
double ColOf(const SurfaceGrid& s, double x) { return (x - s.origin_in_local_m.x()) / s.spacing_m; }
double RowOf(const SurfaceGrid& s, double y) { return (s.origin_in_local_m.y() - y) / s.spacing_m; }
double XOf(const SurfaceGrid& s, int c) { return s.origin_in_local_m.x() + c * s.spacing_m; }
double YOf(const SurfaceGrid& s, int r) { return s.origin_in_local_m.y() - r * s.spacing_m; }

// Twice the signed area of triangle (a, b, p) seen from above: > 0 when p is
// to the left of a->b.
double Cross2(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

bool InTriangle(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c,
                const Eigen::Vector2d& p) {
  const double scale = 1e-9 * std::max(1.0, std::abs(Cross2(a, b, c)));
  const double d1 = Cross2(a, b, p), d2 = Cross2(b, c, p), d3 = Cross2(c, a, p);
  const bool has_negative = d1 < -scale || d2 < -scale || d3 < -scale;
  const bool has_positive = d1 > scale || d2 > scale || d3 > scale;
  return !(has_negative && has_positive);
}

// Whether p lies inside the convex polygon (counter-clockwise vertices).
bool InConvexPolygon(const std::vector<Eigen::Vector2d>& polygon, const Eigen::Vector2d& p) {
  for (size_t i = 0; i < polygon.size(); ++i) {
    if (Cross2(polygon[i], polygon[(i + 1) % polygon.size()], p) < 0) return false;
  }
  return true;
}

// Each row's highest value over the window of 2 * half + 1 cells centred on
// each cell, the row's ends replicated outward: the van Herk / Gil-Werman
// running maximum, three comparisons a cell whatever the window's length.
// `padded`, `ahead` and `behind` are scratch rows of cols + 2 * half cells.
void RowWindowMax(const float* row, int cols, int half, float* out, std::vector<float>* padded,
                  std::vector<float>* ahead, std::vector<float>* behind) {
  const int n = cols + 2 * half;
  const int k = 2 * half + 1;
  padded->resize(n);
  ahead->resize(n);
  behind->resize(n);
  float* x = padded->data();
  for (int i = 0; i < n; ++i) x[i] = row[std::clamp(i - half, 0, cols - 1)];
  // ahead: the maximum from each block's start to the cell; behind: from the
  // cell to its block's end (blocks of k cells from cell 0).
  for (int i = 0; i < n; ++i) (*ahead)[i] = i % k == 0 ? x[i] : std::max((*ahead)[i - 1], x[i]);
  for (int i = n - 1; i >= 0; --i) {
    (*behind)[i] = (i % k == k - 1 || i == n - 1) ? x[i] : std::max((*behind)[i + 1], x[i]);
  }
  // The window [c, c + k - 1] of the padded row holds at most one block start
  // past c: its maximum is behind[c]'s part and ahead[c + k - 1]'s.
  for (int c = 0; c < cols; ++c) out[c] = std::max((*behind)[c], (*ahead)[c + k - 1]);
}

}  // namespace

cv::Mat DiskMaximum(const cv::Mat& z, double radius_cells) {
  if (z.type() != CV_32FC1 || z.empty() || !(radius_cells >= 0) || !std::isfinite(radius_cells)) {
    throw InputError("DiskMaximum: expected a non-empty float grid and a finite radius >= 0");
  }
  const int reach = static_cast<int>(std::floor(radius_cells));
  std::vector<int> half_width(reach + 1, 0);  // per |dr|
  for (int dr = 0; dr <= reach; ++dr) {
    int w = 0;
    while (w + 1 <= reach &&
           static_cast<double>(dr) * dr + static_cast<double>(w + 1) * (w + 1) <=
               radius_cells * radius_cells + 1e-9) {
      ++w;
    }
    half_width[dr] = w;
  }
  cv::Mat out = z.clone();
  cv::Mat rows_max(z.rows, z.cols, CV_32FC1);
  for (int dr = 0; dr <= reach; ++dr) {
    const int w = half_width[dr];
    if (dr > 0 && w == half_width[dr - 1]) continue;  // made already
    // Every |dr'| whose half-width is w.
    int last = dr;
    while (last + 1 <= reach && half_width[last + 1] == w) ++last;
    util::ParallelFor("lander pad rows", z.rows, util::WorkerThreads(0), [&](int r) {
      thread_local std::vector<float> padded, ahead, behind;
      RowWindowMax(z.ptr<float>(r), z.cols, w, rows_max.ptr<float>(r), &padded, &ahead, &behind);
    });
    util::ParallelFor("lander pad rows", z.rows, util::WorkerThreads(0), [&](int r) {
      float* o = out.ptr<float>(r);
      for (int d = dr; d <= last; ++d) {
        for (const int from : {r - d, r + d}) {
          const float* m = rows_max.ptr<float>(std::clamp(from, 0, z.rows - 1));
          for (int c = 0; c < z.cols; ++c) o[c] = std::max(o[c], m[c]);
        }
      }
    });
  }
  return out;
}

std::vector<std::string> LanderGeometry::Validate() const {
  std::vector<std::string> errors;
  RequireOption(legs >= 3 && legs <= 12, "lander.legs", legs, "an integer in [3, 12]", &errors);
  RequireOption(footprint_diameter_m > 0, "lander.footprint_diameter_m", footprint_diameter_m, "> 0", &errors);
  RequireOption(pad_diameter_m >= 0, "lander.pad_diameter_m", pad_diameter_m, ">= 0", &errors);
  RequireOption(max_slope_deg > 0 && max_slope_deg <= 90, "lander.max_slope_deg", max_slope_deg, "in (0, 90]",
                &errors);
  RequireOption(body_clearance_m > 0, "lander.body_clearance_m", body_clearance_m, "> 0", &errors);
  RequireOption(yaw_step_deg > 0 && yaw_step_deg <= 360.0 / std::max(3, legs), "lander.yaw_step_deg",
                yaw_step_deg, "in (0, 360 / legs]", &errors);
  return errors;
}

SurfaceGrid SurfaceOfTruth(const Truth& truth) {
  if (!truth.dem.has_value() || truth.dem->height_in_local_m.empty()) {
    throw InputError("the dataset has no truth DEM in memory: no surface for the lander");
  }
  const TruthDem& dem = *truth.dem;
  SurfaceGrid surface;
  surface.origin_in_local_m = dem.origin_in_local_m;
  surface.spacing_m = dem.spacing_m;
  surface.height_m = dem.height_in_local_m.clone();
  cv::Mat& z = surface.height_m;
  for (const TruthRock& rock : truth.rocks) {
    const double radius = 0.5 * rock.diameter_m;
    const Eigen::Vector3d& centre = rock.center_in_local_m;
    const double top = centre.z() + radius;
    const int r0 = static_cast<int>(std::floor(RowOf(surface, centre.y() + radius)));
    const int r1 = static_cast<int>(std::ceil(RowOf(surface, centre.y() - radius)));
    const int c0 = static_cast<int>(std::floor(ColOf(surface, centre.x() - radius)));
    const int c1 = static_cast<int>(std::ceil(ColOf(surface, centre.x() + radius)));
    for (int r = std::max(0, r0); r <= std::min(z.rows - 1, r1); ++r) {
      for (int c = std::max(0, c0); c <= std::min(z.cols - 1, c1); ++c) {
        const double dx = XOf(surface, c) - centre.x();
        const double dy = YOf(surface, r) - centre.y();
        const double d2 = dx * dx + dy * dy;
        if (d2 >= radius * radius) continue;
        const double cap = centre.z() + std::sqrt(radius * radius - d2);
        float& cell = z.at<float>(r, c);
        cell = std::max(cell, static_cast<float>(cap));
      }
    }
    const int r = static_cast<int>(std::lround(RowOf(surface, centre.y())));
    const int c = static_cast<int>(std::lround(ColOf(surface, centre.x())));
    if (r >= 0 && r < z.rows && c >= 0 && c < z.cols) {
      float& cell = z.at<float>(r, c);
      cell = std::max(cell, static_cast<float>(top));
    }
  }
  return surface;
}

namespace {

// Side, cells, of the squares the body cells are grouped in for the safety
// map: the highest ground of each square bounds its cells' clearance.
constexpr int kBodyTileCells = 4;

}  // namespace

// The stencils are named outside the anonymous namespace: LanderOnSurface's
// Prepared holds them, and a unity build compiles this file as an included one.
namespace internal {

// The body cells of one kBodyTileCells square of offsets, whose top-left
// offset is `corner`.
struct BodyTile {
  cv::Point corner;  // (column, row) offset
  std::vector<cv::Point> cells;
};

// One yaw of the lander on the grid, as offsets from the centre's cell: each
// pad's cell (the cell nearest its centre) and the cells whose centres lie
// inside the pads' polygon, also grouped in squares.
struct YawStencil {
  double yaw_deg = 0.0;
  std::vector<cv::Point> pads;  // (column, row) offsets
  std::vector<cv::Point> body;
  std::vector<BodyTile> body_tiles;
  // The pad triples (i < j < k, in that order) whose triangle holds the
  // centre: the planes the lander may rest on, the same on every cell.
  std::vector<std::array<int, 3>> triangles;
};

}  // namespace internal

namespace {

using internal::BodyTile;
using internal::YawStencil;

// Most pads a lander has (LanderGeometry::Validate) and most triangles of them.
constexpr int kMaxLegs = 12;
constexpr int kMaxTriangles = kMaxLegs * (kMaxLegs - 1) * (kMaxLegs - 2) / 6;

YawStencil MakeYawStencil(double spacing_m, double yaw_deg, const LanderGeometry& lander) {
  YawStencil y;
  y.yaw_deg = yaw_deg;
  const double radius_cells = 0.5 * lander.footprint_diameter_m / spacing_m;
  std::vector<Eigen::Vector2d> corners;
  for (int i = 0; i < lander.legs; ++i) {
    const double angle = (yaw_deg + 360.0 * i / lander.legs) * util::kDegToRad;
    // Columns grow with x, rows against y.
    const cv::Point pad(static_cast<int>(std::lround(radius_cells * std::cos(angle))),
                        static_cast<int>(std::lround(-radius_cells * std::sin(angle))));
    y.pads.push_back(pad);
    corners.emplace_back(pad.x, -pad.y);  // x, y in cells, counter-clockwise
  }
  // Pads in metres from the centre, as AtYawOnCell places them.
  const int n = static_cast<int>(y.pads.size());
  std::vector<Eigen::Vector2d> pads_m;
  for (const cv::Point& q : y.pads) pads_m.emplace_back(q.x * spacing_m, -q.y * spacing_m);
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        if (InTriangle(pads_m[static_cast<size_t>(i)], pads_m[static_cast<size_t>(j)], pads_m[static_cast<size_t>(k)],
                       Eigen::Vector2d::Zero())) {
          y.triangles.push_back({i, j, k});
        }
      }
    }
  }
  const int reach = static_cast<int>(std::ceil(radius_cells)) + 1;
  for (int dr = -reach; dr <= reach; ++dr) {
    for (int dc = -reach; dc <= reach; ++dc) {
      if (InConvexPolygon(corners, Eigen::Vector2d(dc, -dr))) y.body.emplace_back(dc, dr);
    }
  }
  // The squares, in the body's order of first appearance.
  const auto tile_corner = [](int offset) {
    return offset >= 0 ? offset / kBodyTileCells * kBodyTileCells
                       : -((-offset + kBodyTileCells - 1) / kBodyTileCells) * kBodyTileCells;
  };
  // Each square's place in body_tiles, by its corner: a lookup, not a search
  // of the squares so far (a fine DEM puts a million body cells in a hundred
  // thousand squares).
  std::map<std::pair<int, int>, size_t> tile_of_corner;
  for (const cv::Point& b : y.body) {
    const cv::Point corner(tile_corner(b.x), tile_corner(b.y));
    const auto [at, added] = tile_of_corner.emplace(std::make_pair(corner.x, corner.y), y.body_tiles.size());
    if (added) y.body_tiles.push_back(BodyTile{corner, {}});
    y.body_tiles[at->second].cells.push_back(b);
  }
  return y;
}

// The yaws swept over one period of the legs.
std::vector<double> SweptYaws(const LanderGeometry& lander) {
  const double period = 360.0 / lander.legs;
  const int steps = std::max(1, static_cast<int>(std::ceil(period / lander.yaw_step_deg - 1e-9)));
  std::vector<double> yaws;
  for (int i = 0; i < steps; ++i) yaws.push_back(i * period / steps);
  return yaws;
}

// How far outside its limits a yaw is: the larger of slope / limit and
// clearance / limit (under 1: safe).
double Badness(const LandingAtYaw& a, const LanderGeometry& lander) {
  return std::max(a.slope_deg / lander.max_slope_deg, a.clearance_m / lander.body_clearance_m);
}

}  // namespace

struct LanderOnSurface::Prepared {
  SurfaceGrid surface;
  LanderGeometry lander;
  cv::Mat pad_max;   // highest surface under a pad centred on each cell
  cv::Mat body_max;  // highest surface over the square around each cell that holds every body cell
  int reach = 0;     // cells from the centre to the farthest pad or body cell, pad disk included
  std::vector<YawStencil> yaws;
};

LanderOnSurface::LanderOnSurface(const SurfaceGrid& surface, const LanderGeometry& lander)
    : p_(std::make_shared<Prepared>()) {
  hdabench::ThrowIfInvalid("the lander: ", lander.Validate());
  if (!(surface.spacing_m > 0) || surface.height_m.empty() || surface.height_m.type() != CV_32FC1) {
    throw InputError("the lander's surface: expected a float height grid with a spacing > 0");
  }
  Prepared& p = *p_;
  p.surface = surface;
  p.lander = lander;
  for (const double yaw : SweptYaws(lander)) p.yaws.push_back(MakeYawStencil(surface.spacing_m, yaw, lander));
  // A pad's disk: the cells within its radius of the pad's cell.
  const int pad_reach = static_cast<int>(std::floor(0.5 * lander.pad_diameter_m / surface.spacing_m));
  p.pad_max = DiskMaximum(surface.height_m, 0.5 * lander.pad_diameter_m / surface.spacing_m);
  int body_reach = 0;
  for (const YawStencil& y : p.yaws) {
    for (const cv::Point& b : y.body) body_reach = std::max({body_reach, std::abs(b.x), std::abs(b.y)});
    for (const cv::Point& q : y.pads) p.reach = std::max({p.reach, std::abs(q.x) + pad_reach, std::abs(q.y) + pad_reach});
  }
  p.reach = std::max(p.reach, body_reach);
  cv::dilate(surface.height_m, p.body_max,
             cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * body_reach + 1, 2 * body_reach + 1)),
             cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
}

namespace {

// The lander at one yaw with its centre on cell (r, c), whose footprint is
// inside the grid. With `decide_only`, the clearance is computed only as far
// as the verdict needs: when the bound from body_max shows it under the
// limit, it is reported as that bound, and the cells stop at the first over
// the limit.
// With `tile_max` as well (LanderOnSurface::SafetyMap's), the body's squares are
// bounded first, and only the cells of a square whose bound reaches the limit
// are visited.
LandingAtYaw AtYawOnCell(const SurfaceGrid& s, const cv::Mat& pad_max, const cv::Mat& body_max,
                         const cv::Mat* tile_max, const YawStencil& y, const LanderGeometry& lander, int r, int c,
                         bool decide_only) {
  LandingAtYaw out;
  out.yaw_deg = y.yaw_deg;
  const int n = static_cast<int>(y.pads.size());
  const double sp = s.spacing_m;
  // Fixed arrays, not vectors: this runs for every cell and yaw of a safety map.
  std::array<Eigen::Vector3d, kMaxLegs> contacts;
  for (int i = 0; i < n; ++i) {
    const cv::Point& q = y.pads[static_cast<size_t>(i)];
    contacts[static_cast<size_t>(i)] =
        Eigen::Vector3d(q.x * sp, -q.y * sp, pad_max.at<float>(r + q.y, c + q.x));  // metres from the centre
  }
  // The planes the lander can rest on; the worst decides.
  double worst_slope = 0.0;
  std::array<Eigen::Vector3d, kMaxTriangles> normals, points;
  size_t planes = 0;
  for (const std::array<int, 3>& triangle : y.triangles) {
    const auto [i, j, k] = triangle;
    const Eigen::Vector3d& a = contacts[static_cast<size_t>(i)];
    Eigen::Vector3d normal = (contacts[static_cast<size_t>(j)] - a).cross(contacts[static_cast<size_t>(k)] - a);
    if (normal.z() < 0) normal = -normal;
    if (!(normal.z() > 0)) continue;  // a vertical plane: no rest
    normal.normalize();
    bool rests = true;
    for (int m = 0; m < n && rests; ++m) {
      if (m == i || m == j || m == k) continue;
      // Height of contact m above the plane, measured vertically.
      if (normal.dot(contacts[static_cast<size_t>(m)] - a) / normal.z() > kOnPlaneM) rests = false;
    }
    if (!rests) continue;
    worst_slope = std::max(worst_slope, std::acos(std::clamp(normal.z(), -1.0, 1.0)) * util::kRadToDeg);
    normals[planes] = normal;
    points[planes] = a;
    ++planes;
  }
  if (planes == 0) return out;  // cannot happen for a convex ring of pads; no verdict if it does
  out.defined = true;
  out.slope_deg = worst_slope;
  out.unsafe_by_slope = worst_slope > lander.max_slope_deg;
  if (decide_only) {
    if (out.unsafe_by_slope) return out;
    // Over the polygon the planes are lowest at a pad: the highest ground
    // around minus that is a bound on the clearance (measured vertically,
    // so also along the normal).
    double lowest = std::numeric_limits<double>::infinity();
    for (size_t m = 0; m < planes; ++m) {
      for (int pad = 0; pad < n; ++pad) {
        const Eigen::Vector3d& q = contacts[static_cast<size_t>(pad)];
        lowest = std::min(lowest, points[m].z() - (normals[m].x() * (q.x() - points[m].x()) +
                                                   normals[m].y() * (q.y() - points[m].y())) / normals[m].z());
      }
    }
    const double bound = double{body_max.at<float>(r, c)} - lowest;
    if (bound <= lander.body_clearance_m) {
      out.clearance_m = std::max(0.0, bound);
      return out;
    }
  }
  double clearance = 0.0;
  // The height of cell offset b over the highest plane, into clearance; true
  // once over the limit.
  const auto over_limit = [&](const cv::Point& b) {
    const Eigen::Vector3d q(b.x * sp, -b.y * sp, s.height_m.at<float>(r + b.y, c + b.x));
    for (size_t m = 0; m < planes; ++m) clearance = std::max(clearance, normals[m].dot(q - points[m]));
    return clearance > lander.body_clearance_m;
  };
  if (decide_only && tile_max != nullptr) {
    for (const BodyTile& tile : y.body_tiles) {
      // Over the square, each plane's height difference is at most its
      // highest ground against the plane at the square's corner the plane is
      // lowest. The square's top-left cell is clamped into the grid: the
      // maximum is then over a square that still holds the tile's cells.
      const double top = tile_max->at<float>(std::max(0, r + tile.corner.y), std::max(0, c + tile.corner.x));
      const double x_lo = tile.corner.x * sp;
      const double x_hi = (tile.corner.x + kBodyTileCells - 1) * sp;
      const double y_hi = -tile.corner.y * sp;
      const double y_lo = -(tile.corner.y + kBodyTileCells - 1) * sp;
      double bound = -std::numeric_limits<double>::infinity();
      for (size_t m = 0; m < planes; ++m) {
        const Eigen::Vector3d& up = normals[m];
        bound = std::max(bound, up.x() * (up.x() > 0 ? x_hi : x_lo) + up.y() * (up.y() > 0 ? y_hi : y_lo) +
                                    up.z() * top - up.dot(points[m]));
      }
      if (bound <= lander.body_clearance_m - kTileBoundMarginM) {
        clearance = std::max(clearance, bound);
        continue;
      }
      for (const cv::Point& b : tile.cells) {
        if (over_limit(b)) break;
      }
      if (clearance > lander.body_clearance_m) break;
    }
  } else {
    for (const cv::Point& b : y.body) {
      if (over_limit(b) && decide_only) break;
    }
  }
  out.clearance_m = clearance;
  out.unsafe_by_clearance = clearance > lander.body_clearance_m;
  return out;
}

}  // namespace

bool LanderOnSurface::CellOf(const Eigen::Vector2d& centre_in_local_m, int* row, int* col) const {
  const Prepared& p = *p_;
  const double rf = RowOf(p.surface, centre_in_local_m.y());
  const double cf = ColOf(p.surface, centre_in_local_m.x());
  if (!std::isfinite(rf) || !std::isfinite(cf) || std::abs(rf) > 1e9 || std::abs(cf) > 1e9) return false;
  *row = static_cast<int>(std::lround(rf));
  *col = static_cast<int>(std::lround(cf));
  return *row - p.reach >= 0 && *col - p.reach >= 0 && *row + p.reach < p.surface.height_m.rows &&
         *col + p.reach < p.surface.height_m.cols;
}

LandingVerdict LanderOnSurface::Evaluate(const Eigen::Vector2d& centre_in_local_m) const {
  int r = 0, c = 0;
  if (!CellOf(centre_in_local_m, &r, &c)) {
    LandingVerdict verdict;
    verdict.why = "the lander's footprint leaves the truth DEM";
    return verdict;
  }
  return EvaluateOnCell(r, c, false, nullptr);
}

LandingVerdict LanderOnSurface::EvaluateOnCell(int r, int c, bool decide_only, const cv::Mat* tile_max) const {
  const Prepared& p = *p_;
  const LanderGeometry& lander = p.lander;
  LandingVerdict verdict;
  bool first = true;
  LandingAtYaw best;
  for (const YawStencil& y : p.yaws) {
    const LandingAtYaw at = AtYawOnCell(p.surface, p.pad_max, p.body_max, tile_max, y, lander, r, c, decide_only);
    if (!at.defined) {
      verdict = LandingVerdict();
      verdict.why = "no landing plane under the lander";
      return verdict;
    }
    if (lander.chooses_yaw) {
      // A safe yaw is decided exactly either way; without one, the best
      // yaw needs the exact clearances.
      if (decide_only && at.Safe()) {
        verdict.defined = true;
        verdict.safe = true;
        return verdict;
      }
      if (first || Badness(at, lander) < Badness(best, lander)) best = at;
    } else {
      if (first || at.slope_deg > verdict.slope_deg) {
        verdict.slope_deg = at.slope_deg;
        verdict.yaw_deg = at.yaw_deg;
      }
      verdict.clearance_m = first ? at.clearance_m : std::max(verdict.clearance_m, at.clearance_m);
      verdict.unsafe_by_slope = verdict.unsafe_by_slope || at.unsafe_by_slope;
      verdict.unsafe_by_clearance = verdict.unsafe_by_clearance || at.unsafe_by_clearance;
      // One unsafe yaw decides for a lander that cannot choose.
      if (decide_only && at.unsafe_by_slope) break;
    }
    first = false;
  }
  if (lander.chooses_yaw && decide_only) return EvaluateOnCell(r, c, false, nullptr);
  verdict.defined = true;
  if (lander.chooses_yaw) {
    verdict.slope_deg = best.slope_deg;
    verdict.clearance_m = best.clearance_m;
    verdict.yaw_deg = best.yaw_deg;
    verdict.unsafe_by_slope = best.unsafe_by_slope;
    verdict.unsafe_by_clearance = best.unsafe_by_clearance;
  }
  verdict.safe = !verdict.unsafe_by_slope && !verdict.unsafe_by_clearance;
  return verdict;
}

cv::Mat LanderOnSurface::SafetyMap(int stride, int threads) const {
  stride = std::max(1, stride);
  const cv::Mat& z = p_->surface.height_m;
  const int rows = (z.rows + stride - 1) / stride;
  const int cols = (z.cols + stride - 1) / stride;
  const int reach = p_->reach;
  cv::Mat map(rows, cols, CV_8UC1, cv::Scalar(0));
  // The highest surface over the kBodyTileCells square whose top-left cell is
  // each cell, for AtYawOnCell's bounds.
  cv::Mat tile_max;
  cv::dilate(z, tile_max, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(kBodyTileCells, kBodyTileCells)),
             cv::Point(0, 0), 1, cv::BORDER_REPLICATE);
  // Rows on every core; each cell depends on its index only.
  util::ParallelFor("safety map rows", rows, util::WorkerThreads(threads), [&](int mr) {
    const int r = mr * stride;
    if (r - reach < 0 || r + reach >= z.rows) return;
    for (int mc = 0; mc < cols; ++mc) {
      const int c = mc * stride;
      if (c - reach < 0 || c + reach >= z.cols) continue;
      const LandingVerdict v = EvaluateOnCell(r, c, true, &tile_max);
      if (!v.defined) continue;
      map.at<unsigned char>(mr, mc) = v.safe ? 1 : (v.unsafe_by_slope ? 3 : 2);
    }
  });
  return map;
}

LandingAtYaw EvaluateLandingAtYaw(const SurfaceGrid& surface, const Eigen::Vector2d& centre_in_local_m,
                                  double yaw_deg, const LanderGeometry& lander) {
  LanderGeometry one = lander;
  one.yaw_step_deg = 360.0 / lander.legs;  // one yaw: the stencils are made for yaw_deg below
  const LanderOnSurface on(surface, one);
  int r = 0, c = 0;
  LandingAtYaw out;
  out.yaw_deg = yaw_deg;
  if (!on.CellOf(centre_in_local_m, &r, &c)) return out;
  const YawStencil y = MakeYawStencil(surface.spacing_m, yaw_deg, lander);
  return AtYawOnCell(on.p_->surface, on.p_->pad_max, on.p_->body_max, nullptr, y, lander, r, c, false);
}

LandingVerdict EvaluateLanding(const SurfaceGrid& surface, const Eigen::Vector2d& centre_in_local_m,
                               const LanderGeometry& lander) {
  return LanderOnSurface(surface, lander).Evaluate(centre_in_local_m);
}

cv::Mat SafetyMap(const SurfaceGrid& surface, const LanderGeometry& lander, int stride, int threads) {
  return LanderOnSurface(surface, lander).SafetyMap(stride, threads);
}

cv::Mat SafetyMapImage(const cv::Mat& safety_map) {
  // BGR: no verdict grey, safe green, clearance orange, slope red.
  const std::array<cv::Vec3b, 4> colours = {cv::Vec3b(128, 128, 128), cv::Vec3b(60, 160, 40),
                                            cv::Vec3b(0, 150, 255), cv::Vec3b(30, 30, 220)};
  cv::Mat image(safety_map.rows, safety_map.cols, CV_8UC3);
  for (int r = 0; r < safety_map.rows; ++r) {
    for (int c = 0; c < safety_map.cols; ++c) {
      image.at<cv::Vec3b>(r, c) = colours[std::min<int>(3, safety_map.at<unsigned char>(r, c))];
    }
  }
  return image;
}

}  // namespace hdabench::datasets::synth
