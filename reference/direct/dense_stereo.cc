#include "reference/direct/dense_stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "reference/direct/cubic_spline.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"

namespace hdabench::reference {

namespace {

using util::kDegToRad;

// The window of the two-dimensional matches that measure the row offset:
// 9 x 9 pixels.
constexpr int kRowShiftHalfWindow = 4;

// One channel of the camera's size, as float.
cv::Mat ToFloat(const cv::Mat& image, const calib::CameraModel& camera, const char* what) {
  if (image.empty()) throw InputError(std::string("dense stereo: ") + what + " is empty");
  if (image.channels() != 1) {
    throw InputError(std::string("dense stereo: ") + what + " has " + std::to_string(image.channels()) +
                     " channels: expected one");
  }
  if (image.cols != camera.WidthPx() || image.rows != camera.HeightPx()) {
    throw InputError(std::string("dense stereo: ") + what + " is " + std::to_string(image.cols) + " x " +
                     std::to_string(image.rows) + " px, the camera's " + std::to_string(camera.WidthPx()) +
                     " x " + std::to_string(camera.HeightPx()));
  }
  cv::Mat out;
  image.convertTo(out, CV_32F);
  return out;
}

// The value below which `fraction` of the samples lie (every 4th pixel of
// both images).
double JointQuantile(const cv::Mat& a, const cv::Mat& b, double fraction) {
  std::vector<float> samples;
  for (const cv::Mat* image : {&a, &b}) {
    for (int r = 0; r < image->rows; r += 2) {
      const float* row = image->ptr<float>(r);
      for (int c = 0; c < image->cols; c += 2) samples.push_back(row[c]);
    }
  }
  const size_t k = std::min(samples.size() - 1, static_cast<size_t>(fraction * static_cast<double>(samples.size())));
  std::nth_element(samples.begin(), samples.begin() + static_cast<std::ptrdiff_t>(k), samples.end());
  return samples[k];
}

// Pixels per radian at the image centre: the mean of the angles one pixel
// right and one pixel down subtend there.
double CentreFocalPx(const calib::CameraModel& camera, Eigen::Vector3d* centre_ray) {
  const double cx = 0.5 * (camera.WidthPx() - 1), cy = 0.5 * (camera.HeightPx() - 1);
  std::vector<Eigen::Vector3d> rays;
  std::vector<unsigned char> valid;
  camera.Unproject({Eigen::Vector2d(cx, cy), Eigen::Vector2d(cx + 1, cy), Eigen::Vector2d(cx, cy + 1)}, &rays, &valid);
  if (valid[0] == 0 || valid[1] == 0 || valid[2] == 0) return 0.0;
  *centre_ray = rays[0];
  const double a = std::atan2(rays[0].cross(rays[1]).norm(), rays[0].dot(rays[1]));
  const double b = std::atan2(rays[0].cross(rays[2]).norm(), rays[0].dot(rays[2]));
  return a + b > 0 ? 2.0 / (a + b) : 0.0;
}

// The rectified field of image 1: its pixels' rays (a 33 x 33 grid, edges
// included) in the rectified frame, within max_off_axis of the z axis.
bool RectifiedField(const calib::CameraModel& camera, const Eigen::Matrix3d& rect_from_cam1, double max_off_axis_deg,
                    DenseRectification* rect) {
  constexpr int kSteps = 32;
  std::vector<Eigen::Vector2d> pixels;
  for (int i = 0; i <= kSteps; ++i) {
    for (int j = 0; j <= kSteps; ++j) {
      pixels.emplace_back((camera.WidthPx() - 1) * j / static_cast<double>(kSteps),
                          (camera.HeightPx() - 1) * i / static_cast<double>(kSteps));
    }
  }
  std::vector<Eigen::Vector3d> rays;
  std::vector<unsigned char> valid;
  camera.Unproject(pixels, &rays, &valid);
  const double limit = std::tan(max_off_axis_deg * kDegToRad);
  bool any = false;
  for (size_t k = 0; k < rays.size(); ++k) {
    if (valid[k] == 0) continue;
    const Eigen::Vector3d r = rect_from_cam1 * rays[k];
    if (r.z() <= 0.0) continue;
    const double x = std::clamp(r.x() / r.z(), -limit, limit), y = std::clamp(r.y() / r.z(), -limit, limit);
    if (!any) {
      rect->field_x_min = rect->field_x_max = x;
      rect->field_y_min = rect->field_y_max = y;
      any = true;
    }
    rect->field_x_min = std::min(rect->field_x_min, x);
    rect->field_x_max = std::max(rect->field_x_max, x);
    rect->field_y_min = std::min(rect->field_y_min, y);
    rect->field_y_max = std::max(rect->field_y_max, y);
  }
  return any && rect->field_x_max > rect->field_x_min && rect->field_y_max > rect->field_y_min;
}

// The level ground's disparity f B (p_r . (x, y, 1)) at rectified normalised
// coordinates (x, y), p_r its plane in the rectified frame: <= 0 beyond its
// horizon.
double LevelGroundDisparityPx(const DenseRectification& rect, double x, double y) {
  const Eigen::Vector3d p = rect.rect_from_cam1 * rect.level_plane_in_cam1;
  return rect.focal_px * rect.baseline_m * p.dot(Eigen::Vector3d(x, y, 1.0));
}

// The median disparity of points in camera 1 (f B / z in the rectified
// frame, as LevelGroundDisparityPx), over those in front (the upper median
// for an even count); 0 for none.
double MedianDisparityPx(const DenseRectification& rect, const std::vector<Eigen::Vector3d>& points_in_cam1) {
  std::vector<double> disparities;
  for (const Eigen::Vector3d& p : points_in_cam1) {
    const double z = (rect.rect_from_cam1 * p).z();
    if (z > 0.0 && std::isfinite(z)) disparities.push_back(rect.focal_px * rect.baseline_m / z);
  }
  if (disparities.empty()) return 0.0;
  const auto middle = disparities.begin() + static_cast<std::ptrdiff_t>(disparities.size() / 2);
  std::nth_element(disparities.begin(), middle, disparities.end());
  return *middle;
}

// The search: level ground's disparity is linear in the normalised
// coordinates, so its extremes are at the field's corners; the horizon
// (disparity <= 0) bounds it below by 0.
void DisparitySearch(const DenseStereoOptions& options, DenseRectification* rect, bool* clipped) {
  double lo = 0.0, hi = 0.0;
  bool first = true;
  for (const double x : {rect->field_x_min, rect->field_x_max}) {
    for (const double y : {rect->field_y_min, rect->field_y_max}) {
      const double d = std::max(0.0, LevelGroundDisparityPx(*rect, x, y));
      lo = first ? d : std::min(lo, d);
      hi = first ? d : std::max(hi, d);
      first = false;
    }
  }
  const double m = options.inverse_depth_margin;
  // Bounded before the integer casts: ground nearer than a pixel of the
  // search is outside it anyway.
  constexpr double kLargest = 1e6;
  lo = std::min(lo, kLargest);
  hi = std::min(hi, kLargest);
  rect->disparity_shift_px = static_cast<int>(std::floor(lo * (1.0 - m)));
  const double width = hi * (1.0 + m) - rect->disparity_shift_px + 1.0;
  int n = 16 * static_cast<int>(std::ceil(width / 16.0));
  *clipped = n > options.max_disparities;
  rect->num_disparities = std::max(16, std::min(n, options.max_disparities / 16 * 16));
}

// The rectified image of a camera whose rectified frame is rect_from_cam
// (principal point cx), resampled with a cubic kernel, row v read from row
// v + row_shift . (1, u, v) of the rectification; map_x/map_y (CV_32F)
// give each rectified pixel's source pixel (-1e6 where it has none).
void Rectify(const cv::Mat& image, const calib::CameraModel& camera, const Eigen::Matrix3d& rect_from_cam,
             const DenseRectification& rect, double cx, const Eigen::Vector3d& row_shift, cv::Mat* rectified,
             cv::Mat* map_x, cv::Mat* map_y) {
  const Eigen::Matrix3d cam_from_rect = rect_from_cam.transpose();
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(static_cast<size_t>(rect.width_px) * static_cast<size_t>(rect.height_px));
  for (int v = 0; v < rect.height_px; ++v) {
    for (int u = 0; u < rect.width_px; ++u) {
      const double row = v + row_shift.dot(Eigen::Vector3d(1.0, u, v));
      const Eigen::Vector3d in_rect((u - cx) / rect.focal_px, (row - rect.cy_px) / rect.focal_px, 1.0);
      rays.push_back(cam_from_rect * in_rect);
    }
  }
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  camera.Project(rays, &pixels, &valid);
  map_x->create(rect.height_px, rect.width_px, CV_32F);
  map_y->create(rect.height_px, rect.width_px, CV_32F);
  size_t k = 0;
  for (int v = 0; v < rect.height_px; ++v) {
    float* mx = map_x->ptr<float>(v);
    float* my = map_y->ptr<float>(v);
    for (int u = 0; u < rect.width_px; ++u, ++k) {
      const bool ok = valid[k] != 0 && std::abs(pixels[k].x()) < 1e6 && std::abs(pixels[k].y()) < 1e6;
      mx[u] = ok ? static_cast<float>(pixels[k].x()) : -1e6f;
      my[u] = ok ? static_cast<float>(pixels[k].y()) : -1e6f;
    }
  }
  cv::remap(image, *rectified, *map_x, *map_y, cv::INTER_CUBIC, cv::BORDER_CONSTANT, cv::Scalar(0));
}

// The mean of an image's (CV_32F) square window of half-width `half` at (u, v).
double WindowMean(const cv::Mat& image, int u, int v, int half) {
  double sum = 0.0;
  for (int j = -half; j <= half; ++j) {
    const float* row = image.ptr<float>(v + j);
    for (int i = -half; i <= half; ++i) sum += static_cast<double>(row[u + i]);
  }
  return sum / ((2 * half + 1) * (2 * half + 1));
}

// The disparity of rectified pixel (u, v) to a fraction of SGBM's sixteenth:
// Gauss-Newton on d minimising the window's squared differences
// left(u + i, v + j) - right(u + i - d - g . (i, j), v + j), both with their
// window means removed (an offset between the images), right read from the
// cubic spline of its row, the window sheared by g (level ground's disparity
// gradient). SGBM's parabola through three integer costs pulls disparities
// toward whole pixels, and a plane that crosses a few pixels of disparity
// over an ROI then comes back tilted; the window's own fit has no such
// preference. False when the window's gradients (RMS) are under
// min_gradient or the step leaves +-1 px of the start. *ncc: the windows'
// normalised cross-correlation at the last step's start.
bool RefineDisparity(const cv::Mat& left, const cv::Mat& right_rows, int u, int v, int half, double start,
                     const Eigen::Vector2d& gradient, double min_gradient, double* d, double* ncc) {
  double disparity = start;
  constexpr int kIterations = 4;
  const int n = (2 * half + 1) * (2 * half + 1);
  const double mean_left = WindowMean(left, u, v, half);
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    double values[121], slopes[121];
    double mean_right = 0.0, mean_slope = 0.0;
    int k = 0;
    for (int j = -half; j <= half; ++j) {
      for (int i = -half; i <= half; ++i, ++k) {
        values[k] = SampleCubicSplineRow(right_rows, v + j,
                                         u + i - disparity - gradient.x() * i - gradient.y() * j, &slopes[k]);
        mean_right += values[k];
        mean_slope += slopes[k];
      }
    }
    mean_right /= n;
    mean_slope /= n;
    // r = (L - mean L) - (R(x - d) - mean R); dr/dd = R'(x - d) - mean R'.
    double jtj = 0.0, jtr = 0.0, lr = 0.0, ll = 0.0, rr = 0.0;
    k = 0;
    for (int j = -half; j <= half; ++j) {
      const float* row = left.ptr<float>(v + j);
      for (int i = -half; i <= half; ++i, ++k) {
        const double l = static_cast<double>(row[u + i]) - mean_left, rv = values[k] - mean_right;
        const double r = l - rv;
        const double g = slopes[k] - mean_slope;
        jtj += g * g;
        jtr += g * r;
        lr += l * rv;
        ll += l * l;
        rr += rv * rv;
      }
    }
    *ncc = ll > 0.0 && rr > 0.0 ? lr / std::sqrt(ll * rr) : 0.0;
    if (!(jtj >= n * min_gradient * min_gradient)) return false;
    disparity -= jtr / jtj;
    if (!(std::abs(disparity - start) <= 1.0)) return false;
  }
  *d = disparity;
  return true;
}

// The match of rectified pixel (u, v) in two dimensions: the disparity d and
// the row offset e minimising the window's squared differences
// left(u + i, v + j) - right(u + i - d - g . (i, j), v + j + e), window
// means removed (Gauss-Newton from the disparity `start`, image 2 read from
// its cubic spline). False when the window does not constrain both (the
// smaller eigenvalue under a tenth of the larger, or its RMS gradient under
// min_gradient) or the solution leaves +-1 px of the start.
bool RefineMatch2d(const cv::Mat& left, const cv::Mat& right_spline, int u, int v, int half, double start,
                   const Eigen::Vector2d& gradient, double min_gradient, double* d, double* e) {
  Eigen::Vector2d x(start, 0.0);
  const int n = (2 * half + 1) * (2 * half + 1);
  const double mean_left = WindowMean(left, u, v, half);
  constexpr int kIterations = 5;
  std::vector<double> values(static_cast<size_t>(n)), gx(static_cast<size_t>(n)), gy(static_cast<size_t>(n));
  for (int iteration = 0; iteration < kIterations; ++iteration) {
    double mean_right = 0.0, mean_gx = 0.0, mean_gy = 0.0;
    size_t k = 0;
    for (int j = -half; j <= half; ++j) {
      for (int i = -half; i <= half; ++i, ++k) {
        const double column = u + i - x.x() - gradient.x() * i - gradient.y() * j, row = v + j + x.y();
        if (!InsideSpline(right_spline, column, row)) return false;
        const SplineSample sample = SampleCubicSpline(right_spline, column, row);
        values[k] = sample.value;
        gx[k] = sample.dx;
        gy[k] = sample.dy;
        mean_right += values[k];
        mean_gx += gx[k];
        mean_gy += gy[k];
      }
    }
    mean_right /= n;
    mean_gx /= n;
    mean_gy /= n;
    // r = (L - mean L) - (R - mean R); dr/dd = R_x, dr/de = -R_y (means removed).
    Eigen::Matrix2d jtj = Eigen::Matrix2d::Zero();
    Eigen::Vector2d jtr = Eigen::Vector2d::Zero();
    k = 0;
    for (int j = -half; j <= half; ++j) {
      const float* row = left.ptr<float>(v + j);
      for (int i = -half; i <= half; ++i, ++k) {
        const double r = (static_cast<double>(row[u + i]) - mean_left) - (values[k] - mean_right);
        const Eigen::Vector2d g(gx[k] - mean_gx, -(gy[k] - mean_gy));
        jtj += g * g.transpose();
        jtr += g * r;
      }
    }
    // Both directions constrained: the smaller eigenvalue at least a tenth
    // of the larger.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(jtj);
    if (!(eigen.eigenvalues()(0) > 0.1 * eigen.eigenvalues()(1)) ||
        !(eigen.eigenvalues()(0) >= n * min_gradient * min_gradient)) {
      return false;
    }
    x -= jtj.ldlt().solve(jtr);
    if (!(std::abs(x.x() - start) <= 1.0 && std::abs(x.y()) <= 1.0)) return false;
  }
  *d = x.x();
  *e = x.y();
  return true;
}

// The rows of the rectified image 2 that hold image 1's rows: an error of the
// navigation's relative pose (a rotation about the baseline, a baseline
// direction off by a fraction of a degree) leaves the matches a fraction of
// a pixel above or below their row, which a one-dimensional matcher turns
// into disparity errors wherever the texture runs diagonally. The offset e of
// a grid of matches (every `stride` pixels, both directions constrained) is
// fitted as e = a + b u2 + c v (u2 the match's column in image 2, where
// Rectify applies it) (least squares, then again without the matches
// beyond 3 robust sigmas). False with fewer than 50 usable matches.
bool EstimateRowShift(const cv::Mat& left, const cv::Mat& right_spline, const cv::Mat& disparity, int first_column,
                      int half, const Eigen::Vector2d& gradient, double min_gradient, Eigen::Vector3d* shift,
                      int* used) {
  constexpr int kStride = 8;
  std::vector<Eigen::Vector3d> rows;  // (u, v, e)
  for (int v = half + 1; v < left.rows - half - 1; v += kStride) {
    const short* d_row = disparity.ptr<short>(v);
    for (int u = std::max(first_column, half + 1); u < left.cols - half - 1; u += kStride) {
      if (d_row[u] < 0) continue;
      double d = 0.0, e = 0.0;
      if (RefineMatch2d(left, right_spline, u, v, half, d_row[u] / kDisparityStepsPerPx, gradient, min_gradient, &d, &e)) {
        rows.emplace_back(u - d, v, e);  // the offset is applied at image 2's column
      }
    }
  }
  constexpr size_t kMinMatches = 50;
  *used = 0;
  std::vector<bool> keep(rows.size(), true);
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    size_t count = 0;
    for (size_t k = 0; k < rows.size(); ++k) {
      if (!keep[k]) continue;
      const Eigen::Vector3d basis(1.0, rows[k].x(), rows[k].y());
      a += basis * basis.transpose();
      b += basis * rows[k].z();
      ++count;
    }
    if (count < kMinMatches) {
      *used = 0;
      return false;
    }
    *shift = a.ldlt().solve(b);
    *used = static_cast<int>(count);
    if (pass == 1) break;
    std::vector<double> residuals;
    for (const Eigen::Vector3d& r : rows) {
      residuals.push_back(std::abs(r.z() - shift->dot(Eigen::Vector3d(1.0, r.x(), r.y()))));
    }
    std::vector<double> sorted = residuals;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
    const double limit = 3.0 * 1.4826 * sorted[sorted.size() / 2];
    for (size_t k = 0; k < rows.size(); ++k) keep[k] = residuals[k] <= limit;
  }
  if (!std::isfinite(shift->sum())) {
    *used = 0;
    return false;
  }
  return true;
}

