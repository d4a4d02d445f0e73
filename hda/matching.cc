#include "hda/matching.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstddef>
#include <cstring>
#include <limits>
#include <optional>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "tools/util/error.h"
#include "tools/util/options_check.h"

namespace hdabench::hda {

namespace {

// Pixels added to the ORB crop beyond ORB's edge threshold: cvRound of the
// level sizes and the mask's resampling at the box edge.
constexpr int kOrbExtraPadPx = 2;
// ORB descriptors: 256 bits.
constexpr int kOrbDescriptorBytes = 32;
// Half-width of the Gaussian blur (7 x 7) cv::ORB applies before it samples
// its pattern.
constexpr int kOrbBlurHalfWidthPx = 3;
constexpr size_t kOrbDescriptorWords = 4;
// Largest ORB patch and LK window accepted, pixels (a sanity bound).
constexpr int kMaxWindowPx = 255;
// The essential matrix needs five correspondences.
constexpr int kMinRansacPoints = 5;
// Pyramid levels of the sub-pixel refinement above the full resolution: the
// ORB match is already within about a pixel, one level is plenty.
constexpr int kRefineMaxLevel = 1;
constexpr int kRefineMaxIterations = 30;
constexpr double kRefineEpsilonPx = 0.001;
// The nav-aided refinement: at most this many Gauss-Newton steps, converged
// when a step moves the point less than kWarpEpsilonPx. The steps shrink about
// tenfold each, so what is left after the last is about 1e-3 px. A limit of
// 1e-3 px took the 1024 x 1024 benchmark pair from 90.0 to 97.2 ms and
// changed no slope on novac-lateral seeds 1-5 by more than 0.03 deg.
constexpr int kWarpMaxIterations = 20;
constexpr double kWarpEpsilonPx = 1e-2;
// Step in normalised image coordinates for the local focal length (central
// differences: the error is O(step^2)).
constexpr double kFocalStep = 1e-4;
// A pre-warped search box may be at most this many times the area of the box
// it resamples (a motion that compresses image 2 by more than 4 in each
// direction is not a change of view the pre-warp can undo).
constexpr double kMaxPrewarpGrowth = 16.0;

void ThrowIfInvalid(const std::vector<std::string>& errors) {
  hdabench::ThrowIfInvalid("MatchRoiPair: invalid MatchingOptions: ", errors);
}

// Throws InputError unless `image` is CV_8UC1: "<what> type ... is not supported".
void RequireEightBit(const cv::Mat& image, const std::string& what) {
  if (image.type() != CV_8UC1) {
    throw InputError(what + " type " + cv::typeToString(image.type()) + " is not supported: expected CV_8UC1");
  }
}

void CheckImage(const cv::Mat& image, const char* name, const calib::CameraModel& camera) {
  RequireEightBit(image, std::string("MatchRoiPair: ") + name);
  if (image.cols != camera.WidthPx() || image.rows != camera.HeightPx()) {
    throw InputError(std::string("MatchRoiPair: ") + name + " size " + std::to_string(image.cols) +
                     "x" + std::to_string(image.rows) + " differs from the camera's imager " +
                     std::to_string(camera.WidthPx()) + "x" + std::to_string(camera.HeightPx()));
  }
}

cv::Rect Padded(const cv::Rect& box, int pad, const cv::Size& image_size) {
  return cv::Rect(box.x - pad, box.y - pad, box.width + 2 * pad, box.height + 2 * pad) &
         cv::Rect(cv::Point(0, 0), image_size);
}

// ORB's keypoints in one box, found without running FAST over the whole
// padded crop. cv::ORB would detect on every pixel of each pyramid level of
// the crop and only then drop what lies outside the mask: for a 32 px box in
// its 98 px crop that is 90 % of FAST's work thrown away. Here each level of
// the crop is built as cv::ORB builds it (cv::resize INTER_LINEAR_EXACT from
// the level above; the mask the same way, then kept where it is 255), FAST
// runs on the mask's extent plus the 4 pixels its circle and its non-maximum
// suppression look at, and the steps after it are cv::ORB's, in its order:
// the keypoints inside the mask and at least the edge threshold from the
// level's border, the 2n best by FAST score, the Harris response (7 x 7
// block, k = 0.04), the n best by Harris, the intensity-centroid angle, the
// level's scale. The descriptors are then cv::ORB's own, computed for these
// keypoints on these levels (Describe). Result: the keypoints and descriptors
// cv::ORB gives for the crop and mask, at a fraction of the cost (the test
// hda.DetectOrbInBox compares the two on every field and byte).
class OrbInBox {
 public:
  // `box_in_crop` empty: no mask (cv::ORB given none), the whole crop.
  OrbInBox(const cv::Mat& crop, const cv::Rect& box_in_crop, int levels, const MatchingOptions& options,
           int max_features)
      : options_(options), levels_(levels), max_features_(max_features) {
    // cv::ORB keeps its scale factor as a double made from a float.
    const double scale_factor = static_cast<double>(static_cast<float>(options.orb_scale_factor));
    BuildPyramid(crop, box_in_crop, scale_factor);
    FeaturesPerLevel(scale_factor);
    CircleRows();
  }

  // Pixels of every level of the pyramid (the work unit of ORB's levels).
  std::int64_t PyramidPixels() const {
    std::int64_t pixels = 0;
    for (int level = 0; level < levels_; ++level) pixels += static_cast<std::int64_t>(Level(level).total());
    return pixels;
  }

  std::vector<cv::KeyPoint> Detect() const {
    std::vector<cv::KeyPoint> all;
    std::vector<size_t> counts(static_cast<size_t>(levels_));
    for (int level = 0; level < levels_; ++level) {
      std::vector<cv::KeyPoint> keypoints = LevelCorners(level);
      for (cv::KeyPoint& keypoint : keypoints) keypoint.response = HarrisResponse(Level(level), keypoint.pt);
      counts[static_cast<size_t>(level)] = keypoints.size();
      all.insert(all.end(), keypoints.begin(), keypoints.end());
    }
    std::vector<cv::KeyPoint> kept;
    size_t offset = 0;
    for (int level = 0; level < levels_; ++level) {
      const size_t count = counts[static_cast<size_t>(level)];
      std::vector<cv::KeyPoint> keypoints(all.begin() + static_cast<std::ptrdiff_t>(offset),
                                          all.begin() + static_cast<std::ptrdiff_t>(offset + count));
      offset += count;
      cv::KeyPointsFilter::retainBest(keypoints, features_[static_cast<size_t>(level)]);
      kept.insert(kept.end(), keypoints.begin(), keypoints.end());
    }
    for (cv::KeyPoint& keypoint : kept) {
      keypoint.angle = CentroidAngle(images_[static_cast<size_t>(keypoint.octave)], keypoint.pt);
    }
    return kept;
  }

