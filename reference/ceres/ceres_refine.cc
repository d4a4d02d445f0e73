#include "reference/ceres/ceres_refine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <ceres/autodiff_cost_function.h>
#include <ceres/dynamic_autodiff_cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/manifold.h>
#include <ceres/ordered_groups.h>
#include <ceres/problem.h>
#include <ceres/rotation.h>
#include <ceres/solver.h>

#include "tools/util/error.h"
#include "tools/util/angles.h"
#include "tools/util/text.h"
#include "tools/util/options_check.h"

namespace hdabench::reference {

namespace {

// A cost in the refinement's note, with 17 significant digits: the note goes
// into compare.json and compare.md, which have always printed costs so.
std::string CostText(double cost) {
  std::ostringstream out;
  out.precision(17);
  out << cost;
  return out.str();
}

using util::kDegToRad;

// A unit quaternion is accepted within this of norm 1 (docs/conventions.md).
constexpr double kUnitQuaternionTolerance = 1e-6;
// The covariance is symmetric when its largest asymmetry is within this
// fraction of its largest entry.
constexpr double kSymmetryTolerance = 1e-9;
// Ceres's other stopping tests, kept tight so that the function tolerance and
// the iteration limit decide: the largest gradient component (whitened units)
// and the relative step size.
constexpr double kGradientTolerance = 1e-14;
constexpr double kParameterTolerance = 1e-14;

bool IsFinite(double value) { return std::isfinite(value); }

// Rows e1, e2, b: an orthonormal basis whose last row is the unit bearing b
// and whose first two span its tangent plane. e1 is built from the axis least
// aligned with b, so it is well defined for every direction.
Eigen::Matrix3d TangentBasis(const Eigen::Vector3d& unit_bearing) {
  const Eigen::Vector3d abs = unit_bearing.cwiseAbs();
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();
  if (abs.y() <= abs.x() && abs.y() <= abs.z()) {
    axis = Eigen::Vector3d::UnitY();
  } else if (abs.z() <= abs.x() && abs.z() <= abs.y()) {
    axis = Eigen::Vector3d::UnitZ();
  }
  const Eigen::Vector3d e1 = unit_bearing.cross(axis).normalized();
  const Eigen::Vector3d e2 = unit_bearing.cross(e1);
  Eigen::Matrix3d basis;
  basis.row(0) = e1.transpose();
  basis.row(1) = e2.transpose();
  basis.row(2) = unit_bearing.transpose();
  return basis;
}

// Gnomonic residual of a point P (in the observing camera) against the
// observed bearing: scale * (e1 . P, e2 . P) / (b . P). False (no residual)
// when P is not in front of the bearing's tangent plane.
template <typename T>
bool TangentResidual(const Eigen::Matrix3d& basis, double scale, const T* point, T* residual) {
  const T x = basis(0, 0) * point[0] + basis(0, 1) * point[1] + basis(0, 2) * point[2];
  const T y = basis(1, 0) * point[0] + basis(1, 1) * point[1] + basis(1, 2) * point[2];
  const T depth = basis(2, 0) * point[0] + basis(2, 1) * point[1] + basis(2, 2) * point[2];
  if (!(depth > T(0.0))) return false;
  residual[0] = scale * x / depth;
  residual[1] = scale * y / depth;
  return true;
}

// One match: its observation in camera 1 (the fixed gauge) and in camera 2
// (the point mapped by cam2_from_cam1), four residuals in one block so that
// the robust loss weighs the match as a whole. The rotation is an
// Eigen-ordered quaternion (x, y, z, w) on EigenQuaternionManifold.
struct MatchResidual {
  Eigen::Matrix3d basis1;
  Eigen::Matrix3d basis2;
  double scale;  // focal_px / pixel_sigma_px: whitened residuals

