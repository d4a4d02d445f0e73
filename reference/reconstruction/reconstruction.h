// What every reference method returns for one image pair: points in the local
// frame, each with its observation in image 1 (so the comparison can give it
// to the ROIs of the flight quadtree), the relative pose the method ended
// with, and whether it ran at all. Frames and pixels follow
// docs/conventions.md (hdabench pixels: centre of the top-left pixel at 0,0).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::reference {

struct ReconstructedPoint {
  Eigen::Vector3d point_in_local_m = Eigen::Vector3d::Zero();
  Eigen::Vector2d pixel1 = Eigen::Vector2d::Zero();  // observation in image 1, hdabench pixels
};

struct PairReconstruction {
  std::string method;     // "colmap-nav", "colmap-free", ...
  bool ok = false;        // false: the method failed for this run; `failure` says why
  std::string failure;    // one line naming what failed and where (empty when ok)
  std::vector<ReconstructedPoint> points;
  bool has_pose = false;  // cam2_from_cam1 is the method's own estimate
  Rigid3d cam2_from_cam1; // metres
  double wall_s = 0.0;   // wall time (not part of any deterministic output)
  std::string log_dir;    // where the method's logs are, when it keeps any
};

}  // namespace hdabench::reference
