#include "reference/flight/hda_params.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <limits>
#include <sstream>

#include <opencv2/core.hpp>

#include "hda/matching.h"
#include "hda/pipeline.h"
#include "hda/quadtree.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using Json = nlohmann::ordered_json;

// A scaled site's side is within this of its target, pixels (the quadtree
// takes whole pixels), after at most kSiteRescalings rescalings.
constexpr double kSiteTolerancePx = 0.5;
constexpr int kSiteRescalings = 20;
constexpr double kInfinitePx = std::numeric_limits<double>::infinity();
// The small site that measures the side near the axis, as a fraction of the
// range (1 mm at 1 m: its edges 0.03 deg off the axis).
constexpr double kSiteProbeFraction = 1e-3;

// Calls visit(key, field) for every field of HdaOptions, in result.json's
// order; `Options` is HdaOptions or const HdaOptions. The one list of keys.
template <class Options, class Visit>
void ForEachField(Options& o, Visit&& visit) {
  visit("max_hazard_height_m", o.max_hazard_height_m);
  visit("max_slope_deg", o.max_slope_deg);
  visit("quadtree.site_size_m", o.quadtree.site_size_m);
  visit("quadtree.min_block_fraction", o.quadtree.min_block_fraction);
  visit("quadtree.max_block_stddev", o.quadtree.max_block_stddev);
  visit("quadtree.min_block_mean", o.quadtree.min_block_mean);
  visit("quadtree.max_roi_stddev", o.quadtree.max_roi_stddev);
  visit("prediction.nav_position_sigma_m", o.prediction.nav_position_sigma_m);
  visit("prediction.nav_attitude_sigma_deg", o.prediction.nav_attitude_sigma_deg);
  visit("prediction.range_sigma_m", o.prediction.range_sigma_m);
  visit("prediction.sigma_multiplier", o.prediction.sigma_multiplier);
  visit("prediction.min_margin_px", o.prediction.min_margin_px);
  visit("matching.orb_features_per_roi", o.matching.orb_features_per_roi);
  visit("matching.orb_levels", o.matching.orb_levels);
  visit("matching.orb_scale_factor", o.matching.orb_scale_factor);
  visit("matching.orb_fast_threshold", o.matching.orb_fast_threshold);
  visit("matching.orb_patch_size_px", o.matching.orb_patch_size_px);
  visit("matching.ratio_test", o.matching.ratio_test);
  visit("matching.cross_check", o.matching.cross_check);
  visit("matching.guide_radius_px", o.matching.guide_radius_px);
  visit("matching.subpixel_refine", o.matching.subpixel_refine);
  visit("matching.refine_window_px", o.matching.refine_window_px);
  visit("matching.max_refine_shift_px", o.matching.max_refine_shift_px);
  visit("matching.warp_refine", o.matching.warp_refine);
  visit("matching.warp_refine_window_px", o.matching.warp_refine_window_px);
  visit("matching.prewarp_min_stretch", o.matching.prewarp_min_stretch);
  visit("matching.ransac_threshold_px", o.matching.ransac_threshold_px);
  visit("matching.ransac_confidence", o.matching.ransac_confidence);
  visit("matching.ransac_max_iterations", o.matching.ransac_max_iterations);
  visit("triangulation.min_parallax_deg", o.triangulation.min_parallax_deg);
  visit("assumed_pixel_sigma_px", o.assumed_pixel_sigma_px);
  visit("max_relief_m", o.max_relief_m);
  visit("correct_window_lean", o.correct_window_lean);
  visit("min_points", o.min_points);
  visit("pixel_sigma_floor_px", o.pixel_sigma_floor_px);
  visit("match_error_px", o.match_error_px);
  visit("max_slope_sigma_deg", o.max_slope_sigma_deg);
  visit("max_roughness_rms_m", o.max_roughness_rms_m);
  visit("decide_on_probability", o.decide_on_probability);
  visit("min_probability_safe", o.min_probability_safe);
  visit("compute_budget_s", o.compute_budget_s);
  visit("flight_instructions_per_s", o.flight_instructions_per_s);
  visit("fault_match_noise_px", o.fault_match_noise_px);
}