  // cv::ORB's descriptors of Detect()'s keypoints (in their level's pixels,
  // grouped by level), one row each, in their order; then the keypoints put
  // into the crop's pixels, as cv::ORB gives them. cv::ORB given the whole
  // crop would build its own pyramid of it again and blur every level whole.
  // The levels here are its levels, so each level's keypoints go to a
  // one-level cv::ORB with only the part of the level their descriptors
  // read: the keypoints' extent and the reach of the sampling pattern and of
  // the 7 x 7 blur before it. Every pixel a descriptor compares is then the
  // same blurred value, and so is every bit.
  cv::Mat Describe(std::vector<cv::KeyPoint>* keypoints) const {
    const int patch = options_.orb_patch_size_px;
    // cv::ORB's sampling reach (ceil(patch / 2 * sqrt 2)) and its blur's half-width.
    const int reach = static_cast<int>(std::ceil((patch / 2) * std::sqrt(2.0))) + kOrbBlurHalfWidthPx;
    // A part ends `reach` beyond the keypoints, or at its level's border,
    // which is at least the patch size away: cv::ORB keeps keypoints that far
    // inside what it is given. Beyond the part cv::ORB reads the level's own
    // pixels (a view, not isolated) and beyond the level it reflects, as it
    // does for the whole crop.
    const int inside = std::min(reach, patch);
    cv::Ptr<cv::ORB> orb = cv::ORB::create(
        static_cast<int>(keypoints->size()), static_cast<float>(options_.orb_scale_factor), /*nlevels=*/1,
        /*edgeThreshold=*/inside, /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE, patch,
        options_.orb_fast_threshold);
    cv::Mat descriptors(static_cast<int>(keypoints->size()), kOrbDescriptorBytes, CV_8UC1);
    size_t begin = 0;
    while (begin < keypoints->size()) {
      const int level = (*keypoints)[begin].octave;
      size_t end = begin;
      cv::Rect extent;
      std::vector<cv::KeyPoint> in_part;
      for (; end < keypoints->size() && (*keypoints)[end].octave == level; ++end) {
        const cv::Point at(cvRound((*keypoints)[end].pt.x), cvRound((*keypoints)[end].pt.y));
        extent |= cv::Rect(at, cv::Size(1, 1));
      }
      const cv::Rect part =
          cv::Rect(extent.x - reach, extent.y - reach, extent.width + 2 * reach, extent.height + 2 * reach) &
          cv::Rect(0, 0, Level(level).cols, Level(level).rows);
      for (size_t i = begin; i < end; ++i) {
        cv::KeyPoint keypoint = (*keypoints)[i];
        keypoint.pt -= cv::Point2f(static_cast<float>(part.x), static_cast<float>(part.y));
        keypoint.octave = 0;
        in_part.push_back(keypoint);
      }
      cv::Mat part_descriptors;
      orb->detectAndCompute(Level(level)(part), cv::noArray(), in_part, part_descriptors,
                            /*useProvidedKeypoints=*/true);
      // cv::ORB keeps every keypoint given: each lies `inside` within the part.
      CV_Assert(in_part.size() == end - begin && part_descriptors.rows == static_cast<int>(end - begin));
      part_descriptors.copyTo(descriptors.rowRange(static_cast<int>(begin), static_cast<int>(end)));
      begin = end;
    }
    for (cv::KeyPoint& keypoint : *keypoints) keypoint.pt *= scales_[static_cast<size_t>(keypoint.octave)];
    return descriptors;
  }

  // How many keypoints Detect() would give, without the angles, and with the
  // Harris responses only on a level where the cut by them can bind.
  size_t Count() const {
    size_t total = 0;
    for (int level = 0; level < levels_; ++level) {
      std::vector<cv::KeyPoint> keypoints = LevelCorners(level);
      const int keep = features_[static_cast<size_t>(level)];  // >= 0
      if (keypoints.size() > static_cast<size_t>(keep)) {
        for (cv::KeyPoint& keypoint : keypoints) keypoint.response = HarrisResponse(Level(level), keypoint.pt);
        cv::KeyPointsFilter::retainBest(keypoints, keep);
      }
      total += keypoints.size();
    }
    return total;
  }

 private:
  const cv::Mat& Level(int level) const { return images_[static_cast<size_t>(level)]; }

  // A level's FAST corners inside the mask and at least the edge threshold
  // from the level's border, the 2n best by FAST score, with their level and
  // size: cv::ORB's keypoints of the level before the Harris responses.
  std::vector<cv::KeyPoint> LevelCorners(int level) const {
    const int patch = options_.orb_patch_size_px;
    const cv::Mat& image = Level(level);
    const cv::Rect whole(0, 0, image.cols, image.rows);
    // Where a keypoint can be: inside the mask's extent (when there is a
    // mask) and the edge threshold from the border.
    cv::Rect extent(patch, patch, image.cols - 2 * patch, image.rows - 2 * patch);
    if (masked_) extent &= mask_boxes_[static_cast<size_t>(level)];
    std::vector<cv::KeyPoint> keypoints;
    if (extent.width > 0 && extent.height > 0) {
      // FAST tests pixels 3 or more from the edge of what it is given and
      // compares each corner's score with its 8 neighbours': 4 pixels of
      // margin give every pixel of the extent the answer the whole level
      // would give it.
      constexpr int kFastMarginPx = 4;
      const cv::Rect searched = cv::Rect(extent.x - kFastMarginPx, extent.y - kFastMarginPx,
                                         extent.width + 2 * kFastMarginPx, extent.height + 2 * kFastMarginPx) &
                                whole;
      cv::FAST(image(searched), keypoints, options_.orb_fast_threshold, /*nonmaxSuppression=*/true);
      const cv::Point2f shift(static_cast<float>(searched.x), static_cast<float>(searched.y));
      for (cv::KeyPoint& keypoint : keypoints) keypoint.pt += shift;
      // FAST's corners lie on whole pixels: inside the mask is inside its box.
      if (masked_) {
        const cv::Rect& box = mask_boxes_[static_cast<size_t>(level)];
        keypoints.erase(std::remove_if(keypoints.begin(), keypoints.end(),
                                       [&box](const cv::KeyPoint& k) {
                                         return !box.contains(cv::Point(cvRound(k.pt.x), cvRound(k.pt.y)));
                                       }),
                        keypoints.end());
      }
    }
    cv::KeyPointsFilter::runByImageBorder(keypoints, image.size(), patch);
    cv::KeyPointsFilter::retainBest(keypoints, 2 * features_[static_cast<size_t>(level)]);
    for (cv::KeyPoint& keypoint : keypoints) {
      keypoint.octave = level;
      keypoint.size = static_cast<float>(patch) * scales_[static_cast<size_t>(level)];
    }
    return keypoints;
  }

