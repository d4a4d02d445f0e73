#include "reference/opengv/opengv_solvers.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <opengv/relative_pose/CentralRelativeAdapter.hpp>
#include <opengv/relative_pose/methods.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/relative_pose/CentralRelativePoseSacProblem.hpp>
#include <opengv/sac_problems/relative_pose/EigensolverSacProblem.hpp>
#include <opengv/sac_problems/relative_pose/TranslationOnlySacProblem.hpp>
#include <opengv/triangulation/methods.hpp>

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "reference/opengv/opengv_adapter.h"
#include "reference/opengv/two_view_models.h"
#include "tools/util/angles.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using util::kDegToRad;

using opengv::relative_pose::CentralRelativeAdapter;
using opengv::sac_problems::relative_pose::CentralRelativePoseSacProblem;
using opengv::sac_problems::relative_pose::EigensolverSacProblem;
using opengv::sac_problems::relative_pose::TranslationOnlySacProblem;

// A bearing is accepted as unit when | |f| - 1 | is within this.
constexpr double kUnitTolerance = 1e-6;
// Below this the nav baseline is zero: no scale, no triangulation (metres).
constexpr double kMinBaselineM = 1e-9;
// Trimmed refits of the homography (ClassifyConfiguration): matches whose
// transfer error exceeds kHomographyTrim times the median are left out of the
// next fit, so a few outliers do not tilt it.
constexpr int kHomographyRefits = 3;
constexpr double kHomographyTrim = 3.0;

double Deg(double rad) { return rad / kDegToRad; }

// Angle between two vectors (radians, in [0, pi]); 0 when either is zero.
double AngleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

void ThrowIfInvalid(const char* function, const std::vector<std::string>& errors) {
  hdabench::ThrowIfInvalid(std::string(function) + ": invalid OpenGvOptions: ", errors);
}

void CheckInputs(const char* function, const std::vector<Eigen::Vector3d>& bearings1,
                 const std::vector<Eigen::Vector3d>& bearings2, double focal_px,
                 const OpenGvOptions& options) {
  ThrowIfInvalid(function, options.Validate());
  if (bearings1.size() != bearings2.size()) {
    throw InputError(std::string(function) + ": " + std::to_string(bearings1.size()) +
                     " bearings in view 1 but " + std::to_string(bearings2.size()) +
                     " in view 2: expected one per match in each view");
  }
  if (!(std::isfinite(focal_px) && focal_px > 0)) {
    std::ostringstream message;
    message << function << ": focal_px = " << focal_px << ": expected a finite value > 0 (pixels)";
    throw InputError(message.str());
  }
  for (int view = 1; view <= 2; ++view) {
    const std::vector<Eigen::Vector3d>& bearings = view == 1 ? bearings1 : bearings2;
    for (size_t i = 0; i < bearings.size(); ++i) {
      const double norm = bearings[i].norm();
      if (!std::isfinite(norm) || std::abs(norm - 1.0) > kUnitTolerance) {
        std::ostringstream message;
        message << function << ": bearing " << i << " of view " << view << " ("
                << bearings[i].x() << ", " << bearings[i].y() << ", " << bearings[i].z()
                << ") has norm " << norm << ": expected a finite unit vector";
        throw InputError(message.str());
      }
    }
  }
}

opengv::bearingVectors_t ToOpenGv(const std::vector<Eigen::Vector3d>& bearings) {
  return opengv::bearingVectors_t(bearings.begin(), bearings.end());
}

// OpenGV's RANSAC threshold for a pixel threshold: its score is the sum over
// both views of 1 - cos(angle); an angle of atan(threshold_px / focal_px) in
// each view scores 2 (1 - cos) = 4 sin^2(angle / 2).
double OpenGvThreshold(double threshold_px, double focal_px) {
  const double half = 0.5 * std::atan(threshold_px / focal_px);
  return 4.0 * std::sin(half) * std::sin(half);
}

