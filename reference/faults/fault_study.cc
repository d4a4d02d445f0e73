#include "reference/faults/fault_study.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <tuple>

#include <nlohmann/json.hpp>

#include "reference/flight/flight_run.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/python_script.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using Json = nlohmann::ordered_json;

constexpr int kFormatVersion = 1;
// Seconds between two progress lines inside one case.
constexpr double kRoiProgressEveryS = 10.0;

// The box of an ROI in image 1 as a key.
std::tuple<int, int, int, int> BoxKey(const hda::RoiResult& roi) {
  return {roi.box1_px.x, roi.box1_px.y, roi.box1_px.width, roi.box1_px.height};
}

// Fills the counts, statistics and movement against `clean` of a case that ran.
void Measure(const FlightRun& run, const FlightRun* clean, FaultCase* c) {
  c->range_source = ToString(run.range_source);
  c->rois = static_cast<int>(run.result.rois.size());
  c->with_slope = static_cast<int>(std::count_if(run.result.rois.begin(), run.result.rois.end(),
                                                 [](const hda::RoiResult& r) { return hda::HasSlope(r.status); }));
  c->evaluated_share = c->rois > 0 ? c->with_slope / static_cast<double>(c->rois) : 0.0;
  c->stats = ComputeSlopeErrorStats(run);
  c->decision = ComputeFlightDecisions(run);
  if (clean != nullptr) {
    // A site is false-safe when the run calls it safe (evaluated) and the
    // lander's truth says unsafe.
    const auto false_safe = [](const FlightRun& r, size_t i) {
      return r.result.rois[i].status == hda::RoiStatus::kEvaluated && i < r.truths.size() &&
             r.truths[i].available && r.truths[i].landing.defined && !r.truths[i].landing.safe;
    };
    std::set<std::tuple<int, int, int, int>> clean_false_safe;
    for (size_t i = 0; i < clean->result.rois.size(); ++i) {
      if (false_safe(*clean, i)) clean_false_safe.insert(BoxKey(clean->result.rois[i]));
    }
    for (size_t i = 0; i < run.result.rois.size(); ++i) {
      if (false_safe(run, i) && clean_false_safe.count(BoxKey(run.result.rois[i])) == 0) ++c->new_false_safe;
    }
    if (!clean->result.rois.empty()) c->rois_vs_clean = c->rois / static_cast<double>(clean->result.rois.size());
    std::map<std::tuple<int, int, int, int>, double> clean_slopes;
    for (const hda::RoiResult& roi : clean->result.rois) {
      if (hda::HasSlope(roi.status)) clean_slopes[BoxKey(roi)] = roi.slope_deg;
    }
    std::vector<double> moved;
    for (const hda::RoiResult& roi : run.result.rois) {
      if (!hda::HasSlope(roi.status)) continue;
      const auto found = clean_slopes.find(BoxKey(roi));
      if (found != clean_slopes.end()) moved.push_back(std::abs(roi.slope_deg - found->second));
    }
    std::sort(moved.begin(), moved.end());
    c->moved_count = static_cast<int>(moved.size());
    if (!moved.empty()) {
      c->moved_median_deg = util::Quantile(moved, 0.5);
      c->moved_max_deg = moved.back();
    }
  }
}

std::vector<FaultCrossing> Crossings(const std::vector<FaultCase>& cases, const FaultRequirements& requirements) {
  // Per (fault, sign): the cases in order of |magnitude|.
  std::map<std::pair<std::string, int>, std::vector<const FaultCase*>> groups;
  std::vector<std::pair<std::string, int>> order;
  for (const FaultCase& c : cases) {
    if (!c.fault || !c.applied) continue;
    const std::pair<std::string, int> key{datasets::InfoOf(c.fault->kind).name, c.fault->magnitude < 0 ? -1 : 1};
    if (groups.count(key) == 0) order.push_back(key);
    groups[key].push_back(&c);
  }
  std::vector<FaultCrossing> crossings;
  for (const auto& key : order) {
    std::vector<const FaultCase*> group = groups[key];
    std::stable_sort(group.begin(), group.end(), [](const FaultCase* a, const FaultCase* b) {
      return std::abs(a->fault->magnitude) < std::abs(b->fault->magnitude);
    });
    FaultCrossing crossing;
    crossing.fault = key.first;
    crossing.sign = key.second;
    crossing.largest_swept = std::abs(group.back()->fault->magnitude);
    for (const FaultCase* c : group) {
      const double m = c->fault->magnitude;
      const FaultVerdicts meets = VerdictsOf(*c, requirements);
      if (!meets.median && !crossing.median) crossing.median = m;
      if (!meets.p90 && !crossing.p90) crossing.p90 = m;
      if (!meets.within && !crossing.within) crossing.within = m;
      if (!meets.evaluated && !crossing.evaluated) crossing.evaluated = m;
      if (!meets.rois && !crossing.rois) crossing.rois = m;
    }
    crossings.push_back(crossing);
  }
  return crossings;
}

