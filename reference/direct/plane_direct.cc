#include "reference/direct/plane_direct.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "reference/direct/cubic_spline.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using Vector5d = Eigen::Matrix<double, 5, 1>;
using Matrix5d = Eigen::Matrix<double, 5, 5>;

cv::Mat ToFloat(const cv::Mat& image, const char* name) {
  if (image.empty()) throw InputError(std::string(name) + " is empty");
  if (image.channels() != 1) throw InputError(std::string(name) + " must have one channel");
  cv::Mat out;
  image.convertTo(out, CV_32F);
  return out;
}

double RobustSigma(const std::vector<double>& residuals) {
  std::vector<double> a;
  a.reserve(residuals.size());
  for (const double r : residuals) a.push_back(std::abs(r));
  std::sort(a.begin(), a.end());
  return 1.4826 * util::Quantile(a, 0.5);
}

// The ROI's pixels of image 1 with a bearing: what stays fixed in the fit.
struct RoiPixels {
  std::vector<Eigen::Vector2d> pixels;  // image 1, parallel to bearings
  std::vector<Eigen::Vector3d> bearings;
  std::vector<double> values1;
  std::vector<Eigen::RowVector2d> gradients1;    // image 1's gradient at the pixel, DN per pixel
  std::vector<Eigen::Vector3d> corner_bearings;  // the box's four corners
  Eigen::Vector2d corner_spacing_px = Eigen::Vector2d::Ones();  // image-1 distance of corners 1 and 2 from corner 0
};

RoiPixels PixelsOf(const DirectPlaneImages& images, const calib::CameraModel& camera, const cv::Rect& box) {
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(static_cast<size_t>(box.area()) + 4);
  for (int row = box.y; row < box.y + box.height; ++row) {
    for (int col = box.x; col < box.x + box.width; ++col) pixels.emplace_back(col, row);
  }
  const double x0 = box.x, y0 = box.y, x1 = box.x + box.width - 1, y1 = box.y + box.height - 1;
  pixels.emplace_back(x0, y0);
  pixels.emplace_back(x1, y0);
  pixels.emplace_back(x0, y1);
  pixels.emplace_back(x1, y1);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  camera.Unproject(pixels, &bearings, &valid);
  RoiPixels out;
  const size_t n = pixels.size() - 4;
  for (size_t k = 0; k < n; ++k) {
    if (!valid[k]) continue;
    out.pixels.push_back(pixels[k]);
    out.bearings.push_back(bearings[k]);
    const int row = static_cast<int>(pixels[k].y());
    const int col = static_cast<int>(pixels[k].x());
    out.values1.push_back(images.image1.at<float>(row, col));
    out.gradients1.emplace_back(images.gradient_x1.at<float>(row, col), images.gradient_y1.at<float>(row, col));
  }
  out.corner_spacing_px = Eigen::Vector2d(std::max(1.0, x1 - x0), std::max(1.0, y1 - y0));
  for (size_t k = n; k < pixels.size(); ++k) {
    if (valid[k]) out.corner_bearings.push_back(bearings[k]);
  }
  return out;
}

// Where the box's corners land in image 2 with plane p (for the convergence
// test); false when one cannot be projected.
bool CornersInImage2(const RoiPixels& roi, const calib::CameraModel& camera, const Rigid3d& cam2_from_cam1,
                     const Eigen::Vector3d& p, std::vector<Eigen::Vector2d>* corners) {
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& b : roi.corner_bearings) {
    const double pb = p.dot(b);
    if (!(pb > 0.0)) return false;
    points.push_back(cam2_from_cam1 * (b / pb));
  }
  std::vector<unsigned char> valid;
  camera.Project(points, corners, &valid);
  return std::all_of(valid.begin(), valid.end(), [](unsigned char v) { return v != 0; });
}

// The parallax of the ROI: how far each corner moves in image 2 between
// plane p and the plane at infinity (its ray's direction alone), pixels, the
// largest of the four. +infinity when a corner cannot be projected either
// way (the ROI is then not judged by it).
double CornerParallaxPx(const RoiPixels& roi, const calib::CameraModel& camera, const Rigid3d& cam2_from_cam1,
                        const Eigen::Vector3d& p) {
  std::vector<Eigen::Vector3d> points;
  for (const Eigen::Vector3d& b : roi.corner_bearings) {
    const double pb = p.dot(b);
    if (!(pb > 0.0)) return std::numeric_limits<double>::infinity();
    points.push_back(cam2_from_cam1 * (b / pb));
    points.push_back(cam2_from_cam1.rotation * b);
  }
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  if (camera.Project(points, &pixels, &valid) != static_cast<int>(points.size())) {
    return std::numeric_limits<double>::infinity();
  }
  double largest = 0.0;
  for (size_t k = 0; k + 1 < pixels.size(); k += 2) largest = std::max(largest, (pixels[k] - pixels[k + 1]).norm());
  return largest;
}