// OpenGV's samplers draw from a std::mt19937 that the constructor seeds with
// time(0) + clock(), or with the constant 12345 when randomSeed is false; the
// draw goes through rng_gen_, a std::function bound to a *copy* of that engine.
// Re-seeding rng_alg_ alone would therefore change nothing: rebind rng_gen_ to
// an engine seeded from the bench's seed.
template <typename Problem>
void SeedSampler(Problem* problem, std::uint64_t seed) {
  std::seed_seq sequence{static_cast<std::uint32_t>(seed & 0xffffffffULL),
                         static_cast<std::uint32_t>(seed >> 32)};
  problem->rng_alg_.seed(sequence);
  problem->rng_gen_ = std::make_shared<std::function<int()>>(
      std::bind(*problem->rng_dist_, problem->rng_alg_));
}

// OpenGV's EigensolverSacProblem perturbs each hypothesis' starting rotation
// with std::rand(), a process-wide generator (so results would depend on
// whatever else called it, and on other threads). This problem starts each
// hypothesis from the nav rotation turned by a random rotation drawn from its
// own generator, seeded from the bench's seed; the rest is OpenGV's.
class SeededEigensolverProblem : public EigensolverSacProblem {
 public:
  SeededEigensolverProblem(adapter_t& adapter, size_t sample_size,
                           const opengv::rotation_t& start_r12, double jitter_rad,
                           std::uint64_t seed)
      : EigensolverSacProblem(adapter, sample_size, /*randomSeed=*/false),
        start_r12_(start_r12),
        jitter_rad_(jitter_rad),
        start_rng_(seed ^ 0x9e3779b97f4a7c15ULL) {}

  bool computeModelCoefficients(const std::vector<int>& indices,
                                model_t& out_model) const override {
    std::uniform_real_distribution<double> jitter(-jitter_rad_, jitter_rad_);
    const double ax = jitter(start_rng_);
    const double ay = jitter(start_rng_);
    const double az = jitter(start_rng_);
    const Eigen::Vector3d rotation_vector(ax, ay, az);
    const double angle = rotation_vector.norm();
    Eigen::Matrix3d turn = Eigen::Matrix3d::Identity();
    if (angle > 0) turn = Eigen::AngleAxisd(angle, rotation_vector / angle).toRotationMatrix();
    out_model.rotation = start_r12_ * turn;
    opengv::relative_pose::eigensolver(_adapter, indices, out_model);
    return out_model.rotation.allFinite() && out_model.translation.allFinite() &&
           out_model.translation.norm() > 0;
  }

 private:
  opengv::rotation_t start_r12_;
  double jitter_rad_;
  mutable std::mt19937_64 start_rng_;
};

opengv::transformation_t ToTransformation(const opengv::transformation_t& model) { return model; }
opengv::transformation_t ToTransformation(const opengv::eigensolverOutput_t& model) {
  opengv::transformation_t transformation;
  transformation.block<3, 3>(0, 0) = model.rotation;
  transformation.col(3) = model.translation;
  return transformation;
}

// What a RANSAC run gives, in OpenGV's convention ([R12 | t12], t12 unit).
struct RansacOutcome {
  bool found = false;
  opengv::transformation_t model = opengv::transformation_t::Zero();
  std::vector<int> inliers;
  int iterations = 0;
};

template <typename Problem>
RansacOutcome RunRansac(const std::shared_ptr<Problem>& problem, double threshold,
                        const OpenGvOptions& options) {
  opengv::sac::Ransac<Problem> ransac(options.max_iterations, threshold, options.probability);
  ransac.sac_model_ = problem;
  RansacOutcome outcome;
  outcome.found = ransac.computeModel(0);
  outcome.iterations = ransac.iterations_;
  if (!outcome.found) return outcome;
  outcome.model = ToTransformation(ransac.model_coefficients_);
  outcome.inliers = ransac.inliers_;
  const double norm = outcome.model.col(3).norm();
  if (!outcome.model.allFinite() || !(norm > 0)) {
    outcome.found = false;
    return outcome;
  }
  outcome.model.col(3) /= norm;
  return outcome;
}

// The matches within `threshold` of [R12 | t12] by OpenGV's own score (the
// one its sac problems use: triangulate2, then 1 - cos in each view).
std::vector<int> InliersOf(CentralRelativeAdapter* adapter, const opengv::transformation_t& model,
                           double threshold) {
  CentralRelativePoseSacProblem scorer(*adapter, CentralRelativePoseSacProblem::STEWENIUS,
                                       /*randomSeed=*/false);
  std::vector<int> inliers;
  scorer.selectWithinDistance(model, threshold, inliers);
  return inliers;
}