Json NumberOrNull(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

Json OptionalNumber(const std::optional<double>& value) { return value ? Json(*value) : Json(nullptr); }

std::string CrossingCell(const std::optional<double>& value, double largest, int sign) {
  if (value) return util::ShortestText(*value);
  return "met to " + util::ShortestText(sign * largest);
}

}  // namespace

FaultVerdicts VerdictsOf(const FaultCase& c, const FaultRequirements& requirements) {
  FaultVerdicts meets;
  if (!c.ran) return meets;
  const bool stats = c.stats.count > 0;
  meets.median = stats && c.stats.median_abs_deg <= requirements.max_median_deg;
  meets.p90 = stats && c.stats.p90_abs_deg <= requirements.max_p90_deg;
  meets.within = stats && c.stats.within_two_sigma_fraction >= requirements.min_within_two_sigma;
  meets.evaluated = c.evaluated_share >= requirements.min_evaluated_share;
  meets.rois = c.rois_vs_clean >= requirements.min_rois_vs_clean;
  return meets;
}

std::vector<datasets::Fault> DefaultFaultSweep() {
  std::vector<datasets::Fault> faults;
  for (const datasets::FaultInfo& info : datasets::FaultCatalogue()) {
    for (const double m : info.sweep) faults.push_back({info.kind, m});
  }
  return faults;
}

std::vector<std::string> FaultRequirements::Validate() const {
  std::vector<std::string> errors;
  RequireOption(max_median_deg > 0, "--max-median-deg", max_median_deg, "finite and > 0", &errors);
  RequireOption(max_p90_deg > 0, "--max-p90-deg", max_p90_deg, "finite and > 0", &errors);
  const auto share = [&](const char* flag, double value) {
    RequireOption(value >= 0 && value <= 1, flag, value, "in [0, 1]", &errors);
  };
  share("--min-within-two-sigma", min_within_two_sigma);
  share("--min-share", min_evaluated_share);
  share("--min-roi-fraction", min_rois_vs_clean);
  return errors;
}

FaultStudy RunFaultStudy(const datasets::Dataset& dataset, int frame1, int frame2, const HdaSettings& settings,
                         const std::vector<datasets::Fault>& faults, const FaultRequirements& requirements,
                         std::uint64_t seed, const std::function<void(const std::string&)>& progress) {
  ThrowIfInvalid("RunFaultStudy: invalid requirements: ", requirements.Validate());
  HdaSettings study_settings = settings;
  if (study_settings.given.count("compute_budget_s") == 0) {
    study_settings.options.compute_budget_s = 1e9;  // unlimited: every ROI is studied
  }
  FaultStudy study;
  study.dataset_name = dataset.name;
  study.frame1 = frame1;
  study.frame2 = frame2;
  study.seed = seed;
  study.requirements = requirements;

  const auto say = [&](const FaultCase& c) {
    if (!progress) return;
    if (!c.ran) {
      progress(c.label + ": " + (c.applied ? "no result: " : "") + c.error);
      return;
    }
    progress(c.label + ": " + std::to_string(c.with_slope) + "/" + std::to_string(c.rois) +
             " ROIs with a slope, slope error median " + util::FixedText(c.stats.median_abs_deg, 2) +
             " deg, p90 " + util::FixedText(c.stats.p90_abs_deg, 2) + " deg over " + std::to_string(c.stats.count));
  };

  // Inside a case, a line at most every kRoiProgressEveryS: the budget is
  // unlimited, so a case whose fault makes many ROIs or slow ones runs as
  // long as they take.
  const auto roi_progress = [&progress](const std::string& label) -> hda::RoiProgress {
    if (!progress) return {};
    auto last = std::make_shared<double>(hda::SteadySeconds());
    return [&progress, label, last](int evaluated, int rois) {
      const double now = hda::SteadySeconds();
      if (now - *last < kRoiProgressEveryS) return;
      *last = now;
      progress(label + ": " + std::to_string(evaluated) + " of " + std::to_string(rois) + " ROIs evaluated");
    };
  };

  FaultCase clean_case;
  clean_case.label = "clean";
  FlightRun clean;
  try {
    clean = RunFlight(dataset, frame1, frame2, study_settings, {}, roi_progress(clean_case.label));
  } catch (const InputError& e) {
    throw InputError(std::string("the clean run failed, so no fault can be judged: ") + e.what());
  }
  clean_case.ran = true;
  Measure(clean, nullptr, &clean_case);
  say(clean_case);
  study.cases.push_back(clean_case);

  for (const datasets::Fault& fault : faults) {
    FaultCase c;
    c.fault = fault;
    c.label = datasets::FaultLabel(fault);
    datasets::Dataset faulted = dataset;
    try {
      datasets::ApplyFault(fault, frame1, frame2, seed, &faulted);
    } catch (const InputError& e) {
      c.applied = false;
      c.error = std::string("not applied: ") + e.what();
      say(c);
      study.cases.push_back(c);
      continue;
    }
    try {
      const FlightRun run = RunFlight(faulted, frame1, frame2, study_settings, {}, roi_progress(c.label));
      c.ran = true;
      Measure(run, &clean, &c);
    } catch (const InputError& e) {
      c.ran = false;
      c.error = e.what();
    }
    say(c);
    study.cases.push_back(c);
  }
  study.crossings = Crossings(study.cases, requirements);
  return study;
}