  template <typename T>
  bool operator()(const T* rotation_xyzw, const T* translation, const T* point_in_cam1,
                  T* residual) const {
    if (!TangentResidual(basis1, scale, point_in_cam1, residual)) return false;
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(rotation_xyzw);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> t(translation);
    const Eigen::Map<const Eigen::Matrix<T, 3, 1>> p(point_in_cam1);
    const Eigen::Matrix<T, 3, 1> point_in_cam2 = rotation * p + t;
    return TangentResidual(basis2, scale, point_in_cam2.data(), residual + 2);
  }
};

// Prior on camera 2's pose: W * (rotvec(R R_nav^T), t - t_nav), W the inverse
// Cholesky factor of the nav covariance (so the six residuals are whitened).
struct NavPriorResidual {
  Eigen::Quaterniond nav_rotation_inverse;
  Eigen::Vector3d nav_translation;
  Eigen::Matrix<double, 6, 6> whitening;

  template <typename T>
  bool operator()(const T* rotation_xyzw, const T* translation, T* residual) const {
    const Eigen::Map<const Eigen::Quaternion<T>> rotation(rotation_xyzw);
    const Eigen::Quaternion<T> delta = rotation * nav_rotation_inverse.cast<T>();
    const T delta_wxyz[4] = {delta.w(), delta.x(), delta.y(), delta.z()};
    Eigen::Matrix<T, 6, 1> error;
    ceres::QuaternionToAngleAxis(delta_wxyz, error.data());
    for (int k = 0; k < 3; ++k) error[3 + k] = translation[k] - T(nav_translation[k]);
    const Eigen::Matrix<T, 6, 1> whitened = whitening.cast<T>() * error;
    for (int k = 0; k < 6; ++k) residual[k] = whitened[k];
    return true;
  }
};

// The range finder on the ground around its spot: the range along the beam
// (unit, from `origin`) to the plane of normal `normal` through the centroid
// of the support's points, minus the measured range, over its sigma.
struct LrfResidual {
  Eigen::Vector3d origin;
  Eigen::Vector3d beam;
  Eigen::Vector3d normal;
  double range_m;
  double sigma_m;
  int num_points;

