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

// Every flight status twice (30 and 10 points), each with a plane; one
// evaluated ROI without truth, and one whose predicted sigma is infinite.
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
    f.result.rois.push_back(roi);
    RoiTruthValue t;
    t.why = "no truth here";
    f.truths.push_back(truth ? Truth(2.0 + 0.11 * i * (i % 3 == 0 ? -1.0 : 1.0)) : t);
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
  const fs::path dir = FreshTestDir();
  util::WriteFileAtomically(dir / "compare.json", CompareResultJson(run));
  util::WriteFileAtomically(dir / "compare_timings.json", CompareTimingsJson(run));
  const std::vector<GateMetric> metrics = ComputeGateMetrics({dir.string()}, 0.1);
  const auto metric = [&](const std::string& method, const std::string& name) {
    for (const GateMetric& m : metrics) {
      if (m.method == method && m.metric == name && m.fault.empty()) return m.value;
    }
    ADD_FAILURE() << "no " << method << " " << name;
    return kNaN;
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

}  // namespace
}  // namespace hdabench::reference
