// The direct plane reference (plane-nav): per ROI, the plane that best maps
// every pixel of the ROI in image 1 onto image 2 under a given relative pose
// (the navigation's), by photometric Gauss-Newton with a brightness gain and
// offset between the two images. No keypoints, no matching: every pixel with
// a gradient along the epipolar direction constrains the plane. It is the
// heaviest estimator the data allow for a planar site, and so the yardstick
// for how much slope information the flight method's keypoints leave unused.
//
// The model. A plane of camera 1 is written p . X = 1 (p = normal / distance,
// X in camera 1, metres). The pixel u of image 1 with unit bearing b sees the
// point X(p) = b / (p . b); image 2 sees it at q = project(R X + t) with
// cam2_from_cam1 = (R, t). The residual of the pixel is
//   r = I2(q) - (gain * I1(u) + offset)
// with I2 the cubic-spline interpolant of image 2. The five unknowns (p, gain, offset) minimise the
// sum of Huber-weighted squared residuals (the Huber width 1.345 times the
// robust sigma of the residuals, so that shadows, occlusions and rocks that
// break the plane weigh less). The Jacobian of the projection is taken by
// forward differences (any mrcal lens model), the image gradient from image
// 1's (central differences) through the ROI's warp, which keeps it free of
// the noise of the residual it multiplies.
//
// The covariance of the plane is the inverse normal matrix times the
// weighted residual variance: the slope's sigma follows from it (it assumes
// independent pixel residuals, which the optics' blur makes optimistic).
//
// Deterministic: no random numbers, no threads; the same inputs give the same
// bytes.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "calib/camera_model.h"
#include "calib/rigid3.h"
#include "reference/direct/dense_stereo.h"