bool Inside(double x, double y, const calib::CameraModel& camera, double border) {
  return x >= border && y >= border && x <= camera.WidthPx() - 1 - border && y <= camera.HeightPx() - 1 - border;
}

// The rectification of the pair (result->rectification but its level
// plane, which the caller sets): its frame, field, search and image sizes.
// False, with result->reason, when the pair cannot be rectified.
bool SetUpRectification(const calib::CameraModel& camera, const Rigid3d& cam2_from_cam1,
                        const DenseStereoOptions& options, DenseStereoResult* result) {
  DenseRectification& rect = result->rectification;

  // The rectified frame: x along the baseline, z camera 1's view direction
  // without its component along x.
  const Eigen::Vector3d centre2 = cam2_from_cam1.Inverse().translation;
  rect.baseline_m = centre2.norm();
  Eigen::Vector3d view = Eigen::Vector3d::UnitZ();
  rect.focal_px = CentreFocalPx(camera, &view);
  if (!(rect.focal_px > 0.0)) {
    result->reason = "the camera cannot unproject around its image centre";
    return false;
  }
  // A baseline that gives the level ground less disparity than SGBM's step
  // (1 / kDisparityStepsPerPx px) is none: the matcher cannot tell it from zero,
  // and a baseline of rounding errors has no direction to rectify along.
  const double ground_distance_m = 1.0 / rect.level_plane_in_cam1.norm();
  const double disparity_px = rect.focal_px * rect.baseline_m / ground_distance_m;
  if (!std::isfinite(rect.baseline_m)) {
    result->reason = "the baseline is not finite";
    return false;
  }
  if (!(rect.baseline_m > 0.0)) {
    result->reason = "no baseline: camera 2's centre is camera 1's";
    return false;
  }
  if (!(disparity_px >= 1.0 / kDisparityStepsPerPx)) {
    std::ostringstream reason;
    reason << "baseline too short: camera 2's centre is " << rect.baseline_m << " m from camera 1's, about "
           << disparity_px << " px of disparity on the level ground (" << ground_distance_m
           << " m away along its normal), under the matcher's 1/" << kDisparityStepsPerPx << " px step";
    result->reason = reason.str();
    return false;
  }
  const Eigen::Vector3d x_axis = centre2 / rect.baseline_m;
  const Eigen::Vector3d z_raw = view - view.dot(x_axis) * x_axis;
  const double baseline_to_view_deg = std::acos(std::clamp(std::abs(view.dot(x_axis)), 0.0, 1.0)) / kDegToRad;
  if (z_raw.norm() < 1e-9) {
    result->reason = "the baseline is along the view direction: the epipole is the image centre";
    return false;
  }
  const Eigen::Vector3d z_axis = z_raw.normalized();
  rect.rect_from_cam1.row(0) = x_axis.transpose();
  rect.rect_from_cam1.row(1) = z_axis.cross(x_axis).transpose();
  rect.rect_from_cam1.row(2) = z_axis.transpose();
  if (!RectifiedField(camera, rect.rect_from_cam1, options.max_off_axis_deg, &rect)) {
    std::ostringstream reason;
    reason << "the baseline is " << baseline_to_view_deg
           << " deg from the view direction: no part of image 1 is within " << options.max_off_axis_deg
           << " deg of the rectified view";
    result->reason = reason.str();
    return false;
  }
  // At most twice the image's larger side each way, around the image
  // centre's ray (a wide lens seen obliquely would rectify to tens of
  // thousands of pixels).
  const Eigen::Vector3d centre_in_rect = rect.rect_from_cam1 * view;
  const double half_span = std::max(camera.WidthPx(), camera.HeightPx()) / rect.focal_px;
  if (centre_in_rect.z() > 0.0) {
    const double cx = centre_in_rect.x() / centre_in_rect.z(), cy = centre_in_rect.y() / centre_in_rect.z();
    rect.field_x_min = std::max(rect.field_x_min, cx - half_span);
    rect.field_x_max = std::min(rect.field_x_max, cx + half_span);
    rect.field_y_min = std::max(rect.field_y_min, cy - half_span);
    rect.field_y_max = std::min(rect.field_y_max, cy + half_span);
  }
  DisparitySearch(options, &rect, &result->search_clipped);
  const int field_width = static_cast<int>(std::ceil((rect.field_x_max - rect.field_x_min) * rect.focal_px)) + 1;
  rect.height_px = static_cast<int>(std::ceil((rect.field_y_max - rect.field_y_min) * rect.focal_px)) + 1;
  rect.width_px = field_width + rect.num_disparities;
  rect.cx1_px = -rect.field_x_min * rect.focal_px + rect.num_disparities;
  rect.cx2_px = rect.cx1_px + rect.disparity_shift_px;
  rect.cy_px = -rect.field_y_min * rect.focal_px;
  return true;
}

}  // namespace

