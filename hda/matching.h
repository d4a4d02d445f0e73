// Features and matches of one ROI pair (NOVA-C paper, AAS 22-105, "Feature
// detection and matching"): OpenCV ORB keypoints and descriptors in the image-1
// ROI and in its predicted image-2 box, brute-force Hamming matching with a
// ratio test and a cross-check, sub-pixel refinement of each match in image 2,
// and RANSAC on the epipolar geometry. The navigation-based rejection that
// follows lives in hda/pipeline.h (it needs the nav pose and the LRF).
// Pixels follow docs/conventions.md (pixel (0,0) = centre of the top-left
// pixel). Deterministic: the same inputs give the same matches, in the same
// order, on every run. Single-threaded except where OpenCV spreads its own work
// (the LK refinement, pyramid resizing) over the threads cv::setNumThreads
// allows, which does not change the results.
#pragma once

#include <cstddef>
#include <string>
#include <functional>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"
#include "hda/work_model.h"

namespace hdabench::hda {

struct MatchingOptions {
  // ORB (cv::ORB): keypoints are detected only inside the box (a mask), on a
  // crop padded by the descriptor patch so boxes at any size or position work.
  int orb_features_per_roi = 500;  // most keypoints kept per box (best FAST/Harris score first)
  int orb_levels = 3;              // pyramid levels
  double orb_scale_factor = 1.2;   // pyramid decimation ratio, > 1
  int orb_fast_threshold = 10;     // FAST threshold, 8-bit levels (DN)
  int orb_patch_size_px = 31;      // descriptor patch side, pixels (also ORB's edge threshold)

  // Descriptor matching (Hamming distance).
  double ratio_test = 0.8;    // keep a match when best < ratio_test * second best, in (0, 1]
  bool cross_check = true;    // keep a match only when it is also image 2's best for that keypoint
  // Nav-guided matching: when > 0 (and MatchRoiPair is given the expected
  // positions), an image-1 keypoint's candidates are only the image-2
  // keypoints within this radius, pixels, of where navigation puts it (the
  // level ground through the LRF spot); the ratio test and the cross-check
  // then compare those candidates only. For periodic texture (a chessboard,
  // regular patterns), where every period of the box looks alike. 0: every
  // keypoint of the image-2 box is a candidate.
  double guide_radius_px = 0.0;

  // Sub-pixel refinement: pyramidal Lucas-Kanade (cv::calcOpticalFlowPyrLK)
  // tracks each image-1 keypoint from its matched position in image 2. A match
  // whose refinement fails or moves it farther than max_refine_shift_px is
  // dropped (counted in RoiMatches::refine_rejected).
  bool subpixel_refine = true;
  int refine_window_px = 11;         // LK window side, pixels (odd, >= 5)
  double max_refine_shift_px = 2.0;  // largest accepted move from the ORB position, pixels
  // Nav-aided refinement (after Lucas-Kanade; only with subpixel_refine):
  // each match is refined again at full resolution with its image-1 window
  // mapped into image 2 through the local motion expected from navigation
  // (MatchRoiPair's motion_jacobian), solving for the position and a
  // brightness offset. Lucas-Kanade moves a square window by a translation
  // only; where the motion has a gradient across the window it is biased
  // toward the window's texture. At the NOVA-C geometry (45 deg off nadir,
  // 30 m baseline at 566 m) the disparity changes by about 0.05 px per image
  // row, so an 11 px window's estimate moved by 0.1-0.2 px along the
  // baseline, the dominant error of the slopes. The window is centred on the
  // whole pixel nearest the keypoint (which becomes the match's image-1
  // point). A match whose refinement fails (window off an image, no texture,
  // no convergence in 20 steps) or moves farther than max_refine_shift_px
  // from where Lucas-Kanade left it is dropped.
  bool warp_refine = true;
  int warp_refine_window_px = 25;    // window side, pixels (odd, >= 5)

  // Pre-warp, for a change of view that ORB does not survive: when the
  // expected motion (MatchRoiPair's motion_jacobian) stretches or compresses
  // image 2 against image 1 by at least this factor in some direction
  // (MotionStretch), image 2's box is resampled through the inverse of that
  // motion, so that it looks as image 1 does, before ORB detects and
  // describes there; each keypoint is mapped back to image 2, and the
  // Lucas-Kanade refinement runs on the resampled box too (the nav-aided
  // refinement, at full resolution, on image 2 itself). ORB's orientation
  // takes a rotation; its pyramid (3 levels of 1.2) a little scale; a
  // stretch in one direction neither. 0: never.
  double prewarp_min_stretch = 1.05;