namespace hdabench::reference {

struct DirectPlaneOptions {
  // Before Gauss-Newton, the starting plane is moved along the ROI's rays
  // (its inverse distance scaled by 1 - search_fraction .. 1 + search_fraction)
  // in steps that move the ROI's centre by search_step_px in image 2, keeping
  // the position of best normalised cross-correlation: the start then only has
  // to be right in its tilt (level ground is close enough for any site a
  // lander could use), and Gauss-Newton starts within its basin.
  double search_fraction = 0.25;    // in [0, 0.9]; 0: no search
  double search_step_px = 0.5;      // > 0, pixels
  int max_iterations = 30;          // >= 1: Gauss-Newton steps at most
  // Converged when no corner of the ROI moves by more than this in image 2
  // between two steps.
  double convergence_px = 1e-4;     // > 0, pixels
  // Pixels of the ROI that must project into image 2 (with a 1 px border for
  // the interpolation and its gradient); fewer: "outside overlap".
  double min_overlap_fraction = 0.5;  // in (0, 1]
  int min_pixels = 64;              // >= 8: pixels needed at all
  // An ROI whose predicted slope sigma exceeds this is "no texture": its
  // pixels do not constrain the plane (uniform, or gradients only across the
  // epipolar direction); or "low parallax" (parallax_precision_px). compare
  // passes the flight method's max_slope_sigma_deg.
  double max_slope_sigma_deg = 3.0;  // > 0, degrees
  // An ROI the fit leaves without a slope within max_slope_sigma_deg ("no
  // texture", or "diverged" without a sigma under it) is "low parallax"
  // instead where the pose's parallax alone, on the starting plane, would
  // leave its slope more uncertain than that even with every pixel located
  // in image 2 to this precision: then no texture would give a slope, and
  // the cause is the geometry. The default is the step dense-nav's bound
  // takes (kDisparityStepsPerPx). The bounds are not the same: plane-nav's
  // support is larger than the ROI, and it judges only fits without a slope.
  double parallax_precision_px = 1.0 / kDisparityStepsPerPx;  // > 0, pixels

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

enum class DirectPlaneStatus {
  kOk,              // "ok"
  kOutsideOverlap,  // "outside overlap": too few of the ROI's pixels project into image 2
  kNoTexture,       // "no texture": the pixels do not constrain the plane
  kDiverged,        // "diverged": the plane went behind a camera, a step was not finite, or it
                    // did not converge within max_iterations
  kLowParallax,     // "low parallax": the pose moves no corner of the ROI by convergence_px
                    // between the starting plane and infinity (no baseline across its lines of
                    // sight): every plane maps the ROI alike; or the fit gave no slope within
                    // max_slope_sigma_deg where the parallax alone leaves it unobservable
                    // (parallax_precision_px)
};
const char* ToString(DirectPlaneStatus status);

struct DirectPlaneResult {
  DirectPlaneStatus status = DirectPlaneStatus::kDiverged;
  std::string reason;                // one line with numbers
  Eigen::Vector3d plane_in_cam1 = Eigen::Vector3d::Zero();  // p: p . X = 1 (metres^-1)
  Eigen::Matrix3d plane_covariance = Eigen::Matrix3d::Zero();  // of p
  double gain = 1.0;
  double offset_dn = 0.0;
  double residual_rms_dn = 0.0;      // weighted RMS of the residuals at the solution
  double robust_sigma_dn = 0.0;      // 1.4826 * median |residual|
  Eigen::Vector3d up_normal_in_cam1 = Eigen::Vector3d::Zero();  // the plane's unit normal, up
  double slope_deg = 0.0;            // angle between the plane and the level
  double slope_sigma_deg = 0.0;      // the larger semi-axis of the normal's 1-sigma uncertainty
  // Where the fit gave no slope within max_slope_sigma_deg and enough of the
  // ROI's pixels land in image 2: the slope sigma the pose's parallax alone
  // leaves the starting plane with every pixel located to
  // parallax_precision_px (infinity without parallax); 0 elsewhere.
  double parallax_slope_sigma_deg = 0.0;
  int pixels = 0;                    // pixels used at the solution
  double search_scale = 1.0;         // the search's factor on the starting inverse distance
  // The ROI's pixel rays on the fitted plane, in camera 1 (metres): the
  // points a point-based comparison sees.
  std::vector<Eigen::Vector3d> points_in_cam1;
  // The pixels of the solution's residuals (image 1) and their weight in the
  // fit: the Huber weight times the squared norm of the pixel's row of the
  // plane's Jacobian (what the pixel tells of its depth along its ray). Set
  // for an "ok" fit.
  std::vector<Eigen::Vector2d> support_px;
  std::vector<double> support_weights;
  int iterations = 0;
  bool converged = false;            // reached convergence_px before max_iterations
};

// The pair as the fit reads it: image 1 as float, image 2 as the
// coefficients of its cubic-spline interpolant. Build once per pair.
struct DirectPlaneImages {
  cv::Mat image1;       // CV_32F
  cv::Mat gradient_x1;  // CV_32F, image 1's central differences, DN per pixel
  cv::Mat gradient_y1;  // CV_32F
  cv::Mat spline2;      // CV_64F
};
// Throws InputError for an empty image, more than one channel, or images of
// different sizes.
DirectPlaneImages PrepareDirectPlaneImages(const cv::Mat& image1, const cv::Mat& image2);

// Fits the plane of the pixels of `box1` (image 1) against image 2 under
// cam2_from_cam1, starting from `initial_plane_in_cam1` (p . X = 1, in front
// of camera 1 along the ROI's rays); up_in_cam1 (unit: against gravity) gives
// the slope. Throws InputError for invalid options, images not of the
// camera's size, or a box not inside image 1; every other failure is a
// status, and nothing in the result is NaN.
DirectPlaneResult FitPlaneDirect(const DirectPlaneImages& images, const calib::CameraModel& camera,
                                 const cv::Rect& box1, const Rigid3d& cam2_from_cam1,
                                 const Eigen::Vector3d& initial_plane_in_cam1,
                                 const Eigen::Vector3d& up_in_cam1, const DirectPlaneOptions& options);

}  // namespace hdabench::reference