  void BuildPyramid(const cv::Mat& crop, const cv::Rect& box_in_crop, double scale_factor) {
    masked_ = !box_in_crop.empty();
    images_.resize(static_cast<size_t>(levels_));
    scales_.resize(static_cast<size_t>(levels_));
    mask_boxes_.assign(static_cast<size_t>(levels_), cv::Rect());
    images_[0] = crop;
    scales_[0] = 1.0f;
    // The mask, level by level. cv::ORB resizes a mask image with the crop
    // and keeps the pixels still at 255. A box stays a box: a pixel is 255
    // only when every pixel its interpolation weighs is, and the weights
    // along x depend on x alone, along y on y alone. So the box's columns
    // and its rows are resized apart, as one-row images, the same way; the
    // level's mask is the box of the columns and rows still at 255.
    cv::Mat columns, rows;
    if (masked_) {
      mask_boxes_[0] = box_in_crop;
      columns = cv::Mat::zeros(1, crop.cols, CV_8UC1);
      columns.colRange(box_in_crop.x, box_in_crop.x + box_in_crop.width).setTo(255);
      rows = cv::Mat::zeros(1, crop.rows, CV_8UC1);
      rows.colRange(box_in_crop.y, box_in_crop.y + box_in_crop.height).setTo(255);
    }
    for (size_t level = 1; level < images_.size(); ++level) {
      const float scale = static_cast<float>(std::pow(scale_factor, static_cast<double>(level)));
      scales_[level] = scale;
      // The level's size as cv::ORB takes it: the side times the float
      // reciprocal of the scale, rounded half to even. (A division would
      // differ where the quotient lies within a float step of a half:
      // 117 rows at 1.2 give 97.5 and 98 rows, not 97.49999 and 97.)
      const float inverse = 1.0f / scale;
      const cv::Size size(cvRound(static_cast<float>(crop.cols) * inverse),
                          cvRound(static_cast<float>(crop.rows) * inverse));
      cv::resize(images_[level - 1], images_[level], size, 0, 0, cv::INTER_LINEAR_EXACT);
      if (!masked_) continue;
      const cv::Range x = ResizedMaskRun(&columns, size.width);
      const cv::Range y = ResizedMaskRun(&rows, size.height);
      if (!x.empty() && !y.empty()) mask_boxes_[level] = cv::Rect(x.start, y.start, x.size(), y.size());
    }
  }

  // `line` (one row, 0 or 255) resized to `length` as cv::ORB resizes its
  // mask, then kept where it is 255; the run of 255s (empty if none).
  static cv::Range ResizedMaskRun(cv::Mat* line, int length) {
    cv::Mat resized;
    cv::resize(*line, resized, cv::Size(length, 1), 0, 0, cv::INTER_LINEAR_EXACT);
    cv::threshold(resized, *line, 254, 0, cv::THRESH_TOZERO);
    const std::uint8_t* values = line->ptr<std::uint8_t>(0);
    const std::uint8_t* first = std::find(values, values + length, 255);
    const std::uint8_t* end = first;
    while (end != values + length && *end == 255) ++end;
    return cv::Range(static_cast<int>(first - values), static_cast<int>(end - values));
  }

  // max_features shared over the levels in a geometric series, as
  // cv::ORB shares it (in float).
  void FeaturesPerLevel(double scale_factor) {
    const float factor = static_cast<float>(1.0 / scale_factor);
    float per_level = static_cast<float>(max_features_) * (1.0f - factor) /
                      (1.0f - static_cast<float>(std::pow(static_cast<double>(factor), static_cast<double>(levels_))));
    features_.assign(static_cast<size_t>(levels_), 0);
    int sum = 0;
    for (int level = 0; level + 1 < levels_; ++level) {
      features_[static_cast<size_t>(level)] = cvRound(per_level);
      sum += features_[static_cast<size_t>(level)];
      per_level *= factor;
    }
    features_[static_cast<size_t>(levels_ - 1)] = std::max(max_features_ - sum, 0);
  }

  // Half-width of each row of the circular patch the angle is measured on,
  // made symmetric between rows and columns.
  void CircleRows() {
    const int half = options_.orb_patch_size_px / 2;
    half_rows_.assign(static_cast<size_t>(half + 2), 0);
    const float diagonal = static_cast<float>(half) * std::sqrt(2.0f) / 2.0f;
    const int v_max = cvFloor(diagonal + 1.0f);
    const int v_min = cvCeil(diagonal);
    for (int v = 0; v <= v_max; ++v) {
      half_rows_[static_cast<size_t>(v)] =
          cvRound(std::sqrt(static_cast<double>(half) * half - static_cast<double>(v) * v));
    }
    int column = 0;
    for (int v = half; v >= v_min; --v) {
      while (half_rows_[static_cast<size_t>(column)] == half_rows_[static_cast<size_t>(column) + 1]) ++column;
      half_rows_[static_cast<size_t>(v)] = column;
      ++column;
    }
  }

  // Harris corner measure over the 7 x 7 block around `at` (Sobel
  // gradients, k = 0.04), in cv::ORB's scaling and float arithmetic.
  static float HarrisResponse(const cv::Mat& image, const cv::Point2f& at) {
    constexpr int kBlock = 7;
    constexpr int kHalf = kBlock / 2;
    constexpr float kHarrisK = 0.04f;
    const float scale = 1.0f / ((1 << 2) * kBlock * 255.0f);
    const float scale4 = scale * scale * scale * scale;
    const int x0 = cvRound(at.x), y0 = cvRound(at.y);
    const int step = static_cast<int>(image.step[0]);
    int sxx = 0, syy = 0, sxy = 0;
    for (int dy = -kHalf; dy <= kHalf; ++dy) {
      const std::uint8_t* p = image.ptr<std::uint8_t>(y0 + dy) + x0;
      for (int dx = -kHalf; dx <= kHalf; ++dx) {
        const std::uint8_t* q = p + dx;
        const int gx = (q[1] - q[-1]) * 2 + (q[-step + 1] - q[-step - 1]) + (q[step + 1] - q[step - 1]);
        const int gy = (q[step] - q[-step]) * 2 + (q[step - 1] - q[-step - 1]) + (q[step + 1] - q[-step + 1]);
        sxx += gx * gx;
        syy += gy * gy;
        sxy += gx * gy;
      }
    }
    const float a = static_cast<float>(sxx), b = static_cast<float>(syy), c = static_cast<float>(sxy);
    return (a * b - c * c - kHarrisK * (a + b) * (a + b)) * scale4;
  }

  // Orientation of the intensity centroid over the circular patch, degrees
  // (cv::fastAtan2, as cv::ORB).
  float CentroidAngle(const cv::Mat& image, const cv::Point2f& at) const {
    const int half = options_.orb_patch_size_px / 2;
    const std::uint8_t* centre = image.ptr<std::uint8_t>(cvRound(at.y)) + cvRound(at.x);
    const int step = static_cast<int>(image.step[0]);
    int m01 = 0, m10 = 0;
    for (int u = -half; u <= half; ++u) m10 += u * centre[u];
    for (int v = 1; v <= half; ++v) {
      int row_sum = 0;
      const int width = half_rows_[static_cast<size_t>(v)];
      for (int u = -width; u <= width; ++u) {
        const int below = centre[u + v * step], above = centre[u - v * step];
        row_sum += below - above;
        m10 += u * (below + above);
      }
      m01 += v * row_sum;
    }
    return cv::fastAtan2(static_cast<float>(m01), static_cast<float>(m10));
  }

