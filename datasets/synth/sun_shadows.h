// The terrain's cast shadows for one sun direction, made once per scene and
// shared by every frame: the renderer asks it instead of casting each shadow
// ray through the terrain. Frames follow docs/conventions.md: local = ENU, z
// up, metres.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "datasets/synth/scene.h"

namespace hdabench::datasets::synth {

// The shadow height of every DEM node: the lowest height at which a point
// over the node sees the sun past the terrain,
//   S(q) = max over t > 0 of  H(q + t s_xy) - t s_z,
// for the unit sun direction s (s_xy its horizontal part, H the triangulated
// surface, t the distance along the ray). A point (x, y, z) is in the
// terrain's cast shadow when z < S(x, y); a ray that leaves the DEM meets
// nothing, as SceneRaycaster's.
//
// S is made by one sweep of the grid lines across the sun's azimuth, sunward
// line first (columns when the sun is nearer east or west, else rows): a
// node's S is the larger of the surface's highest point on its step to the
// next line sunward and that line's S where the step ends, each less the
// sun's rise over the step. The step ends between two nodes, where S is taken
// as linear between them; when the sun's azimuth is along a grid axis it ends
// on a node, and the nodes' S are exact.
//
// A point's shadow (Hidden) follows the surface exactly over the first
// kExactLines steps sunward: the surface is a plane per triangle, so its
// highest point over the ray's path lies where the path crosses a row, a
// column or a cell's diagonal. Only beyond does it read S, linear between the
// two nodes of the line the ray reaches. Shadows cast within a cell or two
// (the triangles' own creases, most of a rough surface's shadow at a low sun)
// are thus exact; a shadow cast from further away has its edge placed to
// within S's linearity over one cell.
//
class TerrainShadows {
 public:
  // `sun_in_local`: unit vector toward the sun. A sun at the zenith, or a DEM
  // of fewer than 2 x 2 nodes, casts no terrain shadow.
  TerrainShadows(const Heightfield& dem, const Eigen::Vector3d& sun_in_local);

  // Whether the terrain hides the sun from `point_in_local_m` (a ray toward
  // the sun from it meets the terrain). False outside the DEM's xy extent.
  bool Hidden(const Eigen::Vector3d& point_in_local_m) const;

  // Grid steps sunward that Hidden() follows the surface itself.
  static constexpr int kExactLines = 2;

  const Eigen::Vector3d& Sun() const { return sun_in_local_; }
  const Heightfield& Dem() const { return dem_; }

 private:
  // The highest point of the surface less the ray's rise over the segment
  // (u0, v0) -> (u1, v1) in grid coordinates (column, row), the ray rising
  // rise_m over it; -1e30 where the segment is off the DEM.
  double SegmentTop(double u0, double v0, double u1, double v1, double rise_m) const;
  // Hidden() for a sun along a grid axis (drift_ 0), at grid coordinates
  // (u, v) within the DEM.
  bool HiddenAlongGrid(double u, double v, double z) const;
  // The highest node of the cells the segment's bounding box covers.
  double NodeTop(double u0, double v0, double u1, double v1) const;
  // S on a line at a position between nodes, linear between the two.
  double LineValue(int line, double position) const;
  size_t Index(int line, int position) const {
    return along_columns_ ? static_cast<size_t>(position) * dem_.width + line
                          : static_cast<size_t>(line) * dem_.width + position;
  }

  const Heightfield& dem_;
  Eigen::Vector3d sun_in_local_;
  bool along_columns_ = true;   // lines are columns, positions rows; else the reverse
  int line_step_ = 1;           // +1 or -1 line per step sunward
  double drift_ = 0.0;          // positions per step
  double rise_m_ = 0.0;         // the sun ray's rise per step
  std::vector<float> shadow_height_m_;  // as dem_.height_m; -1e30: nothing sunward; empty: no cast shadow
};

}  // namespace hdabench::datasets::synth