std::vector<std::string> DenseStereoOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(block_size_px >= 3 && block_size_px <= 11 && block_size_px % 2 == 1, "block_size_px", block_size_px,
                "odd, in [3, 11]", &errors);
  RequireOption(inverse_depth_margin >= 0 && inverse_depth_margin <= 0.9, "inverse_depth_margin",
                inverse_depth_margin, "in [0, 0.9]", &errors);
  // SGBM's disparities are 16-bit sixteenths of a pixel.
  RequireOption(max_disparities >= 16 && max_disparities <= 2032, "max_disparities", max_disparities,
                "in [16, 2032]", &errors);
  RequireOption(uniqueness_ratio_percent >= 0 && uniqueness_ratio_percent <= 100, "uniqueness_ratio_percent",
                uniqueness_ratio_percent, "in [0, 100]", &errors);
  RequireOption(speckle_window_px >= 0, "speckle_window_px", speckle_window_px, ">= 0", &errors);
  RequireOption(speckle_range_px >= 1, "speckle_range_px", speckle_range_px, ">= 1", &errors);
  RequireOption(max_lr_difference_px >= 1, "max_lr_difference_px", max_lr_difference_px, ">= 1", &errors);
  RequireOption(min_ncc >= -1 && min_ncc <= 1, "min_ncc", min_ncc, "in [-1, 1]", &errors);
  RequireOption(min_roi_share > 0 && min_roi_share <= 1, "min_roi_share", min_roi_share, "in (0, 1]", &errors);
  RequireOption(max_slope_sigma_deg > 0 && max_slope_sigma_deg < 90, "max_slope_sigma_deg", max_slope_sigma_deg,
                "in (0, 90)", &errors);
  RequireOption(max_off_axis_deg > 0 && max_off_axis_deg < 85, "max_off_axis_deg", max_off_axis_deg,
                "in (0, 85) (degrees)", &errors);
  return errors;
}