  const MatchingOptions& options_;
  int levels_;
  int max_features_;
  bool masked_ = false;
  std::vector<cv::Mat> images_;
  std::vector<cv::Rect> mask_boxes_;  // per level, when masked_: the keypoints' allowed box
  std::vector<float> scales_;
  std::vector<int> features_;
  std::vector<int> half_rows_;
};

// DetectOrbInBox for valid options, a CV_8UC1 image and a non-empty box
// inside it.
OrbFeatures DetectInBox(const cv::Mat& image, const cv::Rect& box, const MatchingOptions& options) {
  OrbFeatures features;
  // ORB drops keypoints closer than its edge threshold (the patch size) to the
  // border of each pyramid level: padding the box by the patch keeps every
  // full-resolution keypoint up to the box edge. At level l the threshold is
  // patch * scale^l pixels of the full image, so coarse-level keypoints within
  // patch * (scale^l - 1) of the box edge are lost (12 px at level 2 with the
  // defaults): padding for them too would cost more ORB time for 7 % more
  // keypoints. The padding comes from the image itself where there is image.
  const int patch = options.orb_patch_size_px;
  const int pad = patch + kOrbExtraPadPx;
  const cv::Rect crop = Padded(box, pad, image.size());
  // Levels too small for any keypoint to survive the edge threshold (small
  // boxes, crops clipped by the image border) are not built: they would only
  // cost time, and a level of zero pixels would make ORB fail. Their share of
  // orb_features_per_roi goes to the other levels.
  int levels = 0;
  const int min_side = std::min(crop.width, crop.height);
  while (levels < options.orb_levels &&
         cvRound(min_side / std::pow(options.orb_scale_factor, levels)) > 2 * patch) {
    ++levels;
  }
  if (levels == 0) return features;

  const OrbInBox orb(image(crop), box - crop.tl(), levels, options, options.orb_features_per_roi);
  features.pyramid_pixels = orb.PyramidPixels();
  features.keypoints = orb.Detect();
  if (features.keypoints.empty()) return features;
  features.descriptors = orb.Describe(&features.keypoints);
  const cv::Point2f offset(static_cast<float>(crop.x), static_cast<float>(crop.y));
  for (cv::KeyPoint& keypoint : features.keypoints) keypoint.pt += offset;
  return features;
}

// Bits set in each byte of x (SWAR: no dependence on a popcount instruction,
// which x86-64's baseline lacks).
inline std::uint64_t ByteBitCounts(std::uint64_t x) {
  x = x - ((x >> 1) & 0x5555555555555555ULL);
  x = (x & 0x3333333333333333ULL) + ((x >> 2) & 0x3333333333333333ULL);
  return (x + (x >> 4)) & 0x0f0f0f0f0f0f0f0fULL;
}

// Hamming distance of two 256-bit ORB descriptors.
inline int HammingDistance(const std::uint64_t* a, const std::uint64_t* b) {
  // Each byte of the sum counts at most 32 bits: no carry between bytes.
  const std::uint64_t counts = ByteBitCounts(a[0] ^ b[0]) + ByteBitCounts(a[1] ^ b[1]) +
                               ByteBitCounts(a[2] ^ b[2]) + ByteBitCounts(a[3] ^ b[3]);
  return static_cast<int>((counts * 0x0101010101010101ULL) >> 56);
}

// Index pairs (image 1, image 2) passing the ratio test and, if asked, the
// cross-check, in image-1 keypoint order. Brute force in one pass over all
// pairs: the best two image-2 descriptors of each image-1 descriptor and the
// best image-1 descriptor of each image-2 one, ties going to the lower index.
// The same matches as cv::BFMatcher(NORM_HAMMING) knnMatch(k = 2) and match()
// the other way, at a quarter of the cost (one pass instead of two, no call
// per pair).
// Nav-guided matching's candidates: pair (i, j) is allowed when keypoint j of
// image 2 lies within `radius_px` of keypoint i's expected position.
struct MatchGuide {
  std::vector<cv::Point2d> expected;       // per image-1 keypoint
  std::vector<unsigned char> valid;        // 0: no expectation, no candidate
  std::vector<cv::Point2d> positions2;     // image-2 keypoints
  double radius_px = 0.0;
  bool Allows(size_t i, size_t j) const {
    if (!valid[i]) return false;
    const cv::Point2d d = positions2[j] - expected[i];
    return d.dot(d) <= radius_px * radius_px;
  }
};

std::vector<cv::DMatch> MatchDescriptors(const cv::Mat& descriptors1, const cv::Mat& descriptors2,
                                         const MatchingOptions& options,
                                         const MatchGuide* guide = nullptr) {
  std::vector<cv::DMatch> kept;
  if (descriptors1.empty() || descriptors2.empty()) return kept;
  CV_Assert(descriptors1.type() == CV_8UC1 && descriptors1.cols == kOrbDescriptorBytes &&
            descriptors2.type() == CV_8UC1 && descriptors2.cols == kOrbDescriptorBytes);
  const auto words = [](const cv::Mat& descriptors) {
    std::vector<std::uint64_t> packed(static_cast<size_t>(descriptors.rows) * kOrbDescriptorWords);
    for (int r = 0; r < descriptors.rows; ++r) {
      std::memcpy(&packed[static_cast<size_t>(r) * kOrbDescriptorWords], descriptors.ptr(r),
                  kOrbDescriptorBytes);
    }
    return packed;
  };
  const std::vector<std::uint64_t> words1 = words(descriptors1), words2 = words(descriptors2);
  const size_t count1 = static_cast<size_t>(descriptors1.rows);
  const size_t count2 = static_cast<size_t>(descriptors2.rows);
  constexpr int kNone = std::numeric_limits<int>::max();
  std::vector<int> best_for2(count2, kNone), best_index_for2(count2, -1);
  struct Candidates {
    int best = kNone, second = kNone, index = -1;
  };
  std::vector<Candidates> candidates(count1);
  for (size_t i = 0; i < count1; ++i) {
    const std::uint64_t* a = &words1[i * kOrbDescriptorWords];
    Candidates& c = candidates[i];
    for (size_t j = 0; j < count2; ++j) {
      if (guide != nullptr && !guide->Allows(i, j)) continue;
      const int d = HammingDistance(a, &words2[j * kOrbDescriptorWords]);
      if (d < c.second) {
        if (d < c.best) {
          c.second = c.best;
          c.best = d;
          c.index = static_cast<int>(j);
        } else {
          c.second = d;
        }
      }
      if (d < best_for2[j]) {
        best_for2[j] = d;
        best_index_for2[j] = static_cast<int>(i);
      }
    }
  }
  for (size_t i = 0; i < count1; ++i) {
    const Candidates& c = candidates[i];
    if (c.index < 0) continue;  // no candidate (nav-guided matching)
    // Only one candidate in image 2 (second == kNone): nothing to be ambiguous with.
    if (c.second != kNone && !(c.best < options.ratio_test * c.second)) continue;
    if (options.cross_check &&
        best_index_for2[static_cast<size_t>(c.index)] != static_cast<int>(i)) {
      continue;
    }
    kept.emplace_back(static_cast<int>(i), c.index, static_cast<float>(c.best));
  }
  return kept;
}

// RANSAC's work: the hypotheses OpenCV's adaptive count draws for this
// outcome, each tested on every point.
void CountRansacWork(int points, int inliers, const MatchingOptions& options, WorkCounts* work) {
  const std::int64_t hypotheses =
      RansacHypotheses(points, inliers, options.ransac_confidence, options.ransac_max_iterations);
  (*work)[WorkUnit::kRansacHypotheses] = hypotheses;
  (*work)[WorkUnit::kRansacTests] = hypotheses * points;
}

// A window of `size` inside an image of `image_size` that contains `crop`
// (itself inside the image and no larger than `size`).
cv::Rect Enlarged(const cv::Rect& crop, const cv::Size& size, const cv::Size& image_size) {
  return cv::Rect(std::min(crop.x, image_size.width - size.width),
                  std::min(crop.y, image_size.height - size.height), size.width, size.height);
}

// Each byte value as a double (exact), for WarpRefine's interpolation.
const std::array<double, 256> kByteValues = [] {
  std::array<double, 256> values{};
  for (size_t i = 0; i < values.size(); ++i) values[i] = static_cast<double>(i);
  return values;
}();

// WarpRefine's per-pixel arrays: the template value and the Jacobian row
// (d/dx2, d/dy2; d/d offset is -1). One per box, reused by its matches: every
// element is written before it is read, so a match neither allocates nor
// clears them.
struct WarpWindow {
  std::vector<double> templ, jx, jy;
};

// Nav-aided refinement of one match at full resolution. The image-1 window
// of window_px x window_px pixels centred on the whole pixel p1 is compared
// with image 2 at p2 + J u (u the pixel's offset in the window, J the local
// motion expected from navigation, bilinear interpolation); p2 and a
// brightness offset are solved by Gauss-Newton on the summed squared
// differences, with the image-1 gradients (central differences) mapped
// through J^-T as the Jacobian, so the normal matrix is built once. False
// when a window leaves its image, the window has no texture, or the
// iteration does not converge.
bool WarpRefine(const cv::Mat& image1, const cv::Mat& image2, const cv::Matx22d& jacobian,
                int window_px, const cv::Point& p1, WarpWindow* window, cv::Point2d* p2,
                std::int64_t* pixels_read) {
  const int half = window_px / 2;
  if (p1.x - half < 1 || p1.y - half < 1 || p1.x + half + 1 >= image1.cols ||
      p1.y + half + 1 >= image1.rows) {
    return false;
  }
  const cv::Matx22d to_image2 = jacobian.inv().t();
  const size_t count = static_cast<size_t>(window_px) * static_cast<size_t>(window_px);
  *pixels_read += static_cast<std::int64_t>(count);
  window->templ.resize(count);
  window->jx.resize(count);
  window->jy.resize(count);
  double* const templ = window->templ.data();
  double* const jx = window->jx.data();
  double* const jy = window->jy.data();
  double sxx = 0, sxy = 0, syy = 0, sx = 0, sy = 0;
  size_t k = 0;
  for (int v = -half; v <= half; ++v) {
    const std::uint8_t* above = image1.ptr<std::uint8_t>(p1.y + v - 1);
    const std::uint8_t* row = image1.ptr<std::uint8_t>(p1.y + v);
    const std::uint8_t* below = image1.ptr<std::uint8_t>(p1.y + v + 1);
    for (int u = -half; u <= half; ++u, ++k) {
      const int x = p1.x + u;
      templ[k] = row[x];
      const double gx = 0.5 * (row[x + 1] - row[x - 1]), gy = 0.5 * (below[x] - above[x]);
      jx[k] = to_image2(0, 0) * gx + to_image2(0, 1) * gy;
      jy[k] = to_image2(1, 0) * gx + to_image2(1, 1) * gy;
      sxx += jx[k] * jx[k];
      sxy += jx[k] * jy[k];
      syy += jy[k] * jy[k];
      sx += jx[k];
      sy += jy[k];
    }
  }
  const double n = static_cast<double>(count);
  const cv::Matx33d normal(sxx, sxy, -sx, sxy, syy, -sy, -sx, -sy, n);
  cv::Matx33d inverse;
  if (cv::invert(normal, inverse, cv::DECOMP_CHOLESKY) == 0.0) return false;
  const std::uint8_t* data = image2.ptr<std::uint8_t>(0);
  const size_t step = image2.step[0];
  cv::Point2d p = *p2;
  double offset = 0.0;
  for (int iteration = 0; iteration < kWarpMaxIterations; ++iteration) {
    // The warped window must keep its 2 x 2 stencils inside image 2: check
    // its four corners (the window is a parallelogram), with 1e-3 px to spare
    // for the rounding of the steps along its rows.
    for (const int v : {-half, half}) {
      for (const int u : {-half, half}) {
        const double x = p.x + jacobian(0, 0) * u + jacobian(0, 1) * v;
        const double y = p.y + jacobian(1, 0) * u + jacobian(1, 1) * v;
        if (!(x >= 0.0 && y >= 0.0 && x < image2.cols - 1.001 && y < image2.rows - 1.001)) return false;
      }
    }
    *pixels_read += static_cast<std::int64_t>(count);
    double rx = 0.0, ry = 0.0, r1 = 0.0;
    k = 0;
    const double step_x = jacobian(0, 0), step_y = jacobian(1, 0);
    for (int v = -half; v <= half; ++v) {
      double x = p.x - step_x * half + jacobian(0, 1) * v;
      double y = p.y - step_y * half + jacobian(1, 1) * v;
      for (int u = -half; u <= half; ++u, ++k, x += step_x, y += step_y) {
        const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);  // x, y >= 0: truncation = floor
        const double ax = x - x0, ay = y - y0;
        const std::uint8_t* top = data + static_cast<size_t>(y0) * step + x0;
        const std::uint8_t* bottom = top + step;
        // The four values from the table rather than four conversions: the
        // same doubles (and differences), in fewer cycles.
        const double t0 = kByteValues[top[0]], t1 = kByteValues[top[1]];
        const double b0 = kByteValues[bottom[0]], b1 = kByteValues[bottom[1]];
        const double value = (1.0 - ay) * (t0 + ax * (t1 - t0)) + ay * (b0 + ax * (b1 - b0));
        const double residual = value - templ[k] - offset;
        rx += residual * jx[k];
        ry += residual * jy[k];
        r1 -= residual;
      }
    }
    const cv::Vec3d rhs(rx, ry, r1);
    const cv::Vec3d delta = -(inverse * rhs);
    p.x += delta[0];
    p.y += delta[1];
    offset += delta[2];
    if (!(std::isfinite(p.x) && std::isfinite(p.y))) return false;
    if (std::hypot(delta[0], delta[1]) < kWarpEpsilonPx) {
      *p2 = p;
      return true;
    }
  }
  return false;
}

// Image 2's search box resampled through the inverse of the expected motion
// (MatchingOptions::prewarp_min_stretch): pixel q of `image` shows image 2 at
// to_image2 * (q, 1), so that near the ROI it looks as image 1 does. `box` is
// the resampled search box, with room around it for ORB's patch and the
// Lucas-Kanade window.
struct PrewarpedBox {
  cv::Mat image;
  cv::Rect box;
  cv::Matx23d to_image2;
  cv::Matx23d from_image2;

