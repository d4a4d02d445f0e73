#include "hda/quadtree.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>
#include <sstream>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/util/error.h"
#include "tools/util/text.h"
#include "tools/util/options_check.h"

namespace hdabench::hda {

namespace {

void ThrowIfQuadtreeOptionsInvalid(const char* function, const std::vector<std::string>& errors) {
  hdabench::ThrowIfInvalid(std::string(function) + ": invalid QuadtreeOptions: ", errors);
}

// Mean and population standard deviation from a block's sum and sum of
// squares over `area` pixels, times `scale`.
BlockStats StatsOfSums(double sum, double sqsum, int area, double scale) {
  const double n = static_cast<double>(area);
  const double mean = sum / n;
  // Rounding can make the difference slightly negative for uniform blocks.
  const double variance = std::max(0.0, sqsum / n - mean * mean);
  return BlockStats{mean * scale, std::sqrt(variance) * scale};
}

// The quadtree's halving of a block: its four quarters, top-left, top-right,
// bottom-left, bottom-right (the right and bottom ones take the odd pixel),
// or none when a quarter would be narrower than min_block_px.
bool Quarters(const cv::Rect& box, int min_block_px, cv::Rect quarters[4]) {
  const int left_w = box.width / 2, top_h = box.height / 2;
  if (left_w < min_block_px || top_h < min_block_px) return false;
  const int right_w = box.width - left_w, bottom_h = box.height - top_h;
  quarters[0] = cv::Rect(box.x, box.y, left_w, top_h);
  quarters[1] = cv::Rect(box.x + left_w, box.y, right_w, top_h);
  quarters[2] = cv::Rect(box.x, box.y + top_h, left_w, bottom_h);
  quarters[3] = cv::Rect(box.x + left_w, box.y + top_h, right_w, bottom_h);
  return true;
}

// Every block the quadtree could visit, depth first (a block, then its
// quarters' subtrees in order), with its pixel sum and sum of squares
// (exact: 64-bit integers) and the size of its subtree. The sums of a block
// that has quarters are theirs added up, so each pixel is read once: what
// integral images of the whole image (two of doubles, 16 bytes a pixel)
// gave, without them.
struct SumNode {
  std::uint64_t sum = 0;
  std::uint64_t sqsum = 0;
  size_t subtree = 1;  // this node and its descendants
};

template <typename Pixel>
void SumTree(const cv::Mat& image, const cv::Rect& box, int min_block_px, std::vector<SumNode>* tree) {
  const size_t index = tree->size();
  tree->emplace_back();
  cv::Rect quarters[4];
  SumNode node;
  if (Quarters(box, min_block_px, quarters)) {
    for (const cv::Rect& quarter : quarters) {
      const size_t child = tree->size();
      SumTree<Pixel>(image, quarter, min_block_px, tree);
      node.sum += (*tree)[child].sum;
      node.sqsum += (*tree)[child].sqsum;
    }
  } else {
    for (int y = box.y; y < box.y + box.height; ++y) {
      const Pixel* row = image.ptr<Pixel>(y);
      for (int x = box.x; x < box.x + box.width; ++x) {
        const std::uint64_t value = row[x];
        node.sum += value;
        node.sqsum += value * value;
      }
    }
  }
  node.subtree = tree->size() - index;
  (*tree)[index] = node;
}

}  // namespace

std::vector<std::string> QuadtreeOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(site_size_m > 0, "site_size_m", site_size_m, "> 0", &errors);
  RequireOption(min_block_fraction > 0 && min_block_fraction <= 1, "min_block_fraction",
          min_block_fraction, "in (0, 1]", &errors);
  RequireOption(max_block_stddev > 0, "max_block_stddev", max_block_stddev, "> 0", &errors);
  RequireOption(min_block_mean >= 0 && min_block_mean < 255, "min_block_mean", min_block_mean,
          "in [0, 255)", &errors);
  RequireOption(max_roi_stddev >= max_block_stddev, "max_roi_stddev", max_roi_stddev,
          ">= max_block_stddev", &errors);
  return errors;
}

std::string QuadtreeResult::Summary() const {
  std::ostringstream line;
  line << "quadtree: " << rois.size() << " ROIs, " << blocks_visited << " blocks visited, "
       << rejected_dark << " dark, " << rejected_variable << " variable, " << rejected_small
       << " small, min block " << min_block_px << " px";
  return line.str();
}