const char* ToString(DenseStereoStatus status) {
  switch (status) {
    case DenseStereoStatus::kOk: return "ok";
    case DenseStereoStatus::kNotRectifiable: return "not rectifiable";
  }
  return "unknown";
}

DenseStereoResult RunDenseStereo(const cv::Mat& image1, const cv::Mat& image2, const calib::CameraModel& camera,
                                 const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& level_plane_in_cam1,
                                 const DenseStereoOptions& options) {
  ThrowIfInvalid("dense stereo: invalid options: ", options.Validate());
  const cv::Mat float1 = ToFloat(image1, camera, "image 1");
  const cv::Mat float2 = ToFloat(image2, camera, "image 2");
  if (!level_plane_in_cam1.allFinite() || !(level_plane_in_cam1.norm() > 0.0)) {
    throw InputError("dense stereo: the level ground through the range finder's point is not a plane in front "
                     "of the camera (check the LRF range)");
  }
  DenseStereoResult result;
  DenseRectification& rect = result.rectification;
  rect.level_plane_in_cam1 = level_plane_in_cam1;
  if (!SetUpRectification(camera, cam2_from_cam1, options, &result)) return result;

  // Both images with one linear stretch to 8 bits (the matcher's census of
  // gradients needs the contrast, the images keep their brightness ratio).
  const double lo = JointQuantile(float1, float2, 0.001), hi = JointQuantile(float1, float2, 0.999);
  const double scale = hi > lo ? 255.0 / (hi - lo) : 1.0;
  // A window whose gradients (RMS, DN per pixel) are under one grey level of
  // the matcher's 8 bits has no texture the matcher could see: no disparity.
  const double min_gradient = 1.0 / scale;
  const Eigen::Matrix3d rect_from_cam2 = rect.rect_from_cam1 * cam2_from_cam1.rotation.toRotationMatrix().transpose();
  cv::Mat rect1, rect2, map1x, map1y, map2x, map2y;
  Rectify(float1, camera, rect.rect_from_cam1, rect, rect.cx1_px, Eigen::Vector3d::Zero(), &rect1, &map1x, &map1y);
  Rectify(float2, camera, rect_from_cam2, rect, rect.cx2_px, Eigen::Vector3d::Zero(), &rect2, &map2x, &map2y);
  cv::Mat left, right;
  rect1.convertTo(left, CV_8U, scale, -lo * scale);
  rect2.convertTo(right, CV_8U, scale, -lo * scale);

  const int block = options.block_size_px;
  const cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
      0, rect.num_disparities, block, 8 * block * block, 32 * block * block, options.max_lr_difference_px, 63,
      options.uniqueness_ratio_percent, options.speckle_window_px, options.speckle_range_px, cv::StereoSGBM::MODE_SGBM);
  cv::Mat disparity;  // CV_16S, sixteenths of a pixel
  sgbm->compute(left, right, disparity);

  // Level ground's disparity is affine in the rectified pixel: its gradient
  // shears the refinement's window as the ground does between the views.
  const Eigen::Vector3d level_in_rect = rect.rect_from_cam1 * rect.level_plane_in_cam1;
  const Eigen::Vector2d level_gradient = rect.baseline_m * level_in_rect.head<2>();

  // The navigation's rows corrected, and the pair matched again on them.
  if (options.correct_rows &&
      EstimateRowShift(rect1, CubicSplineCoefficients(rect2), disparity, rect.num_disparities, kRowShiftHalfWindow,
                       level_gradient, min_gradient, &rect.row_shift, &result.row_shift_matches)) {
    for (const double u : {static_cast<double>(rect.num_disparities), rect.width_px - 1.0}) {
      for (const double v : {0.0, rect.height_px - 1.0}) {
        const double shift = std::abs(rect.row_shift.dot(Eigen::Vector3d(1.0, u, v)));
        result.row_shift_max_px = std::max(result.row_shift_max_px, shift);
      }
    }
    Rectify(float2, camera, rect_from_cam2, rect, rect.cx2_px, rect.row_shift, &rect2, &map2x, &map2y);
    rect2.convertTo(right, CV_8U, scale, -lo * scale);
    sgbm->compute(left, right, disparity);
  } else {
    rect.row_shift = Eigen::Vector3d::Zero();
  }
  const cv::Mat right_rows = options.subpixel_refinement ? CubicSplineRowCoefficients(rect2) : cv::Mat();
  const double border = 0.5 * block;
  const Eigen::Matrix3d cam1_from_rect = rect.rect_from_cam1.transpose();
  for (int v = 0; v < rect.height_px; ++v) {
    const short* d_row = disparity.ptr<short>(v);
    const float* m1x = map1x.ptr<float>(v);
    const float* m1y = map1y.ptr<float>(v);
    const float* m2x = map2x.ptr<float>(v);
    const float* m2y = map2y.ptr<float>(v);
    for (int u = rect.num_disparities; u < rect.width_px; ++u) {
      if (!Inside(m1x[u], m1y[u], camera, border)) continue;
      ++result.field_pixels;
      if (d_row[u] < 0) continue;  // no disparity (SGBM marks it below the search)
      double d = d_row[u] / kDisparityStepsPerPx;
      double ncc = 1.0;
      const bool window_inside = v >= block / 2 && v < rect.height_px - block / 2 && u < rect.width_px - block / 2;
      if (options.subpixel_refinement &&
          (!window_inside ||
           !RefineDisparity(rect1, right_rows, u, v, block / 2, d, level_gradient, min_gradient, &d, &ncc) ||
           ncc < options.min_ncc)) {
        continue;
      }
      const int u2 = static_cast<int>(std::lround(u - d));
      if (u2 < 0 || u2 >= rect.width_px || !Inside(m2x[u2], m2y[u2], camera, border)) continue;
      const double total = d + rect.disparity_shift_px;
      if (!(total > 0.0)) continue;
      const double z = rect.focal_px * rect.baseline_m / total;
      const Eigen::Vector3d in_rect((u - rect.cx1_px) / rect.focal_px * z, (v - rect.cy_px) / rect.focal_px * z, z);
      result.points_in_cam1.push_back(cam1_from_rect * in_rect);
      result.pixels1.emplace_back(m1x[u], m1y[u]);
      ++result.valid_pixels;
    }
  }
  result.status = DenseStereoStatus::kOk;
  std::ostringstream reason;
  reason << "rectified " << rect.width_px << " x " << rect.height_px << " px, baseline " << rect.baseline_m
         << " m, disparities " << rect.disparity_shift_px << " to " << rect.disparity_shift_px + rect.num_disparities
         << (result.search_clipped ? " (clipped at max_disparities)" : "") << ", rows corrected by up to "
         << result.row_shift_max_px << " px (" << result.row_shift_matches << " matches), " << result.valid_pixels
         << " of " << result.field_pixels << " pixels with a disparity";
  result.reason = reason.str();
  return result;
}