// The angle between the two rays of match `index` when view 2 is turned by R12
// (radians): the triangulation angle at the point.
double RayAngle(const CentralRelativeAdapter& adapter, size_t index, const Eigen::Matrix3d& r12) {
  return AngleBetween(adapter.getBearingVector1(index), r12 * adapter.getBearingVector2(index));
}

// Triangulation of a set of matches with the adapter's [R12 | t12] (OpenGV's
// triangulate2), guarded: parallel rays are reported, not triangulated, and
// points behind either camera are counted and left out.
struct Triangulation {
  std::vector<TriangulatedMatch> points;
  std::vector<int> degenerate;
  int behind = 0;
};

Triangulation Triangulate(const CentralRelativeAdapter& adapter, const std::vector<int>& indices,
                          double min_ray_angle_rad) {
  const Eigen::Matrix3d r12 = adapter.getR12();
  const Eigen::Vector3d t12 = adapter.gett12();
  Triangulation result;
  for (const int index : indices) {
    const size_t i = static_cast<size_t>(index);
    const double ray_angle = RayAngle(adapter, i, r12);
    if (!(ray_angle >= min_ray_angle_rad)) {
      result.degenerate.push_back(index);
      continue;
    }
    const Eigen::Vector3d point_in_cam1 = opengv::triangulation::triangulate2(adapter, i);
    const Eigen::Vector3d point_in_cam2 = r12.transpose() * (point_in_cam1 - t12);
    if (!point_in_cam1.allFinite()) {
      result.degenerate.push_back(index);
      continue;
    }
    if (point_in_cam1.dot(adapter.getBearingVector1(i)) <= 0 ||
        point_in_cam2.dot(adapter.getBearingVector2(i)) <= 0) {
      ++result.behind;
      continue;
    }
    TriangulatedMatch match;
    match.match_index = index;
    match.point_in_cam1_m = point_in_cam1;
    match.parallax_deg = Deg(ray_angle);
    result.points.push_back(match);
  }
  return result;
}

// The number of matches in front of both cameras for [R12 | t12].
int CountInFront(CentralRelativeAdapter* adapter, const Eigen::Matrix3d& r12,
                 const Eigen::Vector3d& t12, const std::vector<int>& indices,
                 double min_ray_angle_rad) {
  adapter->setR12(r12);
  adapter->sett12(t12);
  return static_cast<int>(Triangulate(*adapter, indices, min_ray_angle_rad).points.size());
}

// Least-squares translation direction with a known rotation: every match's
// epipolar plane contains t12, so t12 is orthogonal to n = f1 x (R12 f2); the
// direction is the eigenvector of sum n n^T with the smallest eigenvalue.
bool TranslationWithKnownRotation(const CentralRelativeAdapter& adapter,
                                  const std::vector<int>& indices, const Eigen::Matrix3d& r12,
                                  const Eigen::Vector3d& sign_reference, Eigen::Vector3d* t12) {
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const int index : indices) {
    const size_t i = static_cast<size_t>(index);
    const Eigen::Vector3d normal =
        adapter.getBearingVector1(i).cross(r12 * adapter.getBearingVector2(i));
    scatter += normal * normal.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  if (solver.info() != Eigen::Success) return false;
  Eigen::Vector3d direction = solver.eigenvectors().col(0);
  if (!direction.allFinite() || !(direction.norm() > 0)) return false;
  direction.normalize();
  if (direction.dot(sign_reference) < 0) direction = -direction;
  *t12 = direction;
  return true;
}

// The smallest eigenvalue of the scatter of the matches triangulated with the
// adapter's pose, over the middle one (1 when fewer than 3 triangulate).
double ShapeEigenvalueRatio(const CentralRelativeAdapter& adapter, const std::vector<int>& indices,
                            double min_ray_angle_deg) {
  const Triangulation triangulation = Triangulate(adapter, indices, min_ray_angle_deg * kDegToRad);
  if (triangulation.points.size() < 3) return 1.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const TriangulatedMatch& p : triangulation.points) centre += p.point_in_cam1_m;
  centre /= static_cast<double>(triangulation.points.size());
  Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
  for (const TriangulatedMatch& p : triangulation.points) {
    const Eigen::Vector3d d = p.point_in_cam1_m - centre;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
  const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
  return eigenvalues(1) > 0 ? std::max(0.0, eigenvalues(0)) / eigenvalues(1) : 0.0;
}

