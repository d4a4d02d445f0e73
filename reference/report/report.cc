#include "reference/report/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <future>
#include <limits>
#include <map>
#include <system_error>
#include <utility>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "datasets/map_preview.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/parallel_for.h"
#include "tools/util/process.h"
#include "tools/util/python_script.h"
#include "reference/compare/compare_outputs.h"
#include "reference/flight/flight_outputs.h"
#include "tools/util/text.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Exit code of report_plots.py when matplotlib or numpy cannot be imported.
constexpr int kPlotsExitNoMatplotlib = 5;

// ---------------------------------------------------------------- files

std::string ReadFileOrThrow(const fs::path& path) {
  std::string bytes, error;
  if (!util::ReadFileBytes(path, &bytes, &error)) {
    throw InputError(path.string() + ": " + error);
  }
  return bytes;
}

Json ParseJsonFile(const fs::path& path) {
  const std::string text = ReadFileOrThrow(path);
  try {
    return Json::parse(text);
  } catch (const Json::exception& e) {
    throw InputError(path.string() + ": not valid JSON (" + util::JsonErrorText(e.what()) + ")");
  }
}

// Checks the "format" and "format_version" keys of a record the report reads.
void CheckFormat(const Json& json, const fs::path& path, const std::string& format, int version) {
  if (!json.is_object() || !json.contains("format") || json["format"] != format) {
    throw InputError(path.string() + ": format is not \"" + format + "\"");
  }
  if (!json.contains("format_version") || !json["format_version"].is_number_integer() ||
      json["format_version"].get<int>() != version) {
    throw InputError(path.string() + ": format_version " +
                     (json.contains("format_version") ? json["format_version"].dump() : "missing") +
                     ": this hdabench reads " + std::to_string(version));
  }
}

// A member of a JSON object, null when absent (or when `json` is no object).
const Json& Member(const Json& json, const char* key) {
  static const Json null_value;
  if (!json.is_object()) return null_value;
  const auto it = json.find(key);
  return it == json.end() ? null_value : *it;
}

// An element of a JSON array, null when absent.
const Json& Element(const Json& json, size_t index) {
  static const Json null_value;
  return json.is_array() && index < json.size() ? json[index] : null_value;
}

bool IsNumber(const Json& j) { return j.is_number() && std::isfinite(j.get<double>()); }
std::string Fixed(const Json& j, int digits) {
  return IsNumber(j) ? util::FixedCell(j.get<double>(), digits) : "-";
}
std::string Text(const Json& j) {
  if (j.is_string()) return j.get<std::string>();
  if (j.is_null()) return "";
  return j.dump();
}
int IntOr(const Json& j, int fallback) { return j.is_number_integer() ? j.get<int>() : fallback; }

// The largest sizes at which the page shows an image (Css()): the page's
// width, and in a grid (the ROI pairs, the maps) also the grid's height.
const cv::Size kPageWide(reference::kFigureShownWidthPx, std::numeric_limits<int>::max());
const cv::Size kInGrid(reference::kFigureShownWidthPx, reference::kFigureGridHeightPx);
// The landing decisions and the safety map, side by side at the top of the page.
const cv::Size kHalfPage(reference::kFigureHalfWidthPx, 900);

// A PNG fitted into `shown`: area-averaged (datasets::PreviewPng) to the
// largest size that fits when it is larger; the bytes unchanged when it fits
// or when OpenCV cannot decode them. The flight figures a run draws fit
// already (reference::kFigureShownWidthPx); those of older runs, and the
// maps, are shrunk here, so that the page embeds no pixel it does not show.
std::string FittedPng(const std::string& bytes, const cv::Size& shown) {
  int width = 0, height = 0;
  if (!datasets::PngSizeOf(bytes, &width, &height) || width <= 0 || height <= 0 ||
      (width <= shown.width && height <= shown.height)) {
    return bytes;
  }
  const double scale = std::min(shown.width / static_cast<double>(width), shown.height / static_cast<double>(height));
  const int side = std::max(1, static_cast<int>(std::floor(scale * std::max(width, height))));
  const std::string fitted = datasets::PreviewPngOfBytes(bytes, side);
  return fitted.empty() ? bytes : fitted;
}

std::string ShrunkNote(const std::string& bytes) {
  int width = 0, height = 0;
  datasets::PngSizeOf(bytes, &width, &height);
  return "shrunk from " + std::to_string(width) + " x " + std::to_string(height) + " px";
}

// A map as the report shows it, fitted into a grid cell, with "shrunk from
// W x H px" in `note` when it is; the bytes unchanged when they fit or when
// OpenCV cannot decode them. A map larger than a preview
// (datasets/map_preview.h) is fitted from its preview: the one written beside
// the map (maps/preview/) when it has the preview's size for the map's,
// otherwise the same bytes made here from a decode of the map.
std::string MapAsShown(const std::string& bytes, const fs::path& preview_path, std::string* note) {
  int width = 0, height = 0;
  if (!datasets::PngSizeOf(bytes, &width, &height)) return bytes;
  std::string smaller = bytes;
  if (std::max(width, height) > datasets::kMapPreviewSidePx) {
    std::string preview, error;
    int preview_width = 0, preview_height = 0;
    const cv::Size expected = datasets::PreviewSize(width, height, datasets::kMapPreviewSidePx);
    if (!(fs::is_regular_file(preview_path) && util::ReadFileBytes(preview_path, &preview, &error) &&
          datasets::PngSizeOf(preview, &preview_width, &preview_height) && preview_width == expected.width &&
          preview_height == expected.height)) {
      preview = datasets::PreviewPngOfBytes(bytes, datasets::kMapPreviewSidePx);
    }
    if (!preview.empty()) smaller = preview;
  }
  const std::string shown = FittedPng(smaller, kInGrid);
  if (shown != bytes) *note = ShrunkNote(bytes);
  return shown;
}

// ---------------------------------------------------------------- text

// Markdown table cells must not hold '|' or line breaks.
std::string MdCell(const std::string& text) {
  std::string out;
  for (const char c : text) {
    if (c == '|') {
      out += "\\|";
    } else if (c == '\n') {
      out += ' ';
    } else {
      out += c;
    }
  }
  return out;
}