double ProjectedSiteSidePx(const calib::CameraModel& camera, double lrf_range_m, double site_size_m,
                           const char* caller) {
  const std::string who = caller;
  if (!(std::isfinite(lrf_range_m) && lrf_range_m > 0)) {
    std::ostringstream message;
    message << who << ": lrf_range_m = " << lrf_range_m << ": expected finite and > 0";
    throw InputError(message.str());
  }
  const Eigen::Vector2d centre_px(0.5 * (camera.WidthPx() - 1), 0.5 * (camera.HeightPx() - 1));
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  if (camera.Unproject({centre_px}, &bearings, &valid) != 1) {
    throw InputError(who + ": camera " + camera.LensModelName() + " cannot unproject the image centre");
  }
  const Eigen::Vector3d ray = bearings[0].normalized();
  // Two directions perpendicular to the ray: the first in the camera's x-z
  // plane (image rows), the second orthogonal to both (image columns).
  Eigen::Vector3d across = Eigen::Vector3d::UnitX() - ray.x() * ray;
  if (across.norm() < 1e-9) across = Eigen::Vector3d::UnitY() - ray.y() * ray;
  across.normalize();
  const Eigen::Vector3d down = ray.cross(across).normalized();
  const Eigen::Vector3d centre_in_cam = lrf_range_m * ray;
  const double half_m = 0.5 * site_size_m;
  const std::vector<Eigen::Vector3d> points_in_cam = {
      centre_in_cam - half_m * across, centre_in_cam + half_m * across,
      centre_in_cam - half_m * down, centre_in_cam + half_m * down};
  std::vector<Eigen::Vector2d> pixels;
  if (camera.Project(points_in_cam, &pixels, &valid) != 4) {
    throw InputError(who + ": camera " + camera.LensModelName() +
                     " cannot project the landing site at the image centre");
  }
  return std::min((pixels[1] - pixels[0]).norm(), (pixels[3] - pixels[2]).norm());
}

int MinimumBlockSizePx(const calib::CameraModel& camera, double lrf_range_m,
                       const QuadtreeOptions& options) {
  ThrowIfQuadtreeOptionsInvalid("MinimumBlockSizePx", options.Validate());
  const double site_px =
      ProjectedSiteSidePx(camera, lrf_range_m, options.site_size_m, "MinimumBlockSizePx");
  // The epsilon keeps an exact product (3000.0 computed as 2999.9999999) from
  // losing a pixel.
  const double side_px = std::floor(options.min_block_fraction * site_px + 1e-9);
  if (!(side_px < 1e9)) {
    throw InputError("quadtree.site_size_m = " + util::ShortestText(options.site_size_m) + ": a site of " +
                     util::ShortestText(site_px) + " px at the LRF range " + util::ShortestText(lrf_range_m) +
                     " m; expected one the image can hold");
  }
  return std::max(kMinBlockSidePx, static_cast<int>(side_px));
}

BlockStats BlockStatsFromIntegral(const cv::Mat& sum, const cv::Mat& sqsum, const cv::Rect& box_px,
                                  double scale) {
  const int x0 = box_px.x, y0 = box_px.y, x1 = box_px.x + box_px.width,
            y1 = box_px.y + box_px.height;
  const double s = sum.at<double>(y1, x1) - sum.at<double>(y0, x1) - sum.at<double>(y1, x0) +
                   sum.at<double>(y0, x0);
  const double sq = sqsum.at<double>(y1, x1) - sqsum.at<double>(y0, x1) -
                    sqsum.at<double>(y1, x0) + sqsum.at<double>(y0, x0);
  return StatsOfSums(s, sq, box_px.area(), scale);
}

