#include "datasets/synth/sun_shadows.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hdabench::datasets::synth {

namespace {

// Shadow height of a node with no terrain sunward, and what SegmentTop gives
// off the DEM: below any height a scene has, and finite, so that
// interpolating it stays a number.
constexpr float kNothingSunward = -1e30f;

}  // namespace

TerrainShadows::TerrainShadows(const Heightfield& dem, const Eigen::Vector3d& sun_in_local)
    : dem_(dem), sun_in_local_(sun_in_local) {
  if (dem.width < 2 || dem.height < 2 || !(dem.spacing_m > 0.0) ||
      dem.height_m.size() != static_cast<size_t>(dem.width) * static_cast<size_t>(dem.height)) {
    return;
  }
  const double sx = sun_in_local.x();
  const double sy = sun_in_local.y();
  const double sz = sun_in_local.z();
  if (!(std::hypot(sx, sy) > 1e-12) || !(sz > 0.0)) return;  // overhead, or not up: no cast shadow
  // Lines are columns (u) when the sun is nearer east or west, else rows (v,
  // which grows southward, against y); a step goes one line sunward and
  // drift_ positions along the line (|drift_| <= 1).
  along_columns_ = std::abs(sx) >= std::abs(sy);
  line_step_ = along_columns_ ? (sx > 0.0 ? 1 : -1) : (sy > 0.0 ? -1 : 1);
  drift_ = along_columns_ ? -sy / std::abs(sx) : sx / std::abs(sy);
  // A sun along a grid axis but for rounding (cos 90 deg is 6e-17) steps along
  // it: else a ray along the DEM's edge would leave it at once.
  if (std::abs(drift_) < 1e-12) drift_ = 0.0;
  rise_m_ = sz * dem.spacing_m / (along_columns_ ? std::abs(sx) : std::abs(sy));

  shadow_height_m_.assign(dem.height_m.size(), kNothingSunward);
  const int lines = along_columns_ ? dem.width : dem.height;
  const int positions = along_columns_ ? dem.height : dem.width;
  // The sunward line has nothing beyond it; every other node's S from the
  // next line's.
  const int first_line = line_step_ > 0 ? lines - 1 : 0;
  const auto node = [&](int line, int position) {
    const int next_line = line + line_step_;
    if (drift_ == 0.0) {
      // The step runs along a grid line, a triangle edge: it ends on the next
      // line's node, and the surface is straight between.
      const size_t next = Index(next_line, position);
      shadow_height_m_[Index(line, position)] = static_cast<float>(
          std::max(double{dem.height_m[next]}, double{shadow_height_m_[next]}) - rise_m_);
      return;
    }
    const double end = position + drift_;
    double best = along_columns_ ? SegmentTop(line, position, next_line, end, rise_m_)
                                 : SegmentTop(position, line, end, next_line, rise_m_);
    if (end >= 0.0 && end <= positions - 1) best = std::max(best, LineValue(next_line, end) - rise_m_);
    shadow_height_m_[Index(line, position)] = static_cast<float>(std::max(best, double{kNothingSunward}));
  };
  if (along_columns_) {
    // Row by row, in the memory's order: a step ends on its own row and the
    // next (drift >= 0; the rows from the last) or the one before (from the
    // first), which are done by then.
    for (int k = 0; k < positions; ++k) {
      const int position = drift_ >= 0.0 ? positions - 1 - k : k;
      for (int line = first_line - line_step_; line >= 0 && line < lines; line -= line_step_) node(line, position);
    }
  } else {
    for (int line = first_line - line_step_; line >= 0 && line < lines; line -= line_step_) {
      for (int position = 0; position < positions; ++position) node(line, position);
    }
  }
}

double TerrainShadows::LineValue(int line, double position) const {
  const int positions = along_columns_ ? dem_.height : dem_.width;
  const int p0 = std::min(static_cast<int>(position), positions - 2);
  const double f = position - p0;
  // Only the nodes of non-zero weight are read (the sweep's order relies on it).
  if (f == 0.0) return double{shadow_height_m_[Index(line, p0)]};
  if (f == 1.0) return double{shadow_height_m_[Index(line, p0 + 1)]};
  return (1.0 - f) * double{shadow_height_m_[Index(line, p0)]} + f * double{shadow_height_m_[Index(line, p0 + 1)]};
}

double TerrainShadows::NodeTop(double u0, double v0, double u1, double v1) const {
  const int c0 = std::max(0, static_cast<int>(std::floor(std::min(u0, u1))));
  const int c1 = std::min(dem_.width - 1, static_cast<int>(std::ceil(std::max(u0, u1))));
  const int r0 = std::max(0, static_cast<int>(std::floor(std::min(v0, v1))));
  const int r1 = std::min(dem_.height - 1, static_cast<int>(std::ceil(std::max(v0, v1))));
  float top = kNothingSunward;
  for (int r = r0; r <= r1; ++r) {
    for (int c = c0; c <= c1; ++c) top = std::max(top, dem_.At(r, c));
  }
  return double{top};
}

