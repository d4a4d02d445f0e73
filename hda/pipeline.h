// The flight HDA method end to end (NOVA-C paper, AAS 22-105): quadtree on
// image 1, ROI prediction into image 2, ORB matching and epipolar RANSAC per
// ROI pair, navigation-based outlier rejection, triangulation with the nav
// relative pose, plane fit (slope against gravity, roughness), status per ROI,
// ranking of the safe sites, all under a time budget with ROIs processed
// nearest-to-the-ILS first. In-memory inputs only; single-threaded.
// Frames follow docs/conventions.md: cam1, cam2 camera frames (OpenCV axes),
// local = ENU; poses are b_from_a.
#pragma once

#include <chrono>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "hda/geometry.h"
#include "hda/hda_options.h"
#include "hda/matching.h"
#include "hda/quadtree.h"
#include "hda/roi_prediction.h"
#include "hda/work_model.h"

namespace hdabench::hda {

// What the flight computer has when HDA starts.
struct HdaInput {
  cv::Mat image1;  // CV_8UC1 or CV_16UC1, the camera's imager size
  cv::Mat image2;  // the same type and size, taken after the lateral motion
  Rigid3d local_from_cam1;   // navigation's pose of camera 1 in the local frame
  Rigid3d cam2_from_cam1;    // navigation's relative pose (IMU), metres
  Eigen::Vector3d gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -1.62);
  // The LRF at image 1: range along the beam from its origin, both in cam1.
  // The spot origin + range * beam fixes the ground's scale: the quadtree's
  // block size uses the spot's distance from the camera, the depth test a
  // level plane through it.
  double lrf_range_m = 0.0;                                        // metres, > 0
  Eigen::Vector3d lrf_origin_in_cam1_m = Eigen::Vector3d::Zero();  // start of the beam
  Eigen::Vector3d lrf_beam_in_cam1 = Eigen::Vector3d::UnitZ();     // direction (normalised here)
  Eigen::Vector3d ils_in_local_m = Eigen::Vector3d::Zero();  // intended landing site
  // ROIs given in image 1's pixels (a test target, a surveyed site): when not
  // empty the quadtree is not run and these are the ROIs (GivenRois).
  std::vector<cv::Rect> given_rois_px;
};

// Status of one ROI, in the order the method decides it.
enum class RoiStatus {
  kEvaluated,        // a slope and roughness within the requirements: a safe, ranked site
  kUnsafeSlope,      // slope over max_slope_deg (probability rule: probability of safety under
                     // min_probability_safe, the slope the part that fails it)
  kUnsafeRoughness,  // noise-corrected roughness over the limit (probability rule: the relief fails it)
  kDegenerate,       // low parallax or near-boresight motion: the slope is not observable
                     // enough (predicted sigma, the lean term left out, over max_slope_sigma_deg); not a confident slope.
                     // Also, before matching, an ROI where under the nav pose no match could
                     // pass both the triangulation's parallax test and the depth test
                     // (depth not observable; no fit)
  kTooFewPoints,     // fewer than min_points triangulated points survived
  kNotInImage2,      // the predicted box does not overlap image 2 (or a ground point is behind a camera)
  kNotEvaluated,     // the time budget ran out before this ROI
};
const char* ToString(RoiStatus status);  // "evaluated", "unsafe slope", ...
// Whether an ROI of this status carries a slope the method stands by:
// evaluated, unsafe slope or unsafe roughness. A degenerate ROI's plane is a
// diagnostic only (its slope is not observable).
bool HasSlope(RoiStatus status);

// Counts of one ROI at each stage.
struct RoiCounts {
  int keypoints1 = 0;
  int keypoints2 = 0;
  int matches = 0;           // ratio test + cross-check
  int refine_rejected = 0;   // sub-pixel refinement failures
  int ransac_inliers = 0;    // after the epipolar RANSAC
  int epipolar_inliers = 0;  // after the nav epipolar test
  int triangulated = 0;      // of those, triangulated with parallax over the minimum
  int depth_inliers = 0;     // of those, with a depth consistent with nav and LRF: the points of the fit
};

struct RoiResult {
  int id = 0;                          // quadtree ROI id (1-based)
  RoiStatus status = RoiStatus::kNotEvaluated;
  std::string reason;                  // one line: why this status (numbers included)
  cv::Rect box1_px;                    // the ROI in image 1
  cv::Rect box2_px;                    // the predicted, enlarged search box in image 2 (empty if none)
  double prediction_margin_px = 0.0;
  int order = 0;                       // 1-based position in processing order (nearest ILS first)
  double ils_distance_m = 0.0;         // horizontal distance of the ROI centre's ground point to the ILS
  RoiCounts counts;
  bool matched = false;                // matching ran (or the matches were given): matching_status holds
  bool depth_unobservable = false;     // refused before matching: the nav pose leaves its depth unobservable
  MatchingStatus matching_status = MatchingStatus::kTooFewMatches;
  bool prewarped = false;              // image 2's box was resampled before ORB (MatchingOptions::prewarp_min_stretch)

