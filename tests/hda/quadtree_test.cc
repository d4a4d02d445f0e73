#include "hda/quadtree.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/util/error.h"
#include "tests/support/cameras.h"
#include "tests/support/test_support.h"

namespace hdabench::hda {
namespace {

using testing_support::CurrentTestSeed;
using testing_support::InputErrorOf;

using testing_support::Pinhole1000;

// A 0/255 checkerboard of single pixels: mean 127.5, stddev 127.5.
void FillChecker(cv::Mat* image, const cv::Rect& box) {
  for (int row = box.y; row < box.y + box.height; ++row) {
    for (int col = box.x; col < box.x + box.width; ++col) {
      image->at<unsigned char>(row, col) = ((row + col) % 2 == 0) ? 0 : 255;
    }
  }
}

// 64 x 64, minimum block 16:
//   top-left quadrant: four uniform 16-blocks 100, 120, 140, 160 (split once);
//   top-right quadrant: uniform 90 (one ROI);
//   bottom-left quadrant: checkerboard (four variable minimum-size blocks);
//   bottom-right quadrant: 150, 200, a shadow of 20, a checkerboard.
cv::Mat ConstructedImage() {
  cv::Mat image(64, 64, CV_8UC1, cv::Scalar(0));
  image(cv::Rect(0, 0, 16, 16)).setTo(100);
  image(cv::Rect(16, 0, 16, 16)).setTo(120);
  image(cv::Rect(0, 16, 16, 16)).setTo(140);
  image(cv::Rect(16, 16, 16, 16)).setTo(160);
  image(cv::Rect(32, 0, 32, 32)).setTo(90);
  FillChecker(&image, cv::Rect(0, 32, 32, 32));
  image(cv::Rect(32, 32, 16, 16)).setTo(150);
  image(cv::Rect(48, 32, 16, 16)).setTo(200);
  image(cv::Rect(32, 48, 16, 16)).setTo(20);
  FillChecker(&image, cv::Rect(48, 48, 16, 16));
  return image;
}

TEST(QuadtreeOptionsValidate, DefaultsAreValidAndBadFieldsAreNamed) {
  QuadtreeOptions options;
  EXPECT_TRUE(options.Validate().empty());
  options.min_block_fraction = 1.5;
  options.max_roi_stddev = 5.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "min_block_fraction = 1.5: expected in (0, 1]");
  EXPECT_EQ(errors[1], "max_roi_stddev = 5: expected >= max_block_stddev");
}

TEST(RunQuadtree, ConstructedImageGivesExactRoisCountsAndNumbering) {
  const QuadtreeResult result = RunQuadtree(ConstructedImage(), 16, QuadtreeOptions());
  // Raster order of top-left corners: row 0 (x 0, 16, 32), row 16, row 32.
  const std::vector<cv::Rect> expected_boxes = {
      {0, 0, 16, 16},   {16, 0, 16, 16},  {32, 0, 32, 32},  {0, 16, 16, 16},
      {16, 16, 16, 16}, {32, 32, 16, 16}, {48, 32, 16, 16}};
  const std::vector<double> expected_means = {100, 120, 90, 140, 160, 150, 200};
  ASSERT_EQ(result.rois.size(), expected_boxes.size());
  for (size_t i = 0; i < expected_boxes.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_EQ(result.rois[i].id, static_cast<int>(i) + 1);
    EXPECT_EQ(result.rois[i].box_px, expected_boxes[i]);
    EXPECT_DOUBLE_EQ(result.rois[i].mean_dn, expected_means[i]);
    EXPECT_EQ(result.rois[i].stddev_dn, 0.0);
  }
  EXPECT_EQ(result.blocks_visited, 17);  // image, 4 quadrants, 3 x 4 children
  EXPECT_EQ(result.rejected_dark, 1);
  EXPECT_EQ(result.rejected_variable, 5);
  EXPECT_EQ(result.rejected_small, 0);
  EXPECT_EQ(result.min_block_px, 16);
  const std::vector<cv::Rect> expected_rejected = {{0, 32, 16, 16},  {16, 32, 16, 16},
                                                   {0, 48, 16, 16},  {16, 48, 16, 16},
                                                   {32, 48, 16, 16}, {48, 48, 16, 16}};
  EXPECT_EQ(result.rejected_boxes, expected_rejected);
  EXPECT_EQ(result.Summary(),
            "quadtree: 7 ROIs, 17 blocks visited, 1 dark, 5 variable, 0 small, min block 16 px");
}

TEST(RunQuadtree, SixteenBitImageGivesTheSameResultInEightBitLevels) {
  const cv::Mat image8 = ConstructedImage();
  cv::Mat image16;
  image8.convertTo(image16, CV_16UC1, 257.0);
  const QuadtreeResult result8 = RunQuadtree(image8, 16, QuadtreeOptions());
  const QuadtreeResult result16 = RunQuadtree(image16, 16, QuadtreeOptions());
  ASSERT_EQ(result16.rois.size(), result8.rois.size());
  for (size_t i = 0; i < result8.rois.size(); ++i) {
    EXPECT_EQ(result16.rois[i].box_px, result8.rois[i].box_px);
    EXPECT_NEAR(result16.rois[i].mean_dn, result8.rois[i].mean_dn, 1e-9);
  }
  EXPECT_EQ(result16.rejected_boxes, result8.rejected_boxes);
}

TEST(RunQuadtree, MinimumSizeBlockBelowRoiStddevIsAccepted) {
  // Alternating 80 / 120 columns: stddev 20, above max_block_stddev (12) but
  // within max_roi_stddev (40); 16 px cannot be split with a 16 px minimum.
  cv::Mat image(16, 16, CV_8UC1);
  for (int col = 0; col < 16; ++col) image.col(col).setTo(col % 2 == 0 ? 80 : 120);
  const QuadtreeResult result = RunQuadtree(image, 16, QuadtreeOptions());
  ASSERT_EQ(result.rois.size(), 1u);
  EXPECT_DOUBLE_EQ(result.rois[0].stddev_dn, 20.0);
  EXPECT_EQ(result.blocks_visited, 1);
}

TEST(RunQuadtree, OddSizedNoiseImageIsTiledByLeaves) {
  std::mt19937_64 rng(CurrentTestSeed());
  cv::Mat image(37, 50, CV_8UC1);
  std::uniform_int_distribution<int> level(0, 255);
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      // Smooth left half, noisy right half, so both kinds of leaf occur.
      image.at<unsigned char>(row, col) =
          static_cast<unsigned char>(col < 25 ? 100 + (row + col) % 3 : level(rng));
    }
  }
  const QuadtreeResult result = RunQuadtree(image, 8, QuadtreeOptions());
  cv::Mat covered(image.size(), CV_32SC1, cv::Scalar(0));
  for (const Roi& roi : result.rois) covered(roi.box_px) += 1;
  for (const cv::Rect& box : result.rejected_boxes) covered(box) += 1;
  double min_count = 0, max_count = 0;
  cv::minMaxLoc(covered, &min_count, &max_count);
  EXPECT_EQ(min_count, 1.0) << "seed " << CurrentTestSeed();
  EXPECT_EQ(max_count, 1.0) << "seed " << CurrentTestSeed();
  EXPECT_FALSE(result.rois.empty());
  EXPECT_GT(result.rejected_variable, 0);
  for (const Roi& roi : result.rois) {
    EXPECT_GE(roi.box_px.width, 8);
    EXPECT_GE(roi.box_px.height, 8);
  }
}