// ---------------------------------------------------------------------------
// SolveRelativePose's steps, in the order it runs them.

// Every outcome returns through here, so that each message names the solver.
RelativePoseResult Finish(bool ok, const std::string& message,
                          std::chrono::steady_clock::time_point start, RelativePoseResult* result) {
  const std::string name = ToString(result->solver);
  result->ok = ok;
  result->message = name + ": " + message;
  result->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return *result;
}

// RANSAC with the chosen solver on the adapter (which holds the nav pose),
// its sampler seeded from options.seed so that runs repeat.
RansacOutcome RunSolverRansac(OpenGvSolver solver, const Eigen::Matrix3d& nav_r12, double threshold,
                              const OpenGvOptions& options, CentralRelativeAdapter* adapter) {
  RansacOutcome outcome;
  switch (solver) {
    case OpenGvSolver::kStewenius:
    case OpenGvSolver::kNister:
    case OpenGvSolver::kEightPoint: {
      const CentralRelativePoseSacProblem::algorithm_t algorithm =
          solver == OpenGvSolver::kStewenius ? CentralRelativePoseSacProblem::STEWENIUS
          : solver == OpenGvSolver::kNister  ? CentralRelativePoseSacProblem::NISTER
                                             : CentralRelativePoseSacProblem::EIGHTPT;
      auto problem = std::make_shared<CentralRelativePoseSacProblem>(*adapter, algorithm,
                                                                     /*randomSeed=*/false);
      SeedSampler(problem.get(), options.seed);
      outcome = RunRansac(problem, threshold, options);
      break;
    }
    case OpenGvSolver::kEigensolver: {
      auto problem = std::make_shared<SeededEigensolverProblem>(
          *adapter, static_cast<size_t>(options.eigensolver_sample_size), nav_r12,
          options.eigensolver_start_jitter_deg * kDegToRad, options.seed);
      SeedSampler(problem.get(), options.seed);
      outcome = RunRansac(problem, threshold, options);
      break;
    }
    case OpenGvSolver::kTwoPointKnownRotation: {
      // TranslationOnlySacProblem takes the rotation from the adapter (set to
      // the nav rotation above) and solves t12 from two matches (twopt).
      auto problem = std::make_shared<TranslationOnlySacProblem>(*adapter, /*randomSeed=*/false);
      SeedSampler(problem.get(), options.seed);
      outcome = RunRansac(problem, threshold, options);
      break;
    }
  }
  return outcome;
}

// The pose being estimated, in OpenGV's convention ([R12 | t12], t12 unit),
// and its inliers.
struct PoseEstimate {
  Eigen::Matrix3d r12;
  Eigen::Vector3d t12;
  std::vector<int> inliers;
};

// Refinement on the inliers, kept when it is finite and keeps at least as
// many inliers, so that it never makes RANSAC's answer worse; true when kept.
bool RefineOnInliers(OpenGvSolver solver, double threshold, double focal_px,
                     const TangentMatches& tangent, CentralRelativeAdapter* adapter,
                     PoseEstimate* pose) {
  Eigen::Matrix3d refined_r12 = pose->r12;
  Eigen::Vector3d refined_t12 = pose->t12;
  bool finite = false;
  if (solver == OpenGvSolver::kTwoPointKnownRotation) {
    finite =
        TranslationWithKnownRotation(*adapter, pose->inliers, pose->r12, pose->t12, &refined_t12);
  } else {
    // Sampson refinement (two_view_models.h) rather than OpenGV's
    // optimize_nonlinear, which stops short of the optimum on narrow fields
    // (0.64 deg of translation direction on the NOVA-C pair where the
    // geometric optimum is within 0.05 deg).
    std::vector<int> position(adapter->getNumberCorrespondences(), -1);
    for (size_t k = 0; k < tangent.index.size(); ++k) position[tangent.index[k]] = static_cast<int>(k);
    std::vector<size_t> subset;
    for (const int i : pose->inliers) {
      const int k = position[static_cast<size_t>(i)];
      if (k >= 0) subset.push_back(static_cast<size_t>(k));
    }
    EpipolarPose refined{pose->r12, pose->t12.normalized()};
    finite = RefineEpipolarPose(tangent, subset, focal_px, &refined);
    refined_r12 = refined.r12;
    refined_t12 = refined.t12;
  }
  if (!finite) return false;
  opengv::transformation_t refined_model;
  refined_model.block<3, 3>(0, 0) = refined_r12;
  refined_model.col(3) = refined_t12;
  std::vector<int> refined_inliers = InliersOf(adapter, refined_model, threshold);
  if (refined_inliers.size() < pose->inliers.size()) return false;
  pose->r12 = refined_r12;
  pose->t12 = refined_t12;
  pose->inliers = std::move(refined_inliers);
  return true;
}

