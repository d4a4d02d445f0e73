// The "flight-refined" reference: a two-view bundle adjustment (Ceres) of the
// flight method's triangulated points and of the relative pose, with the
// navigation's relative pose as a prior weighted by its covariance and a
// robust loss on the image residuals. It shows how much a heavier method
// would buy over triangulating with the nav pose as is.
//
// Frames follow docs/conventions.md: cam1, cam2 are camera frames with OpenCV
// axes; poses are b_from_a. Camera 1 is the fixed gauge (identity); camera 2's
// pose cam2_from_cam1 (rotation as a unit quaternion on Ceres's quaternion
// manifold, translation in metres) and every point (cam1, metres) are free.
// Putting the refined points into the local frame is the caller's job
// (local_from_cam1 * point).
//
// No camera model inside the cost: the caller unprojects its pixels through
// the mrcal model (calib::CameraModel::Unproject) and passes unit bearings.
// The residual of an observation is the error of the predicted direction on
// the tangent plane of the observed bearing b (gnomonic projection: with e1,
// e2 an orthonormal basis of that plane and P the point in that camera,
//   r = focal_px * (e1 . P, e2 . P) / (b . P),
// which is what a pinhole of focal focal_px looking along b would measure), so
// residuals are in pixels: image pixels at the centre of a pinhole camera;
// off axis by an angle a, a pinhole's pixel spans less angle, so there the
// residual is the image error times cos^2 a radially and cos a tangentially
// (0.93 and 0.97 at 15 deg). A point with b . P <= 0 (behind a camera) cannot
// be evaluated: such points are left out of the adjustment (see `excluded`).
//
// What the geometry can observe: the images fix the relative rotation and the
// direction of the baseline (the epipolar geometry), never the baseline's
// length: the scale comes from the nav prior, and from the range finder where
// it is given (CeresRefineInput::lrf). How much of the rest they
// fix depends on the spread of the points. One 10 m site at 565 m (about one
// degree of the field) observes little more than the offset of the epipolar
// lines across the baseline (a rotation about the baseline traded against a
// translation across it); the rotation about the optical axis and the
// baseline's direction stay at the prior. Points across the whole image (a
// 30 deg field, with range varying over an oblique ground) fix all three
// rotation axes and the baseline's direction well below the nav's errors
// (tests/reference/ceres_refine_test.cc measures both cases' numbers).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::reference {

enum class RobustLoss {
  kNone,    // plain least squares
  kHuber,   // quadratic up to the scale, linear beyond
  kCauchy,  // log(1 + (r / scale)^2): gross outliers lose almost all weight
};
const char* ToString(RobustLoss loss);  // "none", "huber", "cauchy"