  // The surviving matches (image 1 and image 2 pixels) and their points, in
  // the local frame, parallel arrays (the PLY clouds and the figures).
  std::vector<cv::Point2d> points1_px;
  std::vector<cv::Point2d> points2_px;
  std::vector<Eigen::Vector3d> points_in_local_m;

  // The fit: meaningful when status is evaluated, unsafe slope, unsafe
  // roughness or degenerate.
  bool has_fit = false;
  double slope_deg = 0.0;              // angle of the plane normal from up (= -gravity)
  double slope_sigma_deg = 0.0;        // predicted 1-sigma of slope_deg (pixel + nav terms)
  SlopeSigmaTerms slope_sigma_terms;
  double pixel_sigma_px = 0.0;         // matching noise used for the prediction (estimated, floored)
  double roughness_rms_m = 0.0;        // RMS of point distances from the plane
  double roughness_max_m = 0.0;        // largest distance from the plane
  double noise_rms_m = 0.0;            // RMS distance the matching noise alone predicts
  double roughness_excess_m = 0.0;     // sqrt(max(0, rms^2 - noise^2)): relief beyond noise
  double median_parallax_deg = 0.0;
  double area_m2 = 0.0;                // the ROI's footprint on the fitted plane
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d centroid_in_local_m = Eigen::Vector3d::Zero();

  // ProbabilitySafe of the fit; NaN where the slope is not one the method
  // stands by (no fit, degenerate).
  double probability_safe = std::numeric_limits<double>::quiet_NaN();
  double score = 0.0;                  // ranking score (RankingScore), evaluated sites only
  int rank = 0;                        // 1 = best safe site; 0 for the others
  double wall_s = 0.0;                // wall time spent on this ROI (not part of the results' bytes)
  WorkCounts work;                     // what the method did on this ROI (prediction to plane)
};

// Wall times of the stages, seconds. Not deterministic: kept apart from the
// results (the budget reads HdaResult::work instead).
struct StageTimes {
  double convert_s = 0.0;     // 16-bit to 8-bit conversion
  double quadtree_s = 0.0;
  double prediction_s = 0.0;
  double matching_s = 0.0;    // ORB, matching, refinement, RANSAC
  double rejection_s = 0.0;   // nav-based rejection and triangulation
  double plane_s = 0.0;       // plane fit, uncertainty, status
  double ranking_s = 0.0;
  double total_s = 0.0;
};

struct HdaResult {
  QuadtreeResult quadtree;        // ROIs of image 1 (ids), rejected blocks, counts
  std::vector<RoiResult> rois;    // one per quadtree ROI, sorted by id
  std::vector<int> ranking;       // ids of the evaluated (safe) ROIs, best first
  double budget_s = 0.0;          // the budget, seconds of the flight computer (compute_budget_s)
  bool budget_exhausted = false;  // some ROIs were kicked out as not evaluated
  // What the method did, counted (hda/work_model.h), and the rate that makes
  // it the flight computer's seconds. Deterministic, unlike `times`.
  WorkCounts work;
  double flight_instructions_per_s = 0.0;
  // The predicted seconds of the flight computer: all, one stage's, one
  // ROI's (0 before a run has set the rate).
  double FlightSeconds() const { return FlightSeconds(work); }
  double FlightSeconds(Stage stage) const {
    return flight_instructions_per_s > 0.0 ? work.Instructions(stage) / flight_instructions_per_s : 0.0;
  }
  double FlightSeconds(const WorkCounts& counts) const {
    return flight_instructions_per_s > 0.0 ? counts.Instructions() / flight_instructions_per_s : 0.0;
  }
  StageTimes times;
  // Why there are no ROIs, when there are none ("image 1 is empty", "the
  // quadtree kept no block: ..."); empty otherwise.
  std::string note;
  // One line: "hda: N ROIs, E evaluated, S unsafe slope, ... , budget B s".
  std::string Summary() const;
};

// Monotonic seconds, for the stages' wall times (StageTimes, RoiResult::wall_s);
// the budget never reads it. Tests pass their own.
using Clock = std::function<double()>;
double SteadySeconds();

// Told after each ROI the method evaluated: how many it has evaluated, of how
// many ROIs (for progress lines on long runs; it does not change the result).
using RoiProgress = std::function<void(int evaluated, int rois)>;