// Translation sign by cheirality: most inliers in front of both cameras.
// false when no inlier is in front either way.
bool ChooseTranslationSign(double min_ray_angle_rad, CentralRelativeAdapter* adapter,
                           PoseEstimate* pose, RelativePoseResult* result) {
  const int front = CountInFront(adapter, pose->r12, pose->t12, pose->inliers, min_ray_angle_rad);
  const int front_flipped =
      CountInFront(adapter, pose->r12, -pose->t12, pose->inliers, min_ray_angle_rad);
  if (front_flipped > front) {
    pose->t12 = -pose->t12;
    result->cheirality_flipped = true;
  }
  return std::max(front, front_flipped) != 0;
}

// Scales the pose to the nav baseline (the unit translation has no scale)
// and triangulates the inliers in metres.
void TriangulateInliers(double baseline_m, double min_ray_angle_rad,
                        CentralRelativeAdapter* adapter, PoseEstimate* pose,
                        RelativePoseResult* result) {
  opengv::transformation_t model;
  model.block<3, 3>(0, 0) = pose->r12;
  model.col(3) = pose->t12;
  result->cam2_from_cam1 = Cam2FromCam1FromOpenGv(model, baseline_m);
  const opengv::transformation_t metric12 = OpenGvFromCam2FromCam1(result->cam2_from_cam1);
  adapter->setR12(metric12.block<3, 3>(0, 0));
  adapter->sett12(metric12.col(3));
  std::vector<int>& inliers = pose->inliers;
  std::sort(inliers.begin(), inliers.end());
  Triangulation triangulation = Triangulate(*adapter, inliers, min_ray_angle_rad);
  result->inlier_indices = inliers;
  result->num_inliers = static_cast<int>(inliers.size());
  result->points = std::move(triangulation.points);
  result->degenerate_indices = std::move(triangulation.degenerate);
  result->num_behind = triangulation.behind;
}

// Camera 2's centre in camera 1: the direction the translation errors compare.
Eigen::Vector3d CentreOfCam2(const Rigid3d& cam2_from_cam1) {
  return cam2_from_cam1.Inverse().translation;
}

// The estimate's errors against the nav pose, and against the truth when given.
void PoseErrors(const Rigid3d& nav_cam2_from_cam1, const Rigid3d* truth_cam2_from_cam1,
                RelativePoseResult* result) {
  const Eigen::Vector3d centre = CentreOfCam2(result->cam2_from_cam1);
  result->rotation_error_vs_nav_deg =
      Deg(result->cam2_from_cam1.rotation.angularDistance(nav_cam2_from_cam1.rotation));
  result->translation_direction_error_vs_nav_deg =
      Deg(AngleBetween(centre, CentreOfCam2(nav_cam2_from_cam1)));
  if (truth_cam2_from_cam1 != nullptr) {
    result->has_truth_errors = true;
    result->rotation_error_deg =
        Deg(result->cam2_from_cam1.rotation.angularDistance(truth_cam2_from_cam1->rotation));
    result->translation_direction_error_deg =
        Deg(AngleBetween(centre, CentreOfCam2(*truth_cam2_from_cam1)));
  }
}

