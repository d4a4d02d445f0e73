#include "hda/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "tools/util/options_check.h"
#include "tools/util/angles.h"

namespace hdabench::hda {

namespace {

using util::kPi;
using util::kDegToRad;
using util::kRadToDeg;
using util::kInfinity;

bool IsFinite(const Eigen::Vector3d& v) { return v.allFinite(); }

bool IsFinite(const Rigid3d& pose) { return pose.AllFinite(); }

// Angle between two non-zero vectors, radians in [0, pi]; atan2 keeps full
// precision near 0 and pi, where acos of the dot product does not.
double AngleRad(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Two unit vectors completing the unit vector d to an orthonormal basis.
void TangentBasis(const Eigen::Vector3d& d, Eigen::Vector3d* e1, Eigen::Vector3d* e2) {
  // Cross with the axis least aligned with d: never near-parallel.
  Eigen::Index axis = 0;
  d.cwiseAbs().minCoeff(&axis);
  *e1 = d.cross(Eigen::Vector3d::Unit(axis)).normalized();
  *e2 = d.cross(*e1);
}

}  // namespace

// ---------------------------------------------------------------------------
// Triangulation

std::vector<std::string> TriangulationOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(min_parallax_deg > 0 && min_parallax_deg < 90, "min_parallax_deg", min_parallax_deg,
          "in (0, 90)", &errors);
  return errors;
}

const char* ToString(TriangulationStatus status) {
  switch (status) {
    case TriangulationStatus::kOk:
      return "ok";
    case TriangulationStatus::kParallelRays:
      return "parallel rays";
    case TriangulationStatus::kBehindCamera:
      return "behind camera";
    case TriangulationStatus::kNonFinite:
      return "non-finite input";
  }
  return "unknown";
}

TriangulationStatus TriangulateMidpoint(const Eigen::Vector3d& bearing1_in_cam1,
                                        const Eigen::Vector3d& bearing2_in_cam2,
                                        const Rigid3d& cam2_from_cam1,
                                        const TriangulationOptions& options,
                                        Eigen::Vector3d* point_in_cam1, double* parallax_deg) {
  if (!IsFinite(bearing1_in_cam1) || !IsFinite(bearing2_in_cam2) || !IsFinite(cam2_from_cam1) ||
      bearing1_in_cam1.norm() == 0.0 || bearing2_in_cam2.norm() == 0.0 ||
      cam2_from_cam1.rotation.norm() == 0.0) {
    return TriangulationStatus::kNonFinite;
  }
  const Eigen::Matrix3d cam1_from_cam2_rotation =
      cam2_from_cam1.rotation.normalized().toRotationMatrix().transpose();
  const Eigen::Vector3d d1 = bearing1_in_cam1.normalized();
  const Eigen::Vector3d d2 = (cam1_from_cam2_rotation * bearing2_in_cam2).normalized();
  const Eigen::Vector3d c2 = -(cam1_from_cam2_rotation * cam2_from_cam1.translation);

  const Eigen::Vector3d n = d1.cross(d2);
  const double sin_parallax = n.norm();
  if (parallax_deg != nullptr) *parallax_deg = std::atan2(sin_parallax, d1.dot(d2)) * kRadToDeg;
  // Parallel and anti-parallel rays alike have no unique closest points.
  if (sin_parallax < std::sin(options.min_parallax_deg * kDegToRad)) {
    return TriangulationStatus::kParallelRays;
  }
  const double n_squared = n.squaredNorm();
  const double s1 = c2.cross(d2).dot(n) / n_squared;
  const double s2 = c2.cross(d1).dot(n) / n_squared;
  if (!(s1 > 0.0) || !(s2 > 0.0)) return TriangulationStatus::kBehindCamera;
  const Eigen::Vector3d point = 0.5 * (s1 * d1 + c2 + s2 * d2);
  if (!IsFinite(point)) return TriangulationStatus::kNonFinite;
  *point_in_cam1 = point;
  return TriangulationStatus::kOk;
}

double EpipolarAngleRad(const Eigen::Vector3d& bearing1_in_cam1,
                        const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1) {
  if (!IsFinite(bearing1_in_cam1) || !IsFinite(bearing2_in_cam2) || !IsFinite(cam2_from_cam1) ||
      bearing1_in_cam1.norm() == 0.0 || bearing2_in_cam2.norm() == 0.0 ||
      cam2_from_cam1.rotation.norm() == 0.0) {
    return kInfinity;
  }
  const Eigen::Vector3d b2 = bearing2_in_cam2.normalized();
  const Eigen::Vector3d r_b1 = (cam2_from_cam1.rotation.normalized() * bearing1_in_cam1).normalized();
  const Eigen::Vector3d& t = cam2_from_cam1.translation;
  const double t_norm = t.norm();
  if (t_norm == 0.0) return AngleRad(b2, r_b1);  // pure rotation: b2 must equal R b1
  const Eigen::Vector3d plane_normal = (t / t_norm).cross(r_b1);
  // sin of the angle between R b1 and the baseline: below this the plane is
  // numerically undefined and the ray of bearing1 images to the epipole only.
  constexpr double kMinSinEpipole = 1e-12;
  const double plane_normal_norm = plane_normal.norm();
  if (plane_normal_norm < kMinSinEpipole) {
    const double angle = AngleRad(b2, t);
    return std::min(angle, kPi - angle);
  }
  return std::asin(std::min(1.0, std::abs(b2.dot(plane_normal)) / plane_normal_norm));
}

double SampsonErrorPx(const Eigen::Vector3d& bearing1_in_cam1,
                      const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1,
                      double focal_px) {
  if (!IsFinite(bearing1_in_cam1) || !IsFinite(bearing2_in_cam2) || !IsFinite(cam2_from_cam1) ||
      !std::isfinite(focal_px) || focal_px <= 0.0 || !(bearing1_in_cam1.z() > 0.0) ||
      !(bearing2_in_cam2.z() > 0.0) || cam2_from_cam1.rotation.norm() == 0.0) {
    return kInfinity;
  }
  const Eigen::Vector3d x1 = bearing1_in_cam1 / bearing1_in_cam1.z();
  const Eigen::Vector3d x2 = bearing2_in_cam2 / bearing2_in_cam2.z();
  Eigen::Matrix3d t_cross;
  const Eigen::Vector3d& t = cam2_from_cam1.translation;
  t_cross << 0.0, -t.z(), t.y(), t.z(), 0.0, -t.x(), -t.y(), t.x(), 0.0;
  const Eigen::Matrix3d essential =
      t_cross * cam2_from_cam1.rotation.normalized().toRotationMatrix();
  const Eigen::Vector3d line2 = essential * x1;              // epipolar line in image 2
  const Eigen::Vector3d line1 = essential.transpose() * x2;  // epipolar line in image 1
  const double gradient_squared = line2.head<2>().squaredNorm() + line1.head<2>().squaredNorm();
  if (!(gradient_squared > 0.0)) return kInfinity;
  return focal_px * std::abs(x2.dot(line2)) / std::sqrt(gradient_squared);
}

// ---------------------------------------------------------------------------
// Plane fit

const char* ToString(PlaneFitStatus status) {
  switch (status) {
    case PlaneFitStatus::kOk:
      return "ok";
    case PlaneFitStatus::kTooFewPoints:
      return "too few points";
    case PlaneFitStatus::kDegenerate:
      return "collinear points";
    case PlaneFitStatus::kInvalidInput:
      return "non-finite point or invalid gravity";
  }
  return "unknown";
}

namespace {

// Checks shared by the plane fits: enough points, all finite, gravity usable.
// Fills status/num_points; on success *up is the unit up vector.
bool CheckPlaneInput(const std::vector<Eigen::Vector3d>& points_in_local,
                     const Eigen::Vector3d& gravity_in_local, int min_points, PlaneFitResult* result,
                     Eigen::Vector3d* up) {
  result->num_points = static_cast<int>(points_in_local.size());
  if (result->num_points < std::max(min_points, 3)) {
    result->status = PlaneFitStatus::kTooFewPoints;
    return false;
  }
  const double gravity_norm = gravity_in_local.norm();
  if (!IsFinite(gravity_in_local) || !(gravity_norm > 0.0) ||
      !std::all_of(points_in_local.begin(), points_in_local.end(),
                   [](const Eigen::Vector3d& p) { return IsFinite(p); })) {
    result->status = PlaneFitStatus::kInvalidInput;
    return false;
  }
  *up = -gravity_in_local / gravity_norm;
  return true;
}

Eigen::Vector3d Centroid(const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  return centroid / static_cast<double>(points.size());
}

Eigen::Matrix3d Scatter(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centroid) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : points) scatter += (p - centroid) * (p - centroid).transpose();
  return scatter;
}