  static cv::Point2d Map(const cv::Matx23d& m, double x, double y) {
    return {m(0, 0) * x + m(0, 1) * y + m(0, 2), m(1, 0) * x + m(1, 1) * y + m(1, 2)};
  }
  cv::Point2d ToImage2(double x, double y) const { return Map(to_image2, x, y); }
  cv::Point2d FromImage2(const cv::Point2d& p) const { return Map(from_image2, p.x, p.y); }
};

// The resampled box, or nothing when the motion cannot be inverted or would
// blow the box up past kMaxPrewarpGrowth times its area.
std::optional<PrewarpedBox> PrewarpBox(const cv::Mat& image2, const cv::Rect& box2, const cv::Matx22d& motion,
                                       const MatchingOptions& options) {
  const double det = cv::determinant(motion);
  if (!(std::isfinite(det) && det > 0.0)) return std::nullopt;
  const cv::Matx22d inverse = motion.inv();
  // The box's pixel-edge corners about its centre, through the inverse motion.
  const cv::Vec2d centre(box2.x + 0.5 * (box2.width - 1), box2.y + 0.5 * (box2.height - 1));
  cv::Vec2d low(HUGE_VAL, HUGE_VAL), high(-HUGE_VAL, -HUGE_VAL);
  for (const double x : {box2.x - 0.5, box2.x + box2.width - 0.5}) {
    for (const double y : {box2.y - 0.5, box2.y + box2.height - 0.5}) {
      const cv::Vec2d q = inverse * (cv::Vec2d(x, y) - centre);
      low = cv::Vec2d(std::min(low[0], q[0]), std::min(low[1], q[1]));
      high = cv::Vec2d(std::max(high[0], q[0]), std::max(high[1], q[1]));
    }
  }
  const double width = std::ceil(high[0] - low[0]), height = std::ceil(high[1] - low[1]);
  if (!(width * height <= kMaxPrewarpGrowth * box2.area()) || width < 1 || height < 1) return std::nullopt;
  const int pad =
      std::max(options.orb_patch_size_px + kOrbExtraPadPx, (options.refine_window_px + 1) << kRefineMaxLevel) + 1;
  PrewarpedBox warped;
  warped.box = cv::Rect(pad, pad, static_cast<int>(width), static_cast<int>(height));
  // q - (pad - 0.5, pad - 0.5) + low = inverse (p - centre): the box's first
  // pixel edge at pad - 0.5.
  const cv::Vec2d shift = centre + motion * (low - cv::Vec2d(pad - 0.5, pad - 0.5));
  warped.to_image2 = cv::Matx23d(motion(0, 0), motion(0, 1), shift[0], motion(1, 0), motion(1, 1), shift[1]);
  const cv::Vec2d back = -(inverse * shift);
  warped.from_image2 =
      cv::Matx23d(inverse(0, 0), inverse(0, 1), back[0], inverse(1, 0), inverse(1, 1), back[1]);
  cv::warpAffine(image2, warped.image, cv::Mat(warped.to_image2),
                 cv::Size(warped.box.width + 2 * pad, warped.box.height + 2 * pad),
                 cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REFLECT_101);
  return warped;
}

// Pyramidal Lucas-Kanade from the image-1 keypoints to image 2, starting at the
// ORB matches. Removes the matches it rejects from points1/points2 and
// refines the others; returns the number rejected.
// With `warped`, Lucas-Kanade tracks into the pre-warped box (where image 2
// looks as image 1 does) and its result is mapped back to image 2 before the
// nav-aided refinement.
int RefineMatches(const cv::Mat& image1, const cv::Mat& image2, const cv::Rect& box1,
                  const cv::Rect& box2, const cv::Matx22d& motion_jacobian,
                  const MatchingOptions& options, const PrewarpedBox* warped,
                  std::vector<cv::Point2d>* points1, std::vector<cv::Point2d>* points2, WorkCounts* work) {
  if (points1->empty()) return 0;
  const cv::Mat& tracked = warped ? warped->image : image2;
  // LK works on equal-sized images: windows around both padded boxes, with
  // room for the LK window at the coarsest level. No copies: views.
  const int pad = (options.refine_window_px + 1) << kRefineMaxLevel;
  const cv::Rect crop1 = Padded(box1, pad, image1.size());
  const cv::Rect crop2 = Padded(warped ? warped->box : box2, pad, tracked.size());
  const cv::Size size(std::max(crop1.width, crop2.width), std::max(crop1.height, crop2.height));
  if (size.width > image1.cols || size.height > image1.rows || size.width > tracked.cols ||
      size.height > tracked.rows) {
    const int rejected = static_cast<int>(points1->size());
    points1->clear();
    points2->clear();
    return rejected;  // a pre-warped box larger than image 1: no common window for LK
  }
  const cv::Rect window1 = Enlarged(crop1, size, image1.size());
  const cv::Rect window2 = Enlarged(crop2, size, tracked.size());

  std::vector<cv::Point2f> previous, next;
  previous.reserve(points1->size());
  next.reserve(points2->size());
  for (size_t i = 0; i < points1->size(); ++i) {
    previous.emplace_back(static_cast<float>((*points1)[i].x - window1.x),
                          static_cast<float>((*points1)[i].y - window1.y));
    const cv::Point2d start = warped ? warped->FromImage2((*points2)[i]) : (*points2)[i];
    next.emplace_back(static_cast<float>(start.x - window2.x), static_cast<float>(start.y - window2.y));
  }
  const std::vector<cv::Point2f> initial = next;
  (*work)[WorkUnit::kTrackedPoints] += static_cast<std::int64_t>(previous.size());
  std::vector<unsigned char> status;
  std::vector<float> error;
  cv::calcOpticalFlowPyrLK(image1(window1), tracked(window2), previous, next, status, error,
                           cv::Size(options.refine_window_px, options.refine_window_px),
                           kRefineMaxLevel,
                           cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                            kRefineMaxIterations, kRefineEpsilonPx),
                           cv::OPTFLOW_USE_INITIAL_FLOW);