// Runs the method. Images of another type or size, non-finite poses, a
// non-positive LRF range, zero gravity or invalid options throw InputError
// naming the input. An empty image (no pixels) or one with no usable block
// (all black, all shadow, all too variable) gives zero ROIs and says why in
// HdaResult::note. The ROI
// results (not the wall times) are deterministic: the same input gives the
// same bytes, the budget included, which counts work, not time.
HdaResult RunHda(const HdaInput& input, const calib::CameraModel& camera, const HdaOptions& options,
                 const Clock& clock = SteadySeconds, const RoiProgress& progress = {});

// The method's steps after matching, on one site whose matches are given
// (the observability study draws them; RunHda runs the same steps on each
// ROI's matches): the site degenerate when the nav pose leaves its depth
// unobservable (as RunHda decides before matching), else nav epipolar test,
// triangulation with the nav pose, depth test against the level ground
// through the LRF spot, plane fit, predicted slope sigma and status. `input`'s images are not used (they may be empty);
// box1_px places the site (its centre's range sets the nav tests) and gives
// its footprint. The result's counts start at the matches (matches =
// ransac_inliers = points1_px.size()); id 1, order 1. The windows' lean
// (sigma_terms.lean_deg) needs image 1: without it none is worked out.
// match_window_px is the
// side of the window the matches' positions come from (MatchWindowPx of the
// options' matcher, for the matcher's own matches as RunHda takes them); 0
// takes their errors as independent (drawn matches). Throws InputError as
// RunHda does for invalid inputs or options, and when the point lists differ
// in length.
RoiResult EvaluateMatchedSite(const HdaInput& input, const calib::CameraModel& camera,
                              const HdaOptions& options, const cv::Rect& box1_px,
                              const std::vector<cv::Point2d>& points1_px,
                              const std::vector<cv::Point2d>& points2_px,
                              double match_window_px = 0.0);

// The image-2 search box RunHda would predict for each image-1 box given as
// an ROI (its placement on the level ground through the LRF spot, then
// PredictRoi with options.prediction), without matching or fitting; an empty
// box where the prediction fails (outside image 2, behind a camera). Throws
// InputError as RunHda does for invalid inputs or options.
std::vector<cv::Rect> PredictSearchBoxes(const HdaInput& input, const calib::CameraModel& camera,
                                         const HdaOptions& options, const std::vector<cv::Rect>& boxes1_px);

// The side of the image-1 window a match's final position is estimated
// from, pixels: the nav-aided refinement's, else Lucas-Kanade's; 0 without
// sub-pixel refinement (ORB's corner positions, taken as independent).
// Matches whose windows share pixels share errors (SharedWindowFraction).
double MatchWindowPx(const MatchingOptions& matching);

// Ranking score of an evaluated site, in [0, 1], higher is better: the mean of
//   area term      min(area_m2 / site_area_m2, 4) / 4        (bigger sites leave margin)
//   slope term     1 - slope_deg / max_slope_deg
//   roughness term 1 - roughness_excess_m / max_hazard_height_m   (clamped to [0, 1])
// Ties are broken by the ROI id.
double RankingScore(double area_m2, double slope_deg, double roughness_excess_m,
                    const HdaOptions& options);

// The probability that a fitted site is within the limits, given the
// method's own uncertainty: P(slope) P(relief), the two taken as independent.
//   P(slope)  = Phi((max_slope_deg - slope_deg) / slope_sigma_deg): the slope
//               Gaussian about its estimate along the dip;
//   P(relief) = Phi(z), z = (max_roughness^2 - (rms^2 - noise^2)) /
//               (noise^2 sqrt(2 / (N - 3))): the relief's squared estimate
//               rms^2 - noise^2, with the 1-sigma spread that chi-square
//               noise over N - 3 degrees of freedom leaves it (the paper
//               rule's 97.7 % bound is z = -2: a site it calls too rough has
//               P(relief) under 0.023).
// NaN for non-finite input, a sigma not > 0, or fewer than 4 points.
double ProbabilitySafe(double slope_deg, double slope_sigma_deg, double max_slope_deg, double roughness_rms_m,
                       double noise_rms_m, int num_points, double max_roughness_rms_m);

// Pixels per radian of the camera at a pixel: the larger of the two image
// displacements of a small rotation of its ray about two perpendicular axes
// (the local focal length of any lens model). 0 when the camera cannot
// unproject the pixel or project the rotated rays.
double PixelsPerRadian(const calib::CameraModel& camera, const Eigen::Vector2d& pixel);

// CV_8UC1 view of an image: an 8-bit image as is (no copy), a 16-bit one
// divided by 257 and rounded. Throws InputError for another type.
cv::Mat ToEightBit(const cv::Mat& image, const char* what);

}  // namespace hdabench::hda