// Slope and roughness of the plane (normal, centroid) through the points.
void FinishPlane(const std::vector<Eigen::Vector3d>& points, Eigen::Vector3d normal,
                 const Eigen::Vector3d& centroid, const Eigen::Vector3d& up, PlaneFitResult* result) {
  normal.normalize();
  if (normal.dot(up) < 0.0) normal = -normal;
  result->status = PlaneFitStatus::kOk;
  result->normal_in_local = normal;
  result->centroid_in_local_m = centroid;
  result->slope_deg = AngleRad(normal, up) * kRadToDeg;
  double sum_squares = 0.0;
  result->roughness_max_m = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const double distance = std::abs(normal.dot(p - centroid));
    sum_squares += distance * distance;
    result->roughness_max_m = std::max(result->roughness_max_m, distance);
  }
  result->roughness_rms_m = std::sqrt(sum_squares / static_cast<double>(points.size()));
}

}  // namespace

PlaneFitResult FitPlane(const std::vector<Eigen::Vector3d>& points_in_local,
                        const Eigen::Vector3d& gravity_in_local, int min_points) {
  PlaneFitResult result;
  Eigen::Vector3d up;
  if (!CheckPlaneInput(points_in_local, gravity_in_local, min_points, &result, &up)) return result;
  const Eigen::Vector3d centroid = Centroid(points_in_local);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(Scatter(points_in_local, centroid));
  const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
  if (!(eigenvalues(2) > 0.0) || eigenvalues(1) <= kCollinearEigenvalueRatio * eigenvalues(2)) {
    result.status = PlaneFitStatus::kDegenerate;
    return result;
  }
  FinishPlane(points_in_local, solver.eigenvectors().col(0), centroid, up, &result);
  return result;
}