std::string FaultStudyCsv(const FaultStudy& study) {
  std::ostringstream out;
  out << "case,fault,magnitude,unit,ran,rois,rois_vs_clean,with_slope,evaluated_share,slope_count,"
         "slope_error_median_deg,slope_error_p90_deg,within_two_sigma,slope_bias_deg,moved_count,moved_median_deg,"
         "moved_max_deg,meets_median,meets_p90,meets_within,meets_evaluated,meets_rois,applied,range_source,error,"
         "declared_safe,false_safe_rate,new_false_safe\n";
  for (const FaultCase& c : study.cases) {
    const bool stats = c.ran && c.stats.count > 0;
    const FaultVerdicts meets = VerdictsOf(c, study.requirements);
    const auto number = [&](bool have, double v) { return have ? util::CsvNumber(v) : std::string(); };
    out << c.label << "," << (c.fault ? datasets::InfoOf(c.fault->kind).name : "") << ","
        << (c.fault ? util::CsvNumber(c.fault->magnitude) : "") << ","
        << (c.fault ? datasets::InfoOf(c.fault->kind).unit : "") << "," << (c.ran ? "true" : "false") << ","
        << c.rois << "," << number(c.ran, c.rois_vs_clean) << "," << c.with_slope << ","
        << util::CsvNumber(c.evaluated_share) << "," << c.stats.count << ","
        << number(stats, c.stats.median_abs_deg) << "," << number(stats, c.stats.p90_abs_deg) << ","
        << number(stats, c.stats.within_two_sigma_fraction) << "," << number(stats, c.stats.bias_deg) << ","
        << c.moved_count << "," << number(c.moved_count > 0, c.moved_median_deg) << ","
        << number(c.moved_count > 0, c.moved_max_deg) << "," << (meets.median ? "true" : "false") << ","
        << (meets.p90 ? "true" : "false") << "," << (meets.within ? "true" : "false") << ","
        << (meets.evaluated ? "true" : "false") << "," << (meets.rois ? "true" : "false") << ","
        << (c.applied ? "true" : "false") << ","
        << c.range_source << ",";
    // The reason in double quotes, its own quotes doubled (RFC 4180).
    if (!c.error.empty()) {
      std::string quoted;
      for (const char ch : c.error) quoted += ch == '"' ? std::string("\"\"") : std::string(1, ch);
      out << '"' << quoted << '"';
    }
    out << "," << c.decision.DeclaredSafe() << "," << number(c.ran, c.decision.FalseSafeRate()) << ","
        << (c.ran ? std::to_string(c.new_false_safe) : "");
    out << "\n";
  }
  return out.str();
}