double DenseSlopeSigmaDeg(const DenseStereoResult& result, const calib::CameraModel& camera, const cv::Rect& box1,
                          int num_points, const std::vector<Eigen::Vector3d>& points_in_cam1) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  const DenseRectification& rect = result.rectification;
  if (result.status != DenseStereoStatus::kOk || num_points <= 0 || box1.width <= 0 || box1.height <= 0) {
    return kInfinity;
  }
  std::vector<Eigen::Vector3d> rays;
  std::vector<unsigned char> valid;
  // The box's centre: its pixels' edges run from box1.x - 0.5 to box1.x + width - 0.5.
  camera.Unproject({Eigen::Vector2d(box1.x + 0.5 * (box1.width - 1), box1.y + 0.5 * (box1.height - 1))}, &rays,
                   &valid);
  if (valid.empty() || valid[0] == 0) return kInfinity;
  const Eigen::Vector3d in_rect = rect.rect_from_cam1 * rays[0];
  if (!(in_rect.z() > 0.0)) return kInfinity;
  double disparity_px = LevelGroundDisparityPx(rect, in_rect.x() / in_rect.z(), in_rect.y() / in_rect.z());
  if (!(disparity_px > 0.0)) disparity_px = MedianDisparityPx(rect, points_in_cam1);
  if (!(disparity_px > 0.0)) return kInfinity;
  const double side_px = std::min(box1.width, box1.height);
  const double tangent = std::sqrt(12.0 / num_points) * rect.focal_px / (kDisparityStepsPerPx * side_px * disparity_px);
  return std::atan(tangent) / kDegToRad;
}