  int rejected = 0;
  size_t kept = 0;
  WarpWindow warp_window;
  for (size_t i = 0; i < previous.size(); ++i) {
    const double x = static_cast<double>(next[i].x), y = static_cast<double>(next[i].y);
    const double shift =
        std::hypot(x - static_cast<double>(initial[i].x), y - static_cast<double>(initial[i].y));
    // Inside the window's pixels (edges at -0.5 and size - 0.5).
    const bool inside = x >= -0.5 && y >= -0.5 && x <= size.width - 0.5 && y <= size.height - 0.5;
    if (status[i] == 0 || !(shift <= options.max_refine_shift_px) || !inside) {
      ++rejected;
      continue;
    }
    cv::Point2d point1 = (*points1)[i];
    cv::Point2d refined(x + window2.x, y + window2.y);
    if (warped) refined = warped->ToImage2(refined.x, refined.y);
    if (options.warp_refine) {
      // The window is centred on the nearest whole pixel of image 1; its
      // starting point in image 2 moves with it through the expected motion.
      const cv::Point whole(cvRound(point1.x), cvRound(point1.y));
      const cv::Vec2d moved = motion_jacobian * cv::Vec2d(whole.x - point1.x, whole.y - point1.y);
      refined += cv::Point2d(moved[0], moved[1]);
      const cv::Point2d start = refined;
      if (!WarpRefine(image1, image2, motion_jacobian, options.warp_refine_window_px, whole, &warp_window,
                      &refined, &(*work)[WorkUnit::kRefinePixels]) ||
          !(std::hypot(refined.x - start.x, refined.y - start.y) <= options.max_refine_shift_px)) {
        ++rejected;
        continue;
      }
      point1 = cv::Point2d(whole.x, whole.y);
    }
    (*points1)[kept] = point1;
    (*points2)[kept] = refined;
    ++kept;
  }
  points1->resize(kept);
  points2->resize(kept);
  return rejected;
}

