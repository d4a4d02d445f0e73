#include "reference/opengv/two_view_models.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>

#include "tools/util/statistics.h"

namespace hdabench::reference {

namespace {

// A robust sigma from the median absolute value (Gaussian consistency).
constexpr double kMadToSigma = 1.4826;
// The general model's fit keeps the matches within this many robust sigmas.
constexpr double kTrim = 3.0;
constexpr int kGeneralPasses = 3;
// Levenberg-Marquardt: iterations, the first damping, the step of the
// central differences (radians of rotation, units of the direction) and the
// relative decrease of the cost under which it stops.
constexpr int kMaxIterations = 50;
constexpr double kFirstDamping = 1e-3;
constexpr double kDifferenceStep = 1e-6;
constexpr double kRelativeDecrease = 1e-12;

double MedianAbsolute(const std::vector<double>& values) {
  std::vector<double> absolute(values.size());
  std::transform(values.begin(), values.end(), absolute.begin(),
                 [](double v) { return std::abs(v); });
  return util::UpperMedian(std::move(absolute));
}

Eigen::Matrix3d RotationToZ(const Eigen::Vector3d& axis) {
  return Eigen::Quaterniond::FromTwoVectors(axis, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

// The essential matrix in the tangent frames: u1~^T E' u2~ = 0.
Eigen::Matrix3d TangentEssential(const TangentMatches& matches, const EpipolarPose& pose) {
  return matches.to_z1 * Skew(pose.t12) * pose.r12 * matches.to_z2.transpose();
}

double SampsonOfEssential(const Eigen::Matrix3d& e, const Eigen::Vector2d& u1,
                          const Eigen::Vector2d& u2) {
  const Eigen::Vector3d x1 = u1.homogeneous();
  const Eigen::Vector3d x2 = u2.homogeneous();
  const Eigen::Vector3d line1 = e * x2;              // gradient with respect to x1
  const Eigen::Vector3d line2 = e.transpose() * x1;  // gradient with respect to x2
  const double denominator = line1.head<2>().squaredNorm() + line2.head<2>().squaredNorm();
  if (!(denominator > 0)) return std::numeric_limits<double>::infinity();
  return x1.dot(line1) / std::sqrt(denominator);
}

// The pose moved by a 5-vector: rotation vector (3) on the right of R12,
// and a step of the translation direction in its tangent plane (2).
EpipolarPose Moved(const EpipolarPose& pose, const Eigen::Matrix<double, 5, 1>& step,
                   const Eigen::Matrix<double, 3, 2>& tangent_basis) {
  EpipolarPose moved;
  const Eigen::Vector3d omega = step.head<3>();
  const double angle = omega.norm();
  const Eigen::Matrix3d turn =
      angle > 0 ? Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix()
                : Eigen::Matrix3d::Identity();
  moved.r12 = pose.r12 * turn;
  moved.t12 = (pose.t12 + tangent_basis * step.tail<2>()).normalized();
  return moved;
}

Eigen::Matrix<double, 3, 2> TangentBasis(const Eigen::Vector3d& direction) {
  Eigen::Vector3d a = direction.unitOrthogonal();
  Eigen::Matrix<double, 3, 2> basis;
  basis.col(0) = a;
  basis.col(1) = direction.cross(a).normalized();
  return basis;
}

Eigen::VectorXd SubsetResiduals(const TangentMatches& matches, const std::vector<size_t>& subset,
                                const EpipolarPose& pose, double focal_px) {
  const Eigen::Matrix3d e = TangentEssential(matches, pose);
  Eigen::VectorXd r(static_cast<Eigen::Index>(subset.size()));
  for (size_t k = 0; k < subset.size(); ++k) {
    r(static_cast<Eigen::Index>(k)) =
        focal_px * SampsonOfEssential(e, matches.u1[subset[k]], matches.u2[subset[k]]);
  }
  return r;
}

// Sampson distance of a match to a homography (tangent plane 1 -> 2): the
// residual is the cross product of u2 with H u1 (two rows), its Jacobian with
// respect to (u1, u2) is J, and the distance is sqrt(r^T (J J^T)^-1 r).
double SampsonOfHomography(const Eigen::Matrix3d& h, const Eigen::Vector2d& u1,
                           const Eigen::Vector2d& u2) {
  const Eigen::Vector3d p = h * u1.homogeneous();
  const Eigen::Vector2d r(u2.x() * p.z() - p.x(), u2.y() * p.z() - p.y());
  Eigen::Matrix<double, 2, 4> j;
  j << u2.x() * h(2, 0) - h(0, 0), u2.x() * h(2, 1) - h(0, 1), p.z(), 0.0,
      u2.y() * h(2, 0) - h(1, 0), u2.y() * h(2, 1) - h(1, 1), 0.0, p.z();
  const Eigen::Matrix2d jjt = j * j.transpose();
  const double determinant = jjt.determinant();
  if (!(std::abs(determinant) > 0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(std::max(0.0, r.dot(jjt.inverse() * r)));
}

Eigen::Matrix3d HartleyNormaliser(const std::vector<Eigen::Vector2d>& u) {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : u) centre += p;
  centre /= static_cast<double>(u.size());
  double mean_distance = 0.0;
  for (const Eigen::Vector2d& p : u) mean_distance += (p - centre).norm();
  mean_distance /= static_cast<double>(u.size());
  const double scale = mean_distance > 0 ? std::sqrt(2.0) / mean_distance : 1.0;
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t(0, 0) = scale;
  t(1, 1) = scale;
  t.block<2, 1>(0, 2) = -scale * centre;
  return t;
}

// The DLT on the used matches; false when fewer than 4.
bool HomographyDlt(const TangentMatches& matches, const std::vector<bool>& used,
                   const Eigen::Matrix3d& norm1, const Eigen::Matrix3d& norm2, Eigen::Matrix3d* h) {
  Eigen::Matrix<double, 9, 9> normal_matrix = Eigen::Matrix<double, 9, 9>::Zero();
  int rows = 0;
  for (size_t i = 0; i < matches.u1.size(); ++i) {
    if (!used[i]) continue;
    const Eigen::Vector3d x = norm1 * matches.u1[i].homogeneous();
    const Eigen::Vector3d y = norm2 * matches.u2[i].homogeneous();
    Eigen::Matrix<double, 2, 9> a = Eigen::Matrix<double, 2, 9>::Zero();
    a.block<1, 3>(0, 3) = -y.z() * x.transpose();
    a.block<1, 3>(0, 6) = y.y() * x.transpose();
    a.block<1, 3>(1, 0) = y.z() * x.transpose();
    a.block<1, 3>(1, 6) = -y.x() * x.transpose();
    normal_matrix += a.transpose() * a;
    rows += 2;
  }
  if (rows < 8) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> solver(normal_matrix);
  const Eigen::Matrix<double, 9, 1> v = solver.eigenvectors().col(0);
  Eigen::Matrix3d h_normalised;
  h_normalised << v(0), v(1), v(2), v(3), v(4), v(5), v(6), v(7), v(8);
  *h = norm2.inverse() * h_normalised * norm1;
  return h->allFinite();
}

}  // namespace

TangentMatches ToTangentPlanes(const std::vector<Eigen::Vector3d>& bearings1,
                               const std::vector<Eigen::Vector3d>& bearings2) {
  TangentMatches matches;
  const size_t n = std::min(bearings1.size(), bearings2.size());
  Eigen::Vector3d mean1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean2 = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean1 += bearings1[i];
    mean2 += bearings2[i];
  }
  if (!(mean1.norm() > 0) || !(mean2.norm() > 0)) return matches;
  matches.valid = true;
  matches.to_z1 = RotationToZ(mean1.normalized());
  matches.to_z2 = RotationToZ(mean2.normalized());
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d a = matches.to_z1 * bearings1[i];
    const Eigen::Vector3d b = matches.to_z2 * bearings2[i];
    if (a.z() <= 0 || b.z() <= 0) continue;
    matches.index.push_back(i);
    matches.u1.push_back(a.head<2>() / a.z());
    matches.u2.push_back(b.head<2>() / b.z());
  }
  return matches;
}

std::vector<double> EpipolarSampsonPx(const TangentMatches& matches, const EpipolarPose& pose,
                                      double focal_px) {
  const Eigen::Matrix3d e = TangentEssential(matches, pose);
  std::vector<double> distances(matches.u1.size());
  for (size_t i = 0; i < matches.u1.size(); ++i) {
    distances[i] = focal_px * SampsonOfEssential(e, matches.u1[i], matches.u2[i]);
  }
  return distances;
}

bool RefineEpipolarPose(const TangentMatches& matches, const std::vector<size_t>& subset,
                        double focal_px, EpipolarPose* pose) {
  if (subset.size() < 5) return false;
  EpipolarPose current = *pose;
  Eigen::VectorXd residuals = SubsetResiduals(matches, subset, current, focal_px);
  double cost = residuals.squaredNorm();
  if (!std::isfinite(cost)) return false;
  double damping = kFirstDamping;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const Eigen::Matrix<double, 3, 2> basis = TangentBasis(current.t12);
    Eigen::MatrixXd jacobian(residuals.size(), 5);
    for (int p = 0; p < 5; ++p) {
      Eigen::Matrix<double, 5, 1> step = Eigen::Matrix<double, 5, 1>::Zero();
      step(p) = kDifferenceStep;
      const Eigen::VectorXd plus = SubsetResiduals(matches, subset, Moved(current, step, basis),
                                                   focal_px);
      const Eigen::VectorXd minus = SubsetResiduals(matches, subset, Moved(current, -step, basis),
                                                    focal_px);
      jacobian.col(p) = (plus - minus) / (2.0 * kDifferenceStep);
    }
    if (!jacobian.allFinite()) return false;
    const Eigen::Matrix<double, 5, 5> normal = jacobian.transpose() * jacobian;
    const Eigen::Matrix<double, 5, 1> gradient = jacobian.transpose() * residuals;
    bool improved = false;
    while (damping < 1e12) {
      Eigen::Matrix<double, 5, 5> damped = normal;
      damped.diagonal() += damping * normal.diagonal().cwiseMax(1e-12);
      const Eigen::Matrix<double, 5, 1> step = damped.ldlt().solve(-gradient);
      const EpipolarPose candidate = Moved(current, step, basis);
      const Eigen::VectorXd candidate_residuals =
          SubsetResiduals(matches, subset, candidate, focal_px);
      const double candidate_cost = candidate_residuals.squaredNorm();
      if (std::isfinite(candidate_cost) && candidate_cost < cost) {
        const double decrease = (cost - candidate_cost) / std::max(cost, 1e-300);
        current = candidate;
        residuals = candidate_residuals;
        cost = candidate_cost;
        damping = std::max(damping / 10.0, 1e-12);
        improved = decrease > kRelativeDecrease;
        break;
      }
      damping *= 10.0;
    }
    if (!improved) break;
  }
  if (!current.r12.allFinite() || !current.t12.allFinite()) return false;
  *pose = current;
  return true;
}

HomographyModel FitHomographyModel(const TangentMatches& matches, double focal_px, int refits,
                                   double trim) {
  HomographyModel model;
  const size_t n = matches.u1.size();
  if (!matches.valid || n < 4) return model;
  const Eigen::Matrix3d norm1 = HartleyNormaliser(matches.u1);
  const Eigen::Matrix3d norm2 = HartleyNormaliser(matches.u2);
  model.used.assign(n, true);
  model.transfer_px.assign(n, 0.0);
  for (int refit = 0; refit < refits; ++refit) {
    Eigen::Matrix3d h;
    if (!HomographyDlt(matches, model.used, norm1, norm2, &h)) break;
    model.h = h;
    model.valid = true;
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d mapped = h * matches.u1[i].homogeneous();
      const double error = (mapped.head<2>() / mapped.z() - matches.u2[i]).norm() * focal_px;
      model.transfer_px[i] = std::isfinite(error) ? error : std::numeric_limits<double>::max();
    }
    const double cut = trim * util::UpperMedian(model.transfer_px);
    for (size_t i = 0; i < n; ++i) model.used[i] = model.transfer_px[i] <= cut;
  }
  if (!model.valid) return model;
  model.sampson_px.resize(n);
  for (size_t i = 0; i < n; ++i) {
    model.sampson_px[i] = focal_px * SampsonOfHomography(model.h, matches.u1[i], matches.u2[i]);
  }
  return model;
}