PlaneFitResult FitPlaneWithCovariance(const std::vector<Eigen::Vector3d>& points_in_local,
                                      const std::vector<Eigen::Matrix3d>& covariances_in_local,
                                      const Eigen::Vector3d& gravity_in_local, int min_points) {
  // The Euclidean fit gives the statuses (and the answer when there is no noise).
  PlaneFitResult result = FitPlane(points_in_local, gravity_in_local, min_points);
  if (result.status != PlaneFitStatus::kOk) return result;
  if (covariances_in_local.size() != points_in_local.size() ||
      !std::all_of(covariances_in_local.begin(), covariances_in_local.end(),
                   [](const Eigen::Matrix3d& c) { return c.allFinite(); })) {
    result = PlaneFitResult();
    result.num_points = static_cast<int>(points_in_local.size());
    result.status = PlaneFitStatus::kInvalidInput;
    return result;
  }
  Eigen::Matrix3d noise = Eigen::Matrix3d::Zero();
  for (const Eigen::Matrix3d& c : covariances_in_local) noise += 0.5 * (c + c.transpose());
  noise /= static_cast<double>(covariances_in_local.size());
  const double trace = noise.trace();
  if (!(trace > 0.0)) return result;  // no noise: the Euclidean fit is the answer
  // A small isotropic part keeps the metric positive definite when the
  // covariances are of rank 2 (it changes the normal by about 1e-9 rad).
  noise += 1e-9 * trace * Eigen::Matrix3d::Identity();
  const Eigen::Vector3d up = -gravity_in_local.normalized();
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::Matrix3d> solver(
      Scatter(points_in_local, result.centroid_in_local_m), noise);
  if (solver.info() != Eigen::Success || !solver.eigenvectors().col(0).allFinite()) {
    result = PlaneFitResult();
    result.num_points = static_cast<int>(points_in_local.size());
    result.status = PlaneFitStatus::kDegenerate;
    return result;
  }
  FinishPlane(points_in_local, solver.eigenvectors().col(0), result.centroid_in_local_m, up,
              &result);
  return result;
}

// ---------------------------------------------------------------------------
// Predicted slope uncertainty