  template <typename T>
  bool operator()(T const* const* points, T* residual) const {
    Eigen::Matrix<T, 3, 1> centroid = Eigen::Matrix<T, 3, 1>::Zero();
    for (int k = 0; k < num_points; ++k) centroid += Eigen::Map<const Eigen::Matrix<T, 3, 1>>(points[k]);
    centroid /= T(num_points);
    const T range = normal.cast<T>().dot(centroid - origin.cast<T>()) / T(normal.dot(beam));
    residual[0] = (range - T(range_m)) / T(sigma_m);
    return true;
  }
};

// The covariance check and its whitening matrix; an empty string when usable.
std::string Whitening(const Eigen::Matrix<double, 6, 6>& covariance,
                      Eigen::Matrix<double, 6, 6>* whitening) {
  if (!covariance.allFinite()) return "nav covariance has a non-finite entry";
  const double largest = covariance.cwiseAbs().maxCoeff();
  const double asymmetry = (covariance - covariance.transpose()).cwiseAbs().maxCoeff();
  if (asymmetry > kSymmetryTolerance * largest) {
    return "nav covariance is not symmetric (largest asymmetry " + util::ShortestText(asymmetry) + ")";
  }
  const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(covariance);
  if (llt.info() != Eigen::Success) return "nav covariance is not positive definite";
  const Eigen::Matrix<double, 6, 6> lower = llt.matrixL();
  *whitening = lower.triangularView<Eigen::Lower>().solve(Eigen::Matrix<double, 6, 6>::Identity());
  if (!whitening->allFinite()) return "nav covariance is too close to singular";
  return "";
}

// The data checks, in order; an empty string when the input is usable.
std::string CheckInput(const CeresRefineInput& input) {
  if (!IsFinite(input.focal_px) || input.focal_px <= 0.0) {
    return "focal_px = " + util::ShortestText(input.focal_px) + ": expected a finite value > 0";
  }
  const size_t n = input.points_in_cam1_m.size();
  if (input.bearings1_in_cam1.size() != n || input.bearings2_in_cam2.size() != n) {
    return "sizes differ: " + std::to_string(input.bearings1_in_cam1.size()) + " bearings in cam1, " +
           std::to_string(input.bearings2_in_cam2.size()) + " in cam2, " + std::to_string(n) +
           " points";
  }
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d& b1 = input.bearings1_in_cam1[i];
    const Eigen::Vector3d& b2 = input.bearings2_in_cam2[i];
    if (!b1.allFinite() || b1.norm() <= 0.0) {
      return "bearing1[" + std::to_string(i) + "] = " + util::VectorText(b1) + ": expected finite, non-zero";
    }
    if (!b2.allFinite() || b2.norm() <= 0.0) {
      return "bearing2[" + std::to_string(i) + "] = " + util::VectorText(b2) + ": expected finite, non-zero";
    }
    if (!input.points_in_cam1_m[i].allFinite()) {
      return "point[" + std::to_string(i) + "] = " + util::VectorText(input.points_in_cam1_m[i]) +
             ": expected finite";
    }
  }
  const Rigid3d& nav = input.nav_cam2_from_cam1;
  if (!nav.rotation.coeffs().allFinite() || !nav.translation.allFinite()) {
    return "nav cam2_from_cam1 is not finite";
  }
  const double norm = nav.rotation.norm();
  if (std::abs(norm - 1.0) > kUnitQuaternionTolerance) {
    return "nav cam2_from_cam1 rotation has norm " + util::ShortestText(norm) + ": expected a unit quaternion";
  }
  if (input.lrf.has_value()) {
    const CeresRefineInput::Lrf& lrf = *input.lrf;
    if (!lrf.origin_in_cam1_m.allFinite() || !lrf.beam_in_cam1.allFinite() || !(lrf.beam_in_cam1.norm() > 0) ||
        !lrf.ground_normal_in_cam1.allFinite() || !(lrf.ground_normal_in_cam1.norm() > 0)) {
      return "lrf: origin " + util::VectorText(lrf.origin_in_cam1_m) + ", beam " +
             util::VectorText(lrf.beam_in_cam1) + ", ground normal " + util::VectorText(lrf.ground_normal_in_cam1) +
             ": expected finite, and a non-zero beam and normal";
    }
    for (const auto& [name, value] : {std::pair<const char*, double>{"range_m", lrf.range_m},
                                      {"range_sigma_m", lrf.range_sigma_m},
                                      {"support_radius_m", lrf.support_radius_m}}) {
      if (!(std::isfinite(value) && value > 0)) {
        return std::string("lrf: ") + name + " = " + util::ShortestText(value) + ": expected a finite value > 0";
      }
    }
    if (lrf.support_points < 3) {
      return "lrf: support_points = " + std::to_string(lrf.support_points) + ": expected >= 3";
    }
  }
  return "";
}

struct ProblemState {
  double rotation_xyzw[4];
  double translation[3];
  std::vector<double> points;  // 3 per point
};

ProblemState StateFrom(const Rigid3d& pose, const std::vector<Eigen::Vector3d>& points) {
  ProblemState state;
  const Eigen::Quaterniond q = pose.rotation.normalized();
  for (int k = 0; k < 4; ++k) state.rotation_xyzw[k] = q.coeffs()[k];
  for (int k = 0; k < 3; ++k) state.translation[k] = pose.translation[k];
  state.points.resize(3 * points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    for (int k = 0; k < 3; ++k) state.points[3 * i + k] = points[i][k];
  }
  return state;
}

Rigid3d PoseOf(const ProblemState& state) {
  Eigen::Quaterniond q(state.rotation_xyzw[3], state.rotation_xyzw[0], state.rotation_xyzw[1],
                       state.rotation_xyzw[2]);
  return Rigid3d(q.normalized(), Eigen::Vector3d(state.translation[0], state.translation[1],
                                                 state.translation[2]));
}

std::vector<Eigen::Vector3d> PointsOf(const ProblemState& state) {
  std::vector<Eigen::Vector3d> points(state.points.size() / 3);
  for (size_t i = 0; i < points.size(); ++i) {
    points[i] = Eigen::Vector3d(state.points[3 * i], state.points[3 * i + 1], state.points[3 * i + 2]);
  }
  return points;
}

double Seconds(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// ---------------------------------------------------------------------------
// RefineTwoView's steps, in the order it runs them.

using Matrix6d = Eigen::Matrix<double, 6, 6>;

// Options errors are the caller's bug: they throw, unlike problems of the data.
void ThrowIfInvalid(const CeresRefineOptions& options) {
  hdabench::ThrowIfInvalid("invalid Ceres refinement options: ", options.Validate());
}

// The result for data that cannot be refined: the nav pose when it is usable,
// so that the caller still has a pose.
CeresRefineResult InvalidInputResult(const std::string& problem, const Rigid3d& nav,
                                     std::chrono::steady_clock::time_point start) {
  CeresRefineResult result;
  result.status = CeresRefineStatus::kInvalidInput;
  result.failure = "invalid input: " + problem;
  if (nav.rotation.coeffs().allFinite() && nav.translation.allFinite() &&
      nav.rotation.norm() > 0.0) {
    result.cam2_from_cam1 = Rigid3d(nav.rotation.normalized(), nav.translation);
  }
  result.wall_s = Seconds(start);
  return result;
}

// The nav prior's covariance: the input's, else diagonal from the options'
// sigmas.
Matrix6d NavCovariance(const CeresRefineInput& input, const CeresRefineOptions& options) {
  Matrix6d covariance = Matrix6d::Zero();
  if (input.nav_covariance) {
    covariance = *input.nav_covariance;
  } else {
    const double attitude_rad = options.nav_attitude_sigma_deg * kDegToRad;
    covariance.diagonal() << attitude_rad * attitude_rad, attitude_rad * attitude_rad,
        attitude_rad * attitude_rad, options.nav_position_sigma_m * options.nav_position_sigma_m,
        options.nav_position_sigma_m * options.nav_position_sigma_m,
        options.nav_position_sigma_m * options.nav_position_sigma_m;
  }
  return covariance;
}

// What the steps after the input checks share: the state Ceres refines, the
// state it started from (returned when the refinement fails), the matches'
// residuals and the result so far.
struct Refinement {
  Refinement(const CeresRefineOptions& refine_options,
             std::chrono::steady_clock::time_point start_time)
      : options(refine_options), start(start_time) {}

  const CeresRefineOptions& options;
  std::chrono::steady_clock::time_point start;
  ProblemState state;
  ProblemState initial;
  std::vector<MatchResidual> residuals;  // whitened, one per match
  std::vector<bool> used;                // evaluable at the start; the others are left out
  std::optional<LrfResidual> lrf;        // the range finder's constraint, when it has a support
  std::vector<size_t> lrf_support;       // its points
  double lrf_offset_m = 0.0;             // their centroid's distance from the beam, at the start
  CeresRefineResult result;
};

// The range finder's support (the used points nearest the beam, within its
// radius) and residual; none, with the reason in result.lrf_note, with fewer
// than three points or a beam that grazes the ground.
void SetUpLrf(const CeresRefineInput::Lrf& lrf, Refinement* run) {
  const Eigen::Vector3d beam = lrf.beam_in_cam1.normalized();
  const auto point = [&](size_t i) {
    return Eigen::Vector3d(run->state.points[3 * i], run->state.points[3 * i + 1], run->state.points[3 * i + 2]);
  };
  // The used points by their distance from the beam's line (index order on ties).
  std::vector<std::pair<double, size_t>> by_distance;
  for (size_t i = 0; i < run->used.size(); ++i) {
    if (!run->used[i]) continue;
    const Eigen::Vector3d offset = point(i) - lrf.origin_in_cam1_m;
    by_distance.emplace_back((offset - offset.dot(beam) * beam).norm(), i);
  }
  std::sort(by_distance.begin(), by_distance.end());
  // The smallest of a quarter, a half and the whole radius that holds three
  // points: the nearer the ground, the less it can differ from the spot's.
  double radius_m = 0.25 * lrf.support_radius_m;
  const auto within = [&](double r) {
    return std::count_if(by_distance.begin(), by_distance.end(), [&](const auto& d) { return d.first <= r; });
  };
  while (radius_m < lrf.support_radius_m && within(radius_m) < 3) radius_m *= 2.0;
  std::vector<Eigen::Vector3d> points;
  for (const auto& [distance, i] : by_distance) {
    if (distance > radius_m || points.size() >= static_cast<size_t>(lrf.support_points)) break;
    run->lrf_support.push_back(i);
    points.push_back(point(i));
  }
  const std::string radius = util::ShortestText(lrf.support_radius_m) + " m of the beam";
  if (points.size() < 3) {
    run->result.lrf_note = "no range constraint: " + std::to_string(points.size()) + " points within " + radius +
                           " (3 needed): the scale is the nav baseline's";
    run->lrf_support.clear();
    return;
  }
  const Eigen::Vector3d normal = lrf.ground_normal_in_cam1.normalized();
  // A plane the beam grazes (within 10 degrees) gives no range.
  if (!(std::abs(normal.dot(beam)) > std::sin(10.0 * kDegToRad))) {
    run->result.lrf_note = "no range constraint: the beam meets the ground within 10 degrees of grazing: the "
                           "scale is the nav baseline's";
    run->lrf_support.clear();
    return;
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  const Eigen::Vector3d offset = centroid - lrf.origin_in_cam1_m;
  run->lrf_offset_m = (offset - offset.dot(beam) * beam).norm();
  run->lrf = LrfResidual{lrf.origin_in_cam1_m, beam, normal, lrf.range_m, lrf.range_sigma_m,
                         static_cast<int>(points.size())};
  run->result.lrf_points = static_cast<int>(points.size());
}

// The residual functors (whitened) and which points can be evaluated at the
// start: a point behind a camera there is left out of the adjustment.
void SetUpResiduals(const CeresRefineInput& input, Refinement* run) {
  const size_t n = input.points_in_cam1_m.size();
  const double whitened_scale = input.focal_px / run->options.pixel_sigma_px;
  run->residuals.resize(n);
  run->used.assign(n, false);
  for (size_t i = 0; i < n; ++i) {
    run->residuals[i] = MatchResidual{TangentBasis(input.bearings1_in_cam1[i].normalized()),
                                      TangentBasis(input.bearings2_in_cam2[i].normalized()),
                                      whitened_scale};
    double r[4];
    run->used[i] = run->residuals[i](run->state.rotation_xyzw, run->state.translation,
                                     &run->state.points[3 * i], r);
    if (!run->used[i]) ++run->result.excluded;
  }
}

// Per-point RMS in pixels at a state (the whitened residuals times sigma).
std::vector<double> PointRms(const Refinement& run, const ProblemState& at) {
  const size_t n = run.residuals.size();
  std::vector<double> rms(n, std::numeric_limits<double>::infinity());
  for (size_t i = 0; i < n; ++i) {
    double r[4];
    if (!run.used[i] || !run.residuals[i](at.rotation_xyzw, at.translation, &at.points[3 * i], r)) {
      continue;
    }
    const double sum = r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3];
    rms[i] = run.options.pixel_sigma_px * std::sqrt(sum / 2.0);
  }
  return rms;
}

// The range constraint's line of the result: its points and the range the
// returned state gives along the beam.
void NoteLrf(const Refinement& run, const ProblemState& at, CeresRefineResult* result) {
  if (!run.lrf.has_value()) return;
  std::vector<const double*> points;
  for (const size_t i : run.lrf_support) points.push_back(&at.points[3 * i]);
  double residual = 0.0;
  (*run.lrf)(points.data(), &residual);
  const double range = run.lrf->range_m + residual * run.lrf->sigma_m;
  result->lrf_note = "range constraint on " + std::to_string(run.lrf->num_points) + " points " +
                     util::FixedText(run.lrf_offset_m, 1) + " m from the beam: " + util::FixedText(range, 3) +
                     " m along the beam, measured " + util::FixedText(run.lrf->range_m, 3) + " m";
}

// Every outcome returns through here: the status and the state `at` (refined
// or initial) with its per-point RMS.
CeresRefineResult Finish(Refinement* run, const ProblemState& at, CeresRefineStatus status,
                         const std::string& why) {
  CeresRefineResult& result = run->result;
  result.status = status;
  result.ok = status == CeresRefineStatus::kOk;
  result.failure = why;
  result.cam2_from_cam1 = PoseOf(at);
  result.points_in_cam1_m = PointsOf(at);
  result.reprojection_rms_px = PointRms(*run, at);
  NoteLrf(*run, at, &result);
  result.wall_s = Seconds(run->start);
  return result;
}

// The robust loss on the whitened residuals; null (plain least squares) for
// RobustLoss::kNone.
std::unique_ptr<ceres::LossFunction> MakeLoss(const CeresRefineOptions& options) {
  std::unique_ptr<ceres::LossFunction> loss;
  const double whitened_loss_scale = options.loss_scale_px / options.pixel_sigma_px;
  if (options.loss == RobustLoss::kHuber) {
    loss = std::make_unique<ceres::HuberLoss>(whitened_loss_scale);
  } else if (options.loss == RobustLoss::kCauchy) {
    loss = std::make_unique<ceres::CauchyLoss>(whitened_loss_scale);
  }
  return loss;
}

// The problem's residual blocks, kept apart so that the cost can be reported
// in parts, and the Schur ordering (points first, then the pose).
struct ResidualBlocks {
  std::vector<ceres::ResidualBlockId> image;
  std::vector<ceres::ResidualBlockId> prior;  // the nav prior, and the range finder's when used
  std::shared_ptr<ceres::ParameterBlockOrdering> ordering;
};

// Adds the pose, the used matches and the nav prior to `problem`, on the
// parameters in run->state.
ResidualBlocks AddResidualBlocks(const Rigid3d& nav, const Matrix6d& whitening,
                                 ceres::LossFunction* loss, ceres::Manifold* quaternion_manifold,
                                 Refinement* run, ceres::Problem* problem) {
  ProblemState& state = run->state;
  problem->AddParameterBlock(state.rotation_xyzw, 4, quaternion_manifold);
  problem->AddParameterBlock(state.translation, 3);
  ResidualBlocks blocks;
  blocks.ordering = std::make_shared<ceres::ParameterBlockOrdering>();
  const size_t n = run->residuals.size();
  blocks.image.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (!run->used[i]) continue;
    double* point = &state.points[3 * i];
    blocks.image.push_back(problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<MatchResidual, 4, 4, 3, 3>(
            new MatchResidual(run->residuals[i])),
        loss, state.rotation_xyzw, state.translation, point));
    blocks.ordering->AddElementToGroup(point, 0);
  }
  blocks.prior = {problem->AddResidualBlock(
      new ceres::AutoDiffCostFunction<NavPriorResidual, 6, 4, 3>(
          new NavPriorResidual{nav.rotation.conjugate(), nav.translation, whitening}),
      nullptr, state.rotation_xyzw, state.translation)};
  blocks.ordering->AddElementToGroup(state.rotation_xyzw, 1);
  blocks.ordering->AddElementToGroup(state.translation, 1);
  if (run->lrf.has_value()) {
    auto* cost = new ceres::DynamicAutoDiffCostFunction<LrfResidual>(new LrfResidual(*run->lrf));
    std::vector<double*> points;
    for (const size_t i : run->lrf_support) {
      cost->AddParameterBlock(3);
      points.push_back(&state.points[3 * i]);
      // The range couples its points: they join the pose's group, so that the
      // first group (eliminated by the Schur complement) stays independent.
      blocks.ordering->AddElementToGroup(points.back(), 1);
    }
    cost->SetNumResiduals(1);
    blocks.prior.push_back(problem->AddResidualBlock(cost, nullptr, points));
  }
  return blocks;
}