// The same for the lander's fields.
template <class Lander, class Visit>
void ForEachLanderField(Lander& l, Visit&& visit) {
  visit("lander.legs", l.legs);
  visit("lander.footprint_diameter_m", l.footprint_diameter_m);
  visit("lander.pad_diameter_m", l.pad_diameter_m);
  visit("lander.max_slope_deg", l.max_slope_deg);
  visit("lander.body_clearance_m", l.body_clearance_m);
  visit("lander.chooses_yaw", l.chooses_yaw);
  visit("lander.yaw_step_deg", l.yaw_step_deg);
}

std::string KnownKeys() {
  std::string list;
  for (const std::string& key : HdaParamKeys()) list += (list.empty() ? "" : ", ") + key;
  for (const std::string& key : LanderParamKeys()) list += ", " + key;
  return list;
}

// A comment in a parameter file: the file's own labels and each value's reason.
bool IsComment(const std::string& key) {
  const std::string suffix = "_why";
  return key == "format" || key == "description" || key == "why" ||
         (key.size() > suffix.size() && key.compare(key.size() - suffix.size(), suffix.size(), suffix) == 0);
}

// The value as the message quotes it: nan and inf as such (JSON writes
// them as null, which is not what was given).
std::string Quoted(const Json& value) {
  if (value.is_number_float() && !std::isfinite(value.get<double>())) return util::ShortestText(value.get<double>());
  return value.dump();
}

void SetField(double* field, const Json& value, const std::string& where) {
  if (!value.is_number() || !std::isfinite(value.get<double>())) {
    throw InputError(where + ": expected a finite number, got " + Quoted(value));
  }
  *field = value.get<double>();
}

void SetField(int* field, const Json& value, const std::string& where) {
  const bool in_range = value.is_number_unsigned() ? value.get<std::uint64_t>() <= 1000000000u
                                                   : value.is_number_integer() &&
                                                         value.get<std::int64_t>() >= -1000000000 &&
                                                         value.get<std::int64_t>() <= 1000000000;
  if (!in_range) {
    throw InputError(where + ": expected a whole number, got " + value.dump());
  }
  *field = value.get<int>();
}

void SetField(bool* field, const Json& value, const std::string& where) {
  if (!value.is_boolean()) throw InputError(where + ": expected true or false, got " + value.dump());
  *field = value.get<bool>();
}

// Text to the JSON value Set takes: true/false, else a number (the whole
// text; an integer when it has no '.', 'e' or 'E').
Json ParseValueText(const std::string& text, const std::string& where) {
  if (text == "true") return true;
  if (text == "false") return false;
  if (text.empty()) throw InputError(where + ": no value");
  if (std::isspace(static_cast<unsigned char>(text.front())) != 0) {
    throw InputError(where + ": '" + text + "' is not a number or true/false");
  }
  const bool integer = text.find_first_of(".eE") == std::string::npos &&
                       text.find_first_of("nNiI") == std::string::npos;
  errno = 0;
  char* end = nullptr;
  if (integer) {
    const long long value = std::strtoll(text.c_str(), &end, 10);
    if (*end == '\0' && errno == 0) return value;
  } else {
    const double value = std::strtod(text.c_str(), &end);
    if (*end == '\0' && errno == 0 && std::isfinite(value)) return value;
  }
  throw InputError(where + ": '" + text + "' is not a number or true/false");
}

std::string Format(double value) {
  std::ostringstream text;
  text.precision(6);
  text << value;
  return text.str();
}

}  // namespace

const std::vector<std::string>& HdaParamKeys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> list;
    hda::HdaOptions options;
    ForEachField(options, [&](const char* key, auto&) { list.emplace_back(key); });
    return list;
  }();
  return keys;
}

const std::vector<std::string>& LanderParamKeys() {
  static const std::vector<std::string> keys = [] {
    std::vector<std::string> list;
    datasets::synth::LanderGeometry lander;
    ForEachLanderField(lander, [&](const char* key, auto&) { list.emplace_back(key); });
    return list;
  }();
  return keys;
}

Json LanderJson(const datasets::synth::LanderGeometry& lander) {
  Json j = Json::object();
  ForEachLanderField(lander, [&](const std::string& key, const auto& value) { j[key.substr(key.find('.') + 1)] = value; });
  return j;
}

Json HdaOptionsJson(const hda::HdaOptions& options) {
  Json j = Json::object();
  ForEachField(options, [&](const std::string& key, const auto& value) {
    const size_t dot = key.find('.');
    if (dot == std::string::npos) {
      j[key] = value;
    } else {
      j[key.substr(0, dot)][key.substr(dot + 1)] = value;
    }
  });
  return j;
}

