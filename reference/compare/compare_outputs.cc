#include "reference/compare/compare_outputs.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include <nlohmann/json.hpp>

#include "tools/util/error.h"
#include "tools/util/files.h"
#include "hda/calibration_sigma.h"
#include "reference/flight/flight_outputs.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

// A double as JSON, null when it is not finite (JSON has no NaN or infinity).
Json Number(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

const RoiTruthValue* TruthOf(const CompareRun& run, size_t i) {
  if (i >= run.flight.truths.size() || !run.flight.truths[i].available) return nullptr;
  return &run.flight.truths[i];
}

Json StatsJson(const ErrorStats& s) {
  if (s.count == 0) return {{"count", 0}, {"median", nullptr}, {"p90", nullptr}, {"max", nullptr}};
  return {{"count", s.count}, {"median", Number(s.median)}, {"p90", Number(s.p90)}, {"max", Number(s.max)}};
}

Json AccuracyJson(const PointAccuracy& a) {
  if (!a.available) return nullptr;
  return {{"num_points", a.num_points},
          {"median_m", Number(a.median_m)},
          {"within_0_1_m", Number(a.within_0_1_m)},
          {"within_0_3_m", Number(a.within_0_3_m)},
          {"within_1_m", Number(a.within_1_m)}};
}

Json MethodRoiJson(const MethodRoi& r) {
  Json j;
  j["status"] = r.StatusName();
  j["reason"] = r.reason;
  j["num_points"] = r.num_points;
  j["slope_deg"] = r.has_fit ? Number(r.slope_deg) : Json(nullptr);
  j["slope_sigma_deg"] = r.has_fit && r.has_sigma ? Number(r.slope_sigma_deg) : Json(nullptr);
  if (r.has_sigma) {
    j["slope_sigma_calibration_deg"] = r.has_fit ? Number(r.slope_sigma_calibration_deg) : Json(nullptr);
    j["slope_sigma_combined_deg"] =
        r.has_fit ? Number(hda::CombinedSlopeSigmaDeg(r.slope_sigma_deg, r.slope_sigma_calibration_deg)) : Json(nullptr);
  }
  j["normal"] = r.has_fit ? Json::array({Number(r.normal_in_local.x()), Number(r.normal_in_local.y()),
                                         Number(r.normal_in_local.z())})
                          : Json(nullptr);
  j["roughness_rms_m"] = r.has_fit ? Number(r.roughness_rms_m) : Json(nullptr);
  j["roughness_max_m"] = r.has_fit ? Number(r.roughness_max_m) : Json(nullptr);
  j["configuration"] = r.configuration.empty() ? Json(nullptr) : Json(r.configuration);
  j["point_accuracy"] = AccuracyJson(r.accuracy);
  return j;
}

// The ROI's own truth and the tilt error's parts against it (null where it
// has none; own_truth then says why).
void AddOwnTruthJson(const MethodRoi& r, const RoiTruthValue* truth, Json* j) {
  const MethodRoi::OwnTruth& own = r.own_truth;
  if (own.available) {
    (*j)["own_truth"] = {{"num_points", own.num_points},
                         {"slope_deg", Number(own.slope_deg)},
                         {"normal", Json::array({Number(own.normal_in_local.x()), Number(own.normal_in_local.y()),
                                                 Number(own.normal_in_local.z())})}};
  } else {
    (*j)["own_truth"] = {{"why", own.why.empty() ? "the dataset has no truth" : own.why}};
  }
  const SlopeSample sample = SampleOfMethodRoi(r, truth);
  (*j)["tilt_definition_deg"] = Number(sample.definition_tilt_deg);
  (*j)["tilt_estimation_deg"] = Number(sample.estimation_tilt_deg);
  (*j)["slope_definition_error_deg"] = Number(sample.definition_error_deg);
  (*j)["slope_estimation_error_deg"] = Number(sample.estimation_error_deg);
}

double SlopeError(const CompareRun& run, size_t m, size_t i) {
  const MethodRoi& r = run.rois[m][i];
  const RoiTruthValue* t = TruthOf(run, i);
  if (!r.has_fit || t == nullptr) return std::nan("");
  return r.slope_deg - t->slope_deg;
}

double TiltError(const CompareRun& run, size_t m, size_t i) {
  const MethodRoi& r = run.rois[m][i];
  const RoiTruthValue* t = TruthOf(run, i);
  if (!r.has_fit || t == nullptr) return std::nan("");
  return TiltErrorDeg(r.normal_in_local, t->normal_in_local);
}

std::string StatsText(const ErrorStats& s, int digits) {
  if (s.count == 0) return "-";
  return util::FixedCell(s.median, digits) + " / " + util::FixedCell(s.p90, digits) + " / " +
         util::FixedCell(s.max, digits) + " (" + std::to_string(s.count) + ")";
}

std::string MarkdownRow(const std::vector<std::string>& cells) {
  std::string line = "|";
  for (const std::string& c : cells) line += " " + c + " |";
  return line + "\n";
}

}  // namespace