// Cost of the current parameter values, in parts; false when it cannot be
// evaluated or is not finite.
bool EvaluateCost(ceres::Problem* problem, const ResidualBlocks& blocks, RefineCost* cost) {
  ceres::Problem::EvaluateOptions evaluate_options;
  evaluate_options.residual_blocks = blocks.image;
  bool good = problem->Evaluate(evaluate_options, &cost->reprojection, nullptr, nullptr, nullptr);
  evaluate_options.residual_blocks = blocks.prior;
  good = good && problem->Evaluate(evaluate_options, &cost->prior, nullptr, nullptr, nullptr);
  cost->total = cost->reprojection + cost->prior;
  return good && std::isfinite(cost->total);
}

// Single-threaded, silent, and stopped by the function tolerance or the
// iteration limit, so that the same input gives the same bytes.
ceres::Solver::Options SolverOptions(const CeresRefineOptions& options,
                                     const std::shared_ptr<ceres::ParameterBlockOrdering>& ordering) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_SCHUR;
  solver_options.linear_solver_ordering = ordering;
  solver_options.num_threads = 1;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = kGradientTolerance;
  solver_options.parameter_tolerance = kParameterTolerance;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  return solver_options;
}

// The outcome of a solve: the refined state unless the solver failed or the
// cost rose, in which case the initial state is returned.
CeresRefineResult FinishSolve(const ceres::Solver::Summary& summary, ceres::Problem* problem,
                              const ResidualBlocks& blocks, Refinement* run) {
  CeresRefineResult& result = run->result;
  const bool usable_solution = summary.termination_type == ceres::CONVERGENCE ||
                               summary.termination_type == ceres::NO_CONVERGENCE;
  RefineCost final_cost;
  if (!usable_solution || !EvaluateCost(problem, blocks, &final_cost)) {
    result.final_cost = result.initial_cost;
    return Finish(run, run->initial, CeresRefineStatus::kSolverFailed,
                  "solver failed: " + summary.message + " (initial state returned)");
  }
  if (!(final_cost.total <= result.initial_cost.total)) {
    result.final_cost = result.initial_cost;
    return Finish(run, run->initial, CeresRefineStatus::kCostIncreased,
                  "cost increased from " + CostText(result.initial_cost.total) + " to " +
                      CostText(final_cost.total) + " (initial state returned)");
  }
  result.final_cost = final_cost;
  if (summary.termination_type == ceres::NO_CONVERGENCE) {
    return Finish(run, run->state, CeresRefineStatus::kNotConverged,
                  "not converged: Ceres stopped at the limit of " +
                      std::to_string(run->options.max_iterations) +
                      " iterations (refined state kept, cost " +
                      CostText(result.initial_cost.total) + " -> " + CostText(final_cost.total) +
                      ")");
  }
  return Finish(run, run->state, CeresRefineStatus::kOk, "");
}