double TerrainShadows::SegmentTop(double u0, double v0, double u1, double v1, double rise_m) const {
  // The surface bends only where the segment crosses a row line (v integer)
  // or a cell's diagonal (u - v integer), and at its end.
  double best = kNothingSunward;
  const auto consider = [&](double s) {
    double z;
    if (dem_.HeightAtGrid(u0 + s * (u1 - u0), v0 + s * (v1 - v0), &z)) best = std::max(best, z - s * rise_m);
  };
  const auto crossings = [&](double a0, double a1) {
    if (a1 == a0) return;
    const double lo = std::min(a0, a1), hi = std::max(a0, a1);
    for (double n = std::floor(lo) + 1.0; n < hi; n += 1.0) consider((n - a0) / (a1 - a0));
  };
  crossings(v0, v1);
  crossings(u0 - v0, u1 - v1);
  consider(1.0);
  return best;
}

bool TerrainShadows::Hidden(const Eigen::Vector3d& point_in_local_m) const {
  if (shadow_height_m_.empty()) return false;
  double u = (point_in_local_m.x() - dem_.origin_x_m) / dem_.spacing_m;
  double v = (dem_.origin_y_m - point_in_local_m.y()) / dem_.spacing_m;
  if (!(u >= 0.0 && v >= 0.0 && u <= dem_.width - 1 && v <= dem_.height - 1)) return false;
  const double z = point_in_local_m.z();
  if (drift_ == 0.0) return HiddenAlongGrid(u, v, z);
  // The surface itself up to kExactLines grid lines sunward, then the
  // shadow heights of the last line's two nodes around the ray, linear
  // between them.
  double rise_m = 0.0;  // of the ray so far
  for (int k = 0; k < kExactLines; ++k) {
    double& line = along_columns_ ? u : v;
    double& position = along_columns_ ? v : u;
    const double next = line_step_ > 0 ? std::floor(line) + 1.0 : std::ceil(line) - 1.0;
    const double fraction = std::abs(next - line);  // of a whole step
    const double u1 = along_columns_ ? next : u + fraction * drift_;
    const double v1 = along_columns_ ? v + fraction * drift_ : next;
    const double step_rise_m = fraction * rise_m_;
    // The surface over the step is no higher than the nodes of its cells.
    if (NodeTop(u, v, u1, v1) - rise_m > z && SegmentTop(u, v, u1, v1, step_rise_m) - rise_m > z) return true;
    rise_m += step_rise_m;
    line = next;
    position += fraction * drift_;
    if (!(u >= 0.0 && v >= 0.0 && u <= dem_.width - 1 && v <= dem_.height - 1)) return false;
  }
  return LineValue(static_cast<int>(along_columns_ ? u : v), along_columns_ ? v : u) - rise_m > z;
}

bool TerrainShadows::HiddenAlongGrid(double u, double v, double z) const {
  // The ray keeps its position between two lines of nodes; per step it
  // crosses one cell, where the surface bends only at the cell's diagonal.
  const int lines = along_columns_ ? dem_.width : dem_.height;
  const int positions = along_columns_ ? dem_.height : dem_.width;
  double line = along_columns_ ? u : v;
  const double position = along_columns_ ? v : u;
  const int p0 = std::min(static_cast<int>(position), positions - 2);
  const double f_position = position - p0;
  const auto height = [&](int l, int p) { return double{dem_.height_m[Index(l, p)]}; };
  double rise_m = 0.0;  // of the ray so far
  for (int k = 0; k < kExactLines; ++k) {
    const double next = line_step_ > 0 ? std::floor(line) + 1.0 : std::ceil(line) - 1.0;
    if (next < 0.0 || next > lines - 1) return false;
    const int l0 = static_cast<int>(std::min(line, next));
    const double h00 = height(l0, p0), h10 = height(l0 + 1, p0), h01 = height(l0, p0 + 1),
                 h11 = height(l0 + 1, p0 + 1);
    const double step_rise_m = std::abs(next - line) * rise_m_;
    // The surface over the cell is no higher than its corners.
    if (std::max(std::max(h00, h10), std::max(h01, h11)) - rise_m > z) {
      // (line, position) are (u, v) or (v, u); h10 is the node one line on.
      const auto surface = [&](double f_line) {
        return along_columns_ ? CellSurfaceHeight(h00, h10, h01, h11, f_line, f_position)
                              : CellSurfaceHeight(h00, h01, h10, h11, f_position, f_line);
      };
      const double f_start = line - l0;
      const double f_end = next - l0;
      if (surface(f_end) - rise_m - step_rise_m > z) return true;
      // The diagonal, where the line coordinate equals the position's.
      if (std::min(f_start, f_end) < f_position && f_position < std::max(f_start, f_end) &&
          surface(f_position) - rise_m - std::abs(f_position - f_start) * rise_m_ > z) {
        return true;
      }
    }
    rise_m += step_rise_m;
    line = next;
  }
  return LineValue(static_cast<int>(line), position) - rise_m > z;
}

}  // namespace hdabench::datasets::synth