std::vector<std::string> SlopeSigmaOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(pixel_sigma_px >= 0, "pixel_sigma_px", pixel_sigma_px, ">= 0", &errors);
  RequireOption(focal_px > 0, "focal_px", focal_px, "> 0", &errors);
  RequireOption(baseline_sigma_m >= 0, "baseline_sigma_m", baseline_sigma_m, ">= 0", &errors);
  RequireOption(attitude_sigma_deg >= 0 && attitude_sigma_deg < 90, "attitude_sigma_deg",
          attitude_sigma_deg, "in [0, 90)", &errors);
  RequireOption(match_window_px >= 0, "match_window_px", match_window_px, ">= 0", &errors);
  return errors;
}

namespace {

// Triangulation inside the predictor only needs the rays not to be exactly
// parallel: low parallax shows up as a large predicted sigma instead.
TriangulationOptions PredictorTriangulationOptions() {
  TriangulationOptions options;
  options.min_parallax_deg = 1e-9;
  return options;
}

// Tilt covariance contribution (3x3, rad^2, in cam1) of a perturbed refit:
// the normal change projected off the nominal normal.
Eigen::Matrix3d TiltOuter(const Eigen::Vector3d& normal, Eigen::Vector3d perturbed) {
  if (perturbed.dot(normal) < 0.0) perturbed = -perturbed;
  const Eigen::Vector3d tilt = perturbed - normal * normal.dot(perturbed);
  return tilt * tilt.transpose();
}

// Slope std (rad) from a tilt covariance: along the dip direction, or the
// per-axis RMS on a level patch.
double SlopeSigmaFromTilt(const Eigen::Matrix3d& tilt_covariance, const Eigen::Vector3d& normal,
                          const Eigen::Vector3d& up) {
  const Eigen::Vector3d dip = up - normal * normal.dot(up);
  constexpr double kMinSlopeRad = 1e-6;
  if (dip.norm() < kMinSlopeRad) return std::sqrt(std::max(0.0, tilt_covariance.trace() / 2.0));
  const Eigen::Vector3d g = dip.normalized();
  return std::sqrt(std::max(0.0, g.dot(tilt_covariance * g)));
}

}  // namespace

bool TriangulationCovariance(const Eigen::Vector3d& bearing1_in_cam1,
                             const Eigen::Vector3d& bearing2_in_cam2, const Rigid3d& cam2_from_cam1,
                             double sigma_rad, Eigen::Matrix3d* covariance_in_cam1) {
  if (!IsFinite(bearing1_in_cam1) || !IsFinite(bearing2_in_cam2) || !IsFinite(cam2_from_cam1) ||
      !std::isfinite(sigma_rad) || bearing1_in_cam1.norm() == 0.0 ||
      bearing2_in_cam2.norm() == 0.0) {
    return false;
  }
  const Eigen::Vector3d b1 = bearing1_in_cam1.normalized();
  const Eigen::Vector3d b2 = bearing2_in_cam2.normalized();
  const TriangulationOptions triangulation = PredictorTriangulationOptions();
  // Step of the central differences, radians: large enough against rounding
  // at 1e3 m ranges, small against the curvature of the triangulation.
  constexpr double kStepRad = 1e-6;
  Eigen::Matrix<double, 3, 4> jacobian;
  for (int k = 0; k < 4; ++k) {
    const bool first = k < 2;
    Eigen::Vector3d e1, e2;
    TangentBasis(first ? b1 : b2, &e1, &e2);
    const Eigen::Vector3d step = kStepRad * ((k % 2 == 0) ? e1 : e2);
    Eigen::Vector3d plus, minus;
    const Eigen::Vector3d b1_plus = first ? Eigen::Vector3d(b1 + step) : b1;
    const Eigen::Vector3d b1_minus = first ? Eigen::Vector3d(b1 - step) : b1;
    const Eigen::Vector3d b2_plus = first ? b2 : Eigen::Vector3d(b2 + step);
    const Eigen::Vector3d b2_minus = first ? b2 : Eigen::Vector3d(b2 - step);
    if (TriangulateMidpoint(b1_plus, b2_plus, cam2_from_cam1, triangulation, &plus, nullptr) !=
            TriangulationStatus::kOk ||
        TriangulateMidpoint(b1_minus, b2_minus, cam2_from_cam1, triangulation, &minus, nullptr) !=
            TriangulationStatus::kOk) {
      return false;
    }
    jacobian.col(k) = (plus - minus) / (2.0 * kStepRad);
  }
  *covariance_in_cam1 = sigma_rad * sigma_rad * jacobian * jacobian.transpose();
  return true;
}