// Builds the Ceres problem on run->state, solves it and finishes.
CeresRefineResult BuildAndSolve(const Rigid3d& nav, const Matrix6d& whitening, Refinement* run) {
  const CeresRefineOptions& options = run->options;
  // The loss and the manifold are shared by many blocks and outlive the
  // problem (which does not own them).
  ceres::EigenQuaternionManifold quaternion_manifold;
  const std::unique_ptr<ceres::LossFunction> loss = MakeLoss(options);
  ceres::Problem::Options problem_options;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  const ResidualBlocks blocks =
      AddResidualBlocks(nav, whitening, loss.get(), &quaternion_manifold, run, &problem);

  if (!EvaluateCost(&problem, blocks, &run->result.initial_cost)) {
    run->result.initial_cost = RefineCost();
    return Finish(run, run->initial, CeresRefineStatus::kSolverFailed,
                  "solver failed: the initial cost cannot be evaluated");
  }
  const ceres::Solver::Options solver_options = SolverOptions(options, blocks.ordering);
  std::string solver_problem;
  if (!solver_options.IsValid(&solver_problem)) {
    return Finish(run, run->initial, CeresRefineStatus::kSolverFailed,
                  "solver failed: Ceres options: " + solver_problem);
  }
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);
  // summary.iterations starts with the initial state (iteration 0).
  run->result.iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  return FinishSolve(summary, &problem, blocks, run);
}

}  // namespace

