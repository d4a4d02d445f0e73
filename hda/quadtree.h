// Quadtree segmentation of image 1 into candidate landing sites (ROIs), after
// the NOVA-C paper (AAS 22-105, "Quadtree"): split the image into quadrants
// until a block's brightness is uniform enough or the block reaches the
// minimum size (just under the landing site projected with the LRF range);
// dark blocks (shadow: rocks, craters) and too-variable blocks are discarded.
// Pixels follow docs/conventions.md: pixel (col, row) covers
// [col - 0.5, col + 0.5] x [row - 0.5, row + 0.5]; a cv::Rect is a set of whole
// pixels (x, y) .. (x + width - 1, y + height - 1).
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/types.hpp>

#include "calib/camera_model.h"

namespace hdabench::hda {

struct QuadtreeOptions {
  double site_size_m = 10.0;         // side of the square landing site on the ground, metres
  double min_block_fraction = 0.9;   // minimum block side = this fraction of the site's projected side, in (0, 1]
  double max_block_stddev = 12.0;    // brightness std below this stops splitting, 8-bit levels (DN)
  double min_block_mean = 40.0;      // mean brightness below this is shadow: rejected, 8-bit levels (DN)
  double max_roi_stddev = 40.0;      // std above this at the minimum size: rejected as variable, 8-bit levels (DN)

  // Every violated constraint, one message each ("field = value: expected ...").
  // Empty when the options are usable.
  std::vector<std::string> Validate() const;
};

// The projected side s_px of a site_size_m square at lrf_range_m along the
// ray of the image centre, as defined for MinimumBlockSizePx below. Throws
// InputError (messages prefixed by `caller`) when lrf_range_m is not finite
// and > 0 or the camera cannot unproject the centre or project the segment.
double ProjectedSiteSidePx(const calib::CameraModel& camera, double lrf_range_m, double site_size_m,
                           const char* caller = "ProjectedSiteSidePx");

// Smallest block side the quadtree splits down to, in pixels, for a camera at
// `lrf_range_m` from the ground:
//   side_px = floor(min_block_fraction * s_px), at least kMinBlockSidePx,
// where s_px is the projected side of a site_size_m square centred on the ray
// of the image centre ((W-1)/2, (H-1)/2), at lrf_range_m along that ray and
// perpendicular to it: the centre pixel is unprojected, the two end points of
// a site_size_m segment along each of two directions perpendicular to the ray
// (one in the camera's x-z plane, one orthogonal to both) are projected, and
// s_px is the shorter of the two pixel distances. For a pinhole camera with the
// principal point at the centre, s_px = f * site_size_m / lrf_range_m (f = 1000,
// 10 m at 570 m: s_px = 17.54, side 15; at 3 m: 3333.3, side 3000). A side
// larger than the image is returned as is: that image cannot hold a site (field
// tests at a few metres scale site_size_m down, as the paper's truck tests did).
// Throws InputError when the options are invalid, lrf_range_m is not finite and
// > 0, or the camera cannot unproject the centre or project the segment.
constexpr int kMinBlockSidePx = 8;
int MinimumBlockSizePx(const calib::CameraModel& camera, double lrf_range_m,
                       const QuadtreeOptions& options);

// One candidate landing site.
struct Roi {
  int id = 0;          // 1-based; ROIs are numbered in raster order of their top-left corners (row, then column)
  cv::Rect box_px;     // the block's pixels in image 1
  double mean_dn = 0;  // mean brightness, 8-bit levels (16-bit images divided by 257)
  double stddev_dn = 0;  // population standard deviation of brightness, 8-bit levels
};

struct QuadtreeResult {
  std::vector<Roi> rois;          // accepted blocks, sorted by id
  int blocks_visited = 0;         // blocks whose statistics were computed (the whole image counts as one)
  int rejected_dark = 0;          // leaves with mean < min_block_mean (shadow)
  int rejected_variable = 0;      // minimum-size leaves with stddev > max_roi_stddev
  int rejected_small = 0;         // 1 when the whole image is smaller than min_block_px on a side, else 0
  int min_block_px = 0;           // the minimum block side used, pixels
  std::vector<cv::Rect> rejected_boxes;  // every rejected leaf, in visiting order (depth first:
                                         // top-left, top-right, bottom-left, bottom-right)
  // One line: "quadtree: N ROIs, V blocks visited, D dark, R variable, S small, min block M px".
  std::string Summary() const;
};

// Runs the quadtree on `image` (CV_8UC1, or CV_16UC1 whose statistics are
// divided by 257 to 8-bit levels).
// Rule, for each block starting with the whole image:
//  - it is split into four quadrants (integer halves: the left/top half gets
//    floor(side / 2), the other half the rest, so any size works) when its
//    stddev >= max_block_stddev and both halves would still be at least
//    min_block_px on each side;
//  - otherwise it is a leaf: rejected as dark when mean < min_block_mean;
//    else rejected as variable when stddev > max_roi_stddev (only possible for
//    a block that reached the minimum size, since max_roi_stddev >=
//    max_block_stddev); else it is an ROI.
//  - a whole image smaller than min_block_px on a side is rejected as small.
// Every block's mean and stddev cost O(1) from integral images of the values
// and their squares (CV_64F: exact for sums up to 2^53, i.e. any 8-bit image
// and 16-bit images up to about 2 megapixels; larger ones round at 1e-16
// relative). Memory: two (W+1) x (H+1) double images and a stack of at most
// 3 * depth + 1 blocks. Deterministic, single-threaded.
// An empty image gives zero ROIs and zero counts; an all-black one zero ROIs
// and one dark rejection (the whole image).
// Throws InputError for another image type ("RunQuadtree: image type CV_32FC1
// is not supported: expected CV_8UC1 or CV_16UC1"), min_block_px < 1, or
// invalid options.
QuadtreeResult RunQuadtree(const cv::Mat& image, int min_block_px, const QuadtreeOptions& options);

// ROIs given by the caller instead of the quadtree's (a test target, a
// surveyed site): ids 1..N in the order given, each box's mean and stddev as
// RunQuadtree computes them; blocks_visited = N, min_block_px = the smallest
// side, nothing rejected. Throws InputError naming the box (1-based) when it
// is empty or not inside the image, or for an image type RunQuadtree refuses.
QuadtreeResult GivenRois(const cv::Mat& image, const std::vector<cv::Rect>& boxes_px);

// Mean and population standard deviation (8-bit levels) of `box_px` in an
// image, from its integral images (cv::integral(image, sum, sqsum, CV_64F,
// CV_64F)); `scale` is 1 for 8-bit images and 1/257 for 16-bit ones. The box
// must be non-empty and inside the image. Exposed for tests.
struct BlockStats {
  double mean_dn = 0;
  double stddev_dn = 0;
};
BlockStats BlockStatsFromIntegral(const cv::Mat& sum, const cv::Mat& sqsum, const cv::Rect& box_px,
                                  double scale);

}  // namespace hdabench::hda
