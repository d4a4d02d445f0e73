// Comparing two flight-method results (result.json) ROI by ROI.
#pragma once

#include <nlohmann/json.hpp>
#include <gtest/gtest.h>

namespace hdabench::testing_support {

// Expects `b` to have `a`'s ROIs, each with the same image-1 box and status,
// and, where `a` has a plane fit, a fit whose slope is within
// `slope_tolerance_deg` of a's. Returns the number of ROIs with a fit.
inline int ExpectSameFlightRois(const nlohmann::json& a, const nlohmann::json& b, double slope_tolerance_deg) {
  EXPECT_EQ(a["rois"].size(), b["rois"].size());
  if (a["rois"].size() != b["rois"].size()) return 0;
  int fits = 0;
  for (size_t i = 0; i < a["rois"].size(); ++i) {
    const nlohmann::json& ra = a["rois"][i];
    const nlohmann::json& rb = b["rois"][i];
    EXPECT_EQ(ra["box1"], rb["box1"]) << i;
    EXPECT_EQ(ra["status"], rb["status"]) << i;
    if (!ra.contains("fit") || !ra["fit"].is_object()) continue;  // null without a fit
    EXPECT_TRUE(rb.contains("fit") && rb["fit"].is_object()) << i;
    if (!rb.contains("fit") || !rb["fit"].is_object()) continue;
    ++fits;
    EXPECT_NEAR(ra["fit"]["slope_deg"].get<double>(), rb["fit"]["slope_deg"].get<double>(), slope_tolerance_deg) << i;
  }
  return fits;
}

}  // namespace hdabench::testing_support