// Camera-2 points' pixels and the projection's Jacobians d pixel / d point
// (forward differences of h = 1e-7 times the point's distance, at least
// 1e-7 m), for the points with use[k]; valid[k] is 1 where the point and its
// three steps project. Points without use[k] are not projected.
struct Projections {
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Matrix<double, 2, 3>> jacobians;
  std::vector<unsigned char> valid;
};

Projections ProjectWithJacobians(const calib::CameraModel& camera, const std::vector<Eigen::Vector3d>& in_cam2,
                                 const std::vector<unsigned char>& use) {
  const size_t n = in_cam2.size();
  std::vector<size_t> used;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> steps;
  for (size_t k = 0; k < n; ++k) {
    if (!use[k]) continue;
    const Eigen::Vector3d& x2 = in_cam2[k];
    const double h = 1e-7 * std::max(1.0, x2.norm());
    used.push_back(k);
    steps.push_back(h);
    points.push_back(x2);
    for (int j = 0; j < 3; ++j) points.push_back(x2 + h * Eigen::Vector3d::Unit(j));
  }
  std::vector<Eigen::Vector2d> projected;
  std::vector<unsigned char> valid;
  camera.Project(points, &projected, &valid);
  Projections out;
  out.pixels.resize(n, Eigen::Vector2d::Zero());
  out.jacobians.resize(n, Eigen::Matrix<double, 2, 3>::Zero());
  out.valid.assign(n, 0);
  for (size_t u = 0; u < used.size(); ++u) {
    if (!valid[4 * u] || !valid[4 * u + 1] || !valid[4 * u + 2] || !valid[4 * u + 3]) continue;
    const size_t k = used[u];
    out.valid[k] = 1;
    out.pixels[k] = projected[4 * u];
    for (int j = 0; j < 3; ++j) out.jacobians[k].col(j) = (projected[4 * u + 1 + j] - projected[4 * u]) / steps[u];
  }
  return out;
}

// The ROI's pixels on plane p: each one's point in camera 1 and in camera 2
// (in_front[k] 0, and both points zero, where its ray meets the plane behind
// camera 1).
struct PointsOnPlane {
  std::vector<Eigen::Vector3d> in_cam1, in_cam2;
  std::vector<unsigned char> in_front;
};

PointsOnPlane OnPlane(const RoiPixels& roi, const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& p) {
  const size_t n = roi.bearings.size();
  PointsOnPlane out;
  out.in_cam1.assign(n, Eigen::Vector3d::Zero());
  out.in_cam2.assign(n, Eigen::Vector3d::Zero());
  out.in_front.assign(n, 0);
  for (size_t k = 0; k < n; ++k) {
    const double pb = p.dot(roi.bearings[k]);
    if (!(pb > 0.0)) continue;
    out.in_front[k] = 1;
    out.in_cam1[k] = roi.bearings[k] / pb;
    out.in_cam2[k] = cam2_from_cam1 * out.in_cam1[k];
  }
  return out;
}

// How the point X = b / (p . b) of a pixel's ray (unit bearing b) on plane
// p moves with p: dX/dp = -X b^T / (p . b).
Eigen::Matrix3d PointOnPlaneJacobian(const Eigen::Vector3d& x, const Eigen::Vector3d& b, const Eigen::Vector3d& p) {
  return -x * b.transpose() / p.dot(b);
}

// One linearisation of the problem at plane p (parameterised as p = scale *
// q), gain and offset: the residuals and their Jacobian rows of the pixels
// that land inside image 2.
struct Linearisation {
  std::vector<double> residuals;
  std::vector<Vector5d> jacobians;
  std::vector<size_t> pixels;  // each residual's pixel of RoiPixels
};

