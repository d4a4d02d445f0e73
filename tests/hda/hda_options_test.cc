#include "hda/hda_options.h"

#include <cmath>
#include <limits>

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

// The budget and the flight computer's rate are written into every result:
// numbers, not inf (null in JSON).
TEST(HdaOptionsValidate, TheBudgetAndTheFlightRateAreFinite) {
  HdaOptions options;
  options.compute_budget_s = std::numeric_limits<double>::infinity();
  options.flight_instructions_per_s = 0.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_EQ(errors[0], "compute_budget_s = inf: expected > 0 and finite (seconds of the flight computer)");
  EXPECT_EQ(errors[1], "flight_instructions_per_s = 0: expected > 0 and finite");
  options.compute_budget_s = 1e9;
  options.flight_instructions_per_s = 1e12;
  EXPECT_TRUE(options.Validate().empty());
}

}  // namespace
}  // namespace hdabench::hda
