// OpenGV relative pose for one ROI (or any set of matches of one image pair):
// RANSAC with one of OpenGV's central relative-pose solvers on unit bearing
// vectors, Sampson refinement on the inliers, the translation scaled to the
// navigation baseline (OpenGV's solvers give it with unit norm), and
// triangulation of the inliers in camera 1. Before trusting a free solve, the
// caller can ask which configuration the matches are in
// (ClassifyConfiguration): a flat 10 m patch seen from 500 m is nearly a
// plane, and a free two-view solve is then close to degenerate.
//
// Poses are cam2_from_cam1 in metres (docs/conventions.md); the one conversion
// from OpenGV's (R12, t12) lives in reference/opengv/opengv_adapter.h. Bearings are
// unit vectors in the OpenCV camera frame (x right, y down, z forward), as
// calib::CameraModel unprojection gives them.
//
// Deterministic: the same inputs and options give the same result bytes on
// every run and whatever the number of threads calling (every call owns its
// OpenGV objects and its random generators, seeded from options.seed; OpenGV's
// own clock seeding and std::rand are never used). Only `seconds` varies.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::reference {

// The OpenGV solvers the bench compares.
enum class OpenGvSolver {
  kStewenius,              // 5-point, Stewenius (Groebner basis): free rotation and translation
  kNister,                 // 5-point, Nister: free rotation and translation
  kEightPoint,             // 8-point, linear: free rotation and translation
  kEigensolver,            // Kneip's eigensolver: rotation by local optimisation from the nav rotation
  kTwoPointKnownRotation,  // 2-point translation with the nav (IMU) rotation held as known
};
// "stewenius", "nister", "eight-point", "eigensolver", "two-point".
const char* ToString(OpenGvSolver solver);
// The inverse of ToString. Throws InputError naming the value and listing the
// valid names.
OpenGvSolver ParseOpenGvSolver(const std::string& name);
// Every solver, in the order of the enum (the order of the comparison tables).
const std::vector<OpenGvSolver>& AllOpenGvSolvers();

struct OpenGvOptions {
  // RANSAC (OpenGV's sac::Ransac). A match is an inlier when the angle between
  // each observed bearing and the reprojection of its triangulated point is,
  // in quadratic mean over the two views, below ransac_threshold_px / focal_px
  // (OpenGV's score, the sum over both views of 1 - cos(angle), compared with
  // 2 (1 - cos(atan(ransac_threshold_px / focal_px)))).
  double ransac_threshold_px = 1.0;  // > 0, pixels
  int max_iterations = 1000;         // >= 1, hypotheses at most
  double probability = 0.999;        // in (0, 1): confidence that stops RANSAC early
  std::uint64_t seed = 1;            // the random sampling's seed (any value)
  // The eigensolver fits each hypothesis to this many matches (it is not a
  // minimal solver) starting from the nav rotation turned by a random rotation
  // of up to eigensolver_start_jitter_deg about each axis (so that hypotheses
  // do not all start in the same basin).
  int eigensolver_sample_size = 10;           // >= 3
  double eigensolver_start_jitter_deg = 5.0;  // in [0, 45], degrees
  // Fewer matches than max(min_matches, the solver's RANSAC sample size) give
  // "too few points" without running anything.
  int min_matches = 12;  // >= 8
  // Refinement on the RANSAC inliers. For the free solvers: Levenberg-Marquardt
  // on the Sampson distances of the inliers (rotation and translation
  // direction; two_view_models.h), which reaches the geometric optimum from
  // any RANSAC model in its basin, so that every 5-point solver ends on the
  // same pose. OpenGV's optimize_nonlinear (1 - cos residuals on numerical
  // derivatives) was the refinement before: it stopped a few hundredths of a
  // degree (up to 0.2) short of the optimum on a well-conditioned pair, and
  // 0.64 deg of translation direction short on the NOVA-C pair. For the
  // 2-point solver the rotation stays the nav rotation and the translation
  // direction is re-solved by least squares over all inliers. The refined
  // pose is kept when it keeps at least the RANSAC model's inlier count.
  bool refine_nonlinear = true;
  // Triangulation (OpenGV's triangulate2, guarded): a match whose two rays meet
  // at less than min_ray_angle_deg is degenerate (parallel rays: no point, or
  // one at an arbitrary depth); its index is reported, it is never
  // triangulated. 0.1 degree: a rotation error of a few hundredths of a degree,
  // what a two-view estimate has, is then already a fifth of the parallax.
  double min_ray_angle_deg = 0.1;  // in (0, 90), degrees