struct CeresRefineOptions {
  // Std of a matched keypoint's position, per image axis, pixels. Divides the
  // image residuals (so they weigh against the whitened prior).
  double pixel_sigma_px = 0.3;
  // Robust loss on the image residuals only (not on the prior), applied per
  // match to the norm of its four residuals (both images: a mismatch is a
  // pair, and one loss per pair keeps the cost smooth where the point has
  // settled on one of its two observations); the scale is in pixels (the
  // residual norm where the loss leaves the quadratic).
  RobustLoss loss = RobustLoss::kHuber;
  double loss_scale_px = 1.0;
  // 1-sigma uncertainty of the nav relative pose, per axis, used when the input
  // has no covariance: translation of cam2_from_cam1 (metres) and its rotation
  // (degrees, a small rotation of cam2 expressed in cam2).
  double nav_position_sigma_m = 0.3;
  double nav_attitude_sigma_deg = 0.05;
  // Fewer points than this (after exclusions) -> kTooFewPoints. The relative
  // pose has five observable degrees of freedom and each point brings one
  // constraint on it.
  int min_points = 5;
  // Ceres stops after this many iterations (kNotConverged, refined state kept)
  // or when the relative decrease of the cost in a step is below
  // function_tolerance.
  int max_iterations = 100;
  double function_tolerance = 1e-12;
  // There is no thread count: the adjustment runs on one thread. Threaded,
  // Ceres sums the cost and gradient of the residual blocks in an order that
  // depends on scheduling, so the last bits of the result would depend on
  // the run; single-threaded the same input gives the same bytes. A two-view
  // problem of a thousand points takes milliseconds.

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

struct CeresRefineInput {
  // N matches: bearings in camera 1 and camera 2 (any positive length; they are
  // normalised), and the initial points in cam1, metres (the flight's
  // triangulation). Parallel arrays.
  std::vector<Eigen::Vector3d> bearings1_in_cam1;
  std::vector<Eigen::Vector3d> bearings2_in_cam2;
  std::vector<Eigen::Vector3d> points_in_cam1_m;
  // The navigation's relative pose: the prior's mean and the starting pose.
  Rigid3d nav_cam2_from_cam1;
  // Optional 6x6 covariance of the nav pose error, replacing the options'
  // sigmas: order (rotation x, y, z in radians, translation x, y, z in
  // metres), where the rotation error is the rotation vector of
  // R * R_nav^T (in cam2) and the translation error is t - t_nav (in cam2).
  // Must be symmetric positive definite.
  std::optional<Eigen::Matrix<double, 6, 6>> nav_covariance;
  // Focal length of the camera, pixels: turns angular residuals into pixels.
  double focal_px = 0.0;
  // The laser range finder at camera 1, when it is used: the range it
  // measured along its beam fixes the scale, which the images cannot (see the
  // file comment). The support_points points nearest the beam's line (at the
  // start), of those within the smallest of a quarter, a half and the whole
  // of support_radius_m that holds three, stand for the ground it hit: the plane of normal ground_normal_in_cam1 through their centroid,
  // where the beam meets it, is range_m away, to range_sigma_m. The normal is
  // given, not fitted: two-view points tilt a plane fitted to a few of them
  // by degrees (their depth noise runs along the lines of sight), and the
  // range errs by the centroid's distance from the beam times the tangent of
  // the tilt (12 m and 3.5 deg: 0.7 m, in the default scene); with level
  // ground as the normal it errs by that distance times the local slope.
  // Fewer than three such points, or a beam within 10 degrees of grazing the
  // plane: no range constraint (CeresRefineResult::lrf_points is 0 and
  // lrf_note says why).
  struct Lrf {
    Eigen::Vector3d origin_in_cam1_m = Eigen::Vector3d::Zero();
    Eigen::Vector3d beam_in_cam1 = Eigen::Vector3d::UnitZ();  // any positive length
    double range_m = 0.0;          // > 0
    double range_sigma_m = 0.1;    // > 0: the range's 1-sigma noise
    double support_radius_m = 5.0;  // > 0
    int support_points = 20;        // >= 3
    Eigen::Vector3d ground_normal_in_cam1 = -Eigen::Vector3d::UnitY();  // any non-zero length
  };
  std::optional<Lrf> lrf;
};

enum class CeresRefineStatus {
  kOk,             // Ceres converged; the refined state is returned
  kNotConverged,   // iteration limit reached; the refined state (better than the start) is kept
  kCostIncreased,  // Ceres ended above the initial cost: the initial state is returned
  kSolverFailed,   // Ceres reported a failure: the initial state is returned
  kTooFewPoints,   // fewer usable points than options.min_points: the initial state is returned
  kInvalidInput,   // sizes differ, a value is not finite, a zero bearing, a bad covariance or focal
};
const char* ToString(CeresRefineStatus status);  // "ok", "not converged", ...

// Costs in Ceres's convention: half the sum of the robustified squared
// whitened residuals (image residuals / pixel_sigma_px, prior residuals
// multiplied by the inverse Cholesky factor of the covariance), dimensionless.
struct RefineCost {
  double total = 0.0;
  double reprojection = 0.0;  // the image residuals' part (with the robust loss)
  double prior = 0.0;         // the nav prior's part, with the range finder's where it is used
};

struct CeresRefineResult {
  CeresRefineStatus status = CeresRefineStatus::kInvalidInput;
  bool ok = false;      // status == kOk
  std::string failure;  // one line naming what went wrong (empty when ok)
  // The refined relative pose and points (cam1, metres), parallel to the
  // input. On kInvalidInput: the nav pose (identity if it is not finite) and
  // no points; on kTooFewPoints, kCostIncreased and kSolverFailed: the initial
  // state.
  Rigid3d cam2_from_cam1;
  std::vector<Eigen::Vector3d> points_in_cam1_m;
  // Per point: the RMS over its two observations of the image error norm,
  // pixels, sqrt((|r1|^2 + |r2|^2) / 2), without the robust loss, at the
  // returned state; +infinity for an excluded point.
  std::vector<double> reprojection_rms_px;
  int excluded = 0;  // points left out: behind a camera at the start (returned as given)
  int lrf_points = 0;    // points the range constraint stands on; 0: none (lrf_note says why)
  std::string lrf_note;  // one line: the range constraint's points and its range at the end, or why none
  RefineCost initial_cost;
  RefineCost final_cost;  // never above initial_cost.total
  int iterations = 0;     // Ceres iterations (steps tried, accepted or not), <= max_iterations
  double wall_s = 0.0;   // wall time (not part of any deterministic output)
};

// Runs the adjustment. Invalid options throw InputError listing every
// violation; problems of the data are statuses (never a throw, never a NaN in
// the result). Deterministic: the same input and options give the same bytes
// (apart from `seconds`).
CeresRefineResult RefineTwoView(const CeresRefineInput& input, const CeresRefineOptions& options);

}  // namespace hdabench::reference