std::string CompareResultJson(const CompareRun& run) {
  Json j;
  j["format"] = kCompareResultFormatName;
  j["format_version"] = kCompareResultFormatVersion;
  const FlightRun& f = run.flight;
  j["dataset"] = f.dataset_name;
  j["frames"] = Json::array({f.frame1, f.frame2});
  j["lens_model"] = f.lens_model;
  j["image_size_px"] = Json::array({f.image_width_px, f.image_height_px});
  j["baseline_m"] = Number(f.baseline_m);
  j["lrf_range_m"] = Number(f.lrf_range_m);
  j["truth"] = run.any_truth;
  j["min_points_for_stats"] = kMinPointsForSlopeStats;
  // The slope limit every method's decision is taken under, and the lander of the truth.
  j["max_slope_deg"] = Number(f.options.max_slope_deg);
  j["lander"] = LanderJson(f.lander);
  j["calibration_term"] = CalibrationTermJson(f.calibration);
  Json methods = Json::array();
  for (size_t m = 0; m < run.methods.size(); ++m) {
    const MethodSummary& s = run.summaries[m];
    Json mj;
    mj["name"] = s.method;
    mj["ok"] = s.ok;
    mj["failure"] = s.ok ? Json(nullptr) : Json(s.failure);
    mj["rois_with_fit"] = s.rois_with_fit;
    mj["slope_error_vs_truth_deg"] = StatsJson(s.slope_vs_truth_deg);
    mj["tilt_error_vs_truth_deg"] = StatsJson(s.tilt_vs_truth_deg);
    mj["slope_bias_vs_truth_deg"] = s.slope_vs_truth_deg.count > 0 ? Number(s.slope_bias_deg) : Json(nullptr);
    mj["tilt_definition_part_deg"] = StatsJson(s.tilt_definition_deg);
    mj["tilt_estimation_part_deg"] = StatsJson(s.tilt_estimation_deg);
    mj["slope_bias_definition_part_deg"] =
        s.tilt_definition_deg.count > 0 ? Number(s.slope_definition_bias_deg) : Json(nullptr);
    mj["slope_bias_estimation_part_deg"] =
        s.tilt_estimation_deg.count > 0 ? Number(s.slope_estimation_bias_deg) : Json(nullptr);
    mj["roughness_error_vs_truth_m"] = StatsJson(s.roughness_vs_truth_m);
    mj["slope_difference_vs_colmap_nav_deg"] = StatsJson(s.slope_vs_colmap_nav_deg);
    mj["point_accuracy"] = AccuracyJson(s.accuracy);
    mj["rotation_error_deg"] = s.has_pose_error ? Number(s.rotation_error_deg) : Json(nullptr);
    mj["translation_direction_error_deg"] =
        s.has_pose_error ? Number(s.translation_direction_error_deg) : Json(nullptr);
    if (run.any_truth) mj["decision"] = DecisionJson(s.decision);
    methods.push_back(mj);
  }
  j["methods"] = methods;
  Json rois = Json::array();
  for (size_t i = 0; i < f.result.rois.size(); ++i) {
    const hda::RoiResult& roi = f.result.rois[i];
    Json rj;
    rj["id"] = roi.id;
    rj["box1"] = Json::array({roi.box1_px.x, roi.box1_px.y, roi.box1_px.width, roi.box1_px.height});
    const RoiTruthValue* t = TruthOf(run, i);
    rj["truth"] = t == nullptr ? Json(nullptr)
                               : Json({{"slope_deg", Number(t->slope_deg)},
                                       {"roughness_rms_m", Number(t->roughness_rms_m)},
                                       {"roughness_max_m", Number(t->roughness_max_m)},
                                       {"normal", Json::array({Number(t->normal_in_local.x()),
                                                               Number(t->normal_in_local.y()),
                                                               Number(t->normal_in_local.z())})},
                                       {"max_rock_height_m", Number(t->max_rock_height_m)},
                                       {"landing", LandingJson(t->landing)}});
    rj["rank"] = roi.rank > 0 ? Json(roi.rank) : Json(nullptr);
    Json per_method = Json::object();
    for (size_t m = 0; m < run.methods.size(); ++m) {
      Json mr = MethodRoiJson(run.rois[m][i]);
      mr["slope_error_deg"] = Number(SlopeError(run, m, i));
      mr["tilt_error_deg"] = Number(TiltError(run, m, i));
      if (run.any_truth) AddOwnTruthJson(run.rois[m][i], t, &mr);
      per_method[run.methods[m]] = mr;
    }
    rj["methods"] = per_method;
    rois.push_back(rj);
  }
  j["rois"] = rois;
  return j.dump(1) + "\n";
}