// A CSS class name for a status ("unsafe slope" -> "st-unsafe-slope").
std::string StatusClass(const std::string& status) {
  std::string out = "st-";
  for (const char c : status) {
    out += (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ? c : '-';
  }
  return out;
}

// ---------------------------------------------------------------- the page model

struct Figure {
  std::string id;       // HTML id, file-name-like
  std::string title;
  std::string caption;
  std::string png;      // the bytes
};

struct Cell {
  std::string text;
  std::string css_class;  // empty: none
  std::string title;      // tooltip (a status's reason); empty: none
};

struct Table {
  std::string id;
  std::vector<std::string> header;
  std::vector<std::vector<Cell>> rows;
};

struct Page {
  std::string kind;                    // "run" or "compare"
  std::string dataset_name;            // as the record names it
  std::string heading;                 // first line
  std::vector<std::string> facts;      // "key: value" lines under the heading
  std::vector<std::string> failures;   // failed methods with their reasons
  std::vector<std::string> notes;      // what is missing
  Table summary;                       // per method (compare) or per status (run)
  std::vector<std::string> summary_lines;  // statistics sentences
  Table rois;                          // the per-ROI table
  std::vector<Figure> plots;           // matplotlib's
  std::string plots_error;             // why there are no plots; empty when they are there
  std::vector<Figure> flight_figures;  // quadtree, matches
  std::vector<Figure> roi_pairs;       // figures/roi_pairs/*.png
  std::vector<Figure> maps;            // the dataset's maps
  std::string dataset_dir;             // where the maps come from
  // What a person looks at first: the landing decisions against the
  // lander's truth, in one line (run) or one row per method (compare), and
  // image 1 with every site in its decision class beside the truth's safety map.
  std::vector<std::string> decision_lines;
  Table decisions;
  std::vector<Figure> decision_figures;
};

std::string StatsText(const Json& stats, int digits) {
  if (IntOr(Member(stats, "count"), 0) == 0) return "-";
  return Fixed(Member(stats, "median"), digits) + " / " + Fixed(Member(stats, "p90"), digits) +
         " / " + Fixed(Member(stats, "max"), digits) + " (" +
         std::to_string(IntOr(Member(stats, "count"), 0)) + ")";
}

std::string Percent(const Json& fraction) {
  return IsNumber(fraction) ? util::FixedCell(100.0 * fraction.get<double>(), 0) : "-";
}

// ---------------------------------------------------------------- run folders

// The statuses in the order of hda::RoiStatus (docs/flight-results.md).
const std::vector<std::string>& FlightStatuses() {
  static const std::vector<std::string> statuses = {
      "evaluated",      "unsafe slope",   "unsafe roughness", "degenerate",
      "too few points", "not in image 2", "not evaluated"};
  return statuses;
}

// ---------------------------------------------------------------- record checks

// What the report reads of a record must be of its kind where it is there:
// an absent or null value shows as "-" (a record written before the key
// existed, or a value the run did not have), one of another kind is damage,
// refused with the file, the place in it and the key, before anything is
// written.
enum class Kind { kNumber, kInteger, kString, kBool, kObject, kArray };

const char* KindName(Kind kind) {
  switch (kind) {
    case Kind::kNumber:
      return "a finite number";
    case Kind::kInteger:
      return "an integer";
    case Kind::kString:
      return "a string";
    case Kind::kBool:
      return "true or false";
    case Kind::kObject:
      return "an object";
    case Kind::kArray:
      return "an array";
  }
  return "?";
}

bool OfKind(const Json& value, Kind kind) {
  switch (kind) {
    case Kind::kNumber:
      return value.is_number() && std::isfinite(value.get<double>());
    case Kind::kInteger:
      return value.is_number_integer();
    case Kind::kString:
      return value.is_string();
    case Kind::kBool:
      return value.is_boolean();
    case Kind::kObject:
      return value.is_object();
    case Kind::kArray:
      return value.is_array();
  }
  return false;
}

std::string Place(const std::string& where, const std::string& key) {
  return where.empty() ? "key \"" + key + "\"" : where + ", key \"" + key + "\"";
}

[[noreturn]] void ThrowDamaged(const fs::path& path, const std::string& place, const std::string& expected,
                               const Json& found) {
  std::string text = found.dump();
  if (text.size() > 60) text = text.substr(0, 57) + "...";
  throw InputError(path.string() + ": " + place + ": expected " + expected + ", found " + text);
}

// Checks that each key of `object` that is there and not null is of its kind.
// `object` itself: an object, or absent (null).
void CheckKinds(const Json& object, const fs::path& path, const std::string& where,
                std::initializer_list<std::pair<const char*, Kind>> keys) {
  if (object.is_null()) return;
  if (!object.is_object()) ThrowDamaged(path, where, "an object", object);
  for (const auto& [key, kind] : keys) {
    const Json& value = Member(object, key);
    if (!value.is_null() && !OfKind(value, kind)) ThrowDamaged(path, Place(where, key), KindName(kind), value);
  }
}

// The elements of an array that is there: each of `kind`.
void CheckElements(const Json& array, const fs::path& path, const std::string& where, Kind kind) {
  if (!array.is_array()) return;
  for (size_t i = 0; i < array.size(); ++i) {
    if (!OfKind(array[i], kind)) {
      ThrowDamaged(path, where + ", element " + std::to_string(i), KindName(kind), array[i]);
    }
  }
}

// A key the record's format requires: there, and an array.
void RequireArray(const Json& record, const char* key, const fs::path& path) {
  if (!Member(record, key).is_array()) ThrowDamaged(path, Place("", key), KindName(Kind::kArray), Member(record, key));
}

// An ROI's status: there, and one of `names`.
void CheckStatus(const Json& status, const std::vector<std::string>& names, const fs::path& path,
                 const std::string& where) {
  if (!status.is_string() || std::find(names.begin(), names.end(), status.get<std::string>()) == names.end()) {
    std::string expected = "one of";
    for (size_t i = 0; i < names.size(); ++i) expected += (i == 0 ? " \"" : ", \"") + names[i] + "\"";
    ThrowDamaged(path, Place(where, "status"), expected, status);
  }
}

// "rois[4] (ROI 5)": an element of a record's ROI list.
std::string RoiPlace(const Json& roi, size_t index) {
  const Json& id = Member(roi, "id");
  return "rois[" + std::to_string(index) + "]" + (id.is_number_integer() ? " (ROI " + id.dump() + ")" : "");
}

void CheckErrorStats(const Json& stats, const fs::path& path, const std::string& where) {
  CheckKinds(stats, path, where,
             {{"count", Kind::kInteger}, {"median", Kind::kNumber}, {"p90", Kind::kNumber}, {"max", Kind::kNumber}});
}

// What FillRunPage and the plots read of a run's result.json.
void CheckRunRecord(const Json& result, const fs::path& path) {
  CheckKinds(result, path, "",
             {{"dataset", Kind::kString}, {"frames", Kind::kArray}, {"inputs", Kind::kObject},
              {"budget_s", Kind::kNumber}, {"budget_exhausted", Kind::kBool}, {"status_counts", Kind::kObject}});
  RequireArray(result, "rois", path);
  CheckElements(Member(result, "frames"), path, "key \"frames\"", Kind::kInteger);
  CheckKinds(Member(result, "inputs"), path, "key \"inputs\"",
             {{"baseline_m", Kind::kNumber}, {"lrf_range_m", Kind::kNumber}});
  const Json& counts = Member(result, "status_counts");
  for (const std::string& status : FlightStatuses()) {
    CheckKinds(counts, path, "key \"status_counts\"", {{status.c_str(), Kind::kInteger}});
  }
  const Json& rois = Member(result, "rois");
  for (size_t i = 0; i < rois.size(); ++i) {
    const Json& roi = rois[i];
    const std::string where = RoiPlace(roi, i);
    if (!roi.is_object()) ThrowDamaged(path, where, "an object", roi);
    CheckKinds(roi, path, where,
               {{"id", Kind::kInteger}, {"reason", Kind::kString}, {"truth", Kind::kObject},
                {"fit", Kind::kObject}, {"counts", Kind::kObject}, {"score", Kind::kNumber},
                {"rank", Kind::kInteger}, {"slope_error_deg", Kind::kNumber}, {"tilt_error_deg", Kind::kNumber}});
    CheckStatus(Member(roi, "status"), FlightStatuses(), path, where);
    CheckKinds(Member(roi, "truth"), path, where + ", key \"truth\"",
               {{"available", Kind::kBool}, {"slope_deg", Kind::kNumber}, {"roughness_rms_m", Kind::kNumber}});
    CheckKinds(Member(roi, "fit"), path, where + ", key \"fit\"",
               {{"slope_deg", Kind::kNumber}, {"slope_sigma_deg", Kind::kNumber},
                {"roughness_excess_m", Kind::kNumber}});
    CheckKinds(Member(roi, "counts"), path, where + ", key \"counts\"", {{"depth_inliers", Kind::kInteger}});
  }
}

// The statuses a compare record's ROI can have: a reference method's (every
// MethodRoiStatus before kFlight, which is the enum's last), or the flight
// method's own.
std::vector<std::string> CompareStatuses() {
  std::vector<std::string> names;
  for (int s = 0; s < static_cast<int>(MethodRoiStatus::kFlight); ++s) {
    names.emplace_back(ToString(static_cast<MethodRoiStatus>(s)));
  }
  for (const std::string& status : FlightStatuses()) names.push_back(status);
  return names;
}

// What FillComparePage and the plots read of a compare.json.
void CheckCompareRecord(const Json& compare, const fs::path& path) {
  CheckKinds(compare, path, "",
             {{"dataset", Kind::kString}, {"frames", Kind::kArray}, {"baseline_m", Kind::kNumber},
              {"lrf_range_m", Kind::kNumber}, {"truth", Kind::kBool}, {"min_points_for_stats", Kind::kInteger}});
  RequireArray(compare, "methods", path);
  RequireArray(compare, "rois", path);
  CheckElements(Member(compare, "frames"), path, "key \"frames\"", Kind::kInteger);
  const Json& methods = Member(compare, "methods");
  for (size_t i = 0; i < methods.size(); ++i) {
    const Json& m = methods[i];
    const std::string where = "methods[" + std::to_string(i) + "]";
    if (!m.is_object()) ThrowDamaged(path, where, "an object", m);
    if (!Member(m, "name").is_string() || Member(m, "name").get<std::string>().empty()) {
      ThrowDamaged(path, Place(where, "name"), "a method's name", Member(m, "name"));
    }
    CheckKinds(m, path, where,
               {{"ok", Kind::kBool}, {"failure", Kind::kString}, {"point_accuracy", Kind::kObject},
                {"rois_with_fit", Kind::kInteger}, {"slope_bias_vs_truth_deg", Kind::kNumber},
                {"rotation_error_deg", Kind::kNumber}, {"translation_direction_error_deg", Kind::kNumber},
                {"slope_error_vs_truth_deg", Kind::kObject}, {"tilt_error_vs_truth_deg", Kind::kObject},
                {"tilt_definition_part_deg", Kind::kObject}, {"tilt_estimation_part_deg", Kind::kObject},
                {"roughness_error_vs_truth_m", Kind::kObject},
                {"slope_difference_vs_colmap_nav_deg", Kind::kObject}});
    CheckKinds(Member(m, "point_accuracy"), path, where + ", key \"point_accuracy\"",
               {{"within_0_1_m", Kind::kNumber}, {"within_0_3_m", Kind::kNumber}, {"within_1_m", Kind::kNumber},
                {"num_points", Kind::kInteger}});
    for (const char* stats : {"slope_error_vs_truth_deg", "tilt_error_vs_truth_deg", "tilt_definition_part_deg",
                              "tilt_estimation_part_deg", "roughness_error_vs_truth_m",
                              "slope_difference_vs_colmap_nav_deg"}) {
      CheckErrorStats(Member(m, stats), path, where + ", key \"" + stats + "\"");
    }
  }
  const std::vector<std::string> statuses = CompareStatuses();
  const Json& rois = Member(compare, "rois");
  for (size_t i = 0; i < rois.size(); ++i) {
    const Json& roi = rois[i];
    const std::string where = RoiPlace(roi, i);
    if (!roi.is_object()) ThrowDamaged(path, where, "an object", roi);
    CheckKinds(roi, path, where, {{"id", Kind::kInteger}, {"truth", Kind::kObject}, {"methods", Kind::kObject}});
    CheckKinds(Member(roi, "truth"), path, where + ", key \"truth\"", {{"slope_deg", Kind::kNumber}});
    // Every method's value, listed or not: the plots read them all.
    const Json& values = Member(roi, "methods");
    for (auto it = values.begin(); values.is_object() && it != values.end(); ++it) {
      const Json& v = it.value();
      if (v.is_null()) continue;  // shown as "no value"
      const std::string method_place = where + ", method \"" + it.key() + "\"";
      CheckKinds(v, path, method_place,
                 {{"reason", Kind::kString}, {"slope_deg", Kind::kNumber}, {"num_points", Kind::kInteger}});
      CheckStatus(Member(v, "status"), statuses, path, method_place);
    }
  }
}

// A folder's result.json (kind "run") or compare.json ("compare"), parsed
// and checked to be of its format, with what the report reads of it of its
// kind (CheckRunRecord, CheckCompareRecord).
Json ReadFolderResult(const fs::path& dir, const std::string& kind) {
  const bool compare = kind == "compare";
  const fs::path path = dir / (compare ? "compare.json" : "result.json");
  Json parsed = ParseJsonFile(path);
  if (compare) {
    CheckFormat(parsed, path, kCompareResultFormatName, kCompareResultFormatVersion);
    CheckCompareRecord(parsed, path);
  } else {
    CheckFormat(parsed, path, kFlightResultFormatName, kFlightResultFormatVersion);
    CheckRunRecord(parsed, path);
  }
  return parsed;
}

// `result`: the folder's result.json (ReadFolderResult).
void FillRunPage(const Json& result, Page* page) {
  const Json& rois = Member(result, "rois");  // an array (CheckRunRecord)
  const Json& frames = Member(result, "frames");

  page->dataset_name = Text(Member(result, "dataset"));
  page->heading = "Flight run of " + page->dataset_name;
  page->facts.push_back("dataset: " + Text(Member(result, "dataset")));
  page->facts.push_back("frames: " + Text(Element(frames, 0)) + ", " + Text(Element(frames, 1)));
  page->facts.push_back("baseline: " + Fixed(Member(Member(result, "inputs"), "baseline_m"), 2) +
                        " m, LRF range " +
                        Fixed(Member(Member(result, "inputs"), "lrf_range_m"), 1) + " m");
  page->facts.push_back("ROIs: " + std::to_string(rois.size()) + "; time budget " +
                        Fixed(Member(result, "budget_s"), 2) + " s of the flight computer" +
                        (Member(result, "budget_exhausted") == true ? " (ran out)" : ""));
  // The camera calibration's term in each slope's sigma (docs/calibration.md).
  const Json& term = Member(result, "calibration_term");
  const bool calibration = Member(term, "available") == true;
  if (calibration) {
    page->facts.push_back("calibration term: " + std::to_string(Member(term, "modes").size()) + " modes of " +
                          Text(Member(term, "model")) + ", corner noise " + Fixed(Member(term, "noise_stdev_px"), 3) +
                          " px; each slope's calibration sigma in the table, in quadrature with the method's in "
                          "the within-two-sigma share");
  } else if (term.is_object()) {
    page->facts.push_back("calibration term: none (" + Text(Member(term, "why")) + ")");
  }

  // Statuses and their counts.
  page->summary.id = "status-table";
  page->summary.header = {"status", "ROIs"};
  const Json& counts = Member(result, "status_counts");
  for (const std::string& status : FlightStatuses()) {
    page->summary.rows.push_back(
        {{status, StatusClass(status), ""}, {std::to_string(IntOr(Member(counts, status.c_str()), 0)), "", ""}});
  }

  // The flight table.
  Table& table = page->rois;
  table.id = "roi-table";
  table.header = {"ROI", "status", "truth slope (deg)", "est. slope (deg)", "sigma (deg)",
                  "# points", "truth rough. RMS (m)", "est. relief (m)", "score", "rank"};
  if (calibration) table.header.insert(table.header.begin() + 5, "calib. sigma (deg)");
  SlopeErrorPool pool;
  std::vector<DecisionSample> decision_samples;
  for (const Json& roi : rois) {
    const Json& truth = Member(roi, "truth");
    const bool has_truth = Member(truth, "available") == true;
    const Json& fit = Member(roi, "fit");
    const std::string status = Text(Member(roi, "status"));
    const int points = IntOr(Member(Member(roi, "counts"), "depth_inliers"), 0);
    table.rows.push_back({
        {Text(Member(roi, "id")), "", ""},
        {status, StatusClass(status), Text(Member(roi, "reason"))},
        {has_truth ? Fixed(Member(truth, "slope_deg"), 2) : "-", "", ""},
        {Fixed(Member(fit, "slope_deg"), 2), "", ""},
        {Fixed(Member(fit, "slope_sigma_deg"), 2), "", ""},
        {fit.is_object() ? std::to_string(points) : "-", "", ""},
        {has_truth ? Fixed(Member(truth, "roughness_rms_m"), 3) : "-", "", ""},
        {Fixed(Member(fit, "roughness_excess_m"), 3), "", ""},
        {Fixed(Member(roi, "score"), 3), "", ""},
        {Member(roi, "rank").is_number() ? Text(Member(roi, "rank")) : "-", "", ""},
    });
    if (calibration) {
      table.rows.back().insert(table.rows.back().begin() + 5,
                               {Fixed(Member(fit, "slope_sigma_calibration_deg"), 3), "",
                                Text(Member(fit, "calibration_sigma_why"))});
    }
    pool.Add(SampleOfFlightRecord(roi));
    decision_samples.push_back(DecisionOfFlightRecord(roi));
  }
  DecisionPool decisions;
  decisions.AddRun(decision_samples);
  if (decisions.sites() > 0) page->decision_lines.push_back("Landing decision: " + DecisionLine(decisions) + ".");
  if (pool.count() == 0) {
    page->summary_lines.push_back("Slope error: no ROI has a slope, truth and at least " +
                                  std::to_string(kMinPointsForSlopeStats) + " points.");
  } else {
    const ErrorStats errors = pool.Slope();
    const ErrorStats tilts = pool.Tilt();
    page->summary_lines.push_back(
        "Slope error over " + std::to_string(errors.count) + " ROI(s) with a slope, truth and at least " +
        std::to_string(kMinPointsForSlopeStats) + " points: median |error| " +
        util::FixedCell(errors.median, 2) + " deg, 90th percentile " + util::FixedCell(errors.p90, 2) + " deg, " +
        util::FixedCell(100.0 * pool.WithinTwoSigmaShare(), 0) + " % within 2 predicted sigmas.");
    if (tilts.count > 0) page->summary_lines.push_back(
        "Tilt error (angle to the true plane): median " + util::FixedCell(tilts.median, 2) +
        " deg, 90th percentile " + util::FixedCell(tilts.p90, 2) +
        " deg; slope bias (mean of estimated - true) " + util::SignedCell(pool.Bias(), 2) + " deg.");
  }
}

// The stage times of a flight run's timings.json against its budget, one line.
std::string TimingLine(const fs::path& timings_path, std::vector<std::string>* notes) {
  if (!fs::is_regular_file(timings_path)) {
    notes->push_back(timings_path.filename().string() + " is missing: no stage times.");
    return "";
  }
  const Json timings = ParseJsonFile(timings_path);
  CheckFormat(timings, timings_path, kFlightTimingsFormatName, kFlightResultFormatVersion);
  CheckKinds(timings, timings_path, "",
             {{"stages", Kind::kObject}, {"budget_s", Kind::kNumber}, {"budget_exhausted", Kind::kBool}});
  const Json& stages = Member(timings, "stages");
  for (auto it = stages.begin(); stages.is_object() && it != stages.end(); ++it) {
    CheckKinds(stages, timings_path, "key \"stages\"", {{it.key().c_str(), Kind::kNumber}});
  }
  const Json& total = Member(Member(timings, "stages"), "total_s");
  const Json& budget = Member(timings, "budget_s");
  // The budget is the flight computer's; a file written before the work was
  // counted has only this machine's time, which is not compared with it.
  const Json& flight = Member(timings, "flight_computer_s");
  std::string line;
  if (IsNumber(flight)) {
    line = "Flight method: " + Fixed(flight, 2) + " s on the flight computer (predicted from its counted work) of a " +
           Fixed(budget, 2) + " s budget";
    if (IsNumber(budget) && budget.get<double>() > 0.0) {
      line += " (" + util::FixedCell(100.0 * flight.get<double>() / budget.get<double>(), 0) + " %)";
    }
    line += "; " + Fixed(total, 3) + " s on this machine";
  } else {
    line = "Flight method time on this machine: " + Fixed(total, 3) + " s";
  }
  if (Member(timings, "budget_exhausted") == true) line += "; the budget ran out";
  return line + ".";
}

// ---------------------------------------------------------------- compare folders

// The seconds per method of the folder's compare_timings.json; a note on
// `page` when it is missing.
std::map<std::string, double> ReadCompareTimings(const fs::path& dir, Page* page) {
  std::map<std::string, double> seconds;
  const fs::path timings_path = dir / "compare_timings.json";
  if (fs::is_regular_file(timings_path)) {
    const Json timings = ParseJsonFile(timings_path);
    CheckFormat(timings, timings_path, kCompareTimingsFormatName, kCompareResultFormatVersion);
    CheckKinds(timings, timings_path, "", {{"methods", Kind::kArray}});
    const Json& timed = Member(timings, "methods");
    for (size_t i = 0; i < timed.size(); ++i) {
      const std::string where = "key \"methods\", element " + std::to_string(i);
      if (!timed[i].is_object()) ThrowDamaged(timings_path, where, "an object", timed[i]);
      CheckKinds(timed[i], timings_path, where, {{"name", Kind::kString}, {"seconds", Kind::kNumber}});
    }
    for (const Json& m : timed) {
      if (IsNumber(Member(m, "seconds"))) seconds[Text(Member(m, "name"))] = Member(m, "seconds").get<double>();
    }
  } else {
    page->notes.push_back("compare_timings.json is missing: no time per method.");
  }
  return seconds;
}

// The page's heading and facts: dataset, frames, geometry, counts.
void FillCompareFacts(const Json& compare, Page* page) {
  const Json& frames = Member(compare, "frames");
  const Json& methods = Member(compare, "methods");
  const Json& rois = Member(compare, "rois");
  page->dataset_name = Text(Member(compare, "dataset"));
  page->heading = "Comparison on " + page->dataset_name;
  page->facts.push_back("dataset: " + Text(Member(compare, "dataset")));
  page->facts.push_back("frames: " + Text(Element(frames, 0)) + ", " + Text(Element(frames, 1)));
  page->facts.push_back("baseline: " + Fixed(Member(compare, "baseline_m"), 2) + " m, LRF range " +
                        Fixed(Member(compare, "lrf_range_m"), 1) + " m");
  page->facts.push_back("ROIs: " + std::to_string(rois.size()) + "; methods: " +
                        std::to_string(methods.size()) +
                        (Member(compare, "truth") == true ? "; with truth" : "; no truth"));
}

// The per-method table, with each method's time; the methods' names in order.
std::vector<std::string> FillCompareMethodTable(const Json& compare, const std::map<std::string, double>& seconds,
                                                Page* page) {
  const Json& methods = Member(compare, "methods");
  std::vector<std::string> names;
  Table& summary = page->summary;
  summary.id = "method-table";
  summary.header = {"method", "status", "ROIs with a slope", "slope error vs truth (deg)",
                    "tilt error vs truth (deg)", "slope bias (deg)", "tilt: definition part (deg)",
                    "tilt: estimation part (deg)", "roughness error vs truth (m)", "slope diff. vs colmap-nav (deg)",
                    "points within 0.1 / 0.3 / 1 m (%)", "rotation / baseline-dir. error (deg)",
                    "time (s)"};
  for (const Json& m : methods) {
    const std::string name = Text(Member(m, "name"));
    names.push_back(name);
    const bool ok = Member(m, "ok") == true;
    if (!ok) page->failures.push_back(name + ": " + Text(Member(m, "failure")));
    const Json& accuracy = Member(m, "point_accuracy");
    const std::string accuracy_text =
        accuracy.is_object() ? Percent(Member(accuracy, "within_0_1_m")) + " / " +
                                   Percent(Member(accuracy, "within_0_3_m")) + " / " +
                                   Percent(Member(accuracy, "within_1_m")) + " (" +
                                   Text(Member(accuracy, "num_points")) + ")"
                             : "-";
    const Json& rotation = Member(m, "rotation_error_deg");
    const Json& direction = Member(m, "translation_direction_error_deg");
    const auto time = seconds.find(name);
    summary.rows.push_back({
        {name, "", ""},
        {ok ? "ok" : "failed", ok ? "" : "st-failed", ok ? "" : Text(Member(m, "failure"))},
        {Text(Member(m, "rois_with_fit")), "", ""},
        {StatsText(Member(m, "slope_error_vs_truth_deg"), 2), "", ""},
        {StatsText(Member(m, "tilt_error_vs_truth_deg"), 2), "", ""},
        {IsNumber(Member(m, "slope_bias_vs_truth_deg"))
             ? util::SignedCell(Member(m, "slope_bias_vs_truth_deg").get<double>(), 2)
             : "-",
         "", ""},
        {StatsText(Member(m, "tilt_definition_part_deg"), 2), "", ""},
        {StatsText(Member(m, "tilt_estimation_part_deg"), 2), "", ""},
        {StatsText(Member(m, "roughness_error_vs_truth_m"), 3), "", ""},
        {StatsText(Member(m, "slope_difference_vs_colmap_nav_deg"), 2), "", ""},
        {accuracy_text, "", ""},
        {IsNumber(rotation) || IsNumber(direction) ? Fixed(rotation, 3) + " / " + Fixed(direction, 2) : "-",
         "", ""},
        {time == seconds.end() ? "-" : util::FixedCell(time->second, 3), "", ""},
    });
  }
  page->summary_lines.push_back(
      "Errors are median / 90th percentile / max (count) over ROIs with a slope and at least " +
      std::to_string(IntOr(Member(compare, "min_points_for_stats"), kMinPointsForSlopeStats)) +
      " points; the tilt error is the angle between the fitted and the true plane, the slope bias the "
      "mean of slope - truth. The tilt error's parts are against the method's own truth, the plane of the "
      "truth points at the pixels its plane stands on, weighted as it weighs them: the definition part (own "
      "truth against the site's truth: where the method looks) and the estimation part (the method against "
      "its own truth: how well it measures).");
  return names;
}

// The landing decisions per method, read from the record by the one rule.
void FillCompareDecisions(const Json& compare, const std::vector<std::string>& names, Page* page) {
  const Json& rois = Member(compare, "rois");
  const Json& limit = Member(compare, "max_slope_deg");
  const double max_slope_deg = IsNumber(limit) ? limit.get<double>() : std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, std::vector<DecisionSample>> decided;
  for (const Json& roi : rois) {
    const Json& values = Member(roi, "methods");
    for (const std::string& name : names) {
      const Json& v = Member(values, name.c_str());
      if (v.is_object() && Member(v, "status").is_string()) {
        decided[name].push_back(DecisionOfCompareRecord(name, v, roi, max_slope_deg));
      }
    }
  }
  Table& decisions = page->decisions;
  decisions.id = "decision-table";
  decisions.header = {"method", "sites with a lander truth", "truly unsafe", "declared safe", "false-safe",
                      "false-safe 95 %", "missed-safe", "top site unsafe"};
  for (const std::string& name : names) {
    DecisionPool pool;
    pool.AddRun(decided[name]);
    if (pool.sites() == 0) continue;
    const auto percent = [](double v) { return std::isfinite(v) ? util::FixedCell(100.0 * v, 1) + " %" : "-"; };
    const Interval interval = pool.FalseSafeInterval();
    decisions.rows.push_back({
        {name, "", ""},
        {std::to_string(pool.sites()), "", ""},
        {std::to_string(pool.truly_unsafe()), "", ""},
        {std::to_string(pool.DeclaredSafe()), "", ""},
        {percent(pool.FalseSafeRate()), "", ""},
        {pool.DeclaredSafe() > 0 ? util::FixedCell(100.0 * interval.low, 1) + " - " +
                                       util::FixedCell(100.0 * interval.high, 1) + " %"
                                 : "-",
         "", ""},
        {percent(pool.MissedSafeRate()), "", ""},
        {pool.ranked_runs() > 0 ? (pool.TopSiteUnsafeShare() > 0.0 ? "yes" : "no") : "-", "", ""},
    });
  }
  if (!decisions.rows.empty()) {
    page->decision_lines.push_back(
        "Against the lander's truth at each site. The flight method declares by its status; every other "
        "method by its slope against the flight method's " + Fixed(limit, 1) +
        " deg (it has no hazard estimate). False-safe: truly unsafe among the sites declared safe; "
        "missed-safe: declared unsafe among the truly safe ones with a verdict.");
  }
}

// The per-ROI table: each method's slope, or its status, with the reason.
void FillCompareRoiTable(const Json& compare, const std::vector<std::string>& names, Page* page) {
  const Json& rois = Member(compare, "rois");
  Table& table = page->rois;
  table.id = "roi-table";
  table.header = {"ROI", "truth slope (deg)"};
  for (const std::string& name : names) table.header.push_back(name);
  for (const Json& roi : rois) {
    std::vector<Cell> row;
    row.push_back({Text(Member(roi, "id")), "", ""});
    row.push_back({Fixed(Member(Member(roi, "truth"), "slope_deg"), 2), "", ""});
    const Json& values = Member(roi, "methods");
    for (const std::string& name : names) {
      const Json& v = Member(values, name.c_str());
      const std::string status = Text(Member(v, "status"));
      const std::string reason = Text(Member(v, "reason"));
      if (IsNumber(Member(v, "slope_deg"))) {
        const bool confident = StatusHasSlope(name == kMethodFlight, status);
        row.push_back({Fixed(Member(v, "slope_deg"), 2) + " (" + Text(Member(v, "num_points")) + ")" +
                           (confident ? "" : " " + status),
                       StatusClass(status), reason});
      } else {
        row.push_back({"- (" + (status.empty() ? "no value" : status) + ")", StatusClass(status), reason});
      }
    }
    table.rows.push_back(std::move(row));
  }
}

// `compare`: the folder's compare.json (ReadFolderResult; its arrays checked
// by CheckCompareRecord).
void FillComparePage(const fs::path& dir, const Json& compare, Page* page) {
  const std::map<std::string, double> seconds = ReadCompareTimings(dir, page);
  FillCompareFacts(compare, page);
  const std::vector<std::string> names = FillCompareMethodTable(compare, seconds, page);
  FillCompareDecisions(compare, names, page);
  FillCompareRoiTable(compare, names, page);
}

// ---------------------------------------------------------------- figures

// Adds `path` as a figure when it is a PNG, fitted into `shown` (FittedPng;
// "shrunk from W x H px" added to the caption when it is); a note otherwise.
void AddPngFile(const fs::path& path, const std::string& id, const std::string& title,
                const std::string& caption, const cv::Size& shown, std::vector<Figure>* figures,
                std::vector<std::string>* notes) {
  const std::string bytes = ReadFileOrThrow(path);
  if (!datasets::IsPng(bytes)) {
    notes->push_back(path.string() + " is not a PNG file: left out.");
    return;
  }
  std::string png = FittedPng(bytes, shown);
  const std::string fitted = png == bytes ? "" : " (" + ShrunkNote(bytes) + ")";
  figures->push_back({id, title, caption + fitted, std::move(png)});
}

void AddRunFigures(const fs::path& figures_dir, Page* page) {
  if (!fs::is_directory(figures_dir)) {
    page->notes.push_back("No figures folder (" + figures_dir.string() +
                          "): the run was made with --no-figures.");
    return;
  }
  const fs::path quadtree = figures_dir / "quadtree.png";
  if (fs::is_regular_file(quadtree)) {
    AddPngFile(quadtree, "fig-quadtree", "Quadtree: ROIs and rejected blocks",
               "Image 1 with every ROI box labelled with its id and coloured by status (green "
               "evaluated, orange unsafe slope, yellow unsafe roughness, red degenerate, greys: "
               "too few points, not in image 2, not evaluated); rejected blocks thin dark blue.",
               kPageWide, &page->flight_figures, &page->notes);
  }
  const fs::path decision = figures_dir / "decision.png";
  if (fs::is_regular_file(decision)) {
    AddPngFile(decision, "fig-decision", "Landing decisions",
               "Image 1 with every site coloured by its decision against the lander's truth (green safe and "
               "truly safe, red FALSE SAFE, orange missed safe, blue unsafe and truly unsafe, light grey no "
               "verdict, dark grey no lander truth), labelled with its slope error (estimated - true, deg).",
               kHalfPage, &page->decision_figures, &page->notes);
  }
  const fs::path matches = figures_dir / "matches.png";
  if (fs::is_regular_file(matches)) {
    AddPngFile(matches, "fig-matches", "Matches",
               "Both images with every surviving match, one colour per ROI.", kPageWide,
               &page->flight_figures, &page->notes);
  }
  const fs::path pairs_dir = figures_dir / "roi_pairs";
  if (!fs::is_directory(pairs_dir)) return;
  std::vector<fs::path> pairs;
  for (const fs::directory_entry& entry : fs::directory_iterator(pairs_dir)) {
    if (entry.is_regular_file() && entry.path().extension() == ".png") pairs.push_back(entry.path());
  }
  // roi_007 < roi_010 < roi_1000: by length, then by name.
  std::sort(pairs.begin(), pairs.end(), [](const fs::path& a, const fs::path& b) {
    const std::string sa = a.filename().string(), sb = b.filename().string();
    return sa.size() != sb.size() ? sa.size() < sb.size() : sa < sb;
  });
  for (const fs::path& path : pairs) {
    const std::string stem = path.stem().string();
    std::string id = stem.substr(stem.find('_') + 1);
    id.erase(0, std::min(id.find_first_not_of('0'), id.size() - 1));
    AddPngFile(path, "fig-" + stem, "ROI " + id,
               "Image-1 box (left) and image-2 search box (right) with the surviving matches.",
               kInGrid, &page->roi_pairs, &page->notes);
  }
}

// The dataset's name from its manifest.json; empty when it cannot be read.
std::string DatasetName(const fs::path& dir) {
  std::string bytes, error;
  if (!util::ReadFileBytes(dir / "manifest.json", &bytes, &error)) return "";
  try {
    const Json manifest = Json::parse(bytes);
    return Text(Member(manifest, "name"));
  } catch (const Json::exception&) {
    return "";
  }
}

// The dataset folder: the given one, or the first folder beside the run whose
// manifest names the run's dataset. Empty when none is found (a note says so).
fs::path FindDataset(const fs::path& run_dir, const std::string& name, const std::string& given,
                     std::vector<std::string>* notes) {
  if (!given.empty()) {
    std::error_code ec;
    if (!fs::is_directory(given, ec)) {
      throw InputError(given + (fs::exists(given, ec) ? ": is not a folder; expected a dataset folder"
                                                      : ": dataset folder not found"));
    }
    const std::string found = DatasetName(given);
    if (found != name) {
      notes->push_back("The dataset folder " + given + " holds '" + found +
                       "', but the run was made on '" + name + "'.");
    }
    return given;
  }
  const fs::path parent = fs::absolute(run_dir).lexically_normal().parent_path();
  std::vector<fs::path> candidates = {parent / "dataset", run_dir / "dataset"};
  if (!name.empty() && name.find('/') == std::string::npos && name != "." && name != "..") {
    candidates.push_back(parent / name);
  }
  for (const fs::path& candidate : candidates) {
    if (!name.empty() && DatasetName(candidate) == name) return candidate;
  }
  notes->push_back("The dataset folder of '" + name +
                   "' was not found beside the run folder (pass --dataset DIR): no elevation and "
                   "slope maps.");
  return {};
}

void AddMaps(const fs::path& dataset_dir, Page* page) {
  page->dataset_dir = dataset_dir.string();
  const struct {
    const char* file;
    const char* title;
    const char* caption;
  } maps[] = {
      {"elevation.png", "Elevation", "The synthetic scene's elevation map (maps/elevation.png)."},
      {"slope.png", "Slope", "The synthetic scene's slope map (maps/slope.png)."},
      {"hazards.png", "Hazards", "The synthetic scene's hazard map (maps/hazards.png)."},
      {"safety.png", "Safety for the lander",
       "Every point about 1 m apart as a landing point of the default lander (maps/safety.png): green safe, "
       "orange unsafe by clearance, red unsafe by slope, grey no verdict (the footprint leaves the DEM)."},
  };
  int found = 0;
  for (const auto& map : maps) {
    const fs::path path = dataset_dir / "maps" / map.file;
    if (!fs::is_regular_file(path)) continue;
    ++found;
    // As read: fitted below from its preview, without decoding the map itself.
    const cv::Size as_read(std::numeric_limits<int>::max(), std::numeric_limits<int>::max());
    AddPngFile(path, std::string("map-") + fs::path(map.file).stem().string(), map.title,
               map.caption, as_read, &page->maps, &page->notes);
    if (!page->maps.empty() && page->maps.back().title == map.title) {
      std::string shrunk;
      page->maps.back().png = MapAsShown(page->maps.back().png,
                                         dataset_dir / "maps" / datasets::kMapPreviewFolder / map.file, &shrunk);
      if (!shrunk.empty()) page->maps.back().caption += " (" + shrunk + ")";
      // The safety map is shown again beside the decisions, at the grid's height.
      if (std::string(map.file) == "safety.png") {
        Figure beside = page->maps.back();
        beside.id = "map-safety-beside-decisions";
        beside.png = FittedPng(beside.png, kHalfPage);
        page->decision_figures.push_back(std::move(beside));
      }
    }
  }
  if (found == 0) {
    page->notes.push_back("The dataset folder " + dataset_dir.string() +
                          " has no maps/ (only synthetic datasets have them).");
  }
}

// The plots of a report: the figures, or why there are none.
struct Plots {
  std::vector<Figure> figures;
  std::string error;  // empty when the figures are there
};

}  // namespace