Linearisation Linearise(const DirectPlaneImages& images, const calib::CameraModel& camera, const RoiPixels& roi,
                        const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& p, double scale, double gain,
                        double offset, const Eigen::Matrix2d& image1_from_image2) {
  const Eigen::Matrix3d R = cam2_from_cam1.RotationMatrix();
  const size_t n = roi.bearings.size();
  const PointsOnPlane on_plane = OnPlane(roi, cam2_from_cam1, p);
  const Projections projections = ProjectWithJacobians(camera, on_plane.in_cam2, on_plane.in_front);
  Linearisation out;
  out.residuals.reserve(n);
  out.jacobians.reserve(n);
  for (size_t k = 0; k < n; ++k) {
    const Eigen::Vector2d& q = projections.pixels[k];
    if (!projections.valid[k] || !InsideSpline(images.spline2, q.x(), q.y())) continue;
    const Eigen::Matrix<double, 2, 3>& dq_dx2 = projections.jacobians[k];
    const SplineSample sample = SampleCubicSpline(images.spline2, q.x(), q.y());
    // Image 2's gradient from image 1's (central differences, which leave
    // out the pixel's own value) through the ROI's warp: noise-free of the
    // residual's own noise. The interpolant's gradient at q shares that
    // noise, with a correlation that depends on the sub-pixel position,
    // which would bias the fit's fixed point as a tilt does.
    // Image 2 is modelled as gain * image 1: its gradient is gain times image 1's.
    const Eigen::RowVector2d g = gain * roi.gradients1[k] * image1_from_image2;
    const Eigen::Vector3d& b = roi.bearings[k];
    // p = scale * q.
    const Eigen::Matrix3d dx_dp = PointOnPlaneJacobian(on_plane.in_cam1[k], b, p);
    Vector5d row;
    row.head<3>() = (g * dq_dx2 * R * dx_dp * scale).transpose();
    row(3) = -roi.values1[k];
    row(4) = -1.0;
    out.residuals.push_back(sample.value - gain * roi.values1[k] - offset);
    out.jacobians.push_back(row);
    out.pixels.push_back(k);
  }
  return out;
}

// Normalised cross-correlation of image 1's pixels with image 2 under plane
// p, over the pixels that land in image 2; -2 with fewer than `min_pixels`.
double Correlation(const DirectPlaneImages& images, const calib::CameraModel& camera, const RoiPixels& roi,
                   const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& p, int min_pixels) {
  std::vector<Eigen::Vector3d> points;
  std::vector<size_t> index;
  for (size_t k = 0; k < roi.bearings.size(); ++k) {
    const double pb = p.dot(roi.bearings[k]);
    if (!(pb > 0.0)) continue;
    points.push_back(cam2_from_cam1 * (roi.bearings[k] / pb));
    index.push_back(k);
  }
  std::vector<Eigen::Vector2d> projected;
  std::vector<unsigned char> valid;
  camera.Project(points, &projected, &valid);
  double s1 = 0, s2 = 0, s11 = 0, s22 = 0, s12 = 0;
  int n = 0;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!valid[i] || !InsideSpline(images.spline2, projected[i].x(), projected[i].y())) continue;
    const double a = roi.values1[index[i]];
    const double b = SampleCubicSpline(images.spline2, projected[i].x(), projected[i].y()).value;
    s1 += a;
    s2 += b;
    s11 += a * a;
    s22 += b * b;
    s12 += a * b;
    ++n;
  }
  if (n < min_pixels) return -2.0;
  const double var1 = s11 - s1 * s1 / n;
  const double var2 = s22 - s2 * s2 / n;
  if (!(var1 > 0.0) || !(var2 > 0.0)) return -2.0;
  return (s12 - s1 * s2 / n) / std::sqrt(var1 * var2);
}