std::string CompareTimingsJson(const CompareRun& run) {
  Json j;
  j["format"] = kCompareTimingsFormatName;
  j["format_version"] = kCompareResultFormatVersion;
  Json methods = Json::array();
  for (size_t m = 0; m < run.methods.size(); ++m) {
    const MethodSummary& s = run.summaries[m];
    Json per_roi = Json::array();
    for (size_t i = 0; i < run.rois[m].size(); ++i) per_roi.push_back(Number(run.rois[m][i].wall_s));
    Json method = {{"name", s.method},
                   {"seconds", Number(s.wall_s)},
                   {"ratio_to_flight", Number(s.time_ratio_to_flight)},
                   {"roi_seconds", per_roi}};
    if (s.flight_computer_s >= 0.0) method["flight_computer_s"] = Number(s.flight_computer_s);
    methods.push_back(method);
  }
  j["methods"] = methods;
  return j.dump(1) + "\n";
}

std::string CompareRoisCsv(const CompareRun& run) {
  std::ostringstream out;
  out << "roi,method,status,num_points,slope_deg,slope_sigma_deg,truth_slope_deg,slope_error_deg,"
         "tilt_error_deg,roughness_rms_m,truth_roughness_rms_m,configuration,points_within_0_3_m,"
         "tilt_definition_deg,tilt_estimation_deg,slope_sigma_calibration_deg\n";
  const auto quoted = [](const std::string& text) {
    std::string q = "\"";
    for (const char c : text) q += c == '"' ? std::string("\"\"") : std::string(1, c);
    return q + "\"";
  };
  for (size_t i = 0; i < run.flight.result.rois.size(); ++i) {
    const RoiTruthValue* t = TruthOf(run, i);
    for (size_t m = 0; m < run.methods.size(); ++m) {
      const MethodRoi& r = run.rois[m][i];
      const SlopeSample parts = SampleOfMethodRoi(r, t);
      out << run.flight.result.rois[i].id << "," << run.methods[m] << "," << quoted(r.StatusName()) << ","
          << r.num_points << "," << (r.has_fit ? util::CsvNumber(r.slope_deg) : "") << ","
          << (r.has_fit && r.has_sigma ? util::CsvNumber(r.slope_sigma_deg) : "") << ","
          << (t != nullptr ? util::CsvNumber(t->slope_deg) : "") << "," << util::CsvNumber(SlopeError(run, m, i))
          << "," << util::CsvNumber(TiltError(run, m, i)) << "," << (r.has_fit ? util::CsvNumber(r.roughness_rms_m) : "") << ","
          << (t != nullptr ? util::CsvNumber(t->roughness_rms_m) : "") << "," << r.configuration << ","
          << (r.accuracy.available ? util::CsvNumber(r.accuracy.within_0_3_m) : "") << ","
          << util::CsvNumber(parts.definition_tilt_deg) << "," << util::CsvNumber(parts.estimation_tilt_deg) << ","
          << (r.has_fit && r.has_sigma ? util::CsvNumber(r.slope_sigma_calibration_deg) : "") << "\n";
    }
  }
  return out.str();
}

