// Whether a lander would stand on a site: its footprint placed on the true
// surface, after the deterministic hazard detection of ALHAT
// (docs/flight-results.md, "The landing decision").
//
// The surface is the truth DEM with the scene's rocks on it (SurfaceOfTruth).
// The lander is centred on the site (on the grid cell nearest it), at a yaw:
//   - its `legs` pads are centred on a circle of footprint_diameter_m, the
//     first on the +x axis of the yaw (yaw 0: east), the others every
//     360 / legs deg counter-clockwise, each on the grid cell nearest it;
//   - each pad rests on the highest surface under its disk: the cells within
//     pad_diameter_m / 2 of the pad's cell (that cell alone for a pad
//     smaller than a cell);
//   - the landing plane goes through three of those contacts: a triangle of
//     pads counts when every other contact lies on or below its plane and the
//     site's centre lies in it (seen from above), so that the lander can rest
//     on those three. Where several count (four pads on a warped surface: the
//     lander rocks between two), the worst of them decides;
//   - slope: the landing plane against gravity (local z up);
//   - clearance: the highest surface above the landing plane, measured along
//     its normal, over the cells inside the polygon of the pads (a hole under
//     the body does not count);
//   - unsafe at that yaw when the slope is over max_slope_deg or the
//     clearance over body_clearance_m.
// Yaws are swept from 0 to 360 / legs deg in yaw_step_deg. A lander that
// cannot choose its yaw (chooses_yaw false) is unsafe when one yaw is; one
// that can is safe when one yaw is.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>

#include "datasets/dataset.h"

namespace hdabench::datasets::synth {

// The lander's footprint and limits. The defaults are NOVA-C's as far as
// they are public (six legs; the paper's 10 deg and 0.30 m); the footprint
// and pad sizes are assumptions: no public source gives them
// (docs/flight-parameters.md, "The lander").
struct LanderGeometry {
  int legs = 6;                        // pads, >= 3
  double footprint_diameter_m = 4.0;   // circle through the pads' centres, > 0
  double pad_diameter_m = 0.5;         // >= 0
  double max_slope_deg = 10.0;         // in (0, 90]
  double body_clearance_m = 0.30;      // > 0
  bool chooses_yaw = false;            // false: the worst yaw decides; true: the best
  double yaw_step_deg = 5.0;           // > 0

  // The fields that break their ranges, each "name = value: must be ...".
  std::vector<std::string> Validate() const;
};

// A height field on a regular grid: cell (r, c) is the height at
// x = origin.x + c * spacing_m, y = origin.y - r * spacing_m (TruthDem's
// layout).
struct SurfaceGrid {
  Eigen::Vector2d origin_in_local_m = Eigen::Vector2d::Zero();
  double spacing_m = 1.0;
  cv::Mat height_m;  // CV_32FC1
};

// The truth DEM with every rock's cap on it: each cell takes the highest of
// the ground and the rock's sphere above the cell's centre; the cell under a
// rock's centre takes at least the rock's top, so that a rock smaller than a
// cell is not lost. Throws InputError when the truth has no DEM in memory.
SurfaceGrid SurfaceOfTruth(const Truth& truth);

// The lander on one site at one yaw.
struct LandingAtYaw {
  bool defined = false;       // false: a pad or the body leaves the grid
  double yaw_deg = 0.0;
  double slope_deg = 0.0;
  double clearance_m = 0.0;   // >= 0
  bool unsafe_by_slope = false;
  bool unsafe_by_clearance = false;
  bool Safe() const { return defined && !unsafe_by_slope && !unsafe_by_clearance; }
};
LandingAtYaw EvaluateLandingAtYaw(const SurfaceGrid& surface, const Eigen::Vector2d& centre_in_local_m,
                                  double yaw_deg, const LanderGeometry& lander);

// The lander on one site, over the yaws.
struct LandingVerdict {
  bool defined = false;  // false: some yaw leaves the grid; no verdict (ALHAT's "indefinite")
  std::string why;       // when not defined
  bool safe = false;
  bool unsafe_by_slope = false;      // the deciding yaw(s) break the slope limit
  bool unsafe_by_clearance = false;  // the deciding yaw(s) break the clearance
  // chooses_yaw false: the largest slope and clearance over the yaws; true:
  // those of the best yaw (the one furthest inside both limits).
  double slope_deg = 0.0;
  double clearance_m = 0.0;
  double yaw_deg = 0.0;  // the deciding yaw: the worst one, or the best one
};
LandingVerdict EvaluateLanding(const SurfaceGrid& surface, const Eigen::Vector2d& centre_in_local_m,
                               const LanderGeometry& lander);

// A lander on a surface, prepared once for many sites: the highest surface
// under a pad at every cell, and each yaw's pads and body as cell offsets.
// Evaluate gives EvaluateLanding's verdict; SafetyMap every stride-th cell's.
class LanderOnSurface {
 public:
  // Throws InputError for an invalid lander or an empty surface.
  LanderOnSurface(const SurfaceGrid& surface, const LanderGeometry& lander);
  LandingVerdict Evaluate(const Eigen::Vector2d& centre_in_local_m) const;
  // See the free SafetyMap below.
  cv::Mat SafetyMap(int stride, int threads = 0) const;
  // The cell nearest a point; false when the lander there would leave the grid.
  bool CellOf(const Eigen::Vector2d& centre_in_local_m, int* row, int* col) const;

 private:
  struct Prepared;
  // decide_only: the clearance only as far as the verdict needs it (the
  // safety map's classes); tile_max (or null): the highest surface over the
  // square of the body's squares' size whose top-left cell is each cell,
  // which bounds the squares in that mode.
  LandingVerdict EvaluateOnCell(int row, int col, bool decide_only, const cv::Mat* tile_max) const;
  friend LandingAtYaw EvaluateLandingAtYaw(const SurfaceGrid&, const Eigen::Vector2d&, double,
                                           const LanderGeometry&);
  std::shared_ptr<Prepared> p_;
};

// The safety of every `stride`-th cell of the surface as a landing point:
// CV_8UC1, 0 = no verdict, 1 = safe, 2 = unsafe by clearance only, 3 =
// unsafe by slope (with or without clearance). Row r, column c of the map is
// the surface's cell (r * stride, c * stride). On `threads` threads (0:
// every core); the map does not depend on it.
cv::Mat SafetyMap(const SurfaceGrid& surface, const LanderGeometry& lander, int stride, int threads = 0);

// The highest value of a float grid within `radius_cells` of each cell (the
// cells (dr, dc) with dr^2 + dc^2 <= radius_cells^2), the grid's edge
// replicated outward: cv::dilate's answer with that disk and BORDER_REPLICATE,
// the same floats, in time that grows with the disk's diameter, not its area
// (a lander's pads on a fine DEM). Throws InputError for an empty or non-float
// grid or a radius that is negative or not finite.
cv::Mat DiskMaximum(const cv::Mat& height, double radius_cells);

// The safety map as a BGR image: no verdict grey, safe green, unsafe by
// clearance orange, unsafe by slope red.
cv::Mat SafetyMapImage(const cv::Mat& safety_map);

}  // namespace hdabench::datasets::synth
