// Geometry core of the flight method: two-view triangulation with the
// navigation's relative pose, epipolar consistency, the landing-site plane fit
// (slope and roughness) and the predicted slope uncertainty (NOVA-C paper,
// "Triangulation" and "Plane fit"; docs/conventions.md for frames).
//
// Frames: cam1, cam2 are camera frames with OpenCV axes; `local` is ENU.
// Bearings are directions in a camera frame (calib::CameraModel::Unproject
// gives unit ones; any positive length is accepted here). Degenerate geometry
// is reported as a status, never as a NaN.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::hda {

// ---------------------------------------------------------------------------
// Triangulation

struct TriangulationOptions {
  // Smallest angle between the two rays (in cam1) for a usable point, degrees.
  // At 570 m slant range, 0.5 deg is a baseline of about 5 m across the line of
  // sight; below it the depth error grows beyond a landing site's size.
  double min_parallax_deg = 0.5;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

enum class TriangulationStatus {
  kOk,
  kParallelRays,  // parallax below options.min_parallax_deg (or above 180 - it)
  kBehindCamera,  // the closest point lies at a distance <= 0 along either ray
  kNonFinite,     // a bearing or the pose is not finite, or a bearing has zero length
};
const char* ToString(TriangulationStatus status);

// Midpoint triangulation. Ray 1 is s1 * d1 from cam1's centre (the origin),
// ray 2 is c2 + s2 * d2 with c2 = -R^T t the centre of cam2 in cam1 and
// d2 = R^T bearing2 (R, t of cam2_from_cam1); d1, d2 normalised. The closest
// points of the two rays are found with n = d1 x d2:
//   s1 = ((c2 x d2) . n) / |n|^2,   s2 = ((c2 x d1) . n) / |n|^2,
// and the point is their midpoint (s1 d1 + c2 + s2 d2) / 2, in cam1, metres.
// The parallax is the angle between d1 and d2, degrees in [0, 180].
// Status order: kNonFinite, then kParallelRays, then kBehindCamera (s1 <= 0 or
// s2 <= 0: the depth along a ray, so it works for bearings of any direction).
// Outputs: *point_in_cam1 is written only on kOk; *parallax_deg (may be null)
// is written unless the status is kNonFinite. The scale of the point is the
// scale of cam2_from_cam1's translation (the nav baseline, metres).
TriangulationStatus TriangulateMidpoint(const Eigen::Vector3d& bearing1_in_cam1,
                                        const Eigen::Vector3d& bearing2_in_cam2,
                                        const Rigid3d& cam2_from_cam1,
                                        const TriangulationOptions& options,
                                        Eigen::Vector3d* point_in_cam1, double* parallax_deg);

// Epipolar consistency of a correspondence with the nav pose, radians in
// [0, pi/2]: the angle between bearing2 and the epipolar plane of bearing1,
// i.e. the plane through cam2's centre spanned by the baseline t and R bearing1
// (all in cam2). Equals asin(|b2 . (t x R b1)| / (|b2| |t x R b1|)), which is
// 0 for an exact correspondence and about offset_px / focal_px for a match
// moved by offset_px across the epipolar line. Where the plane is undefined the
// constraint degenerates to a line and the angle to that line is returned
// instead: bearing1 at the epipole (R b1 parallel to t) -> angle between b2 and
// the line of t; zero baseline (pure rotation) -> angle between b2 and R b1.
// Returns +infinity for non-finite or zero-length input, so that any threshold
// rejects it.
double EpipolarAngleRad(const Eigen::Vector3d& bearing1_in_cam1,
                        const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1);

// Covariance (3x3, m^2, in cam1) of the midpoint-triangulated point of two
// bearings when each bearing has isotropic angular noise of sigma_rad per axis
// of its tangent plane: sigma_rad^2 J J^T, with J (3x4) the derivative of the
// point with respect to the four tangent perturbations (central differences).
// About range^2 sigma / baseline_perp along the line of sight and
// range sigma across it. Returns false (and leaves *covariance_in_cam1 as it
// was) for non-finite or zero-length input or when a perturbed pair cannot be
// triangulated (parallel rays, behind a camera).
bool TriangulationCovariance(const Eigen::Vector3d& bearing1_in_cam1,
                             const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1,
                             double sigma_rad, Eigen::Matrix3d* covariance_in_cam1);

// Sampson distance of the correspondence under the essential matrix
// E = [t]x R, in pixels of a pinhole camera of focal length focal_px: with
// x1 = b1 / b1.z and x2 = b2 / b2.z (normalised image points),
//   d = focal_px * |x2^T E x1| / sqrt((E x1)_0^2 + (E x1)_1^2 + (E^T x2)_0^2 + (E^T x2)_1^2).
// This is the first-order geometric error spread over both images: a match
// moved by o pixels across its epipolar line in image 2 only gives about
// o / sqrt(2) when both epipolar gradients are alike. Scale-free in t.
// Returns +infinity when a bearing has z <= 0, an input is not finite,
// focal_px <= 0, or the epipolar gradients vanish (zero baseline, epipole).
double SampsonErrorPx(const Eigen::Vector3d& bearing1_in_cam1,
                      const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1,
                      double focal_px);

// ---------------------------------------------------------------------------
// Plane fit

enum class PlaneFitStatus {
  kOk,
  kTooFewPoints,  // fewer than max(min_points, 3) points
  kDegenerate,    // collinear (or coincident) points: no unique plane
  kInvalidInput,  // a point or the gravity is not finite, or the gravity is zero
};
const char* ToString(PlaneFitStatus status);

// Points whose second covariance eigenvalue is at most this fraction of the
// largest are collinear (spread across the line below 1e-6 of the spread along it).
inline constexpr double kCollinearEigenvalueRatio = 1e-12;

struct PlaneFitResult {
  PlaneFitStatus status = PlaneFitStatus::kTooFewPoints;
  int num_points = 0;                                                // points given
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();         // unit, n . up > 0
  Eigen::Vector3d centroid_in_local_m = Eigen::Vector3d::Zero();      // mean of the points
  double slope_deg = 0.0;        // angle between the normal and up, degrees
  double roughness_rms_m = 0.0;  // RMS of |n . (p - centroid)|, metres
  double roughness_max_m = 0.0;  // max of |n . (p - centroid)|, metres
};

// Total least squares plane through points_in_local: the normal is the
// eigenvector of the smallest eigenvalue of the points' covariance about their
// centroid, oriented up (up = -gravity / |gravity|). slope_deg = angle(n, up),
// computed as atan2(|n x up|, n . up) (exact near 0, where acos is not).
// These are the definitions of the bench's truth (datasets/synth/truth.h), so
// flight and truth compare like with like. kDegenerate when the middle
// eigenvalue is <= kCollinearEigenvalueRatio * the largest (or the largest is 0).
// On a status other than kOk only status and num_points are meaningful.
PlaneFitResult FitPlane(const std::vector<Eigen::Vector3d>& points_in_local,
                        const Eigen::Vector3d& gravity_in_local, int min_points);

// Plane fit for points with known, anisotropic noise (errors in variables).
// Two-view points are much less certain along the line of sight than across
// it; TLS then tilts the plane toward the line of sight (in the NOVA-C
// geometry, 0.3 px of matching noise adds about 8 deg to a 7 deg slope). This
// fit takes the normal that minimises
//   sum_i (n . (p_i - c))^2 / (n^T C n),   C = mean of the covariances,
// the generalized eigenvector of (scatter, C) with the smallest eigenvalue:
// the expected scatter along n is sum of the true off-plane spread plus
// N n^T C n, so the ratio is smallest at the true normal whatever the shape of
// C (consistent where TLS is not). The centroid is the plain mean, and
// roughness is measured along the new normal as in FitPlane. Statuses as
// FitPlane's, plus kInvalidInput when the covariances are not one per point or
// not finite. With all covariances zero the result is FitPlane's.
PlaneFitResult FitPlaneWithCovariance(const std::vector<Eigen::Vector3d>& points_in_local,
                                      const std::vector<Eigen::Matrix3d>& covariances_in_local,
                                      const Eigen::Vector3d& gravity_in_local, int min_points);

// ---------------------------------------------------------------------------
// Predicted slope uncertainty

struct SlopeSigmaOptions {
  double pixel_sigma_px = 0.5;      // std of a matched keypoint's position, per image axis, pixels
  double focal_px = 1500.0;         // focal length, pixels: angular noise = pixel_sigma_px / focal_px rad
  double baseline_sigma_m = 0.0;    // std of the nav relative translation, per axis, metres
  double attitude_sigma_deg = 0.0;  // std of the nav attitude of cam1 in local, per axis, degrees
  // Side of the square image-1 window each match's position is estimated
  // from, pixels. Two matches whose windows share pixels share that part of
  // the image noise: their errors correlate by the shared fraction of a
  // window, (1 - |du| / w)(1 - |dv| / w) for image-1 offsets du, dv under w.
  // 0: every match independent. Needs the image-1 pixels of the points.
  double match_window_px = 0.0;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// The correlation of two matches' errors whose image-1 windows of side
// window_px are centred `offset_px` apart: the shared fraction of a window,
// (1 - |du| / w)(1 - |dv| / w), 0 once either offset reaches w. With
// window_px <= 0, 1 at a zero offset and 0 elsewhere (independent matches).
double SharedWindowFraction(const Eigen::Vector2d& offset_px, double window_px);

// The noise per image axis of one match, pixels, from the spread of the
// matches' residuals: sum_squares is the sum of squared deviations of n
// residuals from their mean. With correlated errors (correlation rho_ij) the
// expected sum is sigma^2 (n - sum_ij rho_ij / n), less than (n - 1) sigma^2;
// this divides by it. 0 when fewer than 2 residuals or the divisor vanishes.
double SpreadOfCorrelatedResidualsPx(double sum_squares, const std::vector<Eigen::Vector2d>& pixels_px,
                                     double window_px);

// The contributions, each the slope std it alone would give, degrees; the
// total is their root sum of squares.
struct SlopeSigmaTerms {
  PlaneFitStatus status = PlaneFitStatus::kTooFewPoints;
  double pixel_deg = 0.0;
  double baseline_deg = 0.0;
  double attitude_deg = 0.0;
  // Set by the flight method after the prediction (hda/pipeline.h): the
  // slope change its matches' windows lean by on the fitted plane, carried
  // in its sigma where it is not corrected; 0 here.
  double lean_deg = 0.0;
};

// First-order slope std, degrees, of the plane fitted to points triangulated
// from two views, given the (noise-free estimate of the) points in cam1, the
// nav pose cam2_from_cam1 and up (= -gravity) in cam1. Model:
//  * pixel noise: each bearing gets isotropic angular noise
//    sigma_a = pixel_sigma_px / focal_px rad in its tangent plane (a pinhole
//    near the image centre). With match_window_px and the points' image-1
//    pixels, the errors of two points along the normal correlate by
//    SharedWindowFraction of their pixels (the same sign: the points of one
//    site have nearly the same geometry), so the sandwich's middle term is
//    sum_ij rho_ij sigma_perp_i sigma_perp_j a_i a_j^T; without, rho is the
//    identity. The 3x4 Jacobian J_i of the midpoint
//    triangulation w.r.t. the two bearings' tangent perturbations (central
//    differences) gives Cov(X_i) = sigma_a^2 J_i J_i^T: about
//    range^2 sigma_a / baseline_perp along the line of sight and
//    range sigma_a across it. Only the component along the plane normal n
//    moves the fit to first order: sigma_perp_i^2 = n^T Cov(X_i) n. The TLS
//    normal then tilts like the regression h = a + b u + c v of the
//    perpendicular offsets on in-plane coordinates (u, v) about the centroid;
//    with A = [1 u_i v_i], Cov(a,b,c) = (A^T A)^-1 A^T diag(sigma_perp_i^2) A
//    (A^T A)^-1. (For N points uniform over a square of side L with equal
//    sigma_perp this is sigma_tilt ~ sqrt(12 / N) sigma_perp / L per axis.)
//  * baseline: each axis of t perturbed by baseline_sigma_m, all points
//    re-triangulated from their exact bearings and the plane refitted (central
//    differences); a pure scale error leaves the slope unchanged, a direction
//    error distorts the cloud and tilts it.
//  * attitude: an error of cam1's attitude rotates the whole cloud: the normal
//    tilts by attitude_sigma_deg per axis.
// The three tilt covariances add; the slope std is the tilt along the dip
// direction (up projected on the plane); on a level patch (slope < 1e-6 rad),
// where the dip is undefined, the per-axis RMS sqrt(trace / 2) is returned.
// The relative rotation from nav is taken as exact.
// Validity: first order, so only while each point's sigma_perp is well below
// the patch size. In the paper's geometry (566 m slant range, 30 m baseline
// across the line of sight, f = 1500 px, 10 m site, 400 points) Monte Carlo
// agrees within 3 % at 0.05 px and 6 % at 0.1 px; at 0.3 px (depth sigma
// ~3 m) the TLS fit is no longer linear: the real std is 0.64 of the
// prediction and the mean slope is biased by about +8 deg, because the noise
// along the line of sight stretches the cloud toward it.
// The plane's normal is the TLS fit of the points unless normal_in_cam1 is
// given (the normal of another estimator, e.g. FitPlaneWithCovariance).
// Returns +infinity (and terms->status says why) when the plane cannot be
// fitted (fewer than 3 points, collinear, non-finite, a zero normal given) or a
// point cannot be triangulated back (zero parallax, behind a camera), and
// kInvalidInput when pixels1_px is given but not one per point. Options must
// be valid.
double PredictSlopeSigmaDeg(const SlopeSigmaOptions& options,
                            const std::vector<Eigen::Vector3d>& points_in_cam1,
                            const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& up_in_cam1,
                            SlopeSigmaTerms* terms = nullptr,
                            const Eigen::Vector3d* normal_in_cam1 = nullptr,
                            const std::vector<Eigen::Vector2d>* pixels1_px = nullptr);

}  // namespace hdabench::hda
