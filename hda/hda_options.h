// Parameters of the flight HDA method, with the NOVA-C paper's values as
// defaults (Hazard Detection and Avoidance for the NOVA-C Lander, AAS 22-105).
// hda/ links only OpenCV, Eigen and calib's camera model, and reads no files.
#pragma once

#include <string>
#include <vector>

#include "hda/quadtree.h"

namespace hdabench::hda {

struct HdaOptions {
  // Landing-site requirements (paper, "Requirements"); the site size is
  // quadtree.site_size_m.
  double max_hazard_height_m = 0.30;  // largest tolerated rock or hole, metres
  double max_slope_deg = 10.0;        // largest slope from local horizontal, degrees

  // Quadtree on image 1 (hda/quadtree.h): site size, block limits.
  QuadtreeOptions quadtree;

  // Features and matching.
  int orb_features_per_roi = 500;     // ORB keypoints requested per ROI
  double ratio_test = 0.8;            // Lowe ratio for descriptor matches
  double ransac_threshold_px = 1.0;   // epipolar RANSAC inlier threshold, pixels
  double ransac_confidence = 0.999;   // RANSAC confidence, in (0, 1)
  int min_points = 10;                // fewer triangulated points: "too few points"

  // Time budget (paper: about 5 s of imaging and 10 s of computation).
  double compute_budget_s = 10.0;     // seconds of computation on the flight computer
  double processor_scale = 1.0;       // this machine's speed relative to the 1 GHz board

  // Every violated constraint, one message each ("field = value: expected ...";
  // nested options prefixed, e.g. "quadtree.site_size_m = ...").
  // Empty when the options are usable.
  std::vector<std::string> Validate() const;
};

}  // namespace hdabench::hda