// The compare record's methods come in its order, so that each keeps its
// colour when it has no slope.
std::string PlotSeriesJson(const Json& result, const std::string& kind) {
  // The sigma the within-two-sigma share uses: the method's, with the
  // calibration's term in quadrature where the record has one.
  const auto sigma_of = [](const Json& record) -> const Json& {
    const Json& combined = Member(record, "slope_sigma_combined_deg");
    return IsNumber(combined) ? combined : Member(record, "slope_sigma_deg");
  };
  const auto sample = [](const Json& roi_id, const Json& slope, const Json& truth_deg, const Json& sigma,
                         int num_points, bool counts) {
    return Json{{"roi", roi_id},
                {"slope_deg", slope},
                {"truth_deg", IsNumber(truth_deg) ? truth_deg : Json(nullptr)},
                {"sigma_deg", IsNumber(sigma) ? sigma : Json(nullptr)},
                {"num_points", num_points},
                {"counts", counts}};
  };
  Json series = Json::array();
  if (kind == "compare") {
    std::vector<std::string> names;
    for (const Json& m : Member(result, "methods")) names.push_back(Text(Member(m, "name")));
    std::map<std::string, Json> samples;
    for (const Json& roi : Member(result, "rois")) {
      const Json& truth = Member(roi, "truth");
      const Json& values = Member(roi, "methods");
      if (!values.is_object()) continue;
      for (const auto& item : values.items()) {
        const Json& v = item.value();
        if (!IsNumber(Member(v, "slope_deg"))) continue;
        if (std::find(names.begin(), names.end(), item.key()) == names.end()) names.push_back(item.key());
        bool counts = false;
        try {
          counts = SampleOfCompareRecord(item.key(), v, truth).Counts();
        } catch (const Json::exception&) {  // a method entry without its status or count: not counted
        }
        samples[item.key()].push_back(sample(Member(roi, "id"), Member(v, "slope_deg"), Member(truth, "slope_deg"),
                                             sigma_of(v), IntOr(Member(v, "num_points"), 0),
                                             counts));
      }
    }
    for (const std::string& name : names) {
      series.push_back({{"method", name}, {"samples", samples.count(name) ? samples[name] : Json::array()}});
    }
  } else {
    Json flight = Json::array();
    for (const Json& roi : Member(result, "rois")) {
      const Json& fit = Member(roi, "fit");
      if (!IsNumber(Member(fit, "slope_deg"))) continue;
      const Json& truth = Member(roi, "truth");
      flight.push_back(sample(Member(roi, "id"), Member(fit, "slope_deg"),
                              Member(truth, "available") == true ? Member(truth, "slope_deg") : Json(nullptr),
                              sigma_of(fit),
                              IntOr(Member(Member(roi, "counts"), "depth_inliers"), 0),
                              SampleOfFlightRecord(roi).Counts()));
    }
    series.push_back({{"method", kMethodFlight}, {"samples", flight}});
  }
  return Json{{"min_points", kMinPointsForSlopeStats}, {"series", series}}.dump(1) + "\n";
}