QuadtreeResult GivenRois(const cv::Mat& image, const std::vector<cv::Rect>& boxes_px) {
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1) {
    throw InputError("GivenRois: image type " + cv::typeToString(image.type()) +
                     " is not supported: expected CV_8UC1 or CV_16UC1");
  }
  const cv::Rect whole(0, 0, image.cols, image.rows);
  QuadtreeResult result;
  cv::Mat sum, sqsum;
  cv::integral(image, sum, sqsum, CV_64F, CV_64F);
  const double scale = image.type() == CV_16UC1 ? 1.0 / 257.0 : 1.0;
  for (size_t i = 0; i < boxes_px.size(); ++i) {
    const cv::Rect& box = boxes_px[i];
    if (box.width <= 0 || box.height <= 0 || (box & whole) != box) {
      throw InputError("given ROI " + std::to_string(i + 1) + " (x " + std::to_string(box.x) + ", y " +
                       std::to_string(box.y) + ", " + std::to_string(box.width) + " x " +
                       std::to_string(box.height) + " px) is " +
                       (box.width <= 0 || box.height <= 0
                            ? std::string("empty")
                            : "not inside image 1 (" + std::to_string(image.cols) + " x " +
                                  std::to_string(image.rows) + " px)"));
    }
    const BlockStats stats = BlockStatsFromIntegral(sum, sqsum, box, scale);
    result.rois.push_back({static_cast<int>(i) + 1, box, stats.mean_dn, stats.stddev_dn});
    result.min_block_px = i == 0 ? std::min(box.width, box.height)
                                 : std::min({result.min_block_px, box.width, box.height});
  }
  result.blocks_visited = static_cast<int>(boxes_px.size());
  return result;
}

QuadtreeResult RunQuadtree(const cv::Mat& image, int min_block_px, const QuadtreeOptions& options) {
  ThrowIfQuadtreeOptionsInvalid("RunQuadtree", options.Validate());
  if (min_block_px < 1) {
    throw InputError("RunQuadtree: min_block_px = " + std::to_string(min_block_px) +
                     ": expected >= 1");
  }
  QuadtreeResult result;
  result.min_block_px = min_block_px;
  if (image.empty()) return result;
  if (image.type() != CV_8UC1 && image.type() != CV_16UC1) {
    throw InputError("RunQuadtree: image type " + cv::typeToString(image.type()) +
                     " is not supported: expected CV_8UC1 or CV_16UC1");
  }
  const double scale = image.type() == CV_16UC1 ? 1.0 / 257.0 : 1.0;
  const cv::Rect whole(0, 0, image.cols, image.rows);
  if (image.cols < min_block_px || image.rows < min_block_px) {
    result.rejected_small = 1;
    result.rejected_boxes.push_back(whole);
    return result;
  }
  std::vector<SumNode> tree;
  if (image.type() == CV_8UC1) {
    SumTree<std::uint8_t>(image, whole, min_block_px, &tree);
  } else {
    SumTree<std::uint16_t>(image, whole, min_block_px, &tree);
  }

  // Depth first with an explicit stack; children are pushed in reverse so
  // that they are visited top-left, top-right, bottom-left, bottom-right.
  std::vector<std::pair<cv::Rect, size_t>> stack = {{whole, 0}};
  while (!stack.empty()) {
    const auto [box, index] = stack.back();
    stack.pop_back();
    ++result.blocks_visited;
    const SumNode& node = tree[index];
    // The sums are exact integers; as doubles they are what the integral
    // images' corners gave while below 2^53 (any 8-bit image, and 16-bit
    // ones up to about 2 Mpx at full scale).
    const BlockStats stats =
        StatsOfSums(static_cast<double>(node.sum), static_cast<double>(node.sqsum), box.area(), scale);
    cv::Rect quarters[4];
    if (stats.stddev_dn >= options.max_block_stddev && Quarters(box, min_block_px, quarters)) {
      size_t child = index + 1;
      size_t children[4];
      for (size_t& c : children) {
        c = child;
        child += tree[c].subtree;
      }
      for (int q = 3; q >= 0; --q) stack.emplace_back(quarters[q], children[q]);
      continue;
    }
    if (stats.mean_dn < options.min_block_mean) {
      ++result.rejected_dark;
      result.rejected_boxes.push_back(box);
    } else if (stats.stddev_dn > options.max_roi_stddev) {
      ++result.rejected_variable;
      result.rejected_boxes.push_back(box);
    } else {
      result.rois.push_back(Roi{0, box, stats.mean_dn, stats.stddev_dn});
    }
  }
  std::sort(result.rois.begin(), result.rois.end(), [](const Roi& a, const Roi& b) {
    return a.box_px.y != b.box_px.y ? a.box_px.y < b.box_px.y : a.box_px.x < b.box_px.x;
  });
  for (size_t i = 0; i < result.rois.size(); ++i) result.rois[i].id = static_cast<int>(i) + 1;
  return result;
}

}  // namespace hdabench::hda