void HdaSettings::Set(const std::string& key, const Json& value, const std::string& where) {
  bool found = false;
  ForEachField(options, [&](const char* name, auto& field) {
    if (key != name) return;
    found = true;
    SetField(&field, value, where + ": " + key);
  });
  ForEachLanderField(lander, [&](const char* name, auto& field) {
    if (key != name) return;
    found = true;
    SetField(&field, value, where + ": " + key);
  });
  if (!found) {
    throw InputError(where + ": unknown flight-method parameter '" + key + "'; known: " + KnownKeys());
  }
  given.insert(key);
}

void HdaSettings::SetText(const std::string& key, const std::string& value, const std::string& where) {
  Set(key, ParseValueText(value, where + ": " + key), where);
}

void HdaSettings::SetAll(const Json& object, const std::string& where) {
  if (!object.is_object()) throw InputError(where + ": expected a JSON object of parameter: value");
  for (const auto& item : object.items()) {
    if (IsComment(item.key())) continue;
    if (item.value().is_object()) {
      for (const auto& inner : item.value().items()) {
        if (IsComment(inner.key())) continue;
        Set(item.key() + "." + inner.key(), inner.value(), where);
      }
    } else {
      Set(item.key(), item.value(), where);
    }
  }
}

Json HdaSettings::GivenJson() const {
  Json j = Json::object();
  ForEachField(options, [&](const std::string& key, const auto& value) {
    if (given.count(key) > 0) j[key] = value;
  });
  ForEachLanderField(lander, [&](const std::string& key, const auto& value) {
    if (given.count(key) > 0) j[key] = value;
  });
  return j;
}

void HdaSettings::ReadFile(const std::string& path) {
  std::string text, error;
  if (!util::ReadFileBytes(path, &text, &error)) {
    throw InputError(path + ": cannot read the parameter file (" + error + ")");
  }
  Json j;
  try {
    j = Json::parse(text);
  } catch (const Json::exception& e) {
    throw InputError(path + ": not valid JSON: " + util::JsonErrorText(e.what()));
  }
  if (j.is_object() && j.contains("format") && j["format"] != "hdabench-flight-params") {
    throw InputError(path + ": field 'format' must be \"hdabench-flight-params\"");
  }
  if (j.is_object() && j.contains("parameters")) {
    for (const auto& item : j.items()) {
      if (item.key() != "parameters" && !IsComment(item.key())) {
        throw InputError(path + ": field '" + item.key() +
                         "' beside 'parameters'; expected format, description or comments (*_why)");
      }
    }
    SetAll(j["parameters"], path + ": parameters");
    return;
  }
  SetAll(j, path);
}

void HdaSettings::Validate(const std::string& where) const {
  std::vector<std::string> errors = options.Validate();
  for (std::string& e : lander.Validate()) errors.push_back(std::move(e));
  ThrowIfInvalid(where + ": unusable flight-method parameters: ", errors);
}

double OrbKeypointDensity(const cv::Mat& image, const hda::MatchingOptions& matching, double min_lit_dn) {
  const cv::Mat eight = hda::ToEightBit(image, "image 1");
  const int lit = cv::countNonZero(eight >= min_lit_dn);
  if (lit == 0) return 0.0;
  // No cap that could bind: ORB gives level l at most nfeatures * s^-l *
  // (1 - 1/s) / (1 - s^-L) keypoints (s the scale factor, L the levels) and
  // the level has P s^-2l pixels (P image 1's), one keypoint each at most; as
  // (1 - s^-L) / (1 - 1/s) <= L, nfeatures = L * P never cuts. (A larger
  // number only makes ORB reserve, and under AddressSanitizer poison,
  // gigabytes of keypoints.)
  const double uncapped = std::min(static_cast<double>(matching.orb_levels) * static_cast<double>(eight.total()) + 1000.0,
                                   static_cast<double>(std::numeric_limits<int>::max() / 4));
  return static_cast<double>(hda::CountOrbKeypoints(eight, matching, static_cast<int>(uncapped))) / lit;
}

const std::vector<std::string>& GeometryScaledKeys() {
  static const std::vector<std::string> keys = {"quadtree.site_size_m", "max_hazard_height_m",
                                                "max_roughness_rms_m",    "max_relief_m",
                                                "prediction.range_sigma_m",
                                                "prediction.nav_position_sigma_m"};
  return keys;
}