  // RANSAC on the epipolar geometry: essential matrix (5-point) on the bearings
  // from the camera model, inlier threshold in pixels of image 2 (converted
  // with the camera's local focal length).
  double ransac_threshold_px = 1.0;
  double ransac_confidence = 0.999;  // in (0, 1)
  int ransac_max_iterations = 1000;  // >= 1

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

enum class MatchingStatus {
  kOk,             // RANSAC ran; inliers are in RoiMatches
  kTooFewMatches,  // fewer than 5 matches reached RANSAC: nothing kept
  kRansacFailed,   // RANSAC found no model (degenerate configuration): nothing kept
};
const char* ToString(MatchingStatus status);  // "ok", "too few matches", "ransac failed"

struct RoiMatches {
  MatchingStatus status = MatchingStatus::kTooFewMatches;
  // The RANSAC inliers, parallel arrays, full-image pixel coordinates, in the
  // order of the image-1 keypoints (cv::ORB's order).
  std::vector<cv::Point2d> points1_px;
  std::vector<cv::Point2d> points2_px;
  // Their unit bearings from the camera model (calib::CameraModel::Unproject,
  // which RANSAC needed), parallel to the points, so that a caller need not
  // unproject them again. A caller that moves a point clears its side.
  std::vector<Eigen::Vector3d> bearings1;
  std::vector<Eigen::Vector3d> bearings2;
  // Counts at each stage.
  int keypoints1 = 0;        // ORB keypoints in the image-1 box
  int keypoints2 = 0;        // ORB keypoints in the image-2 box
  int matches = 0;           // after the ratio test and the cross-check
  int refine_rejected = 0;   // dropped by the sub-pixel refinement
  int ransac_inliers = 0;    // == points1_px.size()
  bool prewarped = false;    // image 2's box was resampled before ORB (MatchingOptions::prewarp_min_stretch)
  // The matching stage's work (hda/work_model.h): ORB, descriptor pairs,
  // pre-warp, refinements, unprojection and RANSAC.
  WorkCounts work;
};

// How far the local image motion `jacobian` (d image-2 pixel / d image-1
// pixel) departs from a rotation: the largest factor by which it stretches or
// compresses a direction, max(s1, 1 / s2) for its singular values s1 >= s2
// (1 for a rotation; infinity for a singular or non-finite matrix).
double MotionStretch(const cv::Matx22d& jacobian);

// ORB keypoints and descriptors in `box` of a CV_8UC1 image (clipped to
// the image), full-image coordinates: exactly what cv::ORB (options' levels,
// scale factor, patch, FAST threshold, Harris score, at most
// orb_features_per_roi) gives on the box padded by the patch, with the box as
// mask, found at a fraction of cv::ORB's cost (FAST runs on the box only).
// Fewer levels than options.orb_levels where the padded box is too small to
// hold a keypoint at the coarser ones.
struct OrbFeatures {
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;  // CV_8UC1, a row of 32 bytes per keypoint
  std::int64_t pyramid_pixels = 0;  // pixels of the pyramid built (every level of the padded box)
};
OrbFeatures DetectOrbInBox(const cv::Mat& image, const cv::Rect& box, const MatchingOptions& options);

// How many keypoints cv::ORB's detect() finds on the whole of a CV_8UC1
// image with the options' levels, scale factor, patch and FAST threshold and
// `max_features` as its cap (nfeatures, >= 1), counted without computing the
// orientations, and the Harris responses only on a level where the cap binds.
size_t CountOrbKeypoints(const cv::Mat& image, const MatchingOptions& options, int max_features);

// Where navigation expects image-1 pixels in image 2: fills `pixels2` and
// `valid` (0 where there is no expectation) parallel to `pixels1`.
using ExpectedPositions = std::function<void(const std::vector<cv::Point2d>& pixels1,
                                             std::vector<cv::Point2d>* pixels2,
                                             std::vector<unsigned char>* valid)>;

// Matches ROI `box1_px` of image 1 with box `box2_px` of image 2. The images
// are CV_8UC1 (callers convert 16-bit images once: ToEightBit in
// hda/pipeline.h), of the camera's imager size; the boxes must lie inside their images (a box that does not is
// clipped; an empty one gives kTooFewMatches with zero counts).
// motion_jacobian: d(image-2 pixel) / d(image-1 pixel) expected around the ROI
// (RunHda gives the level ground's under the nav pose); the nav-aided
// refinement maps its windows with it, and the pre-warp resamples image 2's
// box through its inverse. The identity means a pure translation.
// expected: where each image-1 keypoint should be in image 2, for nav-guided
// matching (options.guide_radius_px > 0); without it every keypoint of the
// box is a candidate whatever the radius.
// Throws InputError for invalid options, an unsupported image type, or images
// whose size differs from the camera's imager.
RoiMatches MatchRoiPair(const cv::Mat& image1, const cv::Mat& image2, const cv::Rect& box1_px,
                        const cv::Rect& box2_px, const calib::CameraModel& camera,
                        const MatchingOptions& options,
                        const cv::Matx22d& motion_jacobian = cv::Matx22d::eye(),
                        const ExpectedPositions& expected = nullptr);

}  // namespace hdabench::hda
