// The dense stereo reference (dense-nav): the pair rectified with the
// navigation's relative pose through the camera model (any lens model the
// camera can unproject: not CAHVORE),
// semi-global matching (OpenCV's StereoSGBM, sixteenth-pixel disparities),
// and every pixel with a disparity triangulated. Hundreds to thousands of
// points per ROI, from a matcher that shares nothing with the flight
// method's keypoints.
//
// The rectification. The rectified frame's x axis is the baseline (camera 2's
// centre seen from camera 1), its z axis camera 1's view direction (the ray of
// the image centre) with its component along the baseline removed. Both
// rectified images are pinhole views of that orientation, at camera 1's focal
// length at its image centre, so a pixel of the rectified image 1 and its
// match in the rectified image 2 share a row. The field covers image 1 up to
// max_off_axis_deg from the rectified z axis in x and in y (so its corners
// reach further), and at most twice the image's larger side each way around
// the image centre's ray: a baseline near the view
// direction (motion along the boresight) puts the epipole in the image, and
// only the part of image 1 away from it can be rectified; with no such part
// the pair is "not rectifiable".
//
// The disparity search follows from the geometry alone: the disparities of
// level ground through the laser range finder's point over the rectified
// field (linear in the rectified coordinates), widened by
// inverse_depth_margin on either side (relief of that fraction of the
// distance toward or away from the camera). Image 2's rectified principal
// point is shifted by the smallest disparity so that the search starts at 0,
// and image 1's field is padded on the left by the search's width so that
// no pixel of image 1 falls in the columns the matcher leaves out.
//
// The navigation's pose error leaves the matches a fraction of a pixel off
// their rows (0.2-0.7 px on the default scenes), which a one-dimensional
// matcher turns into disparity errors: the row offset is measured on a grid
// of two-dimensional matches, fitted as an affine function of the rectified
// pixel, and image 2 rectified again with it before the matching.
//
// Each SGBM disparity is then refined by its own window (Gauss-Newton on the
// disparity, image 2 read from its cubic spline, the window sheared as level
// ground is between the views): SGBM's sub-pixel parabola pulls disparities
// toward whole pixels, which reads as a tilt over an ROI.
//
// A disparity is kept when the pixel's match window lies in both images
// (the rectified pixel and its match map inside image 1 and image 2 by at
// least half a block), the left-right check agrees (max_lr_difference_px),
// the speckle filter keeps it, the window has texture (its RMS gradient at
// least one grey level of the matcher's 8 bits per pixel) and the refined
// windows correlate (min_ncc).
//
// Deterministic: StereoSGBM in its single-pass mode and fixed arithmetic; the
// same inputs give the same bytes.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"