double DenseOverlapFraction(const DenseStereoResult& result, const calib::CameraModel& camera,
                            const Rigid3d& cam2_from_cam1, const cv::Rect& box1, int block_size_px) {
  if (result.status != DenseStereoStatus::kOk || box1.area() <= 0) return 0.0;
  const DenseRectification& rect = result.rectification;
  std::vector<Eigen::Vector2d> pixels;
  for (int r = box1.y; r < box1.y + box1.height; r += 2) {
    for (int c = box1.x; c < box1.x + box1.width; c += 2) pixels.emplace_back(c, r);
  }
  std::vector<Eigen::Vector3d> rays;
  std::vector<unsigned char> valid;
  camera.Unproject(pixels, &rays, &valid);
  std::vector<Eigen::Vector3d> on_ground;
  std::vector<size_t> index;
  for (size_t k = 0; k < rays.size(); ++k) {
    if (valid[k] == 0) continue;
    const Eigen::Vector3d r = rect.rect_from_cam1 * rays[k];
    if (r.z() <= 0.0) continue;
    const double x = r.x() / r.z(), y = r.y() / r.z();
    if (x < rect.field_x_min || x > rect.field_x_max || y < rect.field_y_min || y > rect.field_y_max) continue;
    const double along = rect.level_plane_in_cam1.dot(rays[k]);
    if (!(along > 0.0)) continue;
    on_ground.push_back(cam2_from_cam1 * (rays[k] / along));
    index.push_back(k);
  }
  std::vector<Eigen::Vector2d> pixels2;
  std::vector<unsigned char> valid2;
  camera.Project(on_ground, &pixels2, &valid2);
  int seen = 0;
  for (size_t k = 0; k < pixels2.size(); ++k) {
    if (valid2[k] != 0 && Inside(pixels2[k].x(), pixels2[k].y(), camera,
                                 0.5 * block_size_px)) {
      ++seen;
    }
  }
  return pixels.empty() ? 0.0 : static_cast<double>(seen) / static_cast<double>(pixels.size());
}

}  // namespace hdabench::reference
