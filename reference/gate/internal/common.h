// What the gate's files share (reference/gate/): reading its JSON files,
// the metrics' names and order, the names of an entry's files, and the hashes
// that name folders. Internal to reference_gate.
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reference/compare/compare.h"  // ColmapOptions
#include "reference/gate/gate.h"
#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::reference::gate_internal {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

inline Json ReadJsonFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  try {
    return Json::parse(text.str());
  } catch (const Json::exception& e) {
    throw InputError(path + ": not valid JSON: " + util::JsonErrorText(e.what()));
  }
}

// Checks that `object` has only `allowed` keys; throws naming the first other.
inline void OnlyKeys(const Json& object, const std::set<std::string>& allowed, const std::string& where) {
  for (const auto& item : object.items()) {
    if (allowed.count(item.key()) == 0) throw InputError(where + ": unknown field '" + item.key() + "'");
  }
}

inline void CheckFormat(const Json& j, const std::string& name, const std::string& path) {
  if (!j.is_object()) throw InputError(path + ": expected a JSON object");
  if (!j.contains("format") || j["format"] != name) {
    throw InputError(path + ": field 'format' must be \"" + name + "\"");
  }
  if (!j.contains("format_version") || j["format_version"] != kGateFormatVersion) {
    throw InputError(path + ": field 'format_version' must be " + std::to_string(kGateFormatVersion));
  }
}

inline std::string StringField(const Json& j, const std::string& key, const std::string& where) {
  if (!j.contains(key) || !j[key].is_string()) {
    throw InputError(where + ": field '" + key + "' must be a string");
  }
  return j[key].get<std::string>();
}

inline double NumberField(const Json& j, const std::string& key, const std::string& where) {
  if (!j[key].is_number() || !std::isfinite(j[key].get<double>())) {
    throw InputError(where + ": field '" + key + "' must be a finite number");
  }
  return j[key].get<double>();
}

inline bool ValidName(const std::string& name) {
  return !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '.' || c == '_' || c == '-';
  }) && name != "." && name != "..";
}

inline const std::vector<std::string>& MetricNames() {
  static const std::vector<std::string> names = {
      "slope_error_median_deg", "slope_error_p90_deg",   "slope_error_max_deg",
      "tilt_error_median_deg",  "tilt_error_p90_deg",    "slope_bias_abs_deg",
      "roughness_error_median_m", "rois_with_slope_share", "within_two_sigma_share",
      "flight_seconds_per_pair", "failed_entries",        "slope_error_rois",
      "observability_p95_deg",  "observability_median_deg", "observability_sigma_ratio",
      "decision_sites",         "truly_unsafe_share",    "false_safe_rate",
      "false_safe_upper_95",    "missed_safe_rate",      "unsafe_caught_rate",
      "top_site_unsafe_share",  "calibration_sigma_share_p90"};
  return names;
}

// Higher is better for these metrics; lower for the others.
inline bool HigherIsBetter(const std::string& metric) {
  return metric == "rois_with_slope_share" || metric == "within_two_sigma_share" ||
         metric == "slope_error_rois" || metric == "decision_sites" || metric == "truly_unsafe_share" ||
         metric == "unsafe_caught_rate";
}

inline std::string FormatValue(double value) { return util::FixedCell(value, 3); }

// The methods compared on an entry: its own, or the suite's.
inline const std::vector<std::string>& EntryMethods(const GateEntry& e, const GateSuite& suite) {
  return e.methods.empty() ? suite.methods : e.methods;
}

// A method's pool as a person reads it: "flight", "flight under lrf-absent".
inline std::string MethodLabel(const std::string& method, const std::string& fault,
                               const std::string& pool = "") {
  const std::string on_pool = pool.empty() ? method : method + " on " + pool;
  return fault.empty() ? on_pool : on_pool + " under " + fault;
}

inline std::string Hex(std::uint64_t value) {
  static const char* digits = "0123456789abcdef";
  std::string text(16, '0');
  for (int i = 15; i >= 0; --i, value >>= 4) text[static_cast<size_t>(i)] = digits[value & 15];
  return text;
}

// FNV-1a of the text: names a dataset by what it was made from.
inline std::uint64_t Fnv1a(const std::string& text) {
  std::uint64_t hash = 1469598103934665603ULL;
  for (const char c : text) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 1099511628211ULL;
  }
  return hash;
}

inline constexpr char kEntryRecord[] = "gate_entry.json";

inline constexpr char kReportPage[] = "report.html";

inline constexpr char kStudyPage[] = "settings.csv";

// The page of a complete entry folder: an observability study's settings, or
// the comparison's report.
inline std::string EntryPage(const fs::path& entry_dir) {
  return fs::exists(entry_dir / "study.json") ? kStudyPage : kReportPage;
}

}  // namespace hdabench::reference::gate_internal