TEST(BlockStatsFromIntegral, EqualsBruteForceOnRandomBlocks) {
  const std::uint64_t seed = CurrentTestSeed();
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> level(0, 65535);
  for (const int type : {CV_8UC1, CV_16UC1}) {
    cv::Mat image(80, 100, type);
    for (int row = 0; row < image.rows; ++row) {
      for (int col = 0; col < image.cols; ++col) {
        if (type == CV_8UC1) {
          image.at<unsigned char>(row, col) = static_cast<unsigned char>(level(rng) % 256);
        } else {
          image.at<unsigned short>(row, col) = static_cast<unsigned short>(level(rng));
        }
      }
    }
    cv::Mat sum, sqsum;
    cv::integral(image, sum, sqsum, CV_64F, CV_64F);
    const double scale = type == CV_16UC1 ? 1.0 / 257.0 : 1.0;
    for (int trial = 0; trial < 50; ++trial) {
      const int x = std::uniform_int_distribution<int>(0, 99)(rng);
      const int y = std::uniform_int_distribution<int>(0, 79)(rng);
      const int w = std::uniform_int_distribution<int>(1, 100 - x)(rng);
      const int h = std::uniform_int_distribution<int>(1, 80 - y)(rng);
      const cv::Rect box(x, y, w, h);
      double brute_sum = 0, brute_sq = 0;
      for (int row = y; row < y + h; ++row) {
        for (int col = x; col < x + w; ++col) {
          const double value = (type == CV_8UC1 ? image.at<unsigned char>(row, col)
                                                : image.at<unsigned short>(row, col)) * scale;
          brute_sum += value;
          brute_sq += value * value;
        }
      }
      const double n = static_cast<double>(box.area());
      const double brute_mean = brute_sum / n;
      const double brute_std = std::sqrt(std::max(0.0, brute_sq / n - brute_mean * brute_mean));
      const BlockStats stats = BlockStatsFromIntegral(sum, sqsum, box, scale);
      // Values are below 256 in 8-bit levels; 1e-9 is far above double rounding.
      EXPECT_NEAR(stats.mean_dn, brute_mean, 1e-9) << "seed " << seed << " trial " << trial;
      EXPECT_NEAR(stats.stddev_dn, brute_std, 1e-6) << "seed " << seed << " trial " << trial;
    }
  }
}

