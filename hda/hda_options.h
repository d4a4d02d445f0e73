// Parameters of the flight HDA method, with the NOVA-C paper's values as
// defaults where the paper gives them (Hazard Detection and Avoidance for the
// NOVA-C Lander, AAS 22-105) and bench choices, stated as such, elsewhere.
// hda/ links only OpenCV, Eigen and calib's camera model, and reads no files.
#pragma once

#include <string>
#include <vector>

#include "hda/geometry.h"
#include "hda/matching.h"
#include "hda/quadtree.h"
#include "hda/roi_prediction.h"

namespace hdabench::hda {

struct HdaOptions {
  // Landing-site requirements (paper, "Requirements"); the site size is
  // quadtree.site_size_m.
  double max_hazard_height_m = 0.30;  // largest tolerated rock or hole, metres
  double max_slope_deg = 10.0;        // largest slope from local horizontal, degrees

  // Quadtree on image 1 (hda/quadtree.h): site size, block limits.
  QuadtreeOptions quadtree;
  // ROI prediction into image 2 (hda/roi_prediction.h): the navigation and LRF
  // uncertainties, also used by the nav-based rejection and the slope sigma.
  PredictionOptions prediction;
  // ORB, matching, sub-pixel refinement, epipolar RANSAC (hda/matching.h).
  MatchingOptions matching;
  // Triangulation (hda/geometry.h): the smallest usable parallax.
  TriangulationOptions triangulation;

  // Navigation-based rejection (bench choices; the paper gives no values).
  // A match is dropped when its epipolar angle under the nav pose exceeds
  //   k * sqrt(2 (sigma_px / f)^2 + sigma_att^2 + (sigma_pos / d)^2)
  // (k = prediction.sigma_multiplier, sigma_px = assumed_pixel_sigma_px), or
  // when its triangulated depth along the ray differs from the depth of a level
  // ground plane through the LRF spot by more than
  //   max_relief_m / incidence + k * (range sigma + depth sigma of the match),
  // with incidence the cosine of the ray to the vertical and the depth sigma
  // depth^2 sigma_px / (f baseline_perp).
  double assumed_pixel_sigma_px = 0.5;  // matching noise before it is measured, pixels
  double max_relief_m = 50.0;           // terrain height range tolerated around the LRF spot's level, metres

  // The nav-aided refinement maps its windows with the level ground's
  // motion; on ground tilted from it each window leans toward its texture
  // (WindowLeanPx in hda/pipeline.cc; docs/flight-method.md, step 6). With
  // this, each match is moved back by its lean under the fitted plane's
  // motion and the plane fitted again; without (the default), the slope
  // change that would make is carried in the slope sigma (lean_deg).
  bool correct_window_lean = false;

  // Plane fit and status.
  int min_points = 10;                  // fewer triangulated points: "too few points"
  // Matching noise. The slope sigma takes each ROI's measured spread of
  // independent noise (correlated matches accounted for), never below the
  // floor; a refinement that weighs reprojection residuals (the comparison's
  // flight-refined) takes match_error_px, the matches' whole error against
  // the truth, shared parts included.
  double pixel_sigma_floor_px = 0.01;   // the measured matching noise is never taken below this, pixels
                                        // (a guard against a few matches' spread coming out too small;
                                        // under the spreads of the default scenes, 0.012-0.034 px)
  double match_error_px = 0.08;         // whole error of a match per axis, pixels (matches against truth
                                        // on the novac-lateral scenes, seeds 1-5, with the nav-aided
                                        // refinement: 0.05-0.07 px per axis, robust)
  double max_slope_sigma_deg = 3.0;     // predicted slope sigma above this: "degenerate", degrees
  double max_roughness_rms_m = 0.15;    // noise-corrected RMS relief above this: "unsafe roughness", metres
                                        // (half the hazard height: 2-sigma relief reaches it)

  // The decision rule. The paper's (default): a site is safe when its slope
  // is under max_slope_deg and its relief is not over max_roughness_rms_m
  // with 97.7 % confidence, ranked by RankingScore. The probability rule
  // (ALHAT's probabilistic hazard detection with the method's own sigmas in
  // place of the DEM's noise): safe when ProbabilitySafe reaches
  // min_probability_safe, ranked by that probability. Every fitted site gets
  // its probability under either rule.
  bool decide_on_probability = false;
  double min_probability_safe = 0.9;    // in (0, 1)

  // Time budget (paper: about 5 s of imaging and 10 s of computation on a
  // 1 GHz single-board computer), counted in work, not read from a clock: the
  // method counts what it does (hda/work_model.h), the count's instructions
  // run at flight_instructions_per_s on the flight computer, and an ROI is
  // kicked out when that predicted time would pass the budget. The same
  // inputs evaluate the same ROIs on any machine under any load
  // (docs/flight-method.md, "Time budget").
  double compute_budget_s = 10.0;             // seconds of computation on the flight computer
  double flight_instructions_per_s = 1.0e9;   // the flight computer's rate, in this machine's (x86-64)
                                              // instructions: 1 GHz at one per cycle

  // Fault injection, for testing the bench's merge gate only (0 in flight):
  // Gaussian noise of this standard deviation, per axis, pixels, added to
  // every image-2 match position after matching, before the nav-based
  // rejection. Deterministic: seeded by the ROI id.
  double fault_match_noise_px = 0.0;

  // Every violated constraint, one message each ("field = value: expected ...";
  // nested options prefixed, e.g. "quadtree.site_size_m = ...").
  // Empty when the options are usable.
  std::vector<std::string> Validate() const;
};

}  // namespace hdabench::hda