std::string FaultStudyJson(const FaultStudy& study) {
  Json j;
  j["format"] = "hdabench-faults";
  j["format_version"] = kFormatVersion;
  j["dataset"] = study.dataset_name;
  j["frames"] = {study.frame1, study.frame2};
  j["seed"] = study.seed;
  j["requirements"] = {{"max_slope_error_median_deg", study.requirements.max_median_deg},
                       {"max_slope_error_p90_deg", study.requirements.max_p90_deg},
                       {"min_within_two_sigma", study.requirements.min_within_two_sigma},
                       {"min_evaluated_share", study.requirements.min_evaluated_share},
                       {"min_rois_vs_clean", study.requirements.min_rois_vs_clean}};
  Json cases = Json::array();
  for (const FaultCase& c : study.cases) {
    Json row;
    row["case"] = c.label;
    row["fault"] = c.fault ? Json(datasets::InfoOf(c.fault->kind).name) : Json(nullptr);
    row["magnitude"] = c.fault ? Json(c.fault->magnitude) : Json(nullptr);
    row["unit"] = c.fault ? Json(datasets::InfoOf(c.fault->kind).unit) : Json(nullptr);
    row["applied"] = c.applied;
    row["ran"] = c.ran;
    row["error"] = c.ran ? Json(nullptr) : Json(c.error);
    row["range_source"] = c.ran ? Json(c.range_source) : Json(nullptr);
    row["rois"] = c.rois;
    row["rois_vs_clean"] = c.ran ? Json(c.rois_vs_clean) : Json(nullptr);
    row["with_slope"] = c.with_slope;
    row["evaluated_share"] = c.evaluated_share;
    const bool stats = c.ran && c.stats.count > 0;
    row["slope_count"] = c.stats.count;
    row["slope_error_median_deg"] = stats ? NumberOrNull(c.stats.median_abs_deg) : Json(nullptr);
    row["slope_error_p90_deg"] = stats ? NumberOrNull(c.stats.p90_abs_deg) : Json(nullptr);
    row["within_two_sigma"] = stats ? NumberOrNull(c.stats.within_two_sigma_fraction) : Json(nullptr);
    row["slope_bias_deg"] = stats ? NumberOrNull(c.stats.bias_deg) : Json(nullptr);
    row["moved_count"] = c.moved_count;
    row["moved_median_deg"] = c.moved_count > 0 ? Json(c.moved_median_deg) : Json(nullptr);
    row["moved_max_deg"] = c.moved_count > 0 ? Json(c.moved_max_deg) : Json(nullptr);
    if (c.ran) {
      const Interval interval = c.decision.FalseSafeInterval();
      row["decision"] = {{"sites", c.decision.sites()},
                         {"truly_unsafe", c.decision.truly_unsafe()},
                         {"declared_safe", c.decision.DeclaredSafe()},
                         {"false_safe", c.decision.Count(Verdict::kSafe, false)},
                         {"false_safe_rate", NumberOrNull(c.decision.FalseSafeRate())},
                         {"false_safe_rate_95", c.decision.DeclaredSafe() > 0
                                                    ? Json::array({interval.low, interval.high})
                                                    : Json(nullptr)},
                         {"new_false_safe", c.new_false_safe},
                         {"top_site_unsafe", c.decision.ranked_runs() > 0
                                                 ? Json(c.decision.TopSiteUnsafeShare() > 0.0)
                                                 : Json(nullptr)}};
    }
    const FaultVerdicts meets = VerdictsOf(c, study.requirements);
    row["meets"] = {{"median", meets.median},
                    {"p90", meets.p90},
                    {"within_two_sigma", meets.within},
                    {"evaluated_share", meets.evaluated},
                    {"rois_vs_clean", meets.rois}};
    cases.push_back(row);
  }
  j["cases"] = cases;
  Json crossings = Json::array();
  for (const FaultCrossing& x : study.crossings) {
    crossings.push_back({{"fault", x.fault},
                         {"sign", x.sign},
                         {"largest_swept", x.largest_swept},
                         {"median", OptionalNumber(x.median)},
                         {"p90", OptionalNumber(x.p90)},
                         {"within_two_sigma", OptionalNumber(x.within)},
                         {"evaluated_share", OptionalNumber(x.evaluated)},
                         {"rois_vs_clean", OptionalNumber(x.rois)}});
  }
  j["crossings"] = crossings;
  return j.dump(1) + "\n";
}

