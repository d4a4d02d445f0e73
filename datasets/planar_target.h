// A real planar target as a dataset: two images of a chessboard taken by
// calibrated cameras (the same camera twice, or the two cameras of a stereo
// pair) become a two-frame dataset whose navigation is each image's pose from
// PnP on the board and whose truth is the board's plane
// (docs/planar-target.md). The flight method's plane on the board is then
// judged against the board's plane by the bench's ordinary truth comparison.
//
// Frames and conventions (docs/conventions.md):
//   board     the board's own frame: corner (i, j) of the W x H inner corners
//             (row-major, calib::DetectChessboard's order) at (i s, j s, 0),
//             s the spacing; its z axis is the board's normal.
//   local     the board frame turned so that z points toward camera 1 (a half
//             turn about board x when camera 1 sees the board from its -z
//             side): x along the rows, z up off the board. Gravity is
//             (0, 0, -9.80665): a slope is the angle between a plane's normal
//             and the board's normal. ILS = the board's centre.
//   body      the camera itself: cam_from_body = identity.
//   camera    frame 0's model (camera 1). Image 2 is resampled into camera 1's
//             model at camera 2's pose (each pixel unprojected with camera 1's
//             model and projected with camera 2's; bilinear; black where
//             camera 2 did not see): the dataset holds one camera model, and
//             the resampling changes the lens, not the viewpoint. With one
//             camera for both images there is nothing to resample.
//   nav       cam_from_board by PnP on each image (every corner unprojected
//             with its camera's model, so any lens model works; OpenCV's IPPE
//             for a planar target, then Levenberg-Marquardt), at 0 s and 1 s.
//             No truth navigation: PnP is the yardstick, not the truth.
//   LRF       along each camera's optical axis from its centre to the board's
//             plane, at 0 s and 1 s.
//   truth     frame 0's points: each pixel's ray met with the board's plane,
//             inside the checkered area (the (W+1) x (H+1) squares, from -s to
//             W s and -s to H s in board coordinates); NaN elsewhere. The
//             board's flatness (the printed board's deviation from a plane) is
//             not measured: truth roughness is 0.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"
#include "calib/chessboard.h"
#include "calib/rigid3.h"
#include "datasets/dataset.h"

namespace hdabench::datasets {

// Standard gravity (the local frame's gravity), m/s^2.
constexpr double kStandardGravityMps2 = 9.80665;

// What each image gave: its board pose and how well the corners fit it.
struct PlanarTargetView {
  std::string image_path;
  std::vector<Eigen::Vector2d> corners_px;  // the board's corners found (row-major)
  Rigid3d cam_from_board;           // PnP
  double reprojection_rms_px = 0.0; // corners against the PnP pose through the model
  double reprojection_max_px = 0.0;
  double range_m = 0.0;             // along the optical axis to the board's plane
  double tilt_deg = 0.0;            // between the optical axis and the board's normal
};

struct PlanarTargetPair {
  Dataset dataset;
  PlanarTargetView view[2];
  // When both models carry extrinsics from one calibration of the pair
  // (rt_cam_ref not both zero): the PnP relative pose against theirs.
  // The largest axis-aligned box of image 1 inside the convex hull of the
  // board's corners there: the board as one ROI (hdabench run --roi).
  cv::Rect board_box_px;
  bool has_calibrated_extrinsics = false;
  double extrinsics_rotation_diff_deg = 0.0;
  double extrinsics_translation_diff = 0.0;  // |t_pnp - t_calibrated|, the spacing's unit
};

// Builds the dataset from image1 (camera1) and image2 (camera2), as the header
// comment says. Images of any type are read as 8-bit grey (colour with
// OpenCV's BT.601 weights). `name` names the dataset (empty: from the image
// file names). Throws InputError naming the file when an image cannot be read
// or does not have its model's imager size, the board is not found in it, a
// corner cannot be unprojected, the two images see the board from opposite
// sides, or an optical axis does not meet the board's plane; InputError for an
// invalid board spec.
PlanarTargetPair MakePlanarTargetPair(const std::string& image1_path, const calib::CameraModel& camera1,
                                      const std::string& image2_path, const calib::CameraModel& camera2,
                                      const calib::ChessboardSpec& board,
                                      calib::CornerDetector detector = calib::CornerDetector::kAuto,
                                      const std::string& name = "");

// The largest axis-aligned box of whole pixels whose pixel centres all lie in
// the convex hull of `points_px` (found exactly over every pair of rows: in a
// convex polygon a row's span is largest where the polygon is widest, so a
// box's columns are limited by its top and bottom rows only). Empty when the
// hull holds no pixel centre.
cv::Rect LargestBoxInHull(const std::vector<Eigen::Vector2d>& points_px);

// cam_from_board of a board seen at `corners_px` (row-major, board.width per
// row) through `camera`; the reprojection RMS and maximum in pixels. Throws
// InputError (prefixed by `where`) when a corner cannot be unprojected or lies
// behind the camera, or PnP fails.
Rigid3d BoardPoseByPnp(const calib::CameraModel& camera, const std::vector<Eigen::Vector2d>& corners_px,
                       const calib::ChessboardSpec& board, const std::string& where, double* rms_px,
                       double* max_px);

}  // namespace hdabench::datasets