std::string CompareMarkdown(const CompareRun& run) {
  std::ostringstream out;
  const FlightRun& f = run.flight;
  out << "# Comparison: " << f.dataset_name << ", frames " << f.frame1 << "," << f.frame2
      << "\n\nBaseline " << util::FixedCell(f.baseline_m, 2) << " m, LRF range "
      << util::FixedCell(f.lrf_range_m, 1) << " m, " << f.result.rois.size() << " ROIs. "
      << f.result.Summary() << "\n\n";
  out << "## Slope per ROI (degrees, number of points in brackets)\n\n";
  std::vector<std::string> header = {"ROI"};
  if (run.any_truth) header.push_back("truth");
  for (const std::string& m : run.methods) header.push_back(m);
  out << MarkdownRow(header);
  out << MarkdownRow(std::vector<std::string>(header.size(), "---"));
  for (size_t i = 0; i < f.result.rois.size(); ++i) {
    std::vector<std::string> row = {std::to_string(f.result.rois[i].id)};
    if (run.any_truth) {
      const RoiTruthValue* t = TruthOf(run, i);
      row.push_back(t != nullptr ? util::FixedCell(t->slope_deg, 2) : "-");
    }
    for (size_t m = 0; m < run.methods.size(); ++m) {
      const MethodRoi& r = run.rois[m][i];
      std::string cell = r.has_fit ? util::FixedCell(r.slope_deg, 2) + " (" + std::to_string(r.num_points) + ")"
                                   : "- (" + r.StatusName() + ")";
      if (r.has_fit && run.methods[m] == kMethodFlight && r.flight_status != hda::RoiStatus::kEvaluated) {
        cell += " " + r.StatusName();
      }
      row.push_back(cell);
    }
    out << MarkdownRow(row);
  }
  out << "\n## Per method\n\nErrors are median / 90th percentile / max (count) over ROIs with a slope and at "
      << "least " << kMinPointsForSlopeStats << " points. The tilt error is the angle between the fitted and "
      << "the true plane; the slope bias the mean of slope - truth. The tilt error's parts are against the "
      << "method's own truth, the plane of the truth points at the pixels its plane stands on, weighted as "
      << "it weighs them: the definition part (own truth against the site's) and the estimation part (the "
      << "method against its own truth), over the ROIs with an own truth.\n\n";
  const std::vector<std::string> method_header = {
      "method", "ROIs with a slope", "slope error vs truth (deg)", "tilt error vs truth (deg)", "slope bias (deg)",
      "tilt: definition part (deg)", "tilt: estimation part (deg)", "roughness error vs truth (m)",
      "slope diff. vs colmap-nav (deg)", "points within 0.1 / 0.3 / 1 m", "rotation / baseline-direction error (deg)",
      "time (s)", "time / flight"};
  out << MarkdownRow(method_header);
  out << MarkdownRow(std::vector<std::string>(method_header.size(), "---"));
  for (const MethodSummary& s : run.summaries) {
    const std::string accuracy =
        s.accuracy.available ? util::FixedCell(100 * s.accuracy.within_0_1_m, 0) + " / " +
                                   util::FixedCell(100 * s.accuracy.within_0_3_m, 0) + " / " +
                                   util::FixedCell(100 * s.accuracy.within_1_m, 0) + " % (" +
                                   std::to_string(s.accuracy.num_points) + ")"
                             : "-";
    const std::string pose = s.has_pose_error ? util::FixedCell(s.rotation_error_deg, 3) + " / " +
                                                    util::FixedCell(s.translation_direction_error_deg, 2)
                                              : "-";
    out << MarkdownRow({s.method + (s.ok ? "" : " (failed)"), std::to_string(s.rois_with_fit),
                        StatsText(s.slope_vs_truth_deg, 2), StatsText(s.tilt_vs_truth_deg, 2),
                        s.slope_vs_truth_deg.count > 0 ? util::SignedCell(s.slope_bias_deg, 2) : "-",
                        StatsText(s.tilt_definition_deg, 2), StatsText(s.tilt_estimation_deg, 2),
                        StatsText(s.roughness_vs_truth_m, 3),
                        StatsText(s.slope_vs_colmap_nav_deg, 2), accuracy, pose,
                        util::FixedCell(s.wall_s, 3), util::FixedCell(s.time_ratio_to_flight, 1)});
  }
  if (run.any_truth) {
    out << "\n## Landing decisions\n\nAgainst the lander's truth at each site (" << f.lander.legs
        << " pads on a " << util::FixedText(f.lander.footprint_diameter_m, 1) << " m circle, limits "
        << util::FixedText(f.lander.max_slope_deg, 1) << " deg and " << util::FixedText(f.lander.body_clearance_m, 2)
        << " m). The flight method declares by its status; every other method by its slope against the "
        << "flight method's " << util::FixedText(f.options.max_slope_deg, 1) << " deg, as it has no hazard "
        << "estimate. False-safe: truly unsafe among the sites declared safe (Wilson 95 % interval); "
        << "missed-safe: declared unsafe among the truly safe ones.\n\n";
    out << MarkdownRow({"method", "decision"});
    out << MarkdownRow({"---", "---"});
    for (const MethodSummary& s : run.summaries) out << MarkdownRow({s.method, DecisionLine(s.decision)});
  }
  bool any_note = false;
  for (const MethodSummary& s : run.summaries) {
    if (s.ok && s.note.empty()) continue;
    if (!any_note) out << "\n";
    any_note = true;
    out << "- " << s.method << ": " << (s.ok ? s.note : "FAILED: " + s.failure) << "\n";
  }
  return out.str();
}

