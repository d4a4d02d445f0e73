// Ground truth of a region of interest (ROI): the numbers every comparison of
// the bench is scored against. Definitions (docs/synthetic-scenes.md, "Truth"):
//   points   the true 3D points (local frame) of the ROI's pixels in the frame's
//            truth raster; pixels whose ray hit nothing are skipped.
//   plane    least-squares plane through those points (total least squares:
//            the normal is the eigenvector of the smallest eigenvalue of their
//            covariance), its normal n pointing up (n . up > 0, up = -gravity).
//   slope    angle between n and up, degrees.
//   roughness_rms_m / roughness_max_m: RMS and maximum of |n . (p - centroid)|.
//   max_rock_height_m: tallest rock (height above the terrain under its
//            centre) whose centre projects into the ROI with the frame's true
//            pose; 0 when none.
//   hazard_height_m: max(roughness_max_m, max_rock_height_m).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "datasets/dataset.h"

namespace hdabench::datasets::synth {

struct PixelRoi {
  int x = 0;       // left column, pixels
  int y = 0;       // top row, pixels
  int width = 0;   // pixels
  int height = 0;  // pixels
};

struct RoiTruth {
  int num_points = 0;
  double slope_deg = 0.0;
  double roughness_rms_m = 0.0;
  double roughness_max_m = 0.0;
  double max_rock_height_m = 0.0;
  double hazard_height_m = 0.0;
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d centroid_in_local_m = Eigen::Vector3d::Zero();
};

// Frame `frame`'s truth points (TruthPoints::points_in_local_m) in memory.
// Throws InputError naming the dataset and frame when it has none.
const cv::Mat& TruthPointsOf(const Dataset& dataset, int frame);

// Truth of `roi` in frame `frame`. The dataset must hold the frame's truth
// points in memory (LoadOptions::keep_truth). Throws InputError when the frame
// has no truth points, the ROI leaves the image or is empty, or fewer than 3
// points (or only collinear ones) fall inside it.
RoiTruth ComputeRoiTruth(const Dataset& dataset, int frame, const PixelRoi& roi);

// The truth of a method's support: the plane of the ground and the weighting
// a method's own plane stands for, as ComputeRoiTruth's but over the image
// positions `pixels` (pixel centres at whole numbers; the truth point
// bilinear between the four pixels around each, left out where one of them
// has none), each weighted by weights[k] (empty: alike; zero: left out).
struct SupportTruth {
  int num_points = 0;  // the support's positions with a truth point and a positive weight
  double slope_deg = 0.0;
  Eigen::Vector3d normal_in_local = Eigen::Vector3d::UnitZ();
};
// Throws InputError as ComputeRoiTruth, and for weights not one per pixel or
// not finite and >= 0.
SupportTruth ComputeSupportTruth(const Dataset& dataset, int frame, const std::vector<Eigen::Vector2d>& pixels,
                                 const std::vector<double>& weights);

// Writes elevation.png, slope.png, hazards.png (slope over max_slope_deg
// measured over a 1 m baseline, or a rock taller than max_hazard_m) and
// safety.png (the default lander on every cell about 1 m apart,
// lander_truth.h's SafetyMap, drawn at the DEM's size) of the dataset's truth
// DEM into out_dir, each atomically, and each one's preview
// for the report into out_dir/preview/ (datasets/map_preview.h) when the map
// is larger than a preview. Throws InputError when
// the dataset has no DEM in memory or a file cannot be written.
void WriteTruthMaps(const Dataset& dataset, const std::string& out_dir, double max_slope_deg = 10.0,
                    double max_hazard_m = 0.30);

// WriteTruthMaps in two steps, so that the maps can be drawn while something
// else is written: each map's PNG bytes and its preview's (empty when the map
// is no larger than a preview), in the order elevation, slope, hazards,
// safety. EncodeTruthMaps throws InputError when the dataset has no DEM in
// memory; WriteTruthMapFiles when a file cannot be written.
struct TruthMapFile {
  std::string name;  // "slope.png"
  std::string png;
  std::string preview_png;
};
std::vector<TruthMapFile> EncodeTruthMaps(const Dataset& dataset, double max_slope_deg = 10.0,
                                          double max_hazard_m = 0.30);
void WriteTruthMapFiles(const std::vector<TruthMapFile>& files, const std::string& out_dir);

}  // namespace hdabench::datasets::synth