const char* ToString(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::kNone:
      return "none";
    case RobustLoss::kHuber:
      return "huber";
    case RobustLoss::kCauchy:
      return "cauchy";
  }
  return "unknown";
}

const char* ToString(CeresRefineStatus status) {
  switch (status) {
    case CeresRefineStatus::kOk:
      return "ok";
    case CeresRefineStatus::kNotConverged:
      return "not converged";
    case CeresRefineStatus::kCostIncreased:
      return "cost increased";
    case CeresRefineStatus::kSolverFailed:
      return "solver failed";
    case CeresRefineStatus::kTooFewPoints:
      return "too few points";
    case CeresRefineStatus::kInvalidInput:
      return "invalid input";
  }
  return "unknown";
}

std::vector<std::string> CeresRefineOptions::Validate() const {
  std::vector<std::string> errors;
  auto positive = [&errors](const char* name, double value) {
    if (!std::isfinite(value) || value <= 0.0) {
      errors.push_back(std::string(name) + " = " + util::ShortestText(value) + ": expected a finite value > 0");
    }
  };
  positive("pixel_sigma_px", pixel_sigma_px);
  positive("loss_scale_px", loss_scale_px);
  positive("nav_position_sigma_m", nav_position_sigma_m);
  positive("nav_attitude_sigma_deg", nav_attitude_sigma_deg);
  if (loss != RobustLoss::kNone && loss != RobustLoss::kHuber && loss != RobustLoss::kCauchy) {
    errors.push_back("loss = " + std::to_string(static_cast<int>(loss)) +
                     ": expected none, huber or cauchy");
  }
  if (min_points < 1) {
    errors.push_back("min_points = " + std::to_string(min_points) + ": expected >= 1");
  }
  if (max_iterations < 1) {
    errors.push_back("max_iterations = " + std::to_string(max_iterations) + ": expected >= 1");
  }
  if (!std::isfinite(function_tolerance) || function_tolerance < 0.0 || function_tolerance >= 1.0) {
    errors.push_back("function_tolerance = " + util::ShortestText(function_tolerance) +
                     ": expected a finite value in [0, 1)");
  }
  return errors;
}