// The search of DirectPlaneOptions::search_fraction: the factor on the
// starting plane (its inverse distance) with the best correlation.
double SearchScale(const DirectPlaneImages& images, const calib::CameraModel& camera, const RoiPixels& roi,
                   const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& p0, const DirectPlaneOptions& options) {
  if (options.search_fraction <= 0.0) return 1.0;
  // The image-2 motion of the box's centre ray per unit of scale.
  const Eigen::Vector3d centre = (roi.corner_bearings[0] + roi.corner_bearings[3]).normalized();
  const auto centre_in_image2 = [&](double s, Eigen::Vector2d* q) {
    const double pb = s * p0.dot(centre);
    if (!(pb > 0.0)) return false;
    std::vector<Eigen::Vector2d> out;
    std::vector<unsigned char> valid;
    camera.Project({cam2_from_cam1 * (centre / pb)}, &out, &valid);
    *q = out[0];
    return valid[0] != 0;
  };
  Eigen::Vector2d a, b;
  const double ds = 1e-3;
  if (!centre_in_image2(1.0 - ds, &a) || !centre_in_image2(1.0 + ds, &b)) return 1.0;
  const double px_per_scale = (b - a).norm() / (2 * ds);
  if (!(px_per_scale > 0.0)) return 1.0;
  const int steps = static_cast<int>(
      std::min(400.0, std::ceil(options.search_fraction * px_per_scale / options.search_step_px)));
  // A candidate must see as many pixels in image 2 as the fit needs; when
  // none does, the start stays as it was.
  const int min_pixels = std::max(
      options.min_pixels,
      static_cast<int>(std::ceil(options.min_overlap_fraction * static_cast<double>(roi.bearings.size()))));
  double best_scale = 1.0, best = -2.0;
  for (int i = -steps; i <= steps; ++i) {
    const double s = 1.0 + options.search_fraction * i / std::max(steps, 1);
    const double c = Correlation(images, camera, roi, cam2_from_cam1, s * p0, min_pixels);
    if (c > best) {
      best = c;
      best_scale = s;
    }
  }
  return best_scale;
}

// Huber weight of a residual for width k.
double HuberWeight(double r, double k) { return std::abs(r) <= k ? 1.0 : k / std::abs(r); }

// The larger semi-axis of the 1-sigma uncertainty of plane p's unit normal
// (the covariance of p propagated to it), degrees.
double NormalSigmaDeg(const Eigen::Vector3d& p, const Eigen::Matrix3d& covariance) {
  const Eigen::Vector3d n = p.normalized();
  const Eigen::Matrix3d j = (Eigen::Matrix3d::Identity() - n * n.transpose()) / p.norm();
  const Eigen::Matrix3d c = j * covariance * j.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (c + c.transpose()));
  const double largest = std::max(0.0, eigen.eigenvalues().maxCoeff());
  return std::sqrt(largest) * util::kRadToDeg;
}

// The slope of plane p against up_in_cam1 and the larger semi-axis of its
// normal's uncertainty.
void SlopeAndSigma(const Eigen::Vector3d& p, const Eigen::Matrix3d& covariance, const Eigen::Vector3d& up,
                   DirectPlaneResult* result) {
  Eigen::Vector3d n = p.normalized();
  if (n.dot(up) < 0.0) n = -n;  // p points from camera 1 to the plane; the surface normal points up
  result->up_normal_in_cam1 = n;
  result->slope_deg = std::acos(std::clamp(n.dot(up), -1.0, 1.0)) * util::kRadToDeg;
  result->slope_sigma_deg = NormalSigmaDeg(p, covariance);
}

// What one fit works on: the pair, the ROI's pixels and the starting plane's
// scale (the plane is p = scale * q with q of order one).
struct Problem {
  const DirectPlaneImages* images;
  const calib::CameraModel* camera;
  const Rigid3d* cam2_from_cam1;
  const DirectPlaneOptions* options;
  RoiPixels roi;
  double scale;

  Eigen::Vector3d Plane(const Eigen::Vector3d& q) const { return scale * q; }
  // Enough of the ROI's pixels in image 2 for the fit.
  bool Enough(const Linearisation& lin) const {
    return static_cast<int>(lin.residuals.size()) >= options->min_pixels &&
           static_cast<double>(lin.residuals.size()) >=
               options->min_overlap_fraction * static_cast<double>(roi.bearings.size());
  }
};

// The unknowns and where the ROI's corners land in image 2 with them.
struct State {
  Eigen::Vector3d q = Eigen::Vector3d::Zero();
  double gain = 1.0;
  double offset = 0.0;
  std::vector<Eigen::Vector2d> corners;
};

// The ROI's warp from image 1 to image 2 (from its corners), inverted: image-1
// gradients into image 2.
Eigen::Matrix2d WarpInverse(const RoiPixels& roi, const std::vector<Eigen::Vector2d>& c) {
  Eigen::Matrix2d a;
  a.col(0) = (c[1] - c[0]) / roi.corner_spacing_px.x();
  a.col(1) = (c[2] - c[0]) / roi.corner_spacing_px.y();
  const double det = a.determinant();
  return std::abs(det) > 1e-9 ? Eigen::Matrix2d(a.inverse()) : Eigen::Matrix2d::Identity();
}