double SharedWindowFraction(const Eigen::Vector2d& offset_px, double window_px) {
  if (!(window_px > 0.0)) return offset_px.isZero() ? 1.0 : 0.0;
  const double share_u = 1.0 - std::abs(offset_px.x()) / window_px;
  const double share_v = 1.0 - std::abs(offset_px.y()) / window_px;
  return share_u > 0.0 && share_v > 0.0 ? share_u * share_v : 0.0;
}

double SpreadOfCorrelatedResidualsPx(double sum_squares, const std::vector<Eigen::Vector2d>& pixels_px,
                                     double window_px) {
  const size_t n = pixels_px.size();
  if (n < 2 || !std::isfinite(sum_squares) || sum_squares < 0.0) return 0.0;
  double correlation_sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    for (size_t j = 0; j < n; ++j) correlation_sum += SharedWindowFraction(pixels_px[i] - pixels_px[j], window_px);
  }
  const double divisor = static_cast<double>(n) - correlation_sum / static_cast<double>(n);
  return divisor > 0.0 ? std::sqrt(sum_squares / divisor) : 0.0;
}

double PredictSlopeSigmaDeg(const SlopeSigmaOptions& options,
                            const std::vector<Eigen::Vector3d>& points_in_cam1,
                            const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& up_in_cam1,
                            SlopeSigmaTerms* terms, const Eigen::Vector3d* normal_in_cam1,
                            const std::vector<Eigen::Vector2d>* pixels1_px) {
  SlopeSigmaTerms local_terms;
  SlopeSigmaTerms& out = terms != nullptr ? *terms : local_terms;
  out = SlopeSigmaTerms();
  if (!IsFinite(cam2_from_cam1) || cam2_from_cam1.rotation.norm() == 0.0 ||
      (pixels1_px != nullptr && pixels1_px->size() != points_in_cam1.size())) {
    out.status = PlaneFitStatus::kInvalidInput;
    return kInfinity;
  }
  // The nominal plane, fitted in cam1 with gravity = -up.
  const PlaneFitResult plane = FitPlane(points_in_cam1, -up_in_cam1, 3);
  out.status = plane.status;
  if (plane.status != PlaneFitStatus::kOk) return kInfinity;
  const Eigen::Vector3d up = up_in_cam1.normalized();
  Eigen::Vector3d normal = plane.normal_in_local;  // in cam1 here
  if (normal_in_cam1 != nullptr) {
    if (!IsFinite(*normal_in_cam1) || normal_in_cam1->norm() == 0.0) {
      out.status = PlaneFitStatus::kInvalidInput;
      return kInfinity;
    }
    normal = normal_in_cam1->normalized();
    if (normal.dot(up) < 0.0) normal = -normal;
  }
  const Rigid3d pose(cam2_from_cam1.rotation.normalized(), cam2_from_cam1.translation);
  const TriangulationOptions triangulation = PredictorTriangulationOptions();

  // Exact bearings of the nominal points.
  const size_t n = points_in_cam1.size();
  std::vector<Eigen::Vector3d> bearings1(n), bearings2(n);
  for (size_t i = 0; i < n; ++i) {
    bearings1[i] = points_in_cam1[i].normalized();
    bearings2[i] = (pose * points_in_cam1[i]).normalized();
  }

  // Pixel noise: per-point covariance along the normal, then the regression
  // sandwich in the plane's coordinates.
  Eigen::Vector3d u, v;
  TangentBasis(normal, &u, &v);
  const double sigma_angle_rad = options.pixel_sigma_px / options.focal_px;
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();  // A^T A
  std::vector<Eigen::Vector3d> weighted_rows(n);            // sigma_perp_i a_i
  for (size_t i = 0; i < n; ++i) {
    Eigen::Matrix3d point_covariance;
    if (!TriangulationCovariance(bearings1[i], bearings2[i], pose, sigma_angle_rad,
                                 &point_covariance)) {
      out.status = PlaneFitStatus::kDegenerate;
      return kInfinity;
    }
    const double sigma_perp = std::sqrt(std::max(0.0, normal.dot(point_covariance * normal)));
    const Eigen::Vector3d offset = points_in_cam1[i] - plane.centroid_in_local_m;
    const Eigen::Vector3d row(1.0, u.dot(offset), v.dot(offset));
    normal_matrix += row * row.transpose();
    weighted_rows[i] = sigma_perp * row;
  }
  // A^T Cov A with Cov_ij = rho_ij sigma_perp_i sigma_perp_j.
  Eigen::Matrix3d meat = Eigen::Matrix3d::Zero();
  const bool correlated = pixels1_px != nullptr && options.match_window_px > 0.0;
  for (size_t i = 0; i < n; ++i) {
    meat += weighted_rows[i] * weighted_rows[i].transpose();
    if (!correlated) continue;
    for (size_t j = i + 1; j < n; ++j) {
      const double rho = SharedWindowFraction((*pixels1_px)[i] - (*pixels1_px)[j], options.match_window_px);
      if (rho == 0.0) continue;
      const Eigen::Matrix3d cross = rho * weighted_rows[i] * weighted_rows[j].transpose();
      meat += cross + cross.transpose();
    }
  }
  const Eigen::Matrix3d bread = normal_matrix.inverse();
  const Eigen::Matrix3d coefficients_covariance = bread * meat * bread;
  // The normal n - b u - c v: tilt covariance from the (b, c) block.
  Eigen::Matrix<double, 3, 2> in_plane;
  in_plane.col(0) = u;
  in_plane.col(1) = v;
  const Eigen::Matrix3d pixel_tilt =
      in_plane * coefficients_covariance.bottomRightCorner<2, 2>() * in_plane.transpose();

  // Baseline: re-triangulate with each translation axis perturbed by one sigma.
  Eigen::Matrix3d baseline_tilt = Eigen::Matrix3d::Zero();
  if (options.baseline_sigma_m > 0.0) {
    std::vector<Eigen::Vector3d> points_plus(n), points_minus(n);
    for (int axis = 0; axis < 3; ++axis) {
      Rigid3d pose_plus = pose, pose_minus = pose;
      pose_plus.translation(axis) += options.baseline_sigma_m;
      pose_minus.translation(axis) -= options.baseline_sigma_m;
      for (size_t i = 0; i < n; ++i) {
        if (TriangulateMidpoint(bearings1[i], bearings2[i], pose_plus, triangulation,
                                &points_plus[i], nullptr) != TriangulationStatus::kOk ||
            TriangulateMidpoint(bearings1[i], bearings2[i], pose_minus, triangulation,
                                &points_minus[i], nullptr) != TriangulationStatus::kOk) {
          out.status = PlaneFitStatus::kDegenerate;
          return kInfinity;
        }
      }
      const PlaneFitResult fit_plus = FitPlane(points_plus, -up, 3);
      const PlaneFitResult fit_minus = FitPlane(points_minus, -up, 3);
      if (fit_plus.status != PlaneFitStatus::kOk || fit_minus.status != PlaneFitStatus::kOk) {
        out.status = PlaneFitStatus::kDegenerate;
        return kInfinity;
      }
      // Central difference of the normal: (n+ - n-) / 2 per sigma.
      Eigen::Vector3d n_plus = fit_plus.normal_in_local, n_minus = fit_minus.normal_in_local;
      if (n_plus.dot(normal) < 0.0) n_plus = -n_plus;
      if (n_minus.dot(normal) < 0.0) n_minus = -n_minus;
      baseline_tilt += TiltOuter(normal, normal + 0.5 * (n_plus - n_minus));
    }
  }

  // Attitude: a rotation by a small angle vector w moves n by w x n.
  const double attitude_sigma_rad = options.attitude_sigma_deg * kDegToRad;
  const Eigen::Matrix3d attitude_tilt = attitude_sigma_rad * attitude_sigma_rad *
                                        (Eigen::Matrix3d::Identity() - normal * normal.transpose());

  out.pixel_deg = SlopeSigmaFromTilt(pixel_tilt, normal, up) * kRadToDeg;
  out.baseline_deg = SlopeSigmaFromTilt(baseline_tilt, normal, up) * kRadToDeg;
  out.attitude_deg = SlopeSigmaFromTilt(attitude_tilt, normal, up) * kRadToDeg;
  return SlopeSigmaFromTilt(pixel_tilt + baseline_tilt + attitude_tilt, normal, up) * kRadToDeg;
}

}  // namespace hdabench::hda
