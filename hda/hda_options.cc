#include "hda/hda_options.h"

#include "calib/options_check.h"

namespace hdabench::hda {

std::vector<std::string> HdaOptions::Validate() const {
  std::vector<std::string> errors;
  for (const std::string& e : quadtree.Validate()) errors.push_back("quadtree." + e);
  RequireOption(max_hazard_height_m > 0, "max_hazard_height_m", max_hazard_height_m, "> 0", &errors);
  RequireOption(max_slope_deg > 0 && max_slope_deg < 90, "max_slope_deg", max_slope_deg, "in (0, 90)",
          &errors);
  RequireOption(orb_features_per_roi >= 8, "orb_features_per_roi", orb_features_per_roi, ">= 8", &errors);
  RequireOption(ratio_test > 0 && ratio_test <= 1, "ratio_test", ratio_test, "in (0, 1]", &errors);
  RequireOption(ransac_threshold_px > 0, "ransac_threshold_px", ransac_threshold_px, "> 0", &errors);
  RequireOption(ransac_confidence > 0 && ransac_confidence < 1, "ransac_confidence", ransac_confidence,
          "in (0, 1)", &errors);
  RequireOption(min_points >= 3, "min_points", min_points, ">= 3 (a plane needs 3 points)", &errors);
  RequireOption(compute_budget_s > 0, "compute_budget_s", compute_budget_s, "> 0", &errors);
  RequireOption(processor_scale > 0, "processor_scale", processor_scale, "> 0", &errors);
  return errors;
}

}  // namespace hdabench::hda