Linearisation LineariseAt(const Problem& problem, const State& state) {
  return Linearise(*problem.images, *problem.camera, problem.roi, *problem.cam2_from_cam1,
                   problem.Plane(state.q), problem.scale, state.gain, state.offset,
                   WarpInverse(problem.roi, state.corners));
}

// The Huber-weighted normal equations of a linearisation.
struct NormalEquations {
  Matrix5d normal = Matrix5d::Zero();
  Vector5d rhs = Vector5d::Zero();
  double weighted_squares = 0.0;
  double weights = 0.0;
};
NormalEquations Accumulate(const Linearisation& lin, double huber) {
  NormalEquations eq;
  for (size_t k = 0; k < lin.residuals.size(); ++k) {
    const double w = HuberWeight(lin.residuals[k], huber);
    eq.normal.noalias() += w * lin.jacobians[k] * lin.jacobians[k].transpose();
    eq.rhs.noalias() += w * lin.jacobians[k] * lin.residuals[k];
    eq.weighted_squares += w * lin.residuals[k] * lin.residuals[k];
    eq.weights += w;
  }
  return eq;
}

// Gauss-Newton from `state` until the corners stop moving or max_iterations;
// false, with the status and reason in *result, when it cannot go on.
bool Iterate(const Problem& problem, State* state, DirectPlaneResult* result) {
  const DirectPlaneOptions& options = *problem.options;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    const Linearisation lin = LineariseAt(problem, *state);
    if (!problem.Enough(lin)) break;
    const NormalEquations eq = Accumulate(lin, 1.345 * std::max(RobustSigma(lin.residuals), 1e-3));
    const Eigen::LDLT<Matrix5d> ldlt(eq.normal);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      result->status = DirectPlaneStatus::kNoTexture;
      result->reason = "the pixels do not constrain the plane (singular normal equations)";
      result->iterations = iteration;
      return false;
    }
    const Vector5d step = -ldlt.solve(eq.rhs);
    if (!step.allFinite()) {
      result->reason = "the Gauss-Newton step is not finite";
      result->iterations = iteration;
      return false;
    }
    // Halve a step that puts the ROI behind a camera.
    double t = 1.0;
    std::vector<Eigen::Vector2d> moved;
    while (t > 1e-3 && !CornersInImage2(problem.roi, *problem.camera, *problem.cam2_from_cam1,
                                        problem.Plane(state->q + t * step.head<3>()), &moved)) {
      t *= 0.5;
    }
    if (t <= 1e-3) {
      result->reason = "every step puts the ROI behind a camera";
      result->iterations = iteration;
      return false;
    }
    state->q += t * step.head<3>();
    state->gain += t * step(3);
    state->offset += t * step(4);
    result->iterations = iteration + 1;
    double largest_move = 0.0;
    for (size_t c = 0; c < state->corners.size(); ++c) {
      largest_move = std::max(largest_move, (moved[c] - state->corners[c]).norm());
    }
    state->corners = moved;
    // A halved step moves little without having converged.
    if (t == 1.0 && largest_move < options.convergence_px) {
      result->converged = true;
      break;
    }
  }
  return true;
}

// The inverse of a normal matrix, taken at unit diagonal (the plane's columns
// and the brightness columns differ by orders of magnitude); false, with the
// reason, when a direction is not constrained.
bool InvertAtUnitDiagonal(const Matrix5d& normal, Matrix5d* inverse, std::string* why) {
  const Vector5d diagonal = normal.diagonal();
  if (!(diagonal.minCoeff() > 0.0)) {
    *why = "the pixels have no gradient: nothing constrains the plane";
    return false;
  }
  const Vector5d unit = diagonal.cwiseSqrt().cwiseInverse();
  const Matrix5d scaled = unit.asDiagonal() * normal * unit.asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Matrix5d> eigen(scaled);
  if (!(eigen.eigenvalues().minCoeff() > 1e-12 * eigen.eigenvalues().maxCoeff())) {
    *why = "the pixels' gradients do not constrain every direction of the plane";
    return false;
  }
  *inverse = unit.asDiagonal() *
             (eigen.eigenvectors() * eigen.eigenvalues().cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose()) *
             unit.asDiagonal();
  return true;
}