std::vector<std::string> WriteCompareOutputs(const CompareRun& run, const cv::Mat& image1,
                                             const cv::Mat& image2, const std::string& dir,
                                             bool figures, int threads) {
  PrepareOutputFolder(dir);
  // compare.json marks a whole comparison: removed first, written last, so a
  // folder whose writing stopped halfway holds none (as result.json for run).
  std::error_code ec;
  fs::remove(fs::path(dir) / "compare.json", ec);
  if (ec) {
    throw InputError((fs::path(dir) / "compare.json").string() + ": cannot remove the earlier comparison (" +
                     ec.message() + ")");
  }
  std::vector<std::string> written = {"compare.json"};  // listed first, as it always was
  const auto write = [&](const std::string& name, const std::string& bytes) {
    util::WriteFileAtomically(fs::path(dir) / name, bytes);
    if (name != "compare.json") written.push_back(name);
  };
  write("compare_timings.json", CompareTimingsJson(run));
  write("compare.csv", CompareRoisCsv(run));
  write("compare.md", CompareMarkdown(run));
  for (const std::string& path :
       WriteFlightOutputs(run.flight, image1, image2, (fs::path(dir) / "flight").string(), figures, threads)) {
    written.push_back("flight/" + path);
  }
  write("compare.json", CompareResultJson(run));
  return written;
}

}  // namespace hdabench::reference