// RunQuadtree sums each pixel once into a tree of blocks: its ROIs must
// carry, to the bit, the statistics the integral images give for their boxes,
// and it must visit the blocks a quadtree on those statistics visits (here
// recomputed from the integral images), for 8- and 16-bit images of odd
// sizes with smooth, textured and dark parts.
TEST(RunQuadtree, StatisticsAndVisitsEqualThoseFromIntegralImages) {
  std::mt19937_64 rng(CurrentTestSeed());
  std::normal_distribution<double> grain(0.0, 1.0);
  for (const int type : {CV_8UC1, CV_16UC1}) {
    cv::Mat image(301, 467, type);
    for (int row = 0; row < image.rows; ++row) {
      for (int col = 0; col < image.cols; ++col) {
        // Dark top-left, smooth bands, and grain whose strength grows to the right.
        const double base = (row < 80 && col < 120) ? 10.0 : 90.0 + 20.0 * std::sin(row * 0.05);
        const double level = std::clamp(base + grain(rng) * col / 30.0, 0.0, 255.0);
        if (type == CV_8UC1) {
          image.at<unsigned char>(row, col) = static_cast<unsigned char>(level);
        } else {
          image.at<unsigned short>(row, col) = static_cast<unsigned short>(level * 257.0);
        }
      }
    }
    const double scale = type == CV_16UC1 ? 1.0 / 257.0 : 1.0;
    cv::Mat sum, sqsum;
    cv::integral(image, sum, sqsum, CV_64F, CV_64F);
    const QuadtreeOptions options;
    const int min_block = 9;
    const QuadtreeResult result = RunQuadtree(image, min_block, options);
    ASSERT_FALSE(result.rois.empty());
    EXPECT_GT(result.rejected_dark, 0);
    EXPECT_GT(result.rejected_variable, 0);
    for (const Roi& roi : result.rois) {
      const BlockStats stats = BlockStatsFromIntegral(sum, sqsum, roi.box_px, scale);
      EXPECT_EQ(roi.mean_dn, stats.mean_dn) << roi.box_px;
      EXPECT_EQ(roi.stddev_dn, stats.stddev_dn) << roi.box_px;
    }
    // The visits of the same quadtree on the integral images' statistics.
    int visited = 0;
    std::vector<cv::Rect> stack = {cv::Rect(0, 0, image.cols, image.rows)};
    while (!stack.empty()) {
      const cv::Rect box = stack.back();
      stack.pop_back();
      ++visited;
      const int left = box.width / 2, top = box.height / 2;
      if (BlockStatsFromIntegral(sum, sqsum, box, scale).stddev_dn >= options.max_block_stddev &&
          left >= min_block && top >= min_block) {
        stack.emplace_back(box.x, box.y, left, top);
        stack.emplace_back(box.x + left, box.y, box.width - left, top);
        stack.emplace_back(box.x, box.y + top, left, box.height - top);
        stack.emplace_back(box.x + left, box.y + top, box.width - left, box.height - top);
      }
    }
    EXPECT_EQ(result.blocks_visited, visited);
  }
}