std::string FaultStudyMarkdown(const FaultStudy& study) {
  std::ostringstream out;
  out << "Faults on " << study.dataset_name << ", frames " << study.frame1 << "," << study.frame2
      << " (slope errors against the truth over the ROIs with a slope, truth and >= " << kMinPointsForSlopeStats
      << " points; moved: |slope - clean slope| on the same boxes; false-safe: sites declared safe that the "
      << "lander's truth calls unsafe, of those declared safe; new false-safe: of them, those the clean run "
      << "did not declare safe)\n\n";
  std::vector<std::vector<std::string>> rows = {{"case", "ROIs", "vs clean", "with slope", "share", "n",
                                                 "median (deg)",
                                                 "p90 (deg)", "within 2 sigma", "bias (deg)", "moved median",
                                                 "moved max", "false-safe", "new false-safe", "meets"}};
  for (const FaultCase& c : study.cases) {
    if (!c.ran) {
      rows.push_back({c.label, "-", "-", "-", "-", "-", "-", "-", "-", "-", "-", "-", "-", "-",
                      (c.applied ? "no result: " : "") + c.error});
      continue;
    }
    const bool stats = c.stats.count > 0;
    const bool moved = c.moved_count > 0;
    const FaultVerdicts verdicts = VerdictsOf(c, study.requirements);
    std::string meets;
    if (verdicts.All()) {
      meets = "all";
    } else {
      for (const auto& [ok, name] : {std::pair<bool, const char*>{verdicts.median, "median"},
                                     {verdicts.p90, "p90"},
                                     {verdicts.within, "2 sigma"},
                                     {verdicts.evaluated, "share"},
                                     {verdicts.rois, "ROIs"}}) {
        if (!ok) meets += std::string(meets.empty() ? "misses " : ", ") + name;
      }
    }
    rows.push_back({c.range_source == "navigation" ? c.label + " (range from nav)" : c.label,
                    std::to_string(c.rois), util::FixedCell(100.0 * c.rois_vs_clean, 0) + " %",
                    std::to_string(c.with_slope),
                    util::FixedCell(100.0 * c.evaluated_share, 0) + " %", std::to_string(c.stats.count),
                    stats ? util::FixedCell(c.stats.median_abs_deg, 2) : "-",
                    stats ? util::FixedCell(c.stats.p90_abs_deg, 2) : "-",
                    stats ? util::FixedCell(100.0 * c.stats.within_two_sigma_fraction, 0) + " %" : "-",
                    stats ? util::SignedCell(c.stats.bias_deg, 2) : "-",
                    moved ? util::FixedCell(c.moved_median_deg, 2) : "-",
                    moved ? util::FixedCell(c.moved_max_deg, 2) : "-",
                    c.decision.DeclaredSafe() > 0
                        ? std::to_string(c.decision.Count(Verdict::kSafe, false)) + "/" +
                              std::to_string(c.decision.DeclaredSafe())
                        : "-",
                    &c == &study.cases.front() ? "-" : std::to_string(c.new_false_safe), meets});
  }
  out << util::FormatTextTable(rows, {true, false, false, false, false, false, false, false, false, false, false,
                                      false, false, false, true});
  const FaultRequirements& r = study.requirements;
  out << "\nRequirements: slope error median <= " << util::ShortestText(r.max_median_deg) << " deg, p90 <= "
      << util::ShortestText(r.max_p90_deg) << " deg, within 2 sigma >= "
      << util::ShortestText(100.0 * r.min_within_two_sigma) << " %, share with a slope >= "
      << util::ShortestText(100.0 * r.min_evaluated_share) << " %, ROIs >= "
      << util::ShortestText(100.0 * r.min_rois_vs_clean)
      << " % of the clean run's. The smallest magnitude that misses each:\n\n";
  std::vector<std::vector<std::string>> crossing_rows = {
      {"fault", "side", "median", "p90", "within 2 sigma", "share", "ROIs"}};
  for (const FaultCrossing& x : study.crossings) {
    crossing_rows.push_back({x.fault, x.sign < 0 ? "-" : "+", CrossingCell(x.median, x.largest_swept, x.sign),
                             CrossingCell(x.p90, x.largest_swept, x.sign),
                             CrossingCell(x.within, x.largest_swept, x.sign),
                             CrossingCell(x.evaluated, x.largest_swept, x.sign),
                             CrossingCell(x.rois, x.largest_swept, x.sign)});
  }
  out << util::FormatTextTable(crossing_rows, {true, true, false, false, false, false, false});
  return out.str();
}

std::string WriteFaultPlots(const std::string& dir, const std::string& python) {
  const std::string absolute = std::filesystem::absolute(dir).string();
  return util::RunPlotScript(python, "faults", "faults_plots.py", FaultsPlotsScript(), {absolute, absolute}, 300.0);
}

}  // namespace hdabench::reference
