#include "hda/roi_prediction.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/angles.h"

namespace hdabench::hda {

namespace {

using util::kPi;

// Slack when turning continuous pixel-edge bounds into whole pixels, pixels.
constexpr double kPixelSlackPx = 1e-6;
// Angular step for the local pixel scale, radians (central differences: the
// error is O(step^2), far below a pixel).
constexpr double kScaleStepRad = 1e-4;

// Pixels per radian of image 2 around the direction of point_in_cam2: the
// larger over two directions perpendicular to the ray. 0 when not projectable.
double LocalScalePxPerRad(const calib::CameraModel& camera, const Eigen::Vector3d& point_in_cam2) {
  const double distance = point_in_cam2.norm();
  const Eigen::Vector3d ray = point_in_cam2 / distance;
  Eigen::Vector3d across = Eigen::Vector3d::UnitX() - ray.x() * ray;
  if (across.norm() < 1e-9) across = Eigen::Vector3d::UnitY() - ray.y() * ray;
  across.normalize();
  const Eigen::Vector3d down = ray.cross(across).normalized();
  const double step_m = distance * kScaleStepRad;
  const std::vector<Eigen::Vector3d> points = {
      point_in_cam2 - step_m * across, point_in_cam2 + step_m * across,
      point_in_cam2 - step_m * down, point_in_cam2 + step_m * down};
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  if (camera.Project(points, &pixels, &valid) != 4) return 0.0;
  return std::max((pixels[1] - pixels[0]).norm(), (pixels[3] - pixels[2]).norm()) /
         (2.0 * kScaleStepRad);
}

}  // namespace

std::vector<std::string> PredictionOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(nav_position_sigma_m >= 0, "nav_position_sigma_m", nav_position_sigma_m, ">= 0",
          &errors);
  RequireOption(nav_attitude_sigma_deg >= 0 && nav_attitude_sigma_deg < 90, "nav_attitude_sigma_deg",
          nav_attitude_sigma_deg, "in [0, 90)", &errors);
  RequireOption(range_sigma_m >= 0, "range_sigma_m", range_sigma_m, ">= 0", &errors);
  RequireOption(sigma_multiplier > 0, "sigma_multiplier", sigma_multiplier, "> 0", &errors);
  RequireOption(min_margin_px >= 0, "min_margin_px", min_margin_px, ">= 0", &errors);
  return errors;
}

const char* PredictionStatusName(PredictionStatus status) {
  switch (status) {
    case PredictionStatus::kOk:
      return "ok";
    case PredictionStatus::kOutsideImage2:
      return "outside image 2";
    case PredictionStatus::kBehindCamera:
      return "behind camera";
  }
  return "unknown";
}

std::vector<Eigen::Vector2d> BoxOutlinePx(const cv::Rect& box) {
  const double u0 = box.x - 0.5, v0 = box.y - 0.5;
  const double u1 = u0 + box.width, v1 = v0 + box.height;
  const double um = 0.5 * (u0 + u1), vm = 0.5 * (v0 + v1);
  return {{um, vm}, {u0, v0}, {um, v0}, {u1, v0}, {u1, vm}, {u1, v1}, {um, v1}, {u0, v1}, {u0, vm}};
}

PredictedRoi PredictRoi(const Roi& roi, const calib::CameraModel& camera, const Rigid3d& cam2_from_cam1,
                        double ground_distance_m, const PredictionOptions& options) {
  ThrowIfInvalid("PredictRoi: invalid PredictionOptions: ", options.Validate());
  if (!(std::isfinite(ground_distance_m) && ground_distance_m > 0)) {
    std::ostringstream message;
    message << "PredictRoi: ground_distance_m = " << ground_distance_m
            << ": expected finite and > 0";
    throw InputError(message.str());
  }
  PredictedRoi predicted;
  predicted.id = roi.id;

  const std::vector<Eigen::Vector2d> outline_px = BoxOutlinePx(roi.box_px);  // the centre first
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  if (camera.Unproject(outline_px, &bearings, &valid) != static_cast<int>(outline_px.size())) {
    return predicted;  // kBehindCamera: no ray
  }
  std::vector<Eigen::Vector3d> points_in_cam2;
  points_in_cam2.reserve(bearings.size());
  for (const Eigen::Vector3d& bearing : bearings) {
    // The ray must reach the plane z_cam1 = ground_distance_m in front of camera 1.
    if (!(bearing.z() > 1e-12)) return predicted;
    points_in_cam2.push_back(cam2_from_cam1 * (bearing * (ground_distance_m / bearing.z())));
    if (!(points_in_cam2.back().z() > 0)) return predicted;
  }
  std::vector<Eigen::Vector2d> pixels;
  if (camera.Project(points_in_cam2, &pixels, &valid) != static_cast<int>(points_in_cam2.size())) {
    return predicted;
  }
  double min_u = pixels[0].x(), max_u = pixels[0].x(), min_v = pixels[0].y(), max_v = pixels[0].y();
  for (const Eigen::Vector2d& pixel : pixels) {
    min_u = std::min(min_u, pixel.x());
    max_u = std::max(max_u, pixel.x());
    min_v = std::min(min_v, pixel.y());
    max_v = std::max(max_v, pixel.y());
  }
  predicted.projected_edges_px = cv::Rect2d(min_u, min_v, max_u - min_u, max_v - min_v);

  const double scale_px_per_rad = LocalScalePxPerRad(camera, points_in_cam2[0]);
  if (!(scale_px_per_rad > 0 && std::isfinite(scale_px_per_rad))) return predicted;
  const double distance_m = points_in_cam2[0].norm();
  const double baseline_m = cam2_from_cam1.translation.norm();
  const double angle_rad = options.nav_position_sigma_m / distance_m +
                           options.nav_attitude_sigma_deg * kPi / 180.0 +
                           options.range_sigma_m * baseline_m / (distance_m * distance_m);
  predicted.margin_px = std::max(static_cast<double>(options.min_margin_px),
                                 options.sigma_multiplier * scale_px_per_rad * angle_rad);

  // Pixels whose centres lie in the enlarged continuous box.
  const double first_col = std::ceil(min_u - predicted.margin_px - kPixelSlackPx);
  const double last_col = std::floor(max_u + predicted.margin_px + kPixelSlackPx);
  const double first_row = std::ceil(min_v - predicted.margin_px - kPixelSlackPx);
  const double last_row = std::floor(max_v + predicted.margin_px + kPixelSlackPx);
  const double width = camera.WidthPx(), height = camera.HeightPx();
  if (last_col < 0 || last_row < 0 || first_col > width - 1 || first_row > height - 1 ||
      last_col < first_col || last_row < first_row) {
    predicted.status = PredictionStatus::kOutsideImage2;
    return predicted;
  }
  // Within the image now, so the conversions to int are exact.
  const double x0 = std::max(first_col, 0.0), y0 = std::max(first_row, 0.0);
  const double x1 = std::min(last_col, width - 1), y1 = std::min(last_row, height - 1);
  predicted.clipped = x0 != first_col || y0 != first_row || x1 != last_col || y1 != last_row;
  predicted.box_px = cv::Rect(static_cast<int>(x0), static_cast<int>(y0),
                              static_cast<int>(x1 - x0) + 1, static_cast<int>(y1 - y0) + 1);
  predicted.status = PredictionStatus::kOk;
  return predicted;
}

}  // namespace hdabench::hda