namespace {

// Runs report_plots.py on the folder of `kind` ("run" or "compare"), with
// the slopes to draw (PlotSeriesJson).
Plots DrawPlots(const fs::path& run_dir, const std::string& kind, const std::string& series,
                const ReportOptions& options) {
  Plots plots;
  const std::string python = util::FindExecutable(options.python);
  if (python.empty()) {
    plots.error = "the Python interpreter '" + options.python +
                  "' was not found; the plots need Python 3 with matplotlib (Debian: "
                  "python3-matplotlib)";
    return plots;
  }
  const util::PythonScript script("report", "report_plots.py", ReportPlotsScript());
  const fs::path out = script.folder() / "plots";
  const fs::path log = script.folder() / "plots.log";
  std::error_code ec;
  fs::create_directories(out, ec);
  util::PythonScriptOptions run;
  run.python = python;
  run.log_file = log.string();
  run.working_dir = script.folder().string();
  run.timeout_s = options.plot_timeout_s;
  const fs::path series_file = script.folder() / "series.json";
  try {
    util::WriteFileAtomically(series_file, series);
  } catch (const InputError& e) {
    plots.error = std::string("the plots' series could not be written: ") + e.what();
    return plots;
  }
  const util::ProcessResult result =
      script.Run({kind, fs::absolute(run_dir).string(), out.string(), series_file.string()}, run);
  if (!result.Ok()) {
    const std::string last_line = util::LastLineOfLog(log.string());
    if (result.started && !result.timed_out && result.exit_code == kPlotsExitNoMatplotlib) {
      plots.error = last_line;
    } else {
      plots.error = "the plotting script (report_plots.py under " + python + ") failed: " + result.error +
                    (last_line.empty() ? "" : ": " + last_line);
    }
    return plots;
  }
  const fs::path listing = out / "plots.json";
  Json list;
  try {
    list = ParseJsonFile(listing);
  } catch (const InputError& e) {
    plots.error = std::string("the plotting script wrote no usable list of plots: ") + e.what();
    return plots;
  }
  for (const Json& plot : list) {
    const std::string file = Text(Member(plot, "file"));
    std::string bytes, error;
    if (!util::ReadFileBytes(out / file, &bytes, &error) || !datasets::IsPng(bytes)) {
      plots.error = "the plotting script did not write a PNG " + file;
      plots.figures.clear();
      return plots;
    }
    plots.figures.push_back({"plot-" + fs::path(file).stem().string(), Text(Member(plot, "title")),
                             Text(Member(plot, "caption")), bytes});
  }
  return plots;
}

// ---------------------------------------------------------------- HTML

// The page's width and its grids' height are those the flight figures are
// drawn for (reference::kFigureShownWidthPx, kFigureGridHeightPx).
std::string Css() {
  return R"css(
body { font-family: "DejaVu Sans", Arial, sans-serif; margin: 24px; color: #222; max-width: )css" +
         std::to_string(reference::kFigureShownWidthPx) + R"css(px; }
h1 { font-size: 24px; margin-bottom: 4px; }
h2 { font-size: 19px; border-bottom: 1px solid #ccc; padding-bottom: 3px; margin-top: 28px; }
ul.facts { list-style: none; padding: 0; margin: 6px 0; color: #444; }
.notes { background: #fff7e0; border: 1px solid #e6c200; padding: 8px 14px; }
.failures, .plots-error { background: #fde8e8; border: 1px solid #d9534f; padding: 8px 14px; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
th, td { border: 1px solid #ccc; padding: 3px 7px; text-align: right; white-space: nowrap; }
th { background: #f0f0f0; }
td:first-child, th:first-child { text-align: left; }
.st-evaluated, .st-ok { background: #dff3df; }
.st-unsafe-slope { background: #ffe1c2; }
.st-unsafe-roughness { background: #fff5b8; }
.st-degenerate, .st-failed, .st-pose-failed { background: #f8d0d0; }
.st-too-few-points, .st-no-search-box { background: #f2f2f2; }
.st-not-in-image-2, .st-planar, .st-low-parallax { background: #dcdcdc; }
.st-not-evaluated { background: #b8b8b8; }
figure { margin: 12px 0 20px 0; }
figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { font-size: 13px; color: #444; margin-top: 4px; }
.scroll { overflow-x: auto; }
.grid { display: flex; flex-wrap: wrap; gap: 12px; }
.grid figure { margin: 0; }
.pair { display: flex; gap: 12px; align-items: flex-start; }
.pair figure { margin: 0; flex: 1 1 0; }
.grid figure img { max-height: )css" +
         std::to_string(reference::kFigureGridHeightPx) + R"css(px; }
)css";
}

void AppendTable(const Table& table, std::string* html) {
  *html += "<div class=\"scroll\"><table id=\"" + table.id + "\">\n<thead><tr>";
  for (const std::string& h : table.header) *html += "<th>" + util::HtmlEscape(h) + "</th>";
  *html += "</tr></thead>\n<tbody>\n";
  for (const std::vector<Cell>& row : table.rows) {
    *html += "<tr>";
    for (const Cell& cell : row) {
      *html += "<td";
      if (!cell.css_class.empty()) *html += " class=\"" + util::HtmlEscape(cell.css_class) + "\"";
      if (!cell.title.empty()) *html += " title=\"" + util::HtmlEscape(cell.title) + "\"";
      *html += ">" + util::HtmlEscape(cell.text) + "</td>";
    }
    *html += "</tr>\n";
  }
  *html += "</tbody>\n</table></div>\n";
}

void AppendFigure(const Figure& figure, std::string* html) {
  *html += "<figure id=\"" + util::HtmlEscape(figure.id) + "\"><img alt=\"" + util::HtmlEscape(figure.title) +
           "\" src=\"data:image/png;base64," + Base64Encode(figure.png) + "\"><figcaption><b>" +
           util::HtmlEscape(figure.title) + ".</b> " + util::HtmlEscape(figure.caption) + "</figcaption></figure>\n";
}

std::string BuildHtml(const Page& page) {
  std::string html =
      "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>hdabench " +
      page.kind + " report: " + util::HtmlEscape(page.heading) + "</title>\n<style>" + Css() +
      "</style>\n</head>\n<body>\n";
  html += "<h1>" + util::HtmlEscape(page.heading) + "</h1>\n<ul class=\"facts\">\n";
  for (const std::string& fact : page.facts) html += "<li>" + util::HtmlEscape(fact) + "</li>\n";
  html += "</ul>\n";
  if (!page.failures.empty()) {
    html += "<div class=\"failures\" id=\"failures\"><b>Failed methods</b> (no values for the run):<ul>\n";
    for (const std::string& f : page.failures) html += "<li>" + util::HtmlEscape(f) + "</li>\n";
    html += "</ul></div>\n";
  }
  if (!page.notes.empty()) {
    html += "<div class=\"notes\" id=\"notes\"><b>Notes</b><ul>\n";
    for (const std::string& n : page.notes) html += "<li>" + util::HtmlEscape(n) + "</li>\n";
    html += "</ul></div>\n";
  }

  if (!page.decision_lines.empty() || !page.decision_figures.empty()) {
    html += "<h2>Landing decision</h2>\n";
    for (const std::string& line : page.decision_lines) html += "<p>" + util::HtmlEscape(line) + "</p>\n";
    if (!page.decisions.rows.empty()) AppendTable(page.decisions, &html);
    if (!page.decision_figures.empty()) {
      html += "<div class=\"pair\">\n";
      for (const Figure& f : page.decision_figures) AppendFigure(f, &html);
      html += "</div>\n";
    }
  }
  html += page.kind == "compare" ? "<h2>Per method</h2>\n" : "<h2>Statuses</h2>\n";
  AppendTable(page.summary, &html);
  for (const std::string& line : page.summary_lines) html += "<p>" + util::HtmlEscape(line) + "</p>\n";

  html += page.kind == "compare"
              ? "<h2>Slope per ROI and method</h2>\n<p>Degrees, number of points in brackets; "
                "without a slope, the status. Hover a cell for its reason.</p>\n"
              : "<h2>Per ROI</h2>\n<p>Hover a status for its reason; # points are the points of "
                "the plane fit, est. relief the roughness beyond the matching noise.</p>\n";
  AppendTable(page.rois, &html);

  html += "<h2>Plots</h2>\n";
  if (!page.plots_error.empty()) {
    html += "<div class=\"plots-error\" id=\"plots-error\"><b>No plots:</b> " +
            util::HtmlEscape(page.plots_error) + "</div>\n";
  } else if (page.plots.empty()) {
    html += "<p>No data to plot: no ROI has a fitted plane or stage times.</p>\n";
  }
  for (const Figure& f : page.plots) AppendFigure(f, &html);

  if (!page.flight_figures.empty() || !page.roi_pairs.empty()) {
    html += "<h2>Flight method figures</h2>\n";
    for (const Figure& f : page.flight_figures) AppendFigure(f, &html);
    if (!page.roi_pairs.empty()) {
      html += "<h3>ROI pairs with matches</h3>\n<div class=\"grid\">\n";
      for (const Figure& f : page.roi_pairs) AppendFigure(f, &html);
      html += "</div>\n";
    }
  }
  html += "<h2>Scene maps</h2>\n";
  if (page.maps.empty()) {
    html += "<p>None (see the notes).</p>\n";
  } else {
    html += "<p>From " + util::HtmlEscape(page.dataset_dir) + ".</p>\n<div class=\"grid\">\n";
    for (const Figure& f : page.maps) AppendFigure(f, &html);
    html += "</div>\n";
  }
  html += "</body>\n</html>\n";
  return html;
}

// ---------------------------------------------------------------- Markdown

void AppendMarkdownTable(const Table& table, std::string* md) {
  std::string line = "|", rule = "|";
  for (const std::string& h : table.header) {
    line += " " + MdCell(h) + " |";
    rule += " --- |";
  }
  *md += line + "\n" + rule + "\n";
  for (const std::vector<Cell>& row : table.rows) {
    line = "|";
    for (const Cell& cell : row) line += " " + MdCell(cell.text) + " |";
    *md += line + "\n";
  }
}

std::string BuildMarkdown(const Page& page, int num_figures) {
  std::string md = "# " + page.heading + "\n\n";
  for (const std::string& fact : page.facts) md += "- " + fact + "\n";
  md += "\n";
  if (!page.failures.empty()) {
    md += "## Failed methods\n\n";
    for (const std::string& f : page.failures) md += "- " + f + "\n";
    md += "\n";
  }
  if (!page.decision_lines.empty()) {
    md += "## Landing decision\n\n";
    for (const std::string& line : page.decision_lines) md += line + "\n\n";
    if (!page.decisions.rows.empty()) {
      AppendMarkdownTable(page.decisions, &md);
      md += "\n";
    }
  }
  md += page.kind == "compare" ? "## Per method\n\n" : "## Statuses\n\n";
  AppendMarkdownTable(page.summary, &md);
  md += "\n";
  for (const std::string& line : page.summary_lines) md += line + "\n\n";
  md += "## Report\n\n`report.html` holds the per-ROI table (" +
        std::to_string(page.rois.rows.size()) + " ROIs) and " + std::to_string(num_figures) +
        " figures:\n\n";
  const auto list = [&md](const std::vector<Figure>& figures) {
    for (const Figure& f : figures) md += "- " + f.title + "\n";
  };
  list(page.decision_figures);
  list(page.plots);
  list(page.flight_figures);
  if (!page.roi_pairs.empty()) {
    md += "- " + std::to_string(page.roi_pairs.size()) + " ROI pair(s) with matches\n";
  }
  list(page.maps);
  if (!page.notes.empty()) {
    md += "\n## Notes\n\n";
    for (const std::string& n : page.notes) md += "- " + n + "\n";
  }
  return md;
}

}  // namespace

std::string Base64Encode(const std::string& bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  const auto byte = [&bytes](size_t k) { return static_cast<unsigned>(static_cast<unsigned char>(bytes[k])); };
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = byte(i) << 16 | byte(i + 1) << 8 | byte(i + 2);
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = byte(i) << 16;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = byte(i) << 16 | byte(i + 1) << 8;
    out += kAlphabet[v >> 18 & 63];
    out += kAlphabet[v >> 12 & 63];
    out += kAlphabet[v >> 6 & 63];
    out += '=';
  }
  return out;
}

std::vector<std::string> ReportOptions::Validate() const {
  std::vector<std::string> errors;
  // An unusable python is not an error here: the report is written without
  // its plots, and says why.
  RequireOption(plot_timeout_s > 0.0, "plot_timeout_s", plot_timeout_s, "> 0 seconds", &errors);
  return errors;
}

namespace {

// The folder's kind: "compare" (compare.json) or "run" (result.json).
std::string FolderKind(const std::string& run_dir) {
  std::error_code ec;
  const fs::path dir(run_dir);
  if (!fs::exists(dir, ec)) throw InputError(run_dir + ": no such folder");
  if (!fs::is_directory(dir, ec)) throw InputError(run_dir + ": is not a folder; expected a run or compare folder");
  if (fs::exists(dir / "compare.json", ec)) return "compare";
  if (fs::exists(dir / "result.json", ec)) return "run";
  throw InputError(run_dir +
                   ": neither a run folder (result.json, from hdabench run) nor a compare "
                   "folder (compare.json, from hdabench compare)");
}

// Everything of the page the folder gives but the plots and the maps: its
// record's tables and lines, the stage times, the flight figures.
void FillFromFolder(const fs::path& dir, const Json& folder_result, Page* page) {
  const bool compare = page->kind == "compare";
  if (compare) {
    FillComparePage(dir, folder_result, page);
  } else {
    FillRunPage(folder_result, page);
  }
  const fs::path flight_dir = compare ? dir / "flight" : dir;
  const std::string timing = TimingLine(flight_dir / "timings.json", &page->notes);
  if (!timing.empty()) page->summary_lines.push_back(timing);
  AddRunFigures(flight_dir / "figures", page);
}

ReportResult WriteReportOrThrow(const std::string& run_dir, const ReportOptions& options) {
  ThrowIfInvalid("", options.Validate());
  const fs::path dir(run_dir);
  Page page;
  page.kind = FolderKind(run_dir);
  // A folder whose result is not of its format is refused before anything
  // starts.
  const Json folder_result = ReadFolderResult(dir, page.kind);
  // The plots are drawn by a Python process while the rest of the page is
  // read here: about half of the report's time, on the other core. What the
  // page holds does not depend on which finishes first. (When reading the
  // folder throws, the future's destructor waits for the plots, then the
  // error goes on. Without a thread to spare, they are drawn when asked for.)
  std::future<Plots> plots = util::StartBeside(
      "report plots", [dir, kind = page.kind, series = PlotSeriesJson(folder_result, page.kind), options] {
        return DrawPlots(dir, kind, series, options);
      });
  FillFromFolder(dir, folder_result, &page);

  const fs::path dataset_dir = FindDataset(dir, page.dataset_name, options.dataset_dir, &page.notes);
  if (!dataset_dir.empty()) AddMaps(dataset_dir, &page);

  Plots drawn = plots.get();
  page.plots = std::move(drawn.figures);
  page.plots_error = std::move(drawn.error);

  ReportResult result;
  result.kind = page.kind;
  result.plots_ok = page.plots_error.empty();
  result.plots_error = page.plots_error;
  result.dataset_dir = page.dataset_dir;
  result.notes = page.notes;  // the plots' problem is in plots_error
  if (!result.plots_ok) page.notes.push_back("No plots: " + page.plots_error);
  result.num_figures = static_cast<int>(page.decision_figures.size() + page.plots.size() +
                                        page.flight_figures.size() + page.roi_pairs.size() + page.maps.size());
  result.num_table_rows = static_cast<int>(page.rois.rows.size());
  result.html_path = (dir / "report.html").string();
  result.markdown_path = (dir / "report.md").string();
  util::WriteFileAtomically(result.html_path, BuildHtml(page));
  util::WriteFileAtomically(result.markdown_path, BuildMarkdown(page, result.num_figures));
  return result;
}

// `read` on run_dir, with a folder or file of the run that cannot be looked
// at (a symbolic link loop, no permission) named as every other problem of
// the folder.
template <typename Read>
auto NamingFilesystemErrors(const std::string& run_dir, const Read& read) {
  try {
    return read();
  } catch (const fs::filesystem_error& e) {
    const std::string where = e.path1().empty() ? run_dir : e.path1().string();
    throw InputError(where + ": cannot be read (" + e.code().message() + ")");
  }
}

}  // namespace

ReportResult WriteReport(const std::string& run_dir, const ReportOptions& options) {
  return NamingFilesystemErrors(run_dir, [&] { return WriteReportOrThrow(run_dir, options); });
}

int CheckReportFolder(const std::string& run_dir) {
  return NamingFilesystemErrors(run_dir, [&] {
    Page page;
    page.kind = FolderKind(run_dir);
    FillFromFolder(run_dir, ReadFolderResult(run_dir, page.kind), &page);
    return static_cast<int>(page.rois.rows.size());
  });
}

}  // namespace hdabench::reference
