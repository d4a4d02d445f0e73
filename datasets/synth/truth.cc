#include "datasets/synth/truth.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Eigenvalues>
#include <opencv2/imgproc.hpp>

#include "datasets/map_preview.h"
#include "datasets/synth/lander_truth.h"
#include "tools/images/png.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/parallel_for.h"

namespace hdabench::datasets::synth {

namespace {
constexpr double kRadToDeg = 57.29577951308232;

Eigen::Vector3d UpInLocal(const Dataset& dataset) {
  return -dataset.gravity_in_local_mps2.normalized();
}

struct TruthPlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, up
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double slope_deg = 0.0;
};

// The total-least-squares plane of `points`, each weighted by weights[k]
// (empty: alike), its normal up. Throws InputError, naming `what`, for fewer
// than 3 points, no positive weight, or collinear points.
TruthPlane PlaneOfTruthPoints(const std::vector<Eigen::Vector3d>& points, const std::vector<double>& weights,
                              const Eigen::Vector3d& up, const std::string& what) {
  if (points.size() < 3) {
    throw InputError(what + " holds " + std::to_string(points.size()) + " true points; a plane needs at least 3");
  }
  const auto weight = [&](size_t k) { return weights.empty() ? 1.0 : weights[k]; };
  double total = 0.0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < points.size(); ++k) {
    centroid += weight(k) * points[k];
    total += weight(k);
  }
  if (!(total > 0.0)) throw InputError(what + ": no true point has a positive weight");
  centroid /= total;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (size_t k = 0; k < points.size(); ++k) {
    covariance += weight(k) * (points[k] - centroid) * (points[k] - centroid).transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  const Eigen::Vector3d eigenvalues = solver.eigenvalues();  // ascending
  if (eigenvalues(1) <= 1e-12 * std::max(1.0, eigenvalues(2))) {
    throw InputError(what + "'s true points are collinear: no plane");
  }
  TruthPlane plane;
  plane.normal = solver.eigenvectors().col(0).normalized();
  if (plane.normal.dot(up) < 0) plane.normal = -plane.normal;
  plane.centroid = centroid;
  plane.slope_deg = std::acos(std::clamp(plane.normal.dot(up), -1.0, 1.0)) * kRadToDeg;
  return plane;
}

// The truth point at an image-1 position (pixel centres at whole numbers),
// bilinear between the four pixels around it; false where one of them with
// a share has no truth (its ray hit nothing) or it leaves the raster.
bool TruthPointAt(const cv::Mat& raster, const Eigen::Vector2d& pixel, Eigen::Vector3d* point) {
  if (!(pixel.x() >= 0.0 && pixel.y() >= 0.0 && pixel.x() <= raster.cols - 1 && pixel.y() <= raster.rows - 1)) {
    return false;
  }
  // The lower neighbours, kept one short of the last row and column so that
  // a position on the raster's far edge interpolates with weight 0 beyond it.
  const int c0 = std::max(0, std::min(static_cast<int>(pixel.x()), raster.cols - 2));
  const int r0 = std::max(0, std::min(static_cast<int>(pixel.y()), raster.rows - 2));
  const double fx = pixel.x() - c0;
  const double fy = pixel.y() - r0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int dr = 0; dr <= 1; ++dr) {
    for (int dc = 0; dc <= 1; ++dc) {
      const double w = (dc == 1 ? fx : 1.0 - fx) * (dr == 1 ? fy : 1.0 - fy);
      if (w == 0.0) continue;
      const int r = std::min(r0 + dr, raster.rows - 1);
      const int c = std::min(c0 + dc, raster.cols - 1);
      const cv::Vec3f& p = raster.at<cv::Vec3f>(r, c);
      if (!(std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2]))) return false;
      sum += w * Eigen::Vector3d(p[0], p[1], p[2]);
    }
  }
  *point = sum;
  return true;
}

}  // namespace

const cv::Mat& TruthPointsOf(const Dataset& dataset, int frame) {
  for (const TruthPoints& points : dataset.truth.points) {
    if (points.frame == frame && !points.points_in_local_m.empty()) return points.points_in_local_m;
  }
  throw InputError("dataset '" + dataset.name + "' has no truth points for frame " + std::to_string(frame) +
                   " in memory (truth.points_in_local; load with its truth)");
}