CeresRefineResult RefineTwoView(const CeresRefineInput& input, const CeresRefineOptions& options) {
  ThrowIfInvalid(options);
  const auto start = std::chrono::steady_clock::now();

  const std::string input_problem = CheckInput(input);
  if (!input_problem.empty()) {
    return InvalidInputResult(input_problem, input.nav_cam2_from_cam1, start);
  }
  Matrix6d whitening;
  const std::string covariance_problem = Whitening(NavCovariance(input, options), &whitening);
  if (!covariance_problem.empty()) {
    // CheckInput passed, so the nav pose is usable and returned.
    return InvalidInputResult(covariance_problem, input.nav_cam2_from_cam1, start);
  }

  const size_t n = input.points_in_cam1_m.size();
  const Rigid3d nav(input.nav_cam2_from_cam1.rotation.normalized(),
                    input.nav_cam2_from_cam1.translation);
  Refinement run(options, start);
  run.state = StateFrom(nav, input.points_in_cam1_m);
  run.initial = run.state;
  SetUpResiduals(input, &run);
  if (input.lrf.has_value()) SetUpLrf(*input.lrf, &run);

  const int usable = static_cast<int>(n) - run.result.excluded;
  if (usable < options.min_points) {
    std::string why = "too few points: " + std::to_string(usable) + " usable of " +
                      std::to_string(n) + ", need at least " + std::to_string(options.min_points);
    if (run.result.excluded > 0) {
      why += " (" + std::to_string(run.result.excluded) + " behind a camera at the start)";
    }
    return Finish(&run, run.initial, CeresRefineStatus::kTooFewPoints, why);
  }
  return BuildAndSolve(nav, whitening, &run);
}

}  // namespace hdabench::reference