namespace {

// The site side from the geometry (ResolveHdaOptions' rule for
// quadtree.site_size_m): the value and the rule in words with its numbers.
DerivedParam SiteFromGeometry(const hda::HdaOptions& o, const calib::CameraModel& camera,
                              const PairGeometry& geometry) {
  const double range = geometry.lrf_range_m;
  const hda::HdaOptions defaults;
  // The lander's site, unless its image is smaller than one ORB patch (it
  // could hold no keypoint of its own) or than the side that holds
  // kSiteKeypointsPerFitPoint * min_points keypoints at image 1's density,
  // or larger than a quarter of the image's smaller side (the quadtree
  // could place too few sites); the last bound over the others.
  const double lander_m = defaults.quadtree.site_size_m;
  double lander_px =
      hda::ProjectedSiteSidePx(camera, range, lander_m, "flight-method site size from the geometry");
  // Near the axis a site's side is in proportion to it. A site that, so
  // measured, is wider than the image has its edges where the lens model
  // is extrapolated (a distortion polynomial can blow up or fold back
  // there): the near-axis side chooses the bound.
  const double probe_m = kSiteProbeFraction * range;
  const double near_axis_px =
      lander_m / probe_m *
      hda::ProjectedSiteSidePx(camera, range, probe_m, "flight-method site size from the geometry");
  std::string lander_how;
  if (near_axis_px > std::max(camera.WidthPx(), camera.HeightPx())) {
    lander_px = near_axis_px;
    lander_how = " (a small site's side scaled up: wider than the image)";
  }
  double lo_px = o.matching.orb_patch_size_px;
  std::string lo_why = "one ORB patch";
  const double density = geometry.keypoints_per_px;
  if (std::isfinite(density) && density > 0) {
    const double texture_px = std::sqrt(kSiteKeypointsPerFitPoint * o.min_points / density);
    if (texture_px > lo_px) {
      lo_px = texture_px;
      lo_why = "the side holding " + Format(kSiteKeypointsPerFitPoint * o.min_points) +
               " ORB keypoints at image 1's " + Format(1000.0 * density) + " per 1000 lit px^2";
    }
  }
  const double hi_px = 0.25 * std::min(camera.WidthPx(), camera.HeightPx());
  const std::string hi_why = "a quarter of the image's smaller side";
  double site = lander_m;
  std::string why = "the lander's " + Format(lander_m) + " m site: " + Format(lander_px) +
                    " px at " + Format(range) + " m, within [" + Format(lo_px) + ", " + Format(hi_px) +
                    "] px";
  // The upper bound wins: an image too small for the lower one still gets
  // sites, whose ROIs then say why they fail.
  const double target_px = std::min(std::max(lander_px, lo_px), hi_px);
  if (target_px != lander_px) {
    site = lander_m * target_px / lander_px;
    // The side is linear in the site only while the lens model projects
    // the site's edges as it does near the axis: a lander's site seen from
    // a few metres reaches far outside the calibrated field, where a
    // distortion polynomial can put it a million pixels wide. Rescaled
    // until the site's own side is the target.
    // The closest of the tries is kept.
    double best_site = site, best_px = kInfinitePx;
    for (int i = 0; i <= kSiteRescalings; ++i) {
      const double side_px =
          hda::ProjectedSiteSidePx(camera, range, site, "flight-method site size from the geometry");
      if (!(side_px > 0.0) || !std::isfinite(side_px)) break;
      if (std::abs(side_px - target_px) < std::abs(best_px - target_px)) {
        best_site = site;
        best_px = side_px;
      }
      if (std::abs(side_px - target_px) <= kSiteTolerancePx) break;
      site *= target_px / side_px;
    }
    site = best_site;
    const double side_px = best_px;
    const bool up = target_px > lander_px;
    why = "the lander's " + Format(lander_m) + " m site is " + Format(lander_px) + " px" + lander_how + " at " +
          Format(range) + " m, " + (up ? "under " + lo_why : "over " + hi_why) +
          (lo_px > hi_px ? " (" + lo_why + " is " + Format(lo_px) + " px, over " + hi_why + ")" : "") +
          ": the site scaled to " + Format(target_px) + " px";
    if (!(std::abs(side_px - target_px) <= kSiteTolerancePx)) {
      why += " (its side is " + Format(side_px) + " px: the lens model does not project it in proportion)";
    }
  }
  return {"quadtree.site_size_m", site, why};
}

// The hazard limits of a site scaled with the geometry (ResolveHdaOptions'
// rule): a site scaled with the geometry stands for a lander scaled as much,
// so its hazard limits scale with it (a 41 m site at 2.5 km; a kilometre one
// at 30 km, where a relief of the lander's 0.15 m is far under the points'
// noise and any site would be "unsafe roughness"). Only the keys not given.
void ScaleHazardLimits(double site_m, const std::function<bool(const std::string&)>& free, hda::HdaOptions* o,
                       std::vector<DerivedParam>* out) {
  const hda::HdaOptions defaults;
  const double lander_m = defaults.quadtree.site_size_m;
  const double site_scale = site_m / lander_m;
  const std::string scaled = site_scale == 1.0 ? " (the site is the lander's)"
                                               : " scaled by the site's " + Format(site_m) +
                                                     " m against the lander's " + Format(lander_m) + " m";
  if (free("max_hazard_height_m")) {
    o->max_hazard_height_m = defaults.max_hazard_height_m * site_scale;
    out->push_back({"max_hazard_height_m", o->max_hazard_height_m,
                    "the lander's " + Format(defaults.max_hazard_height_m) + " m" + scaled});
  }
  if (free("max_roughness_rms_m")) {
    o->max_roughness_rms_m = defaults.max_roughness_rms_m * site_scale;
    out->push_back({"max_roughness_rms_m", o->max_roughness_rms_m,
                    "the lander's " + Format(defaults.max_roughness_rms_m) + " m" + scaled});
  }
}

}  // namespace

