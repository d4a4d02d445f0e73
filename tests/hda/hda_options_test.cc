#include "hda/hda_options.h"

#include <cmath>

#include <gtest/gtest.h>

namespace hdabench::hda {
namespace {

TEST(HdaOptionsValidate, PaperDefaultsAreValid) {
  const HdaOptions options;
  EXPECT_TRUE(options.Validate().empty());
  EXPECT_EQ(options.quadtree.site_size_m, 10.0);
  EXPECT_EQ(options.max_slope_deg, 10.0);
  EXPECT_EQ(options.max_hazard_height_m, 0.30);
}

TEST(HdaOptionsValidate, ReportsEveryBadFieldWithItsValue) {
  HdaOptions options;
  options.quadtree.site_size_m = -1.0;
  options.max_slope_deg = std::nan("");
  options.min_points = 2;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 3u);
  EXPECT_EQ(errors[0], "quadtree.site_size_m = -1: expected > 0");
  EXPECT_EQ(errors[1], "max_slope_deg = nan: expected in (0, 90)");
  EXPECT_EQ(errors[2], "min_points = 2: expected >= 3 (a plane needs 3 points)");
}

// The wall-time budget is compute_budget_s * processor_scale, written into
// every result: it must be a number, not inf (null in JSON).
TEST(HdaOptionsValidate, TheWallTimeBudgetIsFinite) {
  HdaOptions options;
  options.processor_scale = 1e308;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0], "compute_budget_s * processor_scale = inf: expected finite (the wall-time budget, seconds)");
  options.processor_scale = 1e6;
  options.compute_budget_s = 1e9;
  EXPECT_TRUE(options.Validate().empty());
}

}  // namespace
}  // namespace hdabench::hda