// The one-line summary of a successful solve.
std::string SuccessMessage(const RelativePoseResult& result, int num_matches) {
  return std::to_string(result.num_inliers) + " of " + std::to_string(num_matches) +
         " matches inliers after " + std::to_string(result.ransac_iterations) + " hypotheses, " +
         (result.refined ? "refined" : "not refined") + ", " +
         std::to_string(result.points.size()) + " points (" + std::to_string(result.num_behind) +
         " behind, " + std::to_string(result.degenerate_indices.size()) + " degenerate)" +
         (result.cheirality_flipped ? ", translation sign flipped" : "") + "; configuration " +
         ToString(result.configuration.type);
}

}  // namespace

const char* ToString(OpenGvSolver solver) {
  switch (solver) {
    case OpenGvSolver::kStewenius:
      return "stewenius";
    case OpenGvSolver::kNister:
      return "nister";
    case OpenGvSolver::kEightPoint:
      return "eight-point";
    case OpenGvSolver::kEigensolver:
      return "eigensolver";
    case OpenGvSolver::kTwoPointKnownRotation:
      return "two-point";
  }
  return "unknown";
}

const std::vector<OpenGvSolver>& AllOpenGvSolvers() {
  static const std::vector<OpenGvSolver> all = {
      OpenGvSolver::kStewenius, OpenGvSolver::kNister, OpenGvSolver::kEightPoint,
      OpenGvSolver::kEigensolver, OpenGvSolver::kTwoPointKnownRotation};
  return all;
}

OpenGvSolver ParseOpenGvSolver(const std::string& name) {
  std::string valid;
  for (const OpenGvSolver solver : AllOpenGvSolvers()) {
    if (name == ToString(solver)) return solver;
    valid += std::string(valid.empty() ? "" : ", ") + ToString(solver);
  }
  throw InputError("unknown OpenGV solver '" + name + "': expected one of " + valid);
}

const char* ToString(ConfigurationType type) {
  switch (type) {
    case ConfigurationType::kWellConditioned:
      return "well-conditioned";
    case ConfigurationType::kPlanar:
      return "planar";
    case ConfigurationType::kLowParallax:
      return "low parallax";
    case ConfigurationType::kTooFewPoints:
      return "too few points";
  }
  return "unknown";
}

std::vector<std::string> OpenGvOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(ransac_threshold_px > 0, "ransac_threshold_px", ransac_threshold_px, "> 0 (pixels)",
                &errors);
  RequireOption(max_iterations >= 1, "max_iterations", max_iterations, ">= 1", &errors);
  RequireOption(probability > 0 && probability < 1, "probability", probability, "in (0, 1)",
                &errors);
  RequireOption(eigensolver_sample_size >= 3, "eigensolver_sample_size", eigensolver_sample_size,
                ">= 3", &errors);
  RequireOption(eigensolver_start_jitter_deg >= 0 && eigensolver_start_jitter_deg <= 45,
                "eigensolver_start_jitter_deg", eigensolver_start_jitter_deg,
                "in [0, 45] (degrees)", &errors);
  RequireOption(min_matches >= 8, "min_matches", min_matches,
                ">= 8 (the 8-point solver needs 8 matches)", &errors);
  RequireOption(min_ray_angle_deg > 0 && min_ray_angle_deg < 90, "min_ray_angle_deg",
                min_ray_angle_deg, "in (0, 90) (degrees)", &errors);
  RequireOption(low_parallax_deg > 0 && low_parallax_deg < 90, "low_parallax_deg",
                low_parallax_deg, "in (0, 90) (degrees)", &errors);
  RequireOption(planar_eigenvalue_ratio > 0 && planar_eigenvalue_ratio < 1,
                "planar_eigenvalue_ratio", planar_eigenvalue_ratio, "in (0, 1)", &errors);
  return errors;
}

int RansacSampleSize(OpenGvSolver solver, const OpenGvOptions& options) {
  switch (solver) {
    case OpenGvSolver::kStewenius:
    case OpenGvSolver::kNister:
      return 5 + 3;
    case OpenGvSolver::kEightPoint:
      return 8 + 1;
    case OpenGvSolver::kEigensolver:
      return options.eigensolver_sample_size;
    case OpenGvSolver::kTwoPointKnownRotation:
      return 2;
  }
  return 0;
}