GeneralModel FitGeneralModel(const TangentMatches& matches, const EpipolarPose& start,
                             double focal_px) {
  GeneralModel model;
  model.pose = start;
  model.pose.t12.normalize();
  for (int pass = 0; pass < kGeneralPasses; ++pass) {
    const std::vector<double> distances = EpipolarSampsonPx(matches, model.pose, focal_px);
    const double cut = kTrim * kMadToSigma * MedianAbsolute(distances);
    std::vector<size_t> subset;
    for (size_t i = 0; i < distances.size(); ++i) {
      if (std::abs(distances[i]) <= cut) subset.push_back(i);
    }
    if (!RefineEpipolarPose(matches, subset, focal_px, &model.pose)) break;
  }
  model.sampson_px = EpipolarSampsonPx(matches, model.pose, focal_px);
  return model;
}

ModelSelection SelectTwoViewModel(const std::vector<double>& general_sampson_px,
                                  const std::vector<double>& homography_sampson_px) {
  ModelSelection selection;
  const size_t n = std::min(general_sampson_px.size(), homography_sampson_px.size());
  selection.num_matches = static_cast<int>(n);
  if (n == 0) return selection;
  selection.noise_px = std::max(kMadToSigma * MedianAbsolute(general_sampson_px), kMinNoisePx);
  const double variance = selection.noise_px * selection.noise_px;
  constexpr double kR = 4.0;  // two image positions per match
  const auto gric = [&](const std::vector<double>& distances, double dimension, double parameters) {
    const double cap = 2.0 * (kR - dimension);
    double sum = 0.0;
    for (size_t i = 0; i < n; ++i) {
      const double scaled = distances[i] * distances[i] / variance;
      sum += std::isfinite(scaled) ? std::min(scaled, cap) : cap;
    }
    const double count = static_cast<double>(n);
    return sum + std::log(kR) * dimension * count + std::log(kR * count) * parameters;
  };
  selection.gric_general = gric(general_sampson_px, 3.0, 5.0);
  selection.gric_homography = gric(homography_sampson_px, 2.0, 8.0);
  return selection;
}

}  // namespace hdabench::reference
