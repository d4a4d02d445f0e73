#include "hda/hda_options.h"

#include <cmath>

#include "tools/util/options_check.h"

namespace hdabench::hda {

namespace {

void AddPrefixed(const std::vector<std::string>& nested, const char* prefix,
                 std::vector<std::string>* errors) {
  for (const std::string& e : nested) errors->push_back(prefix + e);
}

}  // namespace

std::vector<std::string> HdaOptions::Validate() const {
  std::vector<std::string> errors;
  AddPrefixed(quadtree.Validate(), "quadtree.", &errors);
  AddPrefixed(prediction.Validate(), "prediction.", &errors);
  AddPrefixed(matching.Validate(), "matching.", &errors);
  AddPrefixed(triangulation.Validate(), "triangulation.", &errors);
  RequireOption(max_hazard_height_m > 0, "max_hazard_height_m", max_hazard_height_m, "> 0", &errors);
  RequireOption(max_slope_deg > 0 && max_slope_deg < 90, "max_slope_deg", max_slope_deg, "in (0, 90)",
                &errors);
  RequireOption(assumed_pixel_sigma_px > 0, "assumed_pixel_sigma_px", assumed_pixel_sigma_px, "> 0",
                &errors);
  RequireOption(max_relief_m >= 0, "max_relief_m", max_relief_m, ">= 0", &errors);
  RequireOption(min_points >= 3, "min_points", min_points, ">= 3 (a plane needs 3 points)", &errors);
  RequireOption(pixel_sigma_floor_px > 0, "pixel_sigma_floor_px", pixel_sigma_floor_px, "> 0", &errors);
  RequireOption(match_error_px > 0, "match_error_px", match_error_px, "> 0", &errors);
  RequireOption(min_probability_safe > 0 && min_probability_safe < 1, "min_probability_safe", min_probability_safe,
                "in (0, 1)", &errors);
  RequireOption(max_slope_sigma_deg > 0, "max_slope_sigma_deg", max_slope_sigma_deg, "> 0", &errors);
  RequireOption(max_roughness_rms_m > 0, "max_roughness_rms_m", max_roughness_rms_m, "> 0", &errors);
  RequireOption(compute_budget_s > 0 && std::isfinite(compute_budget_s), "compute_budget_s", compute_budget_s,
                "> 0 and finite (seconds of the flight computer)", &errors);
  RequireOption(fault_match_noise_px >= 0, "fault_match_noise_px", fault_match_noise_px, ">= 0",
                &errors);
  RequireOption(flight_instructions_per_s > 0 && std::isfinite(flight_instructions_per_s),
                "flight_instructions_per_s", flight_instructions_per_s, "> 0 and finite", &errors);
  return errors;
}

}  // namespace hdabench::hda