// The solution's residuals, covariance, slope and status.
void FinishAtSolution(const Problem& problem, const State& state, const Eigen::Vector3d& up_in_cam1,
                      DirectPlaneResult* result) {
  const DirectPlaneOptions& options = *problem.options;
  const Linearisation lin = LineariseAt(problem, state);
  result->pixels = static_cast<int>(lin.residuals.size());
  if (!problem.Enough(lin)) {
    result->status = DirectPlaneStatus::kOutsideOverlap;
    result->reason = std::to_string(lin.residuals.size()) + " of the ROI's " +
                     std::to_string(problem.roi.bearings.size()) + " pixels project into image 2 (at least " +
                     util::FixedText(100.0 * options.min_overlap_fraction, 0) + " % and " +
                     std::to_string(options.min_pixels) + " needed)";
    return;
  }
  result->robust_sigma_dn = RobustSigma(lin.residuals);
  const double huber = 1.345 * std::max(result->robust_sigma_dn, 1e-3);
  const NormalEquations eq = Accumulate(lin, huber);
  const double dof = std::max(1.0, static_cast<double>(lin.residuals.size()) - 5.0);
  // The residual variance, never below the quantisation's (1/12 DN^2): an
  // image is not known better than that, so perfect agreement of untextured
  // pixels gives an unbounded sigma, not zero.
  const double variance = std::max(eq.weighted_squares / dof, 1.0 / 12.0);
  Matrix5d inverse;
  if (!InvertAtUnitDiagonal(eq.normal, &inverse, &result->reason)) {
    result->status = DirectPlaneStatus::kNoTexture;
    return;
  }
  const Matrix5d covariance = variance * inverse;
  result->plane_in_cam1 = problem.Plane(state.q);
  result->plane_covariance = problem.scale * problem.scale * covariance.topLeftCorner<3, 3>();
  result->gain = state.gain;
  result->offset_dn = state.offset;
  result->residual_rms_dn = std::sqrt(eq.weighted_squares / std::max(eq.weights, 1e-12));
  SlopeAndSigma(result->plane_in_cam1, result->plane_covariance, up_in_cam1, result);
  if (!std::isfinite(result->slope_deg) || !std::isfinite(result->slope_sigma_deg)) {
    result->status = DirectPlaneStatus::kDiverged;
    result->reason = "the plane's slope is not finite";
    return;
  }
  std::ostringstream reason;
  reason << result->pixels << " pixels, " << result->iterations << " iterations"
         << (result->converged ? "" : " (not converged)") << ", residual "
         << util::FixedText(result->residual_rms_dn, 2) << " DN, slope sigma "
         << util::FixedText(result->slope_sigma_deg, 2) << " deg";
  result->reason = reason.str();
  if (result->slope_sigma_deg > options.max_slope_sigma_deg) {
    result->status = DirectPlaneStatus::kNoTexture;
    result->reason += " (over " + util::FixedText(options.max_slope_sigma_deg, 2) + ")";
    return;
  }
  // A plane the fit does not settle on is not given, whatever its sigma (at
  // the overlap's edge, a fit that kept moving ended 85 deg steep with a
  // sigma of 1 deg).
  if (!result->converged) {
    result->status = DirectPlaneStatus::kDiverged;
    result->reason += ": a fit that did not settle gives no plane";
    return;
  }
  for (const Eigen::Vector3d& b : problem.roi.bearings) {
    const double pb = result->plane_in_cam1.dot(b);
    if (pb > 0.0) result->points_in_cam1.push_back(b / pb);
  }
  // A pixel's row of the plane's Jacobian is a multiple of its bearing (the
  // plane moves its point only along its ray), so its squared norm, times
  // its Huber weight, is what the pixel tells of its own depth.
  result->support_px.reserve(lin.pixels.size());
  result->support_weights.reserve(lin.pixels.size());
  for (size_t k = 0; k < lin.pixels.size(); ++k) {
    result->support_px.push_back(problem.roi.pixels[lin.pixels[k]]);
    result->support_weights.push_back(HuberWeight(lin.residuals[k], huber) *
                                      lin.jacobians[k].head<3>().squaredNorm());
  }
  result->status = DirectPlaneStatus::kOk;
}