ConfigurationReport ClassifyConfiguration(const std::vector<Eigen::Vector3d>& bearings1,
                                          const std::vector<Eigen::Vector3d>& bearings2,
                                          const Rigid3d& nav_cam2_from_cam1, double focal_px,
                                          const OpenGvOptions& options) {
  CheckInputs("ClassifyConfiguration", bearings1, bearings2, focal_px, options);
  ConfigurationReport report;
  report.num_matches = static_cast<int>(bearings1.size());
  report.nav_baseline_m = nav_cam2_from_cam1.translation.norm();
  if (report.num_matches < options.min_matches) {
    report.type = ConfigurationType::kTooFewPoints;
    report.reason = std::to_string(report.num_matches) + " matches, fewer than min_matches " +
                    std::to_string(options.min_matches);
    return report;
  }

  const opengv::transformation_t nav12 = OpenGvFromCam2FromCam1(nav_cam2_from_cam1);
  const opengv::bearingVectors_t f1 = ToOpenGv(bearings1);
  const opengv::bearingVectors_t f2 = ToOpenGv(bearings2);
  const CentralRelativeAdapter adapter(f1, f2, nav12.col(3), nav12.block<3, 3>(0, 0));
  std::vector<double> parallax_deg(f1.size());
  for (size_t i = 0; i < f1.size(); ++i) {
    parallax_deg[i] = Deg(RayAngle(adapter, i, nav12.block<3, 3>(0, 0)));
  }
  report.median_parallax_deg = util::UpperMedian(parallax_deg);

  // The plane-induced homography and the general model, both fitted to the
  // matches (two_view_models.h). The shape of the points triangulated with
  // the nav pose leaves out the homography's gross outliers: one wrong match
  // far off the patch would otherwise be its thickness.
  const TangentMatches tangent = ToTangentPlanes(bearings1, bearings2);
  const HomographyModel homography =
      FitHomographyModel(tangent, focal_px, kHomographyRefits, kHomographyTrim);
  report.homography_residual_px = homography.valid ? util::UpperMedian(homography.transfer_px) : 0.0;
  report.eigenvalue_ratio = 1.0;
  if (report.nav_baseline_m >= kMinBaselineM) {
    std::vector<int> kept;
    for (size_t k = 0; k < tangent.index.size(); ++k) {
      if (homography.valid && homography.used[k]) kept.push_back(static_cast<int>(tangent.index[k]));
    }
    report.eigenvalue_ratio = ShapeEigenvalueRatio(adapter, kept, options.min_ray_angle_deg);
    if (homography.valid) {
      EpipolarPose nav_pose;
      nav_pose.r12 = nav12.block<3, 3>(0, 0);
      nav_pose.t12 = nav12.col(3).normalized();
      const GeneralModel general = FitGeneralModel(tangent, nav_pose, focal_px);
      const ModelSelection selection = SelectTwoViewModel(general.sampson_px, homography.sampson_px);
      report.noise_px = selection.noise_px;
      report.gric_general = selection.gric_general;
      report.gric_homography = selection.gric_homography;
      report.homography_selected = selection.homography_wins();
    }
  }

  const std::string numbers =
      "median parallax " + util::FixedText(report.median_parallax_deg, 3) + " deg, eigenvalue ratio " +
      util::FixedText(report.eigenvalue_ratio, 4) + ", homography residual " +
      util::FixedText(report.homography_residual_px, 3) + " px, noise " +
      util::FixedText(report.noise_px, 3) + " px, GRIC homography " +
      util::FixedText(report.gric_homography, 1) + " / general " +
      util::FixedText(report.gric_general, 1) + ", " + std::to_string(report.num_matches) +
      " matches, nav baseline " + util::FixedText(report.nav_baseline_m, 3) + " m";
  if (report.nav_baseline_m < kMinBaselineM ||
      report.median_parallax_deg < options.low_parallax_deg) {
    report.type = ConfigurationType::kLowParallax;
    report.reason = numbers + " (low parallax below " + util::FixedText(options.low_parallax_deg, 3) +
                    " deg)";
  } else if (report.eigenvalue_ratio < options.planar_eigenvalue_ratio ||
             report.homography_selected) {
    report.type = ConfigurationType::kPlanar;
    report.reason = numbers + (report.homography_selected
                                   ? " (planar: the homography's GRIC is the lower)"
                                   : " (planar: eigenvalue ratio below " +
                                         util::FixedText(options.planar_eigenvalue_ratio, 4) + ")");
  } else {
    report.type = ConfigurationType::kWellConditioned;
    report.reason = numbers;
  }
  return report;
}