// Normalised image coordinates (x/z, y/z) of pixels; valid[i] is 0 where the
// camera cannot unproject pixel i or its ray is not in front of the camera.
// `bearings` receives the camera model's unit bearings.
std::vector<cv::Point2d> Normalised(const calib::CameraModel& camera,
                                    const std::vector<cv::Point2d>& pixels,
                                    std::vector<unsigned char>* valid,
                                    std::vector<Eigen::Vector3d>* bearings) {
  std::vector<Eigen::Vector2d> pixels_eigen;
  pixels_eigen.reserve(pixels.size());
  for (const cv::Point2d& p : pixels) pixels_eigen.emplace_back(p.x, p.y);
  camera.Unproject(pixels_eigen, bearings, valid);
  std::vector<cv::Point2d> normalised(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) {
    const Eigen::Vector3d& b = (*bearings)[i];
    if ((*valid)[i] == 0 || !(b.z() > 0)) {
      (*valid)[i] = 0;
      continue;
    }
    normalised[i] = cv::Point2d(b.x() / b.z(), b.y() / b.z());
    if (!std::isfinite(normalised[i].x) || !std::isfinite(normalised[i].y)) (*valid)[i] = 0;
  }
  return normalised;
}

// Pixels per unit of normalised image coordinate around `at`: the mean of the
// two directions (as cv::findEssentialMat averages fx and fy). 0 when the
// camera cannot project there.
double LocalFocalPx(const calib::CameraModel& camera, const cv::Point2d& at) {
  const std::vector<Eigen::Vector3d> points = {{at.x - kFocalStep, at.y, 1.0},
                                               {at.x + kFocalStep, at.y, 1.0},
                                               {at.x, at.y - kFocalStep, 1.0},
                                               {at.x, at.y + kFocalStep, 1.0}};
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  if (camera.Project(points, &pixels, &valid) != 4) return 0.0;
  return 0.5 * ((pixels[1] - pixels[0]).norm() + (pixels[3] - pixels[2]).norm()) /
         (2.0 * kFocalStep);
}

}  // namespace

std::vector<std::string> MatchingOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(orb_features_per_roi >= kMinRansacPoints, "orb_features_per_roi",
                orb_features_per_roi, ">= 5 (the essential matrix needs 5 matches)", &errors);
  RequireOption(orb_levels >= 1, "orb_levels", orb_levels, ">= 1", &errors);
  RequireOption(orb_scale_factor > 1 && orb_scale_factor <= 4, "orb_scale_factor", orb_scale_factor,
                "in (1, 4]", &errors);
  RequireOption(orb_fast_threshold >= 1 && orb_fast_threshold <= 255, "orb_fast_threshold",
                orb_fast_threshold, "in [1, 255]", &errors);
  RequireOption(orb_patch_size_px >= 5 && orb_patch_size_px <= kMaxWindowPx, "orb_patch_size_px",
                orb_patch_size_px, "in [5, 255]", &errors);
  RequireOption(ratio_test > 0 && ratio_test <= 1, "ratio_test", ratio_test, "in (0, 1]", &errors);
  RequireOption(guide_radius_px >= 0 && std::isfinite(guide_radius_px), "guide_radius_px", guide_radius_px,
                ">= 0 (0: not guided)", &errors);
  RequireOption(
      refine_window_px >= 5 && refine_window_px <= kMaxWindowPx && refine_window_px % 2 == 1,
      "refine_window_px", refine_window_px, "odd, in [5, 255]", &errors);
  RequireOption(max_refine_shift_px > 0, "max_refine_shift_px", max_refine_shift_px, "> 0",
                &errors);
  RequireOption(warp_refine_window_px >= 5 && warp_refine_window_px <= kMaxWindowPx &&
                    warp_refine_window_px % 2 == 1,
                "warp_refine_window_px", warp_refine_window_px, "odd, in [5, 255]", &errors);
  RequireOption(prewarp_min_stretch == 0 || (prewarp_min_stretch >= 1 && std::isfinite(prewarp_min_stretch)),
                "prewarp_min_stretch", prewarp_min_stretch, ">= 1 (0: never)", &errors);
  RequireOption(ransac_threshold_px > 0, "ransac_threshold_px", ransac_threshold_px, "> 0",
                &errors);
  RequireOption(ransac_confidence > 0 && ransac_confidence < 1, "ransac_confidence",
                ransac_confidence, "in (0, 1)", &errors);
  RequireOption(ransac_max_iterations >= 1, "ransac_max_iterations", ransac_max_iterations, ">= 1",
                &errors);
  return errors;
}

double MotionStretch(const cv::Matx22d& jacobian) {
  for (int k = 0; k < 4; ++k) {
    if (!std::isfinite(jacobian.val[k])) return HUGE_VAL;
  }
  // The singular values of a 2 x 2 matrix: s1^2 + s2^2 = |J|_F^2, s1 s2 = |det J|.
  const double frobenius2 = jacobian.dot(jacobian);
  const double det = std::abs(cv::determinant(jacobian));
  const double gap = std::sqrt(std::max(0.0, frobenius2 * frobenius2 - 4.0 * det * det));
  if (!(det > 0.0)) return HUGE_VAL;
  const double larger = std::sqrt(0.5 * (frobenius2 + gap));  // > 0: larger^2 >= det
  const double smaller = det / larger;
  return std::max(larger, 1.0 / smaller);
}

const char* ToString(MatchingStatus status) {
  switch (status) {
    case MatchingStatus::kOk:
      return "ok";
    case MatchingStatus::kTooFewMatches:
      return "too few matches";
    case MatchingStatus::kRansacFailed:
      return "ransac failed";
  }
  return "unknown";
}

OrbFeatures DetectOrbInBox(const cv::Mat& image, const cv::Rect& box_px, const MatchingOptions& options) {
  ThrowIfInvalid(options.Validate());
  RequireEightBit(image, "DetectOrbInBox: image");
  const cv::Rect box = box_px & cv::Rect(cv::Point(0, 0), image.size());
  if (box.empty()) return OrbFeatures();
  return DetectInBox(image, box, options);
}