TEST(RunQuadtree, EmptyImageGivesNothing) {
  const QuadtreeResult result = RunQuadtree(cv::Mat(), 16, QuadtreeOptions());
  EXPECT_TRUE(result.rois.empty());
  EXPECT_EQ(result.blocks_visited, 0);
  EXPECT_EQ(result.rejected_dark + result.rejected_variable + result.rejected_small, 0);
  EXPECT_TRUE(result.rejected_boxes.empty());
}

TEST(RunQuadtree, AllBlackImageIsOneShadowBlock) {
  const QuadtreeResult result =
      RunQuadtree(cv::Mat(512, 640, CV_8UC1, cv::Scalar(0)), 16, QuadtreeOptions());
  EXPECT_TRUE(result.rois.empty());
  EXPECT_EQ(result.blocks_visited, 1);
  EXPECT_EQ(result.rejected_dark, 1);
  EXPECT_EQ(result.rejected_variable, 0);
}

TEST(RunQuadtree, ImageSmallerThanMinimumBlockIsRejectedAsSmall) {
  const QuadtreeResult result =
      RunQuadtree(cv::Mat(10, 40, CV_8UC1, cv::Scalar(128)), 16, QuadtreeOptions());
  EXPECT_TRUE(result.rois.empty());
  EXPECT_EQ(result.rejected_small, 1);
  EXPECT_EQ(result.rejected_boxes, std::vector<cv::Rect>({cv::Rect(0, 0, 40, 10)}));
}

TEST(GivenRois, BoxesKeepTheirOrderAndStatisticsAndOutsideOnesAreNamed) {
  cv::Mat image(60, 80, CV_8UC1);
  cv::randu(image, 0, 256);
  const std::vector<cv::Rect> boxes = {{40, 10, 30, 20}, {0, 0, 10, 10}};
  const QuadtreeResult result = GivenRois(image, boxes);
  ASSERT_EQ(result.rois.size(), 2u);
  cv::Mat sum, sqsum;
  cv::integral(image, sum, sqsum, CV_64F, CV_64F);
  for (size_t i = 0; i < boxes.size(); ++i) {
    EXPECT_EQ(result.rois[i].id, static_cast<int>(i) + 1);
    EXPECT_EQ(result.rois[i].box_px, boxes[i]);
    const BlockStats stats = BlockStatsFromIntegral(sum, sqsum, boxes[i], 1.0);
    EXPECT_EQ(result.rois[i].mean_dn, stats.mean_dn);
    EXPECT_EQ(result.rois[i].stddev_dn, stats.stddev_dn);
  }
  EXPECT_EQ(result.blocks_visited, 2);
  EXPECT_EQ(result.min_block_px, 10);
  EXPECT_TRUE(result.rejected_boxes.empty());
  EXPECT_EQ(InputErrorOf([&] { GivenRois(image, {{0, 0, 5, 5}, {70, 50, 20, 5}}); }),
            "given ROI 2 (x 70, y 50, 20 x 5 px) is not inside image 1 (80 x 60 px)");
  EXPECT_EQ(InputErrorOf([&] { GivenRois(image, {{3, 3, 0, 5}}); }),
            "given ROI 1 (x 3, y 3, 0 x 5 px) is empty");
}