RoiTruth ComputeRoiTruth(const Dataset& dataset, int frame, const PixelRoi& roi) {
  const cv::Mat& raster = TruthPointsOf(dataset, frame);
  // Compared without a sum that could overflow (x, width near INT_MAX).
  if (roi.width <= 0 || roi.height <= 0 || roi.x < 0 || roi.y < 0 || roi.x > raster.cols - roi.width ||
      roi.y > raster.rows - roi.height) {
    throw InputError("ROI x=" + std::to_string(roi.x) + " y=" + std::to_string(roi.y) + " w=" +
                     std::to_string(roi.width) + " h=" + std::to_string(roi.height) +
                     " is empty or leaves the " + std::to_string(raster.cols) + " x " +
                     std::to_string(raster.rows) + " px image");
  }
  std::vector<Eigen::Vector3d> points;
  for (int r = roi.y; r < roi.y + roi.height; ++r) {
    const cv::Vec3f* row = raster.ptr<cv::Vec3f>(r);
    for (int c = roi.x; c < roi.x + roi.width; ++c) {
      const cv::Vec3f& p = row[c];
      if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) {
        points.emplace_back(p[0], p[1], p[2]);
      }
    }
  }
  const Eigen::Vector3d up = UpInLocal(dataset);
  const TruthPlane plane = PlaneOfTruthPoints(points, {}, up, "the ROI");
  const Eigen::Vector3d& normal = plane.normal;
  const Eigen::Vector3d& centroid = plane.centroid;

  RoiTruth result;
  result.num_points = static_cast<int>(points.size());
  result.normal_in_local = normal;
  result.centroid_in_local_m = centroid;
  result.slope_deg = plane.slope_deg;
  double sum_squares = 0.0;
  for (const Eigen::Vector3d& p : points) {
    const double d = std::abs(normal.dot(p - centroid));
    sum_squares += d * d;
    result.roughness_max_m = std::max(result.roughness_max_m, d);
  }
  result.roughness_rms_m = std::sqrt(sum_squares / static_cast<double>(points.size()));

  // Rocks whose centre projects into the ROI with the frame's true pose.
  if (!dataset.truth.rocks.empty()) {
    const Rigid3d cam_from_local =
        dataset.truth.navigation.empty() ? dataset.CamFromLocal(frame) : dataset.TrueCamFromLocal(frame);
    std::vector<Eigen::Vector3d> centers;
    for (const TruthRock& rock : dataset.truth.rocks) centers.push_back(cam_from_local * rock.center_in_local_m);
    std::vector<Eigen::Vector2d> pixels;
    std::vector<unsigned char> valid;
    dataset.camera.Project(centers, &pixels, &valid);
    for (size_t i = 0; i < centers.size(); ++i) {
      if (!valid[i]) continue;
      const Eigen::Vector2d& q = pixels[i];
      if (q.x() >= roi.x - 0.5 && q.x() < roi.x + roi.width - 0.5 && q.y() >= roi.y - 0.5 &&
          q.y() < roi.y + roi.height - 0.5) {
        result.max_rock_height_m = std::max(result.max_rock_height_m, dataset.truth.rocks[i].height_above_ground_m);
      }
    }
  }
  result.hazard_height_m = std::max(result.roughness_max_m, result.max_rock_height_m);
  return result;
}

SupportTruth ComputeSupportTruth(const Dataset& dataset, int frame, const std::vector<Eigen::Vector2d>& pixels,
                                 const std::vector<double>& weights) {
  const cv::Mat& raster = TruthPointsOf(dataset, frame);
  if (!weights.empty() && weights.size() != pixels.size()) {
    throw InputError("the support has " + std::to_string(pixels.size()) + " pixels but " +
                     std::to_string(weights.size()) + " weights");
  }
  std::vector<Eigen::Vector3d> points;
  std::vector<double> kept_weights;
  for (size_t k = 0; k < pixels.size(); ++k) {
    const double w = weights.empty() ? 1.0 : weights[k];
    if (!(std::isfinite(w) && w >= 0.0)) {
      throw InputError("support pixel " + std::to_string(k) + " has the weight " + std::to_string(w) +
                       " (expected finite, >= 0)");
    }
    Eigen::Vector3d point;
    if (w == 0.0 || !TruthPointAt(raster, pixels[k], &point)) continue;
    points.push_back(point);
    if (!weights.empty()) kept_weights.push_back(w);
  }
  const TruthPlane plane = PlaneOfTruthPoints(points, kept_weights, UpInLocal(dataset), "the support");
  SupportTruth result;
  result.num_points = static_cast<int>(points.size());
  result.normal_in_local = plane.normal;
  result.slope_deg = plane.slope_deg;
  return result;
}