size_t CountOrbKeypoints(const cv::Mat& image, const MatchingOptions& options, int max_features) {
  ThrowIfInvalid(options.Validate());
  RequireEightBit(image, "CountOrbKeypoints: image");
  if (max_features < 1) {
    throw InputError("CountOrbKeypoints: max_features = " + std::to_string(max_features) + ": expected >= 1");
  }
  if (image.empty()) return 0;
  return OrbInBox(image, cv::Rect(), options.orb_levels, options, max_features).Count();
}

RoiMatches MatchRoiPair(const cv::Mat& image1, const cv::Mat& image2, const cv::Rect& box1_px,
                        const cv::Rect& box2_px, const calib::CameraModel& camera,
                        const MatchingOptions& options, const cv::Matx22d& motion_jacobian,
                        const ExpectedPositions& expected) {
  ThrowIfInvalid(options.Validate());
  CheckImage(image1, "image1", camera);
  CheckImage(image2, "image2", camera);
  RoiMatches result;
  const cv::Rect box1 = box1_px & cv::Rect(cv::Point(0, 0), image1.size());
  const cv::Rect box2 = box2_px & cv::Rect(cv::Point(0, 0), image2.size());
  if (box1.empty() || box2.empty()) return result;

  const OrbFeatures features1 = DetectInBox(image1, box1, options);
  std::optional<PrewarpedBox> warped;
  if (options.prewarp_min_stretch > 0.0 && MotionStretch(motion_jacobian) >= options.prewarp_min_stretch) {
    warped = PrewarpBox(image2, box2, motion_jacobian, options);
  }
  OrbFeatures features2;
  if (warped) {
    // Detected and described where image 2 looks as image 1 does; positions
    // in image 2.
    features2 = DetectInBox(warped->image, warped->box, options);
    for (cv::KeyPoint& k : features2.keypoints) {
      const cv::Point2d p = warped->ToImage2(k.pt.x, k.pt.y);
      k.pt = cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y));
    }
    result.prewarped = true;
  } else {
    features2 = DetectInBox(image2, box2, options);
  }
  result.keypoints1 = static_cast<int>(features1.keypoints.size());
  result.keypoints2 = static_cast<int>(features2.keypoints.size());
  WorkCounts& work = result.work;
  work[WorkUnit::kOrbPixels] = features1.pyramid_pixels + features2.pyramid_pixels;
  work[WorkUnit::kOrbKeypoints] = result.keypoints1 + result.keypoints2;
  work[WorkUnit::kDescriptorPairs] = static_cast<std::int64_t>(result.keypoints1) * result.keypoints2;
  if (warped) work[WorkUnit::kPrewarpPixels] = static_cast<std::int64_t>(warped->image.total());
  std::optional<MatchGuide> guide;
  if (options.guide_radius_px > 0.0 && expected) {
    guide.emplace();
    std::vector<cv::Point2d> pixels1;
    for (const cv::KeyPoint& k : features1.keypoints) pixels1.emplace_back(k.pt.x, k.pt.y);
    expected(pixels1, &guide->expected, &guide->valid);
    for (const cv::KeyPoint& k : features2.keypoints) guide->positions2.emplace_back(k.pt.x, k.pt.y);
    guide->radius_px = options.guide_radius_px;
  }
  const std::vector<cv::DMatch> matches = MatchDescriptors(
      features1.descriptors, features2.descriptors, options, guide ? &*guide : nullptr);
  result.matches = static_cast<int>(matches.size());

  std::vector<cv::Point2d> points1, points2;
  points1.reserve(matches.size());
  points2.reserve(matches.size());
  for (const cv::DMatch& match : matches) {
    const cv::Point2f& p1 = features1.keypoints[static_cast<size_t>(match.queryIdx)].pt;
    const cv::Point2f& p2 = features2.keypoints[static_cast<size_t>(match.trainIdx)].pt;
    points1.emplace_back(static_cast<double>(p1.x), static_cast<double>(p1.y));
    points2.emplace_back(static_cast<double>(p2.x), static_cast<double>(p2.y));
  }
  if (options.subpixel_refine) {
    result.refine_rejected = RefineMatches(image1, image2, box1, box2, motion_jacobian, options,
                                           warped ? &*warped : nullptr, &points1, &points2, &work);
  }
  if (static_cast<int>(points1.size()) < kMinRansacPoints) return result;  // kTooFewMatches

  // Normalised coordinates of both points: a match with a pixel the camera
  // cannot unproject, or whose ray is not in front of it, takes no part.
  std::vector<unsigned char> valid1, valid2;
  std::vector<Eigen::Vector3d> bearings1, bearings2;
  const std::vector<cv::Point2d> normalised1 = Normalised(camera, points1, &valid1, &bearings1);
  const std::vector<cv::Point2d> normalised2 = Normalised(camera, points2, &valid2, &bearings2);
  work[WorkUnit::kUnprojectedPixels] = 2 * static_cast<std::int64_t>(points1.size());
  if (UnprojectsIteratively(camera.LensModelName())) work[WorkUnit::kIteratedPixels] = work[WorkUnit::kUnprojectedPixels];
  std::vector<size_t> used;
  std::vector<cv::Point2d> ransac1, ransac2;
  cv::Point2d centroid2(0, 0);
  for (size_t i = 0; i < points1.size(); ++i) {
    if (valid1[i] == 0 || valid2[i] == 0) continue;
    used.push_back(i);
    ransac1.push_back(normalised1[i]);
    ransac2.push_back(normalised2[i]);
    centroid2 += normalised2[i];
  }
  if (static_cast<int>(used.size()) < kMinRansacPoints) return result;  // kTooFewMatches

  centroid2 *= 1.0 / static_cast<double>(used.size());
  const double focal_px = LocalFocalPx(camera, centroid2);
  result.status = MatchingStatus::kRansacFailed;
  if (!(focal_px > 0 && std::isfinite(focal_px))) return result;
  cv::Mat inlier_mask;
  const cv::Mat essential = cv::findEssentialMat(
      ransac1, ransac2, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, options.ransac_confidence,
      options.ransac_threshold_px / focal_px, options.ransac_max_iterations, inlier_mask);
  // With exactly five points OpenCV returns every solution of the 5-point
  // solver stacked (3k x 3) and marks all points inliers.
  if (essential.empty() || essential.cols != 3 || essential.rows % 3 != 0 ||
      inlier_mask.total() != used.size()) {
    CountRansacWork(static_cast<int>(used.size()), 0, options, &work);  // no model: every draw was made
    return result;
  }
  result.status = MatchingStatus::kOk;
  for (size_t k = 0; k < used.size(); ++k) {
    if (inlier_mask.at<unsigned char>(static_cast<int>(k)) == 0) continue;
    result.points1_px.push_back(points1[used[k]]);
    result.points2_px.push_back(points2[used[k]]);
    result.bearings1.push_back(bearings1[used[k]]);
    result.bearings2.push_back(bearings2[used[k]]);
  }
  result.ransac_inliers = static_cast<int>(result.points1_px.size());
  CountRansacWork(static_cast<int>(used.size()), result.ransac_inliers, options, &work);
  return result;
}

}  // namespace hdabench::hda