// The slope sigma (degrees) the pose's parallax alone leaves plane p of the
// ROI: each of its pixels that lands in image 2 located there to
// precision_px, and nothing else known (no texture, no noise, no brightness
// model). A pixel's image-2 motion with the plane is along its epipolar
// line, so the precision is along that line. +infinity when the motion does
// not constrain every direction of the plane; *pixels: the pixels counted.
double ParallaxSlopeSigmaDeg(const Problem& problem, const Eigen::Vector3d& p, double precision_px, int* pixels) {
  const PointsOnPlane on_plane = OnPlane(problem.roi, *problem.cam2_from_cam1, p);
  const Projections projections = ProjectWithJacobians(*problem.camera, on_plane.in_cam2, on_plane.in_front);
  const Eigen::Matrix3d R = problem.cam2_from_cam1->RotationMatrix();
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  *pixels = 0;
  for (size_t k = 0; k < problem.roi.bearings.size(); ++k) {
    const Eigen::Vector2d& q = projections.pixels[k];
    if (!projections.valid[k] || !InsideSpline(problem.images->spline2, q.x(), q.y())) continue;
    const Eigen::Vector3d& b = problem.roi.bearings[k];
    const Eigen::Matrix3d dx_dp = PointOnPlaneJacobian(on_plane.in_cam1[k], b, p);
    const Eigen::Matrix<double, 2, 3> dq_dp = projections.jacobians[k] * R * dx_dp;
    information.noalias() += dq_dp.transpose() * dq_dp;
    ++*pixels;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(information);
  const Eigen::Vector3d values = eigen.eigenvalues();
  if (!(values.minCoeff() > 1e-12 * values.maxCoeff()) || !std::isfinite(values.maxCoeff())) {
    return std::numeric_limits<double>::infinity();
  }
  const Eigen::Matrix3d covariance = precision_px * precision_px * eigen.eigenvectors() *
                                     values.cwiseInverse().asDiagonal() * eigen.eigenvectors().transpose();
  return NormalSigmaDeg(p, covariance);
}

// A fit that gave no slope within the bound (it found no texture, or
// diverged without a sigma under the bound), on a pair whose parallax alone
// would leave the slope over the bound with every pixel located to
// parallax_precision_px, is low parallax: the cause is the geometry, which
// no texture would overcome. The parallax is judged on the starting plane,
// with as many of the ROI's pixels in image 2 as the fit needs; with fewer
// (at the overlap's edge) the fit's status stands.
void AttributeToParallax(const Problem& problem, const Eigen::Vector3d& start, DirectPlaneResult* result) {
  const DirectPlaneOptions& options = *problem.options;
  if (std::isfinite(result->slope_sigma_deg) && result->slope_sigma_deg > 0.0 &&
      result->slope_sigma_deg <= options.max_slope_sigma_deg) {
    return;  // the fit's own sigma was under the bound: a plane that did not settle, not a geometry without one
  }
  int pixels = 0;
  const double sigma_deg = ParallaxSlopeSigmaDeg(problem, start, options.parallax_precision_px, &pixels);
  if (pixels < options.min_pixels ||
      static_cast<double>(pixels) < options.min_overlap_fraction * static_cast<double>(problem.roi.bearings.size())) {
    return;
  }
  result->parallax_slope_sigma_deg = sigma_deg;
  if (sigma_deg <= options.max_slope_sigma_deg) return;
  std::ostringstream reason;
  reason << "the nav pose's parallax (baseline " << problem.cam2_from_cam1->Inverse().translation.norm()
         << " m) leaves the slope uncertain by "
         << (sigma_deg < 90.0 ? util::FixedText(sigma_deg, 1) + " deg" : std::string("any angle"))
         << " on the starting plane even with each of its " << pixels << " pixels located to "
         << util::ShortestText(options.parallax_precision_px) << " px in image 2 (at most "
         << util::FixedText(options.max_slope_sigma_deg, 2) << " deg); the fit: " << result->reason;
  result->status = DirectPlaneStatus::kLowParallax;
  result->reason = reason.str();
}

}  // namespace

std::vector<std::string> DirectPlaneOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(search_fraction >= 0 && search_fraction <= 0.9, "search_fraction", search_fraction, "in [0, 0.9]",
                &errors);
  RequireOption(search_step_px > 0, "search_step_px", search_step_px, "> 0 (pixels)", &errors);
  RequireOption(max_iterations >= 1, "max_iterations", max_iterations, ">= 1", &errors);
  RequireOption(convergence_px > 0, "convergence_px", convergence_px, "> 0 (pixels)", &errors);
  RequireOption(min_overlap_fraction > 0 && min_overlap_fraction <= 1, "min_overlap_fraction",
                min_overlap_fraction, "in (0, 1]", &errors);
  RequireOption(min_pixels >= 8, "min_pixels", min_pixels, ">= 8", &errors);
  RequireOption(max_slope_sigma_deg > 0, "max_slope_sigma_deg", max_slope_sigma_deg, "> 0 (degrees)", &errors);
  RequireOption(parallax_precision_px > 0, "parallax_precision_px", parallax_precision_px, "> 0 (pixels)",
                &errors);
  return errors;
}