std::vector<TruthMapFile> EncodeTruthMaps(const Dataset& dataset, double max_slope_deg, double max_hazard_m) {
  if (!dataset.truth.dem.has_value() || dataset.truth.dem->height_in_local_m.empty()) {
    throw InputError("the dataset has no truth DEM in memory: no maps to draw");
  }
  const TruthDem& dem = *dataset.truth.dem;
  const cv::Mat& z = dem.height_in_local_m;

  // Every cell about a metre apart as a landing point of the default lander
  // (lander_truth.h). First, so that the lander's grids are freed before the
  // maps are drawn.
  const int stride = std::max(1, static_cast<int>(std::lround(1.0 / dem.spacing_m)));
  const cv::Mat safety_classes = SafetyMap(SurfaceOfTruth(dataset.truth), LanderGeometry(), stride);

  // Slope over a baseline of about 1 m (at least one node each side).
  const int k = std::max(1, static_cast<int>(std::lround(0.5 / dem.spacing_m)));
  cv::Mat slope_deg(z.rows, z.cols, CV_32FC1, cv::Scalar(0));
  const int threads = util::WorkerThreads(0);
  util::ParallelFor("slope map rows", z.rows, threads, [&](int r) {
    const int r0 = std::max(0, r - k);
    const int r1 = std::min(z.rows - 1, r + k);
    for (int c = 0; c < z.cols; ++c) {
      const int c0 = std::max(0, c - k);
      const int c1 = std::min(z.cols - 1, c + k);
      const double dzdx = static_cast<double>(z.at<float>(r, c1) - z.at<float>(r, c0)) / ((c1 - c0) * dem.spacing_m);
      const double dzdy = static_cast<double>(z.at<float>(r0, c) - z.at<float>(r1, c)) / ((r1 - r0) * dem.spacing_m);
      slope_deg.at<float>(r, c) = static_cast<float>(std::atan(std::hypot(dzdx, dzdy)) * kRadToDeg);
    }
  });
  cv::Mat elevation_8u;
  cv::normalize(z, elevation_8u, 0, 255, cv::NORM_MINMAX, CV_8UC1);
  cv::Mat elevation_color;
  cv::applyColorMap(elevation_8u, elevation_color, cv::COLORMAP_VIRIDIS);
  elevation_8u.release();
  cv::Mat slope_8u;
  slope_deg.convertTo(slope_8u, CV_8UC1, 255.0 / 30.0);  // 0..30 degrees
  cv::Mat slope_color;
  cv::applyColorMap(slope_8u, slope_color, cv::COLORMAP_INFERNO);
  slope_8u.release();

  // Hazards: red where the slope is over the limit, yellow under rocks over max_hazard_m.
  cv::Mat hazards(z.rows, z.cols, CV_8UC3, cv::Scalar(40, 120, 40));
  hazards.setTo(cv::Scalar(0, 0, 220), slope_deg > max_slope_deg);
  for (const TruthRock& rock : dataset.truth.rocks) {
    if (rock.height_above_ground_m <= max_hazard_m) continue;
    const double col = (rock.center_in_local_m.x() - dem.origin_in_local_m.x()) / dem.spacing_m;
    const double row = (dem.origin_in_local_m.y() - rock.center_in_local_m.y()) / dem.spacing_m;
    const int radius = std::max(1, static_cast<int>(std::lround(0.5 * rock.diameter_m / dem.spacing_m)));
    cv::circle(hazards, cv::Point(static_cast<int>(std::lround(col)), static_cast<int>(std::lround(row))),
               radius, cv::Scalar(0, 220, 255), cv::FILLED);
  }
  slope_deg.release();
  // The safety classes drawn at the DEM's size.
  cv::Mat safety;
  cv::resize(SafetyMapImage(safety_classes), safety, z.size(), 0, 0, cv::INTER_NEAREST);
  const std::array<std::pair<const char*, const cv::Mat*>, 4> maps = {{{"elevation.png", &elevation_color},
                                                                       {"slope.png", &slope_color},
                                                                       {"hazards.png", &hazards},
                                                                       {"safety.png", &safety}}};
  std::vector<TruthMapFile> files(maps.size());
  // Each map is encoded by one worker: PNG encoding is most of the time.
  util::ParallelFor("map files", static_cast<int>(maps.size()), threads, [&](int i) {
    const auto& [name, map] = maps[static_cast<size_t>(i)];
    TruthMapFile& file = files[static_cast<size_t>(i)];
    file.name = name;
    file.png = images::EncodePng(*map);
    // Its preview for the report (the bytes a report would make from the
    // written PNG, which decodes to this image), when the map is larger.
    file.preview_png = PreviewPng(*map, kMapPreviewSidePx);
  });
  return files;
}

void WriteTruthMapFiles(const std::vector<TruthMapFile>& files, const std::string& out_dir) {
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) throw InputError(out_dir + ": cannot create the folder: " + ec.message());
  const std::filesystem::path dir(out_dir);
  for (const TruthMapFile& file : files) {
    util::WriteFileAtomically(dir / file.name, file.png);
    if (!file.preview_png.empty()) util::WriteFileAtomically(dir / kMapPreviewFolder / file.name, file.preview_png);
  }
}

void WriteTruthMaps(const Dataset& dataset, const std::string& out_dir, double max_slope_deg,
                    double max_hazard_m) {
  WriteTruthMapFiles(EncodeTruthMaps(dataset, max_slope_deg, max_hazard_m), out_dir);
}

}  // namespace hdabench::datasets::synth
