// Prediction of an image-1 ROI into image 2 from the navigation's relative
// motion and the LRF range, enlarged to cover navigation error (NOVA-C paper,
// AAS 22-105: "the corresponding ROI from the second image, which we calculate
// from the navigation data and enlarge ... to account for uncertainty").
// Frames and pixels follow docs/conventions.md (camera frames with OpenCV axes,
// pixel (0,0) = centre of the top-left pixel, cam2_from_cam1).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "hda/quadtree.h"

namespace hdabench::hda {

// Navigation and LRF uncertainty behind the margin. The defaults are bench
// choices (the paper gives no values): an IMU-propagated relative pose over
// the 2-3 s between the two images (a velocity error of 0.1 m/s gives 0.25 m;
// a gyro bias of 0.01 deg/s gives 0.02 deg) and a commercial LRF.
struct PredictionOptions {
  double nav_position_sigma_m = 0.25;    // 1-sigma error of the relative position, per axis, metres
  double nav_attitude_sigma_deg = 0.02;  // 1-sigma error of the relative attitude, degrees
  double range_sigma_m = 1.0;            // 1-sigma error of the LRF range, metres
  double sigma_multiplier = 3.0;         // margin covers this many sigmas, dimensionless
  int min_margin_px = 8;                 // margin never smaller than this, pixels

  // Every violated constraint, one message each ("field = value: expected ...").
  // Empty when the options are usable.
  std::vector<std::string> Validate() const;
};

enum class PredictionStatus {
  kOk,             // box_px is the predicted, enlarged box inside image 2 (clipped if needed)
  kOutsideImage2,  // the enlarged box does not overlap image 2
  kBehindCamera,   // a ground point is not in front of camera 1 or 2, or cannot be (un)projected
};

const char* PredictionStatusName(PredictionStatus status);  // "ok", "outside image 2", "behind camera"

struct PredictedRoi {
  int id = 0;                                  // the image-1 ROI's id
  PredictionStatus status = PredictionStatus::kBehindCamera;
  cv::Rect box_px;                             // pixels of image 2 to search; empty unless kOk
  bool clipped = false;                        // the enlarged box was cut at the image 2 border
  cv::Rect2d projected_edges_px;               // bounds of the projected ROI outline before the
                                               // margin, pixel-edge coordinates (continuous)
  double margin_px = 0;                        // margin added on every side, pixels
};

// The outline of `box` in pixel-edge coordinates, the points where the flight
// method samples an ROI's rays: the centre first, then the corners and edge
// middles clockwise from the top-left corner (x - 0.5, y - 0.5); the corners
// are elements 1, 3, 5 and 7.
std::vector<Eigen::Vector2d> BoxOutlinePx(const cv::Rect& box);

// Predicts `roi` (image 1) into image 2 of the same camera.
// Ground model: the plane perpendicular to camera 1's optical axis at
// z_cam1 = ground_distance_m (the LRF range, co-boresighted). The ROI outline
// (its four pixel-edge corners (x - 0.5, y - 0.5) .. (x + w - 0.5, y + h - 0.5),
// the four edge midpoints and the centre) is unprojected, each ray is cut with
// that plane, moved with p_in_cam2 = cam2_from_cam1 * p_in_cam1 and projected.
// The bounding box of the projected outline is enlarged on every side by
//   margin_px = max(min_margin_px,
//                   k * f_px * (sigma_pos / d + sigma_att_rad + sigma_range * B / d^2))
// with k = sigma_multiplier, d = |centre point in cam2| (metres), B = |t_cam2_from_cam1|
// (baseline, metres), and f_px the local scale at the centre point in image 2
// (pixels per radian, larger of the two directions perpendicular to the ray,
// by central differences): a position error shifts lines of sight by up to
// sigma_pos / d, an attitude error by sigma_att, a range error moves the ground
// point along camera 1's ray, which camera 2 sees at up to B / d^2 radians per
// metre. Errors are added linearly (a conservative bound).
// The enlarged continuous box [u0, u1] x [v0, v1] becomes the pixels whose
// centres lie inside it (columns ceil(u0) .. floor(u1), with 1e-6 px of slack
// against rounding), then is clipped to image 2. With the identity pose and zero margin the box
// is the ROI's own box.
// Throws InputError when the options are invalid or ground_distance_m is not
// finite and > 0.
PredictedRoi PredictRoi(const Roi& roi, const calib::CameraModel& camera, const Rigid3d& cam2_from_cam1,
                        double ground_distance_m, const PredictionOptions& options);

}  // namespace hdabench::hda
