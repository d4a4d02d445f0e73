// The flight method's parameters by name: every HdaOptions field under one
// key ("max_relief_m", "quadtree.site_size_m", "matching.ratio_test"), read
// from a JSON parameter file (`--params FILE`), set one at a time
// (`--set hda.KEY=VALUE`, a gate suite entry's "hda" object), written into
// result.json, and the lengths that follow the geometry of the pair when not
// given (docs/flight-parameters.md).
#pragma once

#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "calib/camera_model.h"
#include "datasets/synth/lander_truth.h"
#include "hda/hda_options.h"

namespace hdabench::reference {

// Every key of HdaOptions, in the order of result.json's "options".
const std::vector<std::string>& HdaParamKeys();
// Every key of the lander ("lander.legs", ...), in the order of result.json's
// "lander": the truth's footprint and limits (datasets/synth/lander_truth.h),
// set in the same files and flags as the method's keys.
const std::vector<std::string>& LanderParamKeys();
// The lander as JSON, in the order of LanderParamKeys (result.json's "lander").
nlohmann::ordered_json LanderJson(const datasets::synth::LanderGeometry& lander);

// The options as JSON: nested objects for the nested options, in the order
// of HdaParamKeys (result.json's "options").
nlohmann::ordered_json HdaOptionsJson(const hda::HdaOptions& options);

// The flight method's options and which of them the user gave; a key not
// given and listed in GeometryScaledKeys follows the pair's geometry
// (ResolveHdaOptions). The lander's keys ("lander.*") set `lander`.
struct HdaSettings {
  hda::HdaOptions options;
  datasets::synth::LanderGeometry lander;
  std::set<std::string> given;

  // Sets one key from a JSON value (a number for the numeric fields, true or
  // false for the flags; an integer field takes only whole numbers) and marks
  // it given. Throws InputError naming `where` and the key; an unknown key's
  // message lists the known ones.
  void Set(const std::string& key, const nlohmann::ordered_json& value, const std::string& where);
  // The same from text (`--set hda.KEY=VALUE` gives "KEY", "VALUE"): a number,
  // or true/false.
  void SetText(const std::string& key, const std::string& value, const std::string& where);
  // Every key of a JSON object, nested ({"quadtree": {"site_size_m": 40}})
  // or dotted ({"quadtree.site_size_m": 40}); "format"/"description"/"why"
  // keys and keys ending in "_why" are comments and skipped.
  void SetAll(const nlohmann::ordered_json& object, const std::string& where);
  // SetAll on the file's JSON object; the errors name the file.
  void ReadFile(const std::string& path);
  // The given keys and their values, dotted keys in HdaParamKeys' order
  // ({"quadtree.site_size_m": 40}): what SetAll takes back.
  nlohmann::ordered_json GivenJson() const;
  // The options' own check (HdaOptions::Validate) and the lander's, as one
  // InputError naming `where`.
  void Validate(const std::string& where) const;
};

// The keys whose default follows the geometry (docs/flight-parameters.md).
const std::vector<std::string>& GeometryScaledKeys();

// One value set from the geometry: the key, the value and the rule in words
// with its numbers.
struct DerivedParam {
  std::string key;
  double value = 0.0;
  std::string rule;
};

// The geometry of one pair that the defaults follow, and the texture of
// image 1 at the method's ORB settings.
struct PairGeometry {
  double lrf_range_m = 0.0;  // LRF slant range at frame 1, metres
  double baseline_m = 0.0;   // navigation baseline between the frames, metres
  // ORB keypoints per lit pixel of image 1 (OrbKeypointDensity); not finite
  // or <= 0: unknown, the site follows the geometry only.
  double keypoints_per_px = 0.0;
};

// Keypoints of cv::ORB at `matching`'s pyramid, FAST threshold and patch,
// over the whole of `image` (CV_8UC1 or CV_16UC1), per pixel whose 8-bit
// brightness is at least `min_lit_dn` (the quadtree's shadow limit): how many
// keypoints a site of n x n lit pixels holds, on average, is n^2 times this.
// 0 for an image without lit pixels.
double OrbKeypointDensity(const cv::Mat& image, const hda::MatchingOptions& matching, double min_lit_dn);

// Keypoints a site should hold on average, per point the plane fit needs
// (min_points): matching, the epipolar RANSAC and the depth test keep a
// median 55-65 % of an ROI's keypoints (p90 71-77 %; none in about a tenth of
// the ROIs), measured on the synthetic presets and StereoLunar
// (docs/flight-parameters.md): 5 leaves a margin of about 3 over the median.
inline constexpr double kSiteKeypointsPerFitPoint = 5.0;

// The options for one pair: the given keys as given, every other key of
// GeometryScaledKeys from `geometry` and `camera` by its rule, the rest at
// HdaOptions' defaults. `derived` (may be null) receives one entry per value
// set from the geometry. A baseline that is not finite and > 0 leaves the
// nav sigma at its default (the method reports such a pair's ROIs
// degenerate). Throws InputError when the range is not finite and > 0, or
// the camera cannot project a site at the image centre.
hda::HdaOptions ResolveHdaOptions(const HdaSettings& settings, const calib::CameraModel& camera,
                                  const PairGeometry& geometry, std::vector<DerivedParam>* derived);

// The design point the rules scale from: the NOVA-C geometry (docs/flight-parameters.md).
inline constexpr double kDesignRangeM = 566.0;     // LRF slant range, metres
inline constexpr double kDesignBaselineM = 30.0;   // lateral baseline, metres

}  // namespace hdabench::reference