  // Configuration classification (ClassifyConfiguration), from the matches and
  // the nav pose alone (no solver involved).
  //
  // Low parallax: the median angle between the two rays of a match (nav pose)
  // is below low_parallax_deg. Depth error grows as range * (angular noise) /
  // parallax: at 1 degree, a 0.5 px error at a 1000 px focal length (0.03
  // degree) is already 3 % of the range (17 m at 565 m), and the baseline
  // direction of a free solve is as poorly determined. A zero nav baseline is
  // low parallax whatever the angles. The NOVA-C geometry (31 m at 565 m) has
  // about 3.1 degrees.
  double low_parallax_deg = 1.0;  // > 0, degrees
  // Planar, either of:
  //  - shape: the points triangulated with the nav pose (less the gross
  //    outliers of the homography fit) lie within a small fraction of their
  //    extent of a plane: the smallest eigenvalue of their scatter divided by
  //    the middle one is below planar_eigenvalue_ratio (0.01: a thickness, in
  //    standard deviation, under a tenth of the in-plane spread). With
  //    noise-free matches this is the definition; but triangulation noise
  //    along the lines of sight thickens a flat patch seen from far away, so
  //    the shape alone misses it. Hence:
  //  - relief not seen above the matching noise: the plane-induced homography
  //    explains the matches as well as the general model does, counting what
  //    each costs, by Torr's GRIC with the noise measured on the general
  //    model's residuals (two_view_models.h). No threshold in pixels: the
  //    noise decides. That is when a free 5-point or 8-point solve cannot tell
  //    the scene from a plane (8-point is degenerate on a plane; 5-point has
  //    two solutions and, on a narrow field, a rotation / translation
  //    ambiguity).
  double planar_eigenvalue_ratio = 0.01;  // in (0, 1)

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// The number of matches each RANSAC hypothesis uses: OpenGV's sample sizes
// (5-point: 5 + 3 to pick among the solutions, 8-point: 8 + 1, 2-point: 2),
// the eigensolver's from the options.
int RansacSampleSize(OpenGvSolver solver, const OpenGvOptions& options);

enum class ConfigurationType {
  kWellConditioned,  // enough matches, parallax and relief: a free solve is meaningful
  kPlanar,           // the matches are explained by a plane (see OpenGvOptions)
  kLowParallax,      // the rays of most matches are nearly parallel (includes zero baseline)
  kTooFewPoints,     // fewer than options.min_matches usable matches
};
// "well-conditioned", "planar", "low parallax", "too few points".
const char* ToString(ConfigurationType type);

struct ConfigurationReport {
  ConfigurationType type = ConfigurationType::kTooFewPoints;
  std::string reason;  // one line with the numbers that decided it
  int num_matches = 0;
  double median_parallax_deg = 0.0;      // median angle between the two rays (nav pose)
  double eigenvalue_ratio = 0.0;         // smallest / middle eigenvalue of the points' scatter
  double homography_residual_px = 0.0;   // median transfer error of the fitted homography, image 2
  // The model selection (two_view_models.h), when the nav baseline is not
  // zero and the homography could be fitted; otherwise all zero / false.
  double noise_px = 0.0;                 // matching noise measured on the general model
  double gric_general = 0.0;
  double gric_homography = 0.0;
  bool homography_selected = false;      // the homography's GRIC is the lower
  double nav_baseline_m = 0.0;
};

// Classifies the configuration of the matches (bearings1[i] <-> bearings2[i])
// with the nav pose: too few points, then low parallax, then planar, else well
// conditioned (the first that applies; see OpenGvOptions for the thresholds).
// focal_px converts angles to pixels. Throws
// InputError for invalid options, bearings of different counts, a bearing that
// is not finite and of unit norm (within 1e-6), or focal_px <= 0.
ConfigurationReport ClassifyConfiguration(const std::vector<Eigen::Vector3d>& bearings1,
                                          const std::vector<Eigen::Vector3d>& bearings2,
                                          const Rigid3d& nav_cam2_from_cam1, double focal_px,
                                          const OpenGvOptions& options);

struct TriangulatedMatch {
  int match_index = 0;                                    // index into the input bearings
  Eigen::Vector3d point_in_cam1_m = Eigen::Vector3d::Zero();
  double parallax_deg = 0.0;                              // angle between its two rays
};

struct RelativePoseResult {
  bool ok = false;
  std::string message;  // one line: what was done, or what failed and why
  OpenGvSolver solver = OpenGvSolver::kStewenius;
  // The classification of the input (always computed, also on failure): a
  // caller reports this type rather than a pose from a planar or low-parallax
  // configuration.
  ConfigurationReport configuration;
  // The estimate, when ok: translation scaled so that the camera centres are
  // the nav baseline apart, its sign chosen so that most inliers triangulate in
  // front of both cameras.
  Rigid3d cam2_from_cam1;
  bool refined = false;             // the nonlinear refinement ran and was kept
  bool cheirality_flipped = false;  // the solver's translation sign was reversed
  int ransac_iterations = 0;
  int num_inliers = 0;
  std::vector<int> inlier_indices;  // ascending, into the input bearings
  // Inliers triangulated with the scaled pose, in camera 1 (metres); those
  // with degenerate rays or behind either camera are left out and counted.
  std::vector<TriangulatedMatch> points;
  std::vector<int> degenerate_indices;  // inliers whose rays are (nearly) parallel
  int num_behind = 0;                   // inliers triangulated behind either camera
  // Errors of the estimate: rotation = angle of R_est R_ref^T; translation
  // direction = angle between the camera-2 centres seen from camera 1.
  // Against the nav pose always (when ok), against the truth when given.
  double rotation_error_vs_nav_deg = 0.0;
  double translation_direction_error_vs_nav_deg = 0.0;
  bool has_truth_errors = false;
  double rotation_error_deg = 0.0;
  double translation_direction_error_deg = 0.0;
  double wall_s = 0.0;  // wall time of the call (the one field that varies run to run)
};

// The relative pose of the matches bearings1[i] <-> bearings2[i] with one
// solver (see the file comment). nav_cam2_from_cam1 gives the known rotation
// (2-point solver), the eigensolver's starting rotation and the baseline
// length (metres); focal_px converts ransac_threshold_px to an angle; truth,
// when not null, the pose the errors are measured against. Failures are
// results (ok = false, message says why: too few matches, RANSAC found no
// model, zero nav baseline, no inlier in front of the cameras); nothing in the
// result is NaN. Throws InputError for invalid options, bearings of different
// counts, a bearing that is not finite and of unit norm (within 1e-6), or
// focal_px <= 0.
RelativePoseResult SolveRelativePose(const std::vector<Eigen::Vector3d>& bearings1,
                                     const std::vector<Eigen::Vector3d>& bearings2,
                                     OpenGvSolver solver, const Rigid3d& nav_cam2_from_cam1,
                                     double focal_px, const OpenGvOptions& options,
                                     const Rigid3d* truth_cam2_from_cam1 = nullptr);

}  // namespace hdabench::reference
