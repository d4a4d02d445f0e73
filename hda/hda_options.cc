#include "hda/hda_options.h"

#include <cmath>
#include <sstream>

namespace hdabench::hda {

namespace {
void Require(bool ok, const char* field, double value, const char* expected,
             std::vector<std::string>* errors) {
  if (ok && std::isfinite(value)) return;
  std::ostringstream message;
  message << field << " = " << value << ": expected " << expected;
  errors->push_back(message.str());
}
}  // namespace

std::vector<std::string> HdaOptions::Validate() const {
  std::vector<std::string> errors;
  Require(site_size_m > 0, "site_size_m", site_size_m, "> 0", &errors);
  Require(max_hazard_height_m > 0, "max_hazard_height_m", max_hazard_height_m, "> 0", &errors);
  Require(max_slope_deg > 0 && max_slope_deg < 90, "max_slope_deg", max_slope_deg, "in (0, 90)",
          &errors);
  Require(max_block_stddev > 0, "max_block_stddev", max_block_stddev, "> 0", &errors);
  Require(min_block_mean >= 0 && min_block_mean < 255, "min_block_mean", min_block_mean,
          "in [0, 255)", &errors);
  Require(max_roi_stddev >= max_block_stddev, "max_roi_stddev", max_roi_stddev,
          ">= max_block_stddev", &errors);
  Require(min_block_fraction > 0 && min_block_fraction <= 1, "min_block_fraction",
          min_block_fraction, "in (0, 1]", &errors);
  Require(orb_features_per_roi >= 8, "orb_features_per_roi", orb_features_per_roi, ">= 8", &errors);
  Require(ratio_test > 0 && ratio_test <= 1, "ratio_test", ratio_test, "in (0, 1]", &errors);
  Require(ransac_threshold_px > 0, "ransac_threshold_px", ransac_threshold_px, "> 0", &errors);
  Require(ransac_confidence > 0 && ransac_confidence < 1, "ransac_confidence", ransac_confidence,
          "in (0, 1)", &errors);
  Require(min_points >= 3, "min_points", min_points, ">= 3 (a plane needs 3 points)", &errors);
  Require(compute_budget_s > 0, "compute_budget_s", compute_budget_s, "> 0", &errors);
  Require(processor_scale > 0, "processor_scale", processor_scale, "> 0", &errors);
  return errors;
}

}  // namespace hdabench::hda