const char* ToString(DirectPlaneStatus status) {
  switch (status) {
    case DirectPlaneStatus::kOk:
      return "ok";
    case DirectPlaneStatus::kOutsideOverlap:
      return "outside overlap";
    case DirectPlaneStatus::kNoTexture:
      return "no texture";
    case DirectPlaneStatus::kDiverged:
      return "diverged";
    case DirectPlaneStatus::kLowParallax:
      return "low parallax";
  }
  return "?";
}

DirectPlaneImages PrepareDirectPlaneImages(const cv::Mat& image1, const cv::Mat& image2) {
  DirectPlaneImages images;
  images.image1 = ToFloat(image1, "image 1");
  const cv::Mat float2 = ToFloat(image2, "image 2");
  if (images.image1.size() != float2.size()) {
    throw InputError("the two images differ in size: " + std::to_string(image1.cols) + " x " +
                     std::to_string(image1.rows) + " and " + std::to_string(image2.cols) + " x " +
                     std::to_string(image2.rows));
  }
  // Central differences, (I(x + 1) - I(x - 1)) / 2, the border replicated.
  cv::Sobel(images.image1, images.gradient_x1, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(images.image1, images.gradient_y1, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  images.spline2 = CubicSplineCoefficients(float2);
  return images;
}

DirectPlaneResult FitPlaneDirect(const DirectPlaneImages& images, const calib::CameraModel& camera,
                                 const cv::Rect& box1, const Rigid3d& cam2_from_cam1,
                                 const Eigen::Vector3d& initial_plane_in_cam1,
                                 const Eigen::Vector3d& up_in_cam1, const DirectPlaneOptions& options) {
  ThrowIfInvalid("FitPlaneDirect: invalid DirectPlaneOptions: ", options.Validate());
  const cv::Size size(camera.WidthPx(), camera.HeightPx());
  if (images.image1.size() != size || images.spline2.size() != size) {
    throw InputError("FitPlaneDirect: the images are not of the camera's size " + std::to_string(size.width) +
                     " x " + std::to_string(size.height));
  }
  if (box1.area() <= 0 || (box1 & cv::Rect(cv::Point(0, 0), size)) != box1) {
    throw InputError("FitPlaneDirect: the box is empty or not inside image 1");
  }
  DirectPlaneResult result;
  const Problem problem{&images, &camera, &cam2_from_cam1, &options, PixelsOf(images, camera, box1),
                        initial_plane_in_cam1.norm()};
  if (!initial_plane_in_cam1.allFinite() || !(problem.scale > 0.0) || problem.roi.corner_bearings.size() != 4) {
    result.reason = "no usable starting plane or box corners";
    return result;
  }
  // The plane is seen through parallax only: with none (no baseline across
  // the ROI's lines of sight) every plane maps the ROI alike.
  const double parallax_px = CornerParallaxPx(problem.roi, camera, cam2_from_cam1, initial_plane_in_cam1);
  if (!(parallax_px >= options.convergence_px)) {
    result.status = DirectPlaneStatus::kLowParallax;
    std::ostringstream reason;
    reason << "the pose (baseline " << cam2_from_cam1.Inverse().translation.norm()
           << " m) moves the ROI's corners by at most " << parallax_px
           << " px between its starting plane and infinity, under convergence_px (" << options.convergence_px
           << "): the plane is not observable";
    result.reason = reason.str();
    return result;
  }
  result.search_scale = SearchScale(images, camera, problem.roi, cam2_from_cam1, initial_plane_in_cam1, options);
  State state;
  state.q = result.search_scale * initial_plane_in_cam1 / problem.scale;
  if (!CornersInImage2(problem.roi, camera, cam2_from_cam1, problem.scale * state.q, &state.corners)) {
    result.reason = "the starting plane puts the ROI behind a camera";
    return result;
  }
  if (Iterate(problem, &state, &result)) FinishAtSolution(problem, state, up_in_cam1, &result);
  if (result.status == DirectPlaneStatus::kNoTexture || result.status == DirectPlaneStatus::kDiverged) {
    AttributeToParallax(problem, initial_plane_in_cam1, &result);
  }
  return result;
}

}  // namespace hdabench::reference
