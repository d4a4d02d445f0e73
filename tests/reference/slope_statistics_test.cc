// The one rule of which slopes count (reference/flight/slope_statistics.h),
// and compare, the report (its text and the data handed to the plots), the
// gate and the flight run's own text agreeing on a record built to hold every
// status, with and without a plane, truth and enough points.
#include "reference/flight/slope_statistics.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "reference/compare/compare.h"
#include "reference/compare/compare_outputs.h"
#include "reference/flight/flight_outputs.h"
#include "reference/gate/gate.h"
#include "reference/report/report.h"
#include "tests/support/test_support.h"
#include "tools/util/angles.h"
#include "tools/util/files.h"
#include "tools/util/text.h"

namespace hdabench::reference {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(StatusHasSlope, TheFlightMethodsThreeStatusesAndEveryReferencesOk) {
  for (const char* status : {"evaluated", "unsafe slope", "unsafe roughness"}) {
    EXPECT_TRUE(StatusHasSlope(true, status)) << status;
    EXPECT_FALSE(StatusHasSlope(false, status)) << status;
  }
  for (const char* status : {"degenerate", "too few points", "not in image 2", "not evaluated"}) {
    EXPECT_FALSE(StatusHasSlope(true, status)) << status;
  }
  EXPECT_TRUE(StatusHasSlope(false, "ok"));
  EXPECT_FALSE(StatusHasSlope(true, "ok"));
  for (int s = 0; s < static_cast<int>(MethodRoiStatus::kFlight); ++s) {
    const std::string name = ToString(static_cast<MethodRoiStatus>(s));
    EXPECT_EQ(StatusHasSlope(false, name), name == "ok") << name;
  }
}

TEST(WithinTwoSigma, NeedsAFiniteSigma) {
  EXPECT_TRUE(WithinTwoSigma(1.0, 0.5));
  EXPECT_FALSE(WithinTwoSigma(1.01, 0.5));
  EXPECT_FALSE(WithinTwoSigma(0.0, kInf));  // no sigma predicted is no sigma met
  EXPECT_FALSE(WithinTwoSigma(0.0, kNaN));
}

TEST(SlopeSample, CountsWithASlopeATruthAndEnoughPoints) {
  SlopeSample s;
  s.has_slope = true;
  s.num_points = kMinPointsForSlopeStats;
  s.error_deg = 0.3;
  EXPECT_TRUE(s.Counts());
  s.num_points = kMinPointsForSlopeStats - 1;
  EXPECT_FALSE(s.Counts());
  s.num_points = kMinPointsForSlopeStats;
  s.error_deg = kNaN;  // no truth
  EXPECT_FALSE(s.Counts());
  s.error_deg = 0.3;
  s.has_slope = false;
  EXPECT_FALSE(s.Counts());
}

// The tilt error's parts count where the error counts and both parts are
// there; each part's bias is the mean of its signed slope differences. A
// compare record gives the same sample as the ROI in memory.
TEST(SlopeErrorPool, TheErrorsPartsOverTheSamplesThatCountAndHaveThem) {
  SlopeErrorPool pool;
  SlopeSample s;
  s.has_slope = true;
  s.num_points = kMinPointsForSlopeStats;
  s.error_deg = 0.5;
  s.tilt_error_deg = 0.6;
  s.definition_tilt_deg = 0.2;
  s.estimation_tilt_deg = 0.5;
  s.definition_error_deg = 0.1;
  s.estimation_error_deg = 0.4;
  pool.Add(s);
  s.definition_tilt_deg = 0.4;
  s.estimation_tilt_deg = 0.3;
  s.definition_error_deg = -0.3;
  s.estimation_error_deg = 0.8;
  pool.Add(s);
  s.definition_tilt_deg = kNaN;  // no own truth: its error counts, its parts do not
  pool.Add(s);
  s.definition_tilt_deg = 9.0;
  s.num_points = kMinPointsForSlopeStats - 1;  // does not count at all
  pool.Add(s);
  EXPECT_EQ(pool.count(), 3);
  EXPECT_EQ(pool.DefinitionTilt().count, 2);
  EXPECT_EQ(pool.EstimationTilt().count, 2);
  EXPECT_DOUBLE_EQ(pool.DefinitionTilt().median, 0.3);
  EXPECT_DOUBLE_EQ(pool.EstimationTilt().max, 0.5);
  EXPECT_DOUBLE_EQ(pool.DefinitionBias(), -0.1);
  EXPECT_DOUBLE_EQ(pool.EstimationBias(), 0.6);
  EXPECT_EQ(SlopeErrorPool().DefinitionBias(), 0.0);

  const nlohmann::json entry = {{"status", "ok"},
                                {"num_points", 30},
                                {"slope_deg", 5.0},
                                {"slope_error_deg", 0.5},
                                {"tilt_error_deg", 0.6},
                                {"tilt_definition_deg", 0.2},
                                {"tilt_estimation_deg", 0.5},
                                {"slope_definition_error_deg", 0.1},
                                {"slope_estimation_error_deg", 0.4}};
  const SlopeSample read = SampleOfCompareRecord("dense-nav", entry, {{"slope_deg", 4.5}});
  EXPECT_EQ(read.definition_tilt_deg, 0.2);
  EXPECT_EQ(read.estimation_tilt_deg, 0.5);
  EXPECT_EQ(read.definition_error_deg, 0.1);
  EXPECT_EQ(read.estimation_error_deg, 0.4);
}

// The truth of ROI i: a slope tilted toward +y.
RoiTruthValue Truth(double slope_deg) {
  RoiTruthValue truth;
  truth.available = true;
  truth.num_points = 200;
  truth.slope_deg = slope_deg;
  truth.roughness_rms_m = 0.05;
  truth.roughness_max_m = 0.15;
  truth.normal_in_local =
      Eigen::Vector3d(0.0, std::sin(slope_deg * util::kDegToRad), std::cos(slope_deg * util::kDegToRad));
  return truth;
}

// A plane tilted by slope_deg toward +y and `yaw_deg` about the vertical.
Eigen::Vector3d Normal(double slope_deg, double yaw_deg) {
  const double s = slope_deg * util::kDegToRad, y = yaw_deg * util::kDegToRad;
  return Eigen::Vector3d(std::sin(s) * std::sin(y), std::sin(s) * std::cos(y), std::cos(s));
}

// The lander's truth at ROI i: undefined at every fifth ROI; unsafe by slope
// from ROI 9 on (6 + 0.5 i deg over 10), by clearance at ROIs 1, 5, 9, 13.
datasets::synth::LandingVerdict Landing(int i) {
  datasets::synth::LandingVerdict v;
  if (i % 5 == 4) {
    v.why = "the lander's footprint leaves the truth DEM";
    return v;
  }
  v.defined = true;
  v.slope_deg = 6.0 + 0.5 * i;
  v.clearance_m = i % 4 == 1 ? 0.4 : 0.1;
  v.unsafe_by_slope = v.slope_deg > 10.0;
  v.unsafe_by_clearance = v.clearance_m > 0.3;
  v.safe = !v.unsafe_by_slope && !v.unsafe_by_clearance;
  return v;
}

// Every flight status twice (30 and 10 points), each with a plane; one
// evaluated ROI without truth, and one whose predicted sigma is infinite.
// The evaluated ROIs are ranked in order; every truth has a Landing(i) and
// a rock of 0.1 (i % 6) m. The slope limit is 4 deg, so that the
// reference's slopes (1.5 + 0.29 i) fall on both sides of it.
// The reference column (plane-nav) has every status of the table, each with
// a plane, at 30 points, and one ok at 10.
CompareRun EveryStatusRun() {
  const std::vector<hda::RoiStatus> statuses = {
      hda::RoiStatus::kEvaluated,     hda::RoiStatus::kUnsafeSlope,  hda::RoiStatus::kUnsafeRoughness,
      hda::RoiStatus::kDegenerate,    hda::RoiStatus::kTooFewPoints, hda::RoiStatus::kNotInImage2,
      hda::RoiStatus::kNotEvaluated};
  CompareRun run;
  FlightRun& f = run.flight;
  f.dataset_name = "every-status";
  f.frame1 = 0;
  f.frame2 = 6;
  f.lens_model = "LENSMODEL_PINHOLE";
  f.image_width_px = 256;
  f.image_height_px = 256;
  f.baseline_m = 30.0;
  f.lrf_range_m = 566.0;
  f.result.budget_s = 10.0;
  f.result.times.total_s = 0.2;
  f.options.max_slope_deg = 4.0;
  int rank = 0;
  const auto add_flight = [&](hda::RoiStatus status, int points, double sigma_deg, bool truth) {
    const int i = static_cast<int>(f.result.rois.size());
    hda::RoiResult roi;
    roi.id = i + 1;
    roi.status = status;
    roi.reason = hda::ToString(status);
    roi.box1_px = cv::Rect(16 * (i % 8), 16 * (i / 8), 16, 16);
    roi.order = i + 1;
    roi.counts.depth_inliers = points;
    for (int k = 0; k < points; ++k) roi.points_in_local_m.emplace_back(0.3 * k, 0.1 * i, 0.0);
    roi.has_fit = true;
    roi.slope_deg = 2.0 + 0.37 * i;
    roi.normal_in_local = Normal(roi.slope_deg, 3.0 * i);
    roi.slope_sigma_deg = sigma_deg;
    roi.roughness_rms_m = 0.04 + 0.01 * i;
    if (status == hda::RoiStatus::kEvaluated) roi.rank = ++rank;
    f.result.rois.push_back(roi);
    RoiTruthValue t;
    t.why = "no truth here";
    if (truth) {
      t = Truth(2.0 + 0.11 * i * (i % 3 == 0 ? -1.0 : 1.0));
      t.landing = Landing(i);
      t.max_rock_height_m = 0.1 * (i % 6);
    }
    f.truths.push_back(t);
  };
  for (const hda::RoiStatus status : statuses) {
    add_flight(status, 30, 0.4, true);
    add_flight(status, 10, 0.4, true);
  }
  add_flight(hda::RoiStatus::kEvaluated, 40, 0.4, false);
  add_flight(hda::RoiStatus::kEvaluated, 40, kInf, true);
  run.any_truth = true;

  run.methods = {kMethodFlight, kMethodPlaneNav};
  run.rois.resize(2);
  run.summaries.resize(2);
  for (size_t i = 0; i < f.result.rois.size(); ++i) {
    const hda::RoiResult& r = f.result.rois[i];
    MethodRoi flight;
    flight.status = MethodRoiStatus::kFlight;
    flight.flight_status = r.status;
    flight.num_points = static_cast<int>(r.points_in_local_m.size());
    flight.has_fit = true;
    flight.slope_deg = r.slope_deg;
    flight.normal_in_local = r.normal_in_local;
    flight.roughness_rms_m = r.roughness_rms_m;
    flight.has_sigma = std::isfinite(r.slope_sigma_deg);
    flight.slope_sigma_deg = r.slope_sigma_deg;
    run.rois[0].push_back(flight);

    MethodRoi ref;
    ref.status = static_cast<MethodRoiStatus>(i % static_cast<size_t>(MethodRoiStatus::kFlight));
    ref.num_points = i == 14 ? 10 : 30;
    if (i == 14) ref.status = MethodRoiStatus::kOk;
    ref.has_fit = true;
    ref.slope_deg = 1.5 + 0.29 * static_cast<double>(i);
    ref.normal_in_local = Normal(ref.slope_deg, -2.0 * static_cast<double>(i));
    ref.roughness_rms_m = 0.06;
    ref.has_sigma = true;
    ref.slope_sigma_deg = 0.3;
    run.rois[1].push_back(ref);
  }
  run.summaries[0].method = kMethodFlight;
  run.summaries[1].method = kMethodPlaneNav;
  SummariseCompareRun(&run);
  return run;
}

// The run's compare.json and compare_timings.json written into a fresh
// folder, and the gate's metrics read back from them.
std::vector<GateMetric> GateMetricsOfWrittenRun(const CompareRun& run, fs::path* dir) {
  *dir = FreshTestDir();
  util::WriteFileAtomically(*dir / "compare.json", CompareResultJson(run));
  util::WriteFileAtomically(*dir / "compare_timings.json", CompareTimingsJson(run));
  return ComputeGateMetrics({dir->string()});
}

// A metric of the main pool; NaN when the gate has none.
double MetricOf(const std::vector<GateMetric>& metrics, const std::string& method, const std::string& name) {
  for (const GateMetric& m : metrics) {
    if (m.method == method && m.metric == name && m.fault.empty() && m.pool.empty()) return m.value;
  }
  return kNaN;
}

TEST(SlopeStatistics, CompareReportGateAndRunAgreeOnEveryStatus) {
  const CompareRun run = EveryStatusRun();
  // By the rule: the flight method's three statuses with a slope at 30
  // points and truth, and the evaluated one with an infinite sigma (4); the
  // reference's ok ROIs at 30 points (ROIs 0 and 12 of 16; ROI 14's has 10).
  EXPECT_EQ(run.summaries[0].slope_vs_truth_deg.count, 4);
  EXPECT_EQ(run.summaries[0].rois_with_fit, 3 * 2 + 2);
  EXPECT_EQ(run.summaries[1].slope_vs_truth_deg.count, 2);
  EXPECT_EQ(run.summaries[1].rois_with_fit, 3);

  // The gate, from the written record.
  fs::path dir;
  const std::vector<GateMetric> metrics = GateMetricsOfWrittenRun(run, &dir);
  const auto metric = [&](const std::string& method, const std::string& name) {
    const double value = MetricOf(metrics, method, name);
    if (std::isnan(value)) ADD_FAILURE() << "no " << method << " " << name;
    return value;
  };
  for (size_t m = 0; m < run.methods.size(); ++m) {
    const MethodSummary& s = run.summaries[m];
    const std::string& name = run.methods[m];
    SCOPED_TRACE(name);
    EXPECT_EQ(metric(name, "slope_error_rois"), s.slope_vs_truth_deg.count);
    EXPECT_EQ(metric(name, "slope_error_median_deg"), s.slope_vs_truth_deg.median);
    EXPECT_EQ(metric(name, "slope_error_p90_deg"), s.slope_vs_truth_deg.p90);
    EXPECT_EQ(metric(name, "slope_error_max_deg"), s.slope_vs_truth_deg.max);
    EXPECT_EQ(metric(name, "slope_bias_abs_deg"), std::abs(s.slope_bias_deg));
    EXPECT_EQ(metric(name, "tilt_error_median_deg"), s.tilt_vs_truth_deg.median);
    EXPECT_EQ(metric(name, "tilt_error_p90_deg"), s.tilt_vs_truth_deg.p90);
    EXPECT_EQ(metric(name, "roughness_error_median_m"), s.roughness_vs_truth_m.median);
    EXPECT_EQ(metric(name, "rois_with_slope_share"),
              static_cast<double>(s.rois_with_fit) / static_cast<double>(run.rois[m].size()));
  }

  // The flight run's own statistics (`hdabench run`'s text) and the gate's
  // within-2-sigma share: the infinite sigma is not met.
  const SlopeErrorStats flight = ComputeSlopeErrorStats(run.flight);
  EXPECT_EQ(flight.count, run.summaries[0].slope_vs_truth_deg.count);
  EXPECT_EQ(flight.median_abs_deg, run.summaries[0].slope_vs_truth_deg.median);
  EXPECT_EQ(flight.p90_abs_deg, run.summaries[0].slope_vs_truth_deg.p90);
  EXPECT_EQ(flight.bias_deg, run.summaries[0].slope_bias_deg);
  EXPECT_EQ(metric(kMethodFlight, "within_two_sigma_share"), flight.within_two_sigma_fraction);

  // The report of the flight run folder says the same.
  const fs::path run_dir = dir / "run";
  fs::create_directories(run_dir);
  util::WriteFileAtomically(run_dir / "result.json", FlightResultJson(run.flight));
  util::WriteFileAtomically(run_dir / "timings.json", FlightTimingsJson(run.flight));
  ReportOptions no_plots;
  no_plots.python = "/nonexistent/python3";
  WriteReport(run_dir.string(), no_plots);
  const std::string expected =
      "Slope error over " + std::to_string(flight.count) + " ROI(s) with a slope, truth and at least " +
      std::to_string(kMinPointsForSlopeStats) + " points: median |error| " +
      util::FixedCell(flight.median_abs_deg, 2) + " deg, 90th percentile " + util::FixedCell(flight.p90_abs_deg, 2) +
      " deg, " + util::FixedCell(100.0 * flight.within_two_sigma_fraction, 0) + " % within 2 predicted sigmas.";
  EXPECT_NE(ReadText(run_dir / "report.md").find(expected), std::string::npos) << expected;

  // The data handed to the plots: per method, the samples marked as counted
  // are those the statistics count.
  const auto counted = [](const std::string& series_json) {
    std::map<std::string, int> counts;
    const nlohmann::json series = nlohmann::json::parse(series_json);
    for (const nlohmann::json& entry : series.at("series")) {
      int n = 0;
      for (const nlohmann::json& sample : entry.at("samples")) n += sample.at("counts").get<bool>() ? 1 : 0;
      counts[entry.at("method").get<std::string>()] = n;
    }
    return counts;
  };
  const std::map<std::string, int> compare_plots =
      counted(PlotSeriesJson(nlohmann::json::parse(ReadText(dir / "compare.json")), "compare"));
  EXPECT_EQ(compare_plots.at(kMethodFlight), run.summaries[0].slope_vs_truth_deg.count);
  EXPECT_EQ(compare_plots.at(kMethodPlaneNav), run.summaries[1].slope_vs_truth_deg.count);
  const std::map<std::string, int> run_plots =
      counted(PlotSeriesJson(nlohmann::json::parse(ReadText(run_dir / "result.json")), "run"));
  EXPECT_EQ(run_plots.at(kMethodFlight), flight.count);
}

// The landing decisions: compare's in-memory pools, the gate's metrics from
// the written compare.json, the flight run's own pool and the one read back
// from its result.json agree, and the flight column's counts are those of the
// rule worked out by hand.
TEST(DecisionStatistics, CompareGateAndRunAgreeOnEveryStatus) {
  const CompareRun run = EveryStatusRun();
  const DecisionPool& flight = run.summaries[0].decision;
  // ROIs 0..13 are the seven statuses twice, 14 evaluated without truth, 15
  // evaluated. Landing defined except at 4, 9, 14: sites 0-3, 5-8, 10-13, 15
  // (13). Declared safe: the evaluated ROIs 0, 1, 15; unsafe: 2-5 (the two
  // unsafe statuses), of which 4 has no truth. Truly unsafe: 1 and 5
  // (clearance), 10-13 and 15 (slope, 11 and over 10 deg).
  EXPECT_EQ(flight.sites(), 13);
  EXPECT_EQ(flight.sites_without_truth(), 3);
  EXPECT_EQ(flight.truly_unsafe(), 7);
  EXPECT_EQ(flight.Count(Verdict::kSafe, true), 1);    // ROI 0
  EXPECT_EQ(flight.Count(Verdict::kSafe, false), 2);   // ROIs 1 and 15
  EXPECT_EQ(flight.Count(Verdict::kUnsafe, true), 2);  // ROIs 2 and 3
  EXPECT_EQ(flight.Count(Verdict::kUnsafe, false), 1); // ROI 5
  EXPECT_DOUBLE_EQ(flight.FalseSafeRate(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(flight.MissedSafeRate(), 2.0 / 3.0);
  // Ranks 1 (ROI 0, safe), 2 (ROI 1, unsafe); ROI 14 (rank 3) has no truth, ROI 15 (rank 4) is unsafe.
  EXPECT_EQ(flight.ranked_runs(), 1);
  EXPECT_DOUBLE_EQ(flight.TopSiteUnsafeShare(), 0.0);
  EXPECT_DOUBLE_EQ(flight.TopKUnsafeShare(), 1.0);

  fs::path dir;
  const std::vector<GateMetric> metrics = GateMetricsOfWrittenRun(run, &dir);
  const auto metric = [&](const std::string& method, const std::string& name) {
    return MetricOf(metrics, method, name);
  };
  for (size_t m = 0; m < run.methods.size(); ++m) {
    const DecisionPool& pool = run.summaries[m].decision;
    const std::string& name = run.methods[m];
    SCOPED_TRACE(name);
    EXPECT_GT(pool.DeclaredSafe(), 0);
    EXPECT_EQ(metric(name, "decision_sites"), pool.sites());
    EXPECT_EQ(metric(name, "truly_unsafe_share"), static_cast<double>(pool.truly_unsafe()) / pool.sites());
    EXPECT_EQ(metric(name, "false_safe_rate"), pool.FalseSafeRate());
    EXPECT_EQ(metric(name, "false_safe_upper_95"), pool.FalseSafeInterval().high);
    EXPECT_EQ(metric(name, "missed_safe_rate"), pool.MissedSafeRate());
    EXPECT_EQ(metric(name, "unsafe_caught_rate"), pool.UnsafeCaughtRate());
  }
  EXPECT_EQ(metric(kMethodFlight, "top_site_unsafe_share"), flight.TopSiteUnsafeShare());
  EXPECT_TRUE(std::isnan(metric(kMethodPlaneNav, "top_site_unsafe_share")));  // a reference ranks nothing
  // The reference declares by its slope against 4 deg, on its ok ROIs only:
  // 0 (1.5 deg: safe, truly safe) and 12 (4.98 deg: unsafe, truly unsafe);
  // 14 has no truth.
  const DecisionPool& ref = run.summaries[1].decision;
  EXPECT_EQ(ref.Count(Verdict::kSafe, true), 1);
  EXPECT_EQ(ref.Count(Verdict::kUnsafe, false), 1);
  EXPECT_EQ(ref.Count(Verdict::kSafe, false) + ref.Count(Verdict::kUnsafe, true), 0);
  EXPECT_EQ(ref.Count(Verdict::kNone, true) + ref.Count(Verdict::kNone, false), 11);
  // The flight run's own pool and its record read back.
  const DecisionPool own = ComputeFlightDecisions(run.flight);
  const nlohmann::json record = nlohmann::json::parse(FlightResultJson(run.flight));
  std::vector<DecisionSample> samples;
  for (const nlohmann::json& roi : record.at("rois")) samples.push_back(DecisionOfFlightRecord(roi));
  DecisionPool read;
  read.AddRun(samples);
  for (const DecisionPool* pool : {&own, static_cast<const DecisionPool*>(&read)}) {
    EXPECT_EQ(DecisionJson(*pool), DecisionJson(flight));
  }
  // The record's decision is that pool's, with the probability rule's beside it.
  nlohmann::json decision = record.at("decision");
  ASSERT_TRUE(decision.contains("probability_rule"));
  const nlohmann::json probability_rule = decision.at("probability_rule");
  decision.erase("probability_rule");
  EXPECT_EQ(decision, nlohmann::json::parse(DecisionJson(flight).dump()));
  const ProbabilityDecisions probability = ComputeProbabilityDecisions(run.flight);
  nlohmann::json rule = nlohmann::json::parse(DecisionJson(probability.pool).dump());
  EXPECT_EQ(probability_rule.at("confusion"), rule.at("confusion"));
  EXPECT_EQ(probability_rule.at("calibration"),
            nlohmann::json::parse(SafetyCalibrationJson(probability.calibration).dump()));
}

}  // namespace
}  // namespace hdabench::reference