RelativePoseResult SolveRelativePose(const std::vector<Eigen::Vector3d>& bearings1,
                                     const std::vector<Eigen::Vector3d>& bearings2,
                                     OpenGvSolver solver, const Rigid3d& nav_cam2_from_cam1,
                                     double focal_px, const OpenGvOptions& options,
                                     const Rigid3d* truth_cam2_from_cam1) {
  const auto start = std::chrono::steady_clock::now();
  CheckInputs("SolveRelativePose", bearings1, bearings2, focal_px, options);
  RelativePoseResult result;
  result.solver = solver;

  result.configuration =
      ClassifyConfiguration(bearings1, bearings2, nav_cam2_from_cam1, focal_px, options);
  const int num_matches = static_cast<int>(bearings1.size());
  const int needed = std::max(options.min_matches, RansacSampleSize(solver, options));
  if (num_matches < needed) {
    return Finish(false,
                  "too few points: " + std::to_string(num_matches) +
                      " matches, the solver needs at least " + std::to_string(needed),
                  start, &result);
  }
  const double baseline_m = nav_cam2_from_cam1.translation.norm();
  if (!(baseline_m >= kMinBaselineM)) {
    return Finish(false,
                  "the nav baseline is " + util::FixedText(baseline_m, 9) +
                      " m: no scale for the translation, nothing to triangulate",
                  start, &result);
  }

  // The adapter holds references to f1 and f2, which must outlive it.
  const opengv::transformation_t nav12 = OpenGvFromCam2FromCam1(nav_cam2_from_cam1);
  const Eigen::Matrix3d nav_r12 = nav12.block<3, 3>(0, 0);
  const Eigen::Vector3d nav_t12_unit = nav12.col(3) / baseline_m;
  const opengv::bearingVectors_t f1 = ToOpenGv(bearings1);
  const opengv::bearingVectors_t f2 = ToOpenGv(bearings2);
  CentralRelativeAdapter adapter(f1, f2, nav_t12_unit, nav_r12);
  const double threshold = OpenGvThreshold(options.ransac_threshold_px, focal_px);
  const double min_ray_angle_rad = options.min_ray_angle_deg * kDegToRad;

  const RansacOutcome outcome = RunSolverRansac(solver, nav_r12, threshold, options, &adapter);
  result.ransac_iterations = outcome.iterations;
  const int sample_size = RansacSampleSize(solver, options);
  if (!outcome.found) {
    return Finish(false,
                  "RANSAC found no model in " + std::to_string(outcome.iterations) +
                      " hypotheses (" + ToString(result.configuration.type) + ": " +
                      result.configuration.reason + ")",
                  start, &result);
  }
  if (static_cast<int>(outcome.inliers.size()) < sample_size) {
    return Finish(false,
                  "RANSAC's best model has " + std::to_string(outcome.inliers.size()) +
                      " inliers, fewer than its sample size " + std::to_string(sample_size),
                  start, &result);
  }

  PoseEstimate pose{outcome.model.block<3, 3>(0, 0), outcome.model.col(3), outcome.inliers};
  const TangentMatches tangent = ToTangentPlanes(bearings1, bearings2);
  if (options.refine_nonlinear &&
      RefineOnInliers(solver, threshold, focal_px, tangent, &adapter, &pose)) {
    result.refined = true;
  }
  if (!ChooseTranslationSign(min_ray_angle_rad, &adapter, &pose, &result)) {
    return Finish(false,
                  "no inlier triangulates in front of both cameras (" +
                      std::to_string(pose.inliers.size()) + " inliers)",
                  start, &result);
  }
  TriangulateInliers(baseline_m, min_ray_angle_rad, &adapter, &pose, &result);
  PoseErrors(nav_cam2_from_cam1, truth_cam2_from_cam1, &result);
  return Finish(true, SuccessMessage(result, num_matches), start, &result);
}

}  // namespace hdabench::reference