hda::HdaOptions ResolveHdaOptions(const HdaSettings& settings, const calib::CameraModel& camera,
                                  const PairGeometry& geometry, std::vector<DerivedParam>* derived) {
  const double range = geometry.lrf_range_m;
  const double baseline = geometry.baseline_m;
  if (!(std::isfinite(range) && range > 0)) {
    throw InputError("flight-method parameters from the geometry: LRF range " + Format(range) +
                     " m: expected finite and > 0");
  }
  hda::HdaOptions o = settings.options;
  const hda::HdaOptions defaults;
  std::vector<DerivedParam> out;
  const auto free = [&](const std::string& key) { return settings.given.count(key) == 0; };
  const double range_scale = range / kDesignRangeM;
  // A pair without a baseline keeps the default nav sigma; its ROIs end
  // degenerate in the method itself.
  const double baseline_scale = baseline / kDesignBaselineM;

  if (free("quadtree.site_size_m")) {
    const DerivedParam site = SiteFromGeometry(o, camera, geometry);
    o.quadtree.site_size_m = site.value;
    out.push_back(site);
    ScaleHazardLimits(site.value, free, &o, &out);
  }
  if (free("max_relief_m")) {
    o.max_relief_m = defaults.max_relief_m * range_scale;
    out.push_back({"max_relief_m", o.max_relief_m,
                   Format(defaults.max_relief_m) + " m at " + Format(kDesignRangeM) +
                       " m of range, scaled with the LRF range " + Format(range) + " m"});
  }
  if (free("prediction.range_sigma_m")) {
    o.prediction.range_sigma_m = defaults.prediction.range_sigma_m * range_scale;
    out.push_back({"prediction.range_sigma_m", o.prediction.range_sigma_m,
                   Format(defaults.prediction.range_sigma_m) + " m at " + Format(kDesignRangeM) +
                       " m of range, scaled with the LRF range " + Format(range) + " m"});
  }
  if (free("prediction.nav_position_sigma_m") && std::isfinite(baseline) && baseline > 0) {
    o.prediction.nav_position_sigma_m = defaults.prediction.nav_position_sigma_m * baseline_scale;
    out.push_back({"prediction.nav_position_sigma_m", o.prediction.nav_position_sigma_m,
                   Format(defaults.prediction.nav_position_sigma_m) + " m over " +
                       Format(kDesignBaselineM) + " m of baseline, scaled with the baseline " +
                       Format(baseline) + " m"});
  }
  if (derived != nullptr) *derived = std::move(out);
  return o;
}

}  // namespace hdabench::reference