TEST(RunQuadtree, BadInputThrowsInputErrorWithExactMessage) {
  try {
    RunQuadtree(cv::Mat(8, 8, CV_32FC1, cv::Scalar(0.5)), 4, QuadtreeOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "RunQuadtree: image type CV_32FC1 is not supported: expected CV_8UC1 or CV_16UC1");
  }
  try {
    RunQuadtree(cv::Mat(8, 8, CV_8UC3), 4, QuadtreeOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "RunQuadtree: image type CV_8UC3 is not supported: expected CV_8UC1 or CV_16UC1");
  }
  try {
    RunQuadtree(cv::Mat(8, 8, CV_8UC1), 0, QuadtreeOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "RunQuadtree: min_block_px = 0: expected >= 1");
  }
  QuadtreeOptions bad;
  bad.max_block_stddev = -1;
  try {
    RunQuadtree(cv::Mat(8, 8, CV_8UC1), 4, bad);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "RunQuadtree: invalid QuadtreeOptions: max_block_stddev = -1: expected > 0");
  }
}

TEST(MinimumBlockSizePx, LanderAndTruckGiveTheExpectedPinholeSizes) {
  const calib::CameraModel camera = Pinhole1000();
  const QuadtreeOptions options;
  // 10 m at 570 m: 1000 * 10 / 570 = 17.54 px; 0.9 of it is 15.79: 15 px.
  EXPECT_EQ(MinimumBlockSizePx(camera, 570.0, options), 15);
  // 10 m at 3 m: 3333.3 px; 0.9 of it is exactly 3000 px (larger than the image).
  EXPECT_EQ(MinimumBlockSizePx(camera, 3.0, options), 3000);
  // At 5 km the site is 1.8 px: the floor of 8 px applies.
  EXPECT_EQ(MinimumBlockSizePx(camera, 5000.0, options), kMinBlockSidePx);
}

TEST(MinimumBlockSizePx, TruckWithScaledSiteCoversTheSameFractionOfTheSite) {
  const calib::CameraModel camera = Pinhole1000();
  QuadtreeOptions lander;
  QuadtreeOptions truck;
  truck.site_size_m = lander.site_size_m * 3.0 / 570.0;  // the paper rescaled quadtree for the truck
  const int lander_px = MinimumBlockSizePx(camera, 570.0, lander);
  const int truck_px = MinimumBlockSizePx(camera, 3.0, truck);
  EXPECT_EQ(lander_px, 15);
  EXPECT_EQ(truck_px, 15);
  // Ground size of a minimum block as a fraction of the site: 15 * 570 / 1000 / 10.
  EXPECT_DOUBLE_EQ(lander_px * 570.0 / 1000.0 / lander.site_size_m, 0.855);
  EXPECT_NEAR(truck_px * 3.0 / 1000.0 / truck.site_size_m, 0.855, 1e-12);
  // Same options, any range: the block is within one pixel's footprint of
  // min_block_fraction * site_size_m on the ground.
  for (const double range_m : {30.0, 100.0, 250.0, 570.0}) {
    const int side_px = MinimumBlockSizePx(camera, range_m, lander);
    const double footprint_m = range_m / 1000.0;
    EXPECT_LE(side_px * footprint_m, 9.0 + 1e-9) << range_m;
    EXPECT_GT((side_px + 1) * footprint_m, 9.0) << range_m;
  }
}

TEST(MinimumBlockSizePx, BadRangeThrowsInputError) {
  try {
    MinimumBlockSizePx(Pinhole1000(), -3.0, QuadtreeOptions());
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "MinimumBlockSizePx: lrf_range_m = -3: expected finite and > 0");
  }
  EXPECT_THROW(MinimumBlockSizePx(Pinhole1000(), std::nan(""), QuadtreeOptions()), InputError);
}

}  // namespace
}  // namespace hdabench::hda