namespace hdabench::reference {

// SGBM's disparities are in sixteenths of a pixel: the matcher's step.
constexpr double kDisparityStepsPerPx = 16.0;

struct DenseStereoOptions {
  int block_size_px = 5;             // odd, in [3, 11]: SGBM's matching window
  // The search around level ground: disparities of level ground times
  // 1 - margin .. 1 + margin (the inverse distance's fraction).
  double inverse_depth_margin = 0.25;  // in [0, 0.9]
  int max_disparities = 512;         // in [16, 2032]: the search's width at most (a multiple of 16)
  int uniqueness_ratio_percent = 10; // in [0, 100]: the best cost beats the second by this much
  int speckle_window_px = 100;       // >= 0: smaller regions of similar disparity are dropped (0: off)
  int speckle_range_px = 2;          // >= 1: disparity variation within a region
  int max_lr_difference_px = 1;      // >= 1: left-right consistency (the disparity of both images' matches)
  double max_off_axis_deg = 60.0;    // in (0, 85): the rectified field's half-width from its z axis
  // Each SGBM disparity refined by its window's own Gauss-Newton fit (see
  // dense_stereo.cc, RefineDisparity): off, SGBM's parabola alone.
  bool subpixel_refinement = true;
  // A refined match whose two windows correlate (normalised, offsets
  // removed) under this is dropped: SGBM keeps matches whose cost is unique,
  // not only those whose windows look alike, and at occlusions, shadow edges
  // and repeated texture the two differ. With refinement only. On the
  // StereoLunar nadir pairs 0.9 cut dense-nav's p90 slope error from 2.3-13.9
  // to 0.9-1.9 deg and on the truck from 8.1 to 0.2; on the default scenes
  // it changes nothing measurable.
  double min_ncc = 0.9;              // in [-1, 1]
  // Image 2's rows corrected for the navigation pose's error before the
  // matching (see dense_stereo.cc, EstimateRowShift): off, the nav pose's
  // rows as they are.
  bool correct_rows = true;
  // An ROI (hdabench compare) has a plane when at least this share of its
  // image-1 pixels have a disparity.
  double min_roi_share = 0.5;        // in (0, 1]
  // An ROI (hdabench compare) has a plane only where the matcher's
  // disparity step alone leaves its slope at most this uncertain
  // (DenseSlopeSigmaDeg; compare passes the flight method's
  // max_slope_sigma_deg): a shorter baseline across the line of sight, a
  // farther ROI or fewer points make depth differences across the ROI smaller
  // than the step.
  double max_slope_sigma_deg = 3.0;  // in (0, 90)
  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// The rectified pair's geometry: enough to map between image 1, the
// rectified images and the triangulated points.
struct DenseRectification {
  Eigen::Matrix3d rect_from_cam1 = Eigen::Matrix3d::Identity();  // rows: the rectified x, y, z axes in camera 1
  double focal_px = 0.0;           // both rectified images
  double cx1_px = 0.0;             // rectified image 1's principal point (column)
  double cx2_px = 0.0;             // rectified image 2's: cx1_px + disparity_shift_px
  double cy_px = 0.0;
  int width_px = 0;
  int height_px = 0;
  double baseline_m = 0.0;
  int disparity_shift_px = 0;      // the search's smallest disparity
  int num_disparities = 0;         // the search's width (a multiple of 16)
  // The rectified field in normalised coordinates (x/z, y/z), image 1's part.
  double field_x_min = 0.0, field_x_max = 0.0, field_y_min = 0.0, field_y_max = 0.0;
  // Rectified image 2's row v is read from row v + row_shift . (1, u, v) of
  // the nav pose's rectification (the correction of its error; zero when
  // not corrected).
  Eigen::Vector3d row_shift = Eigen::Vector3d::Zero();
  Eigen::Vector3d level_plane_in_cam1 = Eigen::Vector3d::Zero();  // the search's level ground (p . X = 1)
};

enum class DenseStereoStatus {
  kOk,              // "ok"
  kNotRectifiable,  // "not rectifiable": no baseline, or no part of image 1 away from the epipole
};
const char* ToString(DenseStereoStatus status);

struct DenseStereoResult {
  DenseStereoStatus status = DenseStereoStatus::kNotRectifiable;
  std::string reason;              // one line with numbers
  DenseRectification rectification;
  bool search_clipped = false;     // the search was wider than max_disparities
  double row_shift_max_px = 0.0;   // the row correction's largest magnitude over the field
  int row_shift_matches = 0;       // the matches it was fitted to (0: not corrected)
  int valid_pixels = 0;            // pixels of rectified image 1 (inside image 1) with a disparity
  int field_pixels = 0;            // pixels of rectified image 1 inside image 1
  // One per pixel with a disparity: the point in camera 1 (metres) and where
  // image 1 sees it (hdabench pixels).
  std::vector<Eigen::Vector3d> points_in_cam1;
  std::vector<Eigen::Vector2d> pixels1;
};

// The slope uncertainty (degrees) that the matcher's disparity step (1/16
// px, taken as each point's disparity error) alone leaves the plane of an ROI
// whose `num_points` points cover image-1 box `box1`. Over a side of w pixels
// a least-squares plane's disparity gradient is uncertain by
// step / (w sqrt(N / 12)) per pixel; on ground of disparity d (the level
// ground's at the box's centre) a slope of tangent t changes the disparity
// by d t / f per pixel, so tan(sigma) = step sqrt(12 / N) f / (w d). Where
// the box's centre looks above the level ground's horizon (ground higher
// than the camera, ahead of an oblique one), d is the median disparity of
// the ROI's own points (`points_in_cam1`, camera 1, metres) instead.
// Infinity where the pair is not rectified, the box's centre has no ray in
// the rectified frame, or neither gives a disparity.
double DenseSlopeSigmaDeg(const DenseStereoResult& result, const calib::CameraModel& camera, const cv::Rect& box1,
                          int num_points, const std::vector<Eigen::Vector3d>& points_in_cam1 = {});

// The dense reconstruction of the pair: images 1 and 2 (one channel, 8-bit,
// 16-bit or float, of the camera's size; both mapped to 8 bits by the same
// linear stretch of their joint 0.1-99.9 % range), the relative pose
// cam2_from_cam1 (metres), level ground through the range finder's point
// (p . X = 1 in camera 1). Throws InputError for invalid options or images;
// geometry that cannot be rectified is a status.
DenseStereoResult RunDenseStereo(const cv::Mat& image1, const cv::Mat& image2, const calib::CameraModel& camera,
                                 const Rigid3d& cam2_from_cam1, const Eigen::Vector3d& level_plane_in_cam1,
                                 const DenseStereoOptions& options);

// The share of the pixels of `box1` (image 1) that the dense reconstruction
// can see at all: inside the rectified field, and (on level ground) inside
// image 2 with half a block to spare. In [0, 1]; 0 for a pair that was not
// rectified.
double DenseOverlapFraction(const DenseStereoResult& result, const calib::CameraModel& camera,
                            const Rigid3d& cam2_from_cam1, const cv::Rect& box1, int block_size_px);

}  // namespace hdabench::reference
