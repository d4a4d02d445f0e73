#include "reference/gate/gate.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tools/util/build_identity.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tests/support/synth_scene.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

namespace fs = std::filesystem;
using testing_support::CommandResult;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;
using testing_support::WriteText;

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

// Found by the gate_files fuzz harness: a number too large for a double
// ("444444444e4444") made nlohmann's parser throw out_of_range, not
// parse_error, and the reader let it through (std::terminate in the harness,
// an internal error in hdabench). Now an InputError naming the file, for the
// suite and the thresholds alike.
TEST(ReadGateSuite, ANumberTooLargeForADoubleIsNamedNotACrash) {
  const fs::path dir = FreshTestDir();
  WriteText(dir / "overflow.json", "{\n \"format\": 444444444e4444e4444444444444e-lateral.jsnovaR-cthegin;  'why20");
  for (const auto& read : std::vector<std::function<void()>>{
           [&] { ReadGateSuite((dir / "overflow.json").string()); },
           [&] { ReadGateThresholds((dir / "overflow.json").string()); }}) {
    const std::string error = ErrorOf(read);
    EXPECT_NE(error.find((dir / "overflow.json").string() + ": not valid JSON"), std::string::npos) << error;
    EXPECT_NE(error.find("number overflow"), std::string::npos) << error;
  }
}

TEST(ReadGateSuite, MalformedSuitesAreNamedWithTheField) {
  const fs::path dir = FreshTestDir();
  const auto suite = [&](const std::string& body) {
    WriteText(dir / "suite.json",
              R"({"format": "hdabench-gate-suite", "format_version": 1, )" + body + "}");
    return ErrorOf([&] { ReadGateSuite((dir / "suite.json").string()); });
  };
  const std::string ok_entry = R"({"name": "a", "synth": {"preset": "novac-lateral"}})";
  EXPECT_EQ(suite(R"("methods": ["flight"], "entries": [)" + ok_entry + "]"), "no error");
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [)" + ok_entry + ", " + ok_entry + "]")
                .find("entries[1]: name 'a' is repeated"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["colmap"], "entries": [)" + ok_entry + "]").find("unknown method 'colmap'"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a"}])")
                .find("entries[0]: give exactly one of 'synth', 'dataset', 'stereolunar', 'observability'"),
            std::string::npos);
  // A named pool: a plain name, for a dataset entry.
  EXPECT_EQ(suite(R"("methods": ["flight"], "entries": [{"name": "a", "synth": {"preset": "novac-lateral"}, )"
                  R"("pool": "steep"}])"),
            "no error");
  EXPECT_EQ(ReadGateSuite((dir / "suite.json").string()).entries[0].pool, "steep");
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "synth": {"preset": "novac-lateral"}, )"
                  R"("pool": "a b"}])")
                .find("entries[0]: pool 'a b' must be letters, digits"),
            std::string::npos);
  // An observability entry: the study's options, checked when read.
  EXPECT_EQ(suite(R"("methods": ["flight"], "entries": [{"name": "o", "observability": )"
                  R"({"geometry": ["lateral"], "baselines_m": [20, 30], "pixel_noise_px": [0.1], "trials": 10}}])"),
            "no error");
  const GateEntry study = ReadGateSuite((dir / "suite.json").string()).entries[0];
  ASSERT_TRUE(study.observability.has_value());
  EXPECT_EQ(study.observability->baselines_m, (std::vector<double>{20, 30}));
  EXPECT_EQ(study.observability->trials, 10);
  EXPECT_EQ(study.observability->geometries.size(), 1u);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "o", "observability": {"trials": 10}}])")
                .find("entries[0].observability: field 'baselines_m' is required"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "o", "observability": )"
                  R"({"baselines_m": [10], "geometry": ["sideways"]}}])")
                .find("entries[0].observability: geometry: "),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "o", "observability": )"
                  R"({"baselines_m": [10], "trials": 0}}])")
                .find("entries[0].observability: trials = 0"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "o", "dataset": "x", "observability": )"
                  R"({"baselines_m": [10]}}])")
                .find("give exactly one of"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "synth": {"preset": "novac-lateral", "set": {"speed": 3}}}])")
                .find("entries[0].synth: "),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a b", "dataset": "x"}])").find("name 'a b'"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [)" + ok_entry + R"(], "extra": 1)").find("unknown field 'extra'"),
            std::string::npos);
  // COLMAP's options for the suite: the number of SIFT features, an integer.
  EXPECT_EQ(suite(R"("methods": ["flight"], "colmap": {"max_features": 8192}, "entries": [)" + ok_entry + "]"),
            "no error");
  EXPECT_EQ(ReadGateSuite((dir / "suite.json").string()).colmap.max_features, 8192);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"max_features": 8.5}, "entries": [)" + ok_entry + "]")
                .find("colmap: field 'max_features' must be an integer in [10, 1000000]"),
            std::string::npos);
  // The extraction and matching options, each in ColmapOptions' range.
  EXPECT_EQ(suite(R"("methods": ["flight"], "colmap": {"first_octave": -2, "octave_resolution": 4, )"
                  R"("peak_threshold": 0.004, "nav_band_px": 2.5}, "entries": [)" + ok_entry + "]"),
            "no error");
  const GateSuite read = ReadGateSuite((dir / "suite.json").string());
  EXPECT_FALSE(read.colmap.max_features.has_value());
  EXPECT_EQ(read.colmap.first_octave, -2);
  EXPECT_EQ(read.colmap.octave_resolution, 4);
  EXPECT_EQ(read.colmap.peak_threshold, 0.004);
  EXPECT_EQ(read.colmap.nav_band_px, 2.5);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"first_octave": -3}, "entries": [)" + ok_entry + "]")
                .find("colmap: sift_first_octave = -3: expected in [-2, 2]"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"octave_resolution": 2.5}, "entries": [)" + ok_entry + "]")
                .find("colmap: field 'octave_resolution' must be an integer"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"nav_band_px": -1}, "entries": [)" + ok_entry + "]")
                .find("colmap: nav_guided_max_error_px = -1: expected in [0, 1000]"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"peak_threshold": "low"}, "entries": [)" + ok_entry + "]")
                .find("colmap: field 'peak_threshold' must be a finite number"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "colmap": {"peak": 1}, "entries": [)" + ok_entry + "]")
                .find("colmap: unknown field 'peak'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { ReadGateSuite((dir / "missing.json").string()); }).find("missing.json: cannot read"),
            std::string::npos);
  // An entry's flight-method parameters: "hda", every HdaOptions key, nested
  // or dotted; unknown keys and bad values named.
  EXPECT_EQ(suite(R"("methods": ["flight"], "entries": [{"name": "a", "synth": {"preset": "truck"}, )"
                  R"("hda": {"max_relief_m": 0.5, "quadtree": {"max_block_stddev": 15}}}])"),
            "no error");
  const GateEntry entry = ReadGateSuite((dir / "suite.json").string()).entries[0];
  EXPECT_EQ(entry.hda.options.max_relief_m, 0.5);
  EXPECT_EQ(entry.hda.options.quadtree.max_block_stddev, 15.0);
  EXPECT_EQ(entry.hda.given.size(), 2u);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "hda": {"relief": 1}}])")
                .find("entries[0].hda: unknown flight-method parameter 'relief'; known: max_hazard_height_m"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "hda": {"min_points": 1}}])")
                .find("entries[0]: unusable flight-method parameters: min_points = 1"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "hda": {"flight_instructions_per_s": 1}}])")
                .find("entries[0].hda: 'flight_instructions_per_s' is the gate's own"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "site_size_m": 3, )"
                  R"("hda": {"min_points": 12}}])")
                .find("give the site size once"),
            std::string::npos);
  // A fault (one magnitude, or none for a fault without one) and the entry's own methods.
  EXPECT_EQ(suite(R"("methods": ["flight", "plane-nav"], "entries": [{"name": "a", "dataset": "x", )"
                  R"("fault": "lrf-scale=0.050", "methods": ["flight"]}, {"name": "b", "dataset": "x", )"
                  R"("fault": "lrf-absent"}])"),
            "no error");
  const GateSuite faulted = ReadGateSuite((dir / "suite.json").string());
  ASSERT_TRUE(faulted.entries[0].fault.has_value());
  EXPECT_EQ(datasets::FaultLabel(*faulted.entries[0].fault), "lrf-scale=0.05");
  EXPECT_EQ(faulted.entries[0].methods, (std::vector<std::string>{"flight"}));
  EXPECT_EQ(datasets::FaultLabel(*faulted.entries[1].fault), "lrf-absent");
  EXPECT_TRUE(faulted.entries[1].methods.empty());
  EXPECT_EQ(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "fault": "lrf-scale"}])"),
            (dir / "suite.json").string() +
                ": entries[0]: fault: 'lrf-scale' is a sweep of 8 magnitudes: give one, NAME=M");
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "fault": "lrf-gone=1"}])")
                .find("entries[0]: fault: unknown fault 'lrf-gone'"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "fault": "lrf-absent=2"}])")
                .find("entries[0]: fault: 'lrf-absent=2': lrf-absent takes no magnitude"),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "a", "dataset": "x", "methods": ["sift"]}])")
                .find("entries[0]: methods: "),
            std::string::npos);
  EXPECT_NE(suite(R"("methods": ["flight"], "entries": [{"name": "o", "fault": "lrf-absent", "observability": )"
                  R"({"baselines_m": [10]}}])")
                .find("entries[0]: 'fault' applies to a dataset, not to an observability study"),
            std::string::npos);
}

TEST(ReadGateThresholds, OneBoundPerThresholdAndKnownNames) {
  const fs::path dir = FreshTestDir();
  const auto thresholds = [&](const std::string& list) {
    WriteText(dir / "t.json",
              R"({"format": "hdabench-gate-thresholds", "format_version": 1, "thresholds": [)" + list + "]}");
    return ErrorOf([&] { ReadGateThresholds((dir / "t.json").string()); });
  };
  EXPECT_EQ(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5, "tolerance": 0.5})"),
            "no error");
  EXPECT_NE(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5, "min": 1})")
                .find("exactly one of 'max' and 'min'"),
            std::string::npos);
  EXPECT_NE(thresholds(R"({"method": "flight", "metric": "slope_p90", "max": 5})").find("unknown metric 'slope_p90'"),
            std::string::npos);
  EXPECT_NE(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5},
                          {"method": "flight", "metric": "slope_error_p90_deg", "max": 6})")
                .find("given twice"),
            std::string::npos);
  // A fault's pool has its own thresholds; its label is the fault's, whatever the spelling.
  EXPECT_EQ(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5},
                          {"method": "flight", "metric": "slope_error_p90_deg", "max": 6, "fault": "clock-offset=0.050"})"),
            "no error");
  EXPECT_EQ(ReadGateThresholds((dir / "t.json").string()).thresholds[1].fault, "clock-offset=0.05");
  EXPECT_NE(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5, "fault": "clock-offset=0.05"},
                          {"method": "flight", "metric": "slope_error_p90_deg", "max": 6, "fault": "clock-offset=5e-2"})")
                .find("flight under clock-offset=0.05 slope_error_p90_deg is given twice"),
            std::string::npos);
  EXPECT_NE(thresholds(R"({"method": "flight", "metric": "slope_error_p90_deg", "max": 5, "fault": "clock-offset"})")
                .find("thresholds[0]: fault: 'clock-offset' is a sweep of"),
            std::string::npos);
}

// The suites and thresholds checked in under gate/ read without error, and
// every threshold is for a method its suite compares.
TEST(ReadGateSuite, TheCheckedInSuitesAndThresholdsRead) {
  const fs::path gate = fs::path(HDABENCH_SOURCE_DIR) / "gate";
  for (const std::string name : {"", "-ci", "-lateral", "-forward", "-oblique", "-decision", "-scale", "-external"}) {
    SCOPED_TRACE("gate/suite" + name + ".json");
    const GateSuite suite = ReadGateSuite((gate / ("suite" + name + ".json")).string());
    const GateThresholds thresholds = ReadGateThresholds((gate / ("thresholds" + name + ".json")).string());
    EXPECT_FALSE(suite.entries.empty());
    EXPECT_FALSE(thresholds.thresholds.empty());
    for (const GateThreshold& threshold : thresholds.thresholds) {
      EXPECT_NE(std::find(suite.methods.begin(), suite.methods.end(), threshold.method), suite.methods.end())
          << threshold.method << " " << threshold.metric;
      EXPECT_FALSE(threshold.why.empty()) << threshold.method << " " << threshold.metric;
      // A named pool's threshold: an entry of the suite is in that pool.
      if (!threshold.pool.empty()) {
        EXPECT_TRUE(std::any_of(suite.entries.begin(), suite.entries.end(),
                                [&](const GateEntry& e) { return e.pool == threshold.pool; }))
            << threshold.method << " on " << threshold.pool << " " << threshold.metric;
      }
      if (threshold.fault.empty()) continue;
      // A fault's threshold: an entry of the suite runs the method under that fault.
      const bool under_fault = std::any_of(suite.entries.begin(), suite.entries.end(), [&](const GateEntry& e) {
        const std::vector<std::string>& methods = e.methods.empty() ? suite.methods : e.methods;
        return e.fault && datasets::FaultLabel(*e.fault) == threshold.fault && e.pool == threshold.pool &&
               std::find(methods.begin(), methods.end(), threshold.method) != methods.end();
      });
      EXPECT_TRUE(under_fault) << threshold.method << " under " << threshold.fault << " " << threshold.metric;
    }
  }
}

// Two hand-written entries: the metrics pool their ROIs.
TEST(ComputeGateMetrics, PoolsTheRoisOfEveryEntry) {
  const fs::path dir = FreshTestDir();
  const auto entry = [&](const std::string& name, const std::vector<double>& errors, double seconds) {
    nlohmann::json rois = nlohmann::json::array();
    for (size_t i = 0; i < errors.size(); ++i) {
      rois.push_back({{"id", i + 1},
                      {"truth", {{"slope_deg", 2.0}, {"roughness_rms_m", 0.1}}},
                      {"methods",
                       {{"flight",
                         {{"status", "evaluated"}, {"num_points", 30}, {"slope_deg", 2.0 + errors[i]},
                          {"slope_sigma_deg", 1.0}, {"slope_error_deg", errors[i]},
                          {"tilt_error_deg", 2.0 * std::abs(errors[i])}, {"roughness_rms_m", 0.3}}}}}});
    }
    // A ROI the method calls degenerate: its plane (a large error) is a
    // diagnostic, not a slope, and stays out of the error statistics.
    rois.push_back({{"id", 98},
                    {"truth", {{"slope_deg", 2.0}, {"roughness_rms_m", 0.1}}},
                    {"methods", {{"flight", {{"status", "degenerate"}, {"num_points", 21}, {"slope_deg", 40.0},
                                             {"slope_sigma_deg", nullptr}, {"slope_error_deg", 38.0},
                                             {"roughness_rms_m", 0.6}}}}}});
    // One ROI without a slope, and one with too few points.
    rois.push_back({{"id", 99}, {"truth", nullptr},
                    {"methods", {{"flight", {{"status", "too few points"}, {"num_points", 3},
                                             {"slope_deg", nullptr}, {"slope_sigma_deg", nullptr},
                                             {"slope_error_deg", nullptr}, {"roughness_rms_m", nullptr}}}}}});
    fs::create_directories(dir / name);
    WriteText(dir / name / "compare.json",
              nlohmann::json({{"methods", {{{"name", "flight"}, {"ok", true}}}}, {"rois", rois}}).dump());
    WriteText(dir / name / "compare_timings.json",
              nlohmann::json({{"methods", {{{"name", "flight"}, {"seconds", 0.01}, {"flight_computer_s", seconds}}}}})
                  .dump());
    return (dir / name).string();
  };
  const std::vector<GateMetric> metrics =
      ComputeGateMetrics({entry("a", {1.0, -3.0}, 2.0), entry("b", {0.5, 2.5, -4.0}, 4.0)});
  const auto value = [&](const std::string& metric) {
    for (const GateMetric& m : metrics) {
      if (m.method == "flight" && m.metric == metric) return m.value;
    }
    ADD_FAILURE() << "no " << metric;
    return -1.0;
  };
  EXPECT_DOUBLE_EQ(value("slope_error_median_deg"), 2.5);    // of 0.5 1 2.5 3 4
  EXPECT_DOUBLE_EQ(value("slope_error_p90_deg"), 3.6);       // 3 + 0.6 * (4 - 3)
  EXPECT_DOUBLE_EQ(value("slope_error_max_deg"), 4.0);
  EXPECT_DOUBLE_EQ(value("tilt_error_median_deg"), 5.0);     // twice the slope errors
  EXPECT_DOUBLE_EQ(value("tilt_error_p90_deg"), 7.2);
  EXPECT_DOUBLE_EQ(value("slope_bias_abs_deg"), 0.6);        // |(1 - 3 + 0.5 + 2.5 - 4) / 5|
  EXPECT_DOUBLE_EQ(value("roughness_error_median_m"), 0.2);
  EXPECT_DOUBLE_EQ(value("rois_with_slope_share"), 5.0 / 9.0);
  EXPECT_DOUBLE_EQ(value("within_two_sigma_share"), 2.0 / 5.0);  // |error| <= 2 sigma = 2: 0.5 and 1
  EXPECT_DOUBLE_EQ(value("flight_seconds_per_pair"), 4.0);     // the larger predicted time, not the wall time
  EXPECT_DOUBLE_EQ(value("failed_entries"), 0.0);
  EXPECT_DOUBLE_EQ(value("slope_error_rois"), 5.0);

  // An entry whose record names a fault is pooled apart, per fault: the pool
  // without a fault is the same as before, and the fault's pool has its own.
  const std::string faulted = entry("c", {7.0, -9.0}, 9.0);
  WriteText(fs::path(faulted) / "gate_entry.json",
            nlohmann::json({{"entry", {{"name", "c"}, {"fault", "lrf-scale=0.05"}}}}).dump());
  const std::vector<GateMetric> with_fault = ComputeGateMetrics(
      {(dir / "a").string(), faulted, (dir / "b").string()});
  const auto pooled = [&](const std::string& fault, const std::string& metric) {
    for (const GateMetric& m : with_fault) {
      if (m.method == "flight" && m.metric == metric && m.fault == fault) return m.value;
    }
    ADD_FAILURE() << "no " << metric << " under '" << fault << "'";
    return -1.0;
  };
  for (const GateMetric& m : metrics) {
    EXPECT_DOUBLE_EQ(pooled("", m.metric), m.value) << m.metric;
  }
  EXPECT_DOUBLE_EQ(pooled("lrf-scale=0.05", "slope_error_median_deg"), 8.0);
  EXPECT_DOUBLE_EQ(pooled("lrf-scale=0.05", "slope_error_max_deg"), 9.0);
  EXPECT_DOUBLE_EQ(pooled("lrf-scale=0.05", "slope_error_rois"), 2.0);
  EXPECT_DOUBLE_EQ(pooled("lrf-scale=0.05", "flight_seconds_per_pair"), 9.0);
  EXPECT_DOUBLE_EQ(pooled("lrf-scale=0.05", "rois_with_slope_share"), 2.0 / 4.0);
  // The metrics file keeps the fault, and only where there is one.
  const std::string json = GateMetricsJson(with_fault);
  EXPECT_EQ(json.find("\"fault\": \"\""), std::string::npos);
  WriteText(dir / "metrics.json", json);
  const std::vector<GateMetric> read = ReadGateMetrics((dir / "metrics.json").string());
  ASSERT_EQ(read.size(), with_fault.size());
  for (size_t i = 0; i < read.size(); ++i) {
    EXPECT_EQ(read[i].fault, with_fault[i].fault);
    EXPECT_EQ(read[i].metric, with_fault[i].metric);
  }
  // A threshold on the fault's pool checks that pool, and says so by name.
  GateThresholds thresholds;
  thresholds.thresholds = {{"flight", "slope_error_max_deg", 8.0, std::nullopt, 0.0, "", "lrf-scale=0.05", ""},
                           {"flight", "slope_error_max_deg", 8.0, std::nullopt, 0.0, "", "", ""}};
  const std::vector<GateCheck> checks = CheckGate(with_fault, thresholds, nullptr);
  ASSERT_EQ(checks.size(), 2u);
  EXPECT_EQ(checks[0].Summary(), "flight under lrf-scale=0.05 slope_error_max_deg = 9.000 > 8.000 (threshold)");
  EXPECT_TRUE(checks[1].passed);
  EXPECT_NE(GateTable(checks).find("| flight under lrf-scale=0.05 | slope_error_max_deg | 9.000 |"), std::string::npos);
}

// A named pool (a suite entry's "pool") is checked apart from the main one
// and from a fault's, and named so; its metrics keep their pool through the
// metrics file.
TEST(CheckGate, ANamedPoolIsCheckedApartAndNamed) {
  const std::vector<GateMetric> metrics = {{"flight", "false_safe_rate", 0.01, "", ""},
                                           {"flight", "false_safe_rate", 0.45, "", "steep"},
                                           {"flight", "false_safe_rate", 0.50, "lrf-absent", "steep"}};
  GateThresholds thresholds;
  thresholds.thresholds = {{"flight", "false_safe_rate", 0.03, std::nullopt, 0.0, "", "", ""},
                           {"flight", "false_safe_rate", 0.37, std::nullopt, 0.0, "", "", "steep"},
                           {"flight", "false_safe_rate", 0.60, std::nullopt, 0.0, "", "lrf-absent", "steep"}};
  const std::vector<GateCheck> checks = CheckGate(metrics, thresholds, nullptr);
  ASSERT_EQ(checks.size(), 3u);
  EXPECT_TRUE(checks[0].passed);
  EXPECT_FALSE(checks[1].passed);
  EXPECT_EQ(checks[1].Summary(), "flight on steep false_safe_rate = 0.450 > 0.370 (threshold)");
  EXPECT_TRUE(checks[2].passed);
  EXPECT_EQ(checks[2].Summary(), "flight on steep under lrf-absent false_safe_rate = 0.500");
  const fs::path dir = FreshTestDir();
  util::WriteFileAtomically(dir / "metrics.json", GateMetricsJson(metrics));
  const std::vector<GateMetric> read = ReadGateMetrics((dir / "metrics.json").string());
  ASSERT_EQ(read.size(), 3u);
  EXPECT_EQ(read[1].pool, "steep");
  EXPECT_EQ(read[2].fault, "lrf-absent");
  EXPECT_EQ(read[2].pool, "steep");
}

TEST(CheckGate, ThresholdsMarginsAndRegressions) {
  GateThresholds thresholds;
  thresholds.thresholds = {{"flight", "slope_error_p90_deg", 5.0, std::nullopt, 0.5, "", "", ""},
                           {"flight", "within_two_sigma_share", std::nullopt, 0.8, 0.05, "", "", ""},
                           {"flight", "slope_error_max_deg", 20.0, std::nullopt, 1.0, "", "", ""}};
  const std::vector<GateMetric> metrics = {{"flight", "slope_error_p90_deg", 4.0, "", ""},
                                           {"flight", "within_two_sigma_share", 0.7, "", ""}};
  const std::vector<GateMetric> baseline = {{"flight", "slope_error_p90_deg", 3.4, "", ""},
                                            {"flight", "within_two_sigma_share", 0.72, "", ""}};
  const std::vector<GateCheck> checks = CheckGate(metrics, thresholds, &baseline);
  ASSERT_EQ(checks.size(), 3u);
  EXPECT_TRUE(checks[0].passed);
  EXPECT_DOUBLE_EQ(checks[0].margin, 1.0);
  EXPECT_TRUE(checks[0].regressed);  // 0.6 worse than the baseline, tolerance 0.5
  EXPECT_FALSE(checks[1].passed);
  EXPECT_NEAR(checks[1].margin, -0.1, 1e-12);
  EXPECT_FALSE(checks[1].regressed);  // 0.02 worse, tolerance 0.05
  EXPECT_EQ(checks[1].Summary(), "flight within_two_sigma_share = 0.700 < 0.800 (threshold)");
  EXPECT_FALSE(checks[2].has_value);  // no data is a failure, named as such
  EXPECT_NE(checks[2].Summary().find("no value"), std::string::npos);
  EXPECT_NE(GateTable(checks).find("| flight | slope_error_p90_deg | 4.000 | <= 5.000 | 1.000 | 3.400 | pass but REGRESSED |"),
            std::string::npos)
      << GateTable(checks);
}

// ---------------------------------------------------------------------------
// The command on a real scene: two entries on the default scene (exact
// navigation), flight only (deterministic to the byte).

class GateCommand : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new fs::path(testing_support::CachedExactNavLateralScene(HDABENCH_TEST_TMP));
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  // The suite: the scene with 10 m and 14 m sites.
  static fs::path WriteSuite(const fs::path& dir) {
    nlohmann::json suite = {{"format", "hdabench-gate-suite"},
                            {"format_version", 1},
                            {"methods", {"flight"}},
                            {"entries",
                             {{{"name", "sites-10m"}, {"dataset", scene_->string()}, {"site_size_m", 10}},
                              {{"name", "sites-14m"}, {"dataset", scene_->string()}, {"site_size_m", 14}}}}};
    WriteText(dir / "suite.json", suite.dump(1));
    return dir / "suite.json";
  }
  static fs::path WriteThresholds(const fs::path& dir, const std::string& name,
                                  const nlohmann::json& list) {
    WriteText(dir / name, nlohmann::json({{"format", "hdabench-gate-thresholds"},
                                          {"format_version", 1},
                                          {"thresholds", list}})
                              .dump(1));
    return dir / name;
  }
  static double Metric(const fs::path& metrics_file, const std::string& metric) {
    for (const GateMetric& m : ReadGateMetrics(metrics_file.string())) {
      if (m.method == "flight" && m.metric == metric) return m.value;
    }
    ADD_FAILURE() << "no flight " << metric << " in " << metrics_file;
    return 0.0;
  }
  // `hdabench gate ARGS`, sent `signal_number` once `file` exists (RunHdabenchUntil).
  static int RunGateUntil(const std::vector<std::string>& gate_args, const fs::path& file, int signal_number,
                          const fs::path& err_file) {
    std::vector<std::string> args = {"gate"};
    args.insert(args.end(), gate_args.begin(), gate_args.end());
    return testing_support::RunHdabenchUntil(args, file, signal_number, err_file);
  }
  static fs::path* scene_;
};
fs::path* GateCommand::scene_ = nullptr;

TEST_F(GateCommand, PassesCleanAndFailsNamingTheMetricWhenTheFlightMethodIsMadeWorse) {
  const fs::path dir = FreshTestDir();
  const fs::path suite = WriteSuite(dir);
  const fs::path loose = WriteThresholds(
      dir, "loose.json",
      {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", 90}},
       {{"method", "flight"}, {"metric", "rois_with_slope_share"}, {"min", 0.0}, {"tolerance", 0.1}}});
  CommandResult clean = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", loose.string(),
                                     "--out", (dir / "clean").string(), "--write-baseline",
                                     (dir / "baseline.json").string()},
                                    dir);
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  EXPECT_NE(clean.out.find("| flight | slope_error_median_deg |"), std::string::npos) << clean.out;
  const double median = Metric(dir / "baseline.json", "slope_error_median_deg");
  const double p90 = Metric(dir / "baseline.json", "slope_error_p90_deg");
  const double tilt = Metric(dir / "baseline.json", "tilt_error_median_deg");
  const double share = Metric(dir / "baseline.json", "rois_with_slope_share");
  EXPECT_GT(Metric(dir / "baseline.json", "slope_error_rois"), 20.0);

  // Thresholds from the clean run plus a margin: the clean run passes them.
  const fs::path tight = WriteThresholds(
      dir, "tight.json",
      {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", median + 1.0}, {"tolerance", 0.3}},
       {{"method", "flight"}, {"metric", "slope_error_p90_deg"}, {"max", p90 + 2.0}, {"tolerance", 0.5}},
       {{"method", "flight"}, {"metric", "tilt_error_median_deg"}, {"max", tilt + 1.0}, {"tolerance", 0.3}},
       {{"method", "flight"}, {"metric", "rois_with_slope_share"}, {"min", share - 0.2}, {"tolerance", 0.1}}});
  clean = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", tight.string(), "--out",
                       (dir / "clean").string(), "--baseline", (dir / "baseline.json").string()},
                      dir);
  EXPECT_EQ(clean.exit_code, 0) << clean.err;

  // 0.6 px of noise on the flight method's matches (its own error is about
  // 0.06 px): the method finds the slopes unobservable (degenerate). The
  // fault's noise is independent from match to match, where the sigma takes
  // the matches' noise as shared between overlapping windows, so the sigma
  // overstates it and no slope is kept: the error metrics have no value,
  // which fails them as a value over the threshold would.
  const CommandResult worse = RunHdabench(
      {"gate", "--suite", suite.string(), "--thresholds", tight.string(), "--out",
       (dir / "worse").string(), "--fault-match-noise-px", "0.6"},
      dir);
  EXPECT_EQ(worse.exit_code, 1) << worse.err;
  EXPECT_NE(worse.err.find("FAILED flight rois_with_slope_share = "), std::string::npos) << worse.err;
  EXPECT_NE(worse.err.find("FAILED flight tilt_error_median_deg"), std::string::npos) << worse.err;
  // The page says so too, with the failing row marked and each entry linked to its report.
  const std::string page = ReadText(dir / "worse" / "gate.html");
  EXPECT_NE(page.find("FAIL: "), std::string::npos);
  EXPECT_NE(page.find("<tr class=\"fail\""), std::string::npos);
  EXPECT_NE(page.find("<a href=\"entries/sites-10m/report.html\">"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "worse" / "entries" / "sites-10m" / "report.html"));
  EXPECT_NE(ReadText(dir / "clean" / "gate.html").find("PASS: every metric within its threshold"),
            std::string::npos);
  EXPECT_NE(worse.out.find("| flight | slope_error_median_deg |"), std::string::npos);

  // Against the baseline, with thresholds it still meets: a regression.
  const CommandResult regressed = RunHdabench(
      {"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--out",
       (dir / "worse").string(), "--fault-match-noise-px", "0.6", "--baseline",
       (dir / "baseline.json").string()},
      dir);
  EXPECT_EQ(regressed.exit_code, 1) << regressed.err;
  EXPECT_NE(regressed.err.find("FAILED flight rois_with_slope_share = "), std::string::npos) << regressed.err;
  EXPECT_NE(regressed.err.find("regressed from the baseline's"), std::string::npos) << regressed.err;
  // The second run reused the entries of the first.
  EXPECT_NE(regressed.err.find("complete from an earlier run"), std::string::npos) << regressed.err;
}

// The external method in the gate: its metrics are gated like a built-in
// method's, a rerun reuses the entry, and a changed program redoes it. A suite
// that lists it without a program is refused when read.
TEST_F(GateCommand, TheExternalMethodIsGatedAndAChangedProgramRedoesTheEntry) {
  const fs::path dir = FreshTestDir();
  const fs::path program = dir / "plane_fit.py";
  fs::copy_file(fs::path(HDABENCH_SOURCE_DIR) / "tools" / "external" / "plane_fit.py", program);
  nlohmann::json suite = {{"format", "hdabench-gate-suite"},
                          {"format_version", 1},
                          {"methods", {"flight", "external"}},
                          {"entries", {{{"name", "sites-10m"}, {"dataset", scene_->string()}}}}};
  WriteText(dir / "no-program.json", suite.dump(1));
  try {
    ReadGateSuite((dir / "no-program.json").string());
    ADD_FAILURE() << "a suite with the external method and no program was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("entries[0]: the method 'external' needs the suite's \"external\""),
              std::string::npos)
        << e.what();
  }
  // "./": a program in the suite's folder (a bare name is looked up in PATH).
  suite["external"] = {{"program", "./plane_fit.py"}, {"timeout_s", 120}};
  WriteText(dir / "suite.json", suite.dump(1));
  // The flight method's own bar: the example fits the flight method's points.
  const fs::path thresholds = WriteThresholds(
      dir, "thresholds.json",
      {{{"method", "external"}, {"metric", "slope_error_median_deg"}, {"max", 1.0}, {"tolerance", 0.1}},
       {{"method", "external"}, {"metric", "rois_with_slope_share"}, {"min", 0.5}, {"tolerance", 0.1}}});
  const std::vector<std::string> args = {"gate", "--suite", (dir / "suite.json").string(), "--thresholds",
                                         thresholds.string(), "--out", (dir / "out").string()};
  const CommandResult first = RunHdabench(args, dir);
  ASSERT_EQ(first.exit_code, 0) << first.err;
  EXPECT_NE(first.out.find("| external | slope_error_median_deg |"), std::string::npos) << first.out;
  EXPECT_TRUE(fs::exists(dir / "out" / "entries" / "sites-10m" / "external" / "output.json"));
  const CommandResult again = RunHdabench(args, dir);
  EXPECT_EQ(again.exit_code, 0) << again.err;
  EXPECT_NE(again.err.find("complete from an earlier run"), std::string::npos) << again.err;
  std::ofstream(program, std::ios::app) << "# changed\n";
  const CommandResult changed = RunHdabench(args, dir);
  EXPECT_EQ(changed.exit_code, 0) << changed.err;
  EXPECT_EQ(changed.err.find("complete from an earlier run"), std::string::npos) << changed.err;
}

// Starts the gate in the background and kills it (SIGKILL) once the first
// entry is complete; the rerun finishes the suite without redoing it, and the
// metrics equal those of an uninterrupted run.
TEST_F(GateCommand, KilledHalfwayItResumesWithoutRedoingAndGivesTheSameResults) {
  const fs::path dir = FreshTestDir();
  const fs::path suite = WriteSuite(dir);
  const fs::path loose = WriteThresholds(
      dir, "loose.json", {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", 90}}});
  const fs::path first = dir / "resumed" / "entries" / "sites-10m" / "compare.json";
  const int status = RunGateUntil({"--suite", suite.string(), "--thresholds", loose.string(), "--jobs", "1",
                                   "--quiet", "--out", (dir / "resumed").string()},
                                  first, SIGKILL, "");
  ASSERT_TRUE(fs::exists(first)) << "the first entry never completed";
  ASSERT_TRUE(WIFSIGNALED(status)) << "the gate finished before it could be killed";
  EXPECT_FALSE(fs::exists(dir / "resumed" / "entries" / "sites-14m" / "compare.json"));
  const auto first_time = fs::last_write_time(first);

  const CommandResult rerun = RunHdabench(
      {"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--jobs", "1", "--out",
       (dir / "resumed").string()},
      dir);
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  EXPECT_NE(rerun.err.find("sites-10m: complete from an earlier run"), std::string::npos) << rerun.err;
  EXPECT_NE(rerun.err.find("sites-14m: done in"), std::string::npos) << rerun.err;
  EXPECT_EQ(fs::last_write_time(first), first_time);  // not redone
  for (const auto& item : fs::directory_iterator(dir / "resumed" / "entries")) {
    EXPECT_EQ(item.path().filename().string().find(".partial"), std::string::npos) << item.path();
  }

  const CommandResult whole = RunHdabench(
      {"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--jobs", "2", "--out",
       (dir / "whole").string()},
      dir);
  ASSERT_EQ(whole.exit_code, 0) << whole.err;
  // The same metrics, the flight time too (counted work, not a clock).
  const std::vector<GateMetric> resumed = ReadGateMetrics((dir / "resumed" / "metrics.json").string());
  const std::vector<GateMetric> uninterrupted = ReadGateMetrics((dir / "whole" / "metrics.json").string());
  ASSERT_EQ(resumed.size(), uninterrupted.size());
  for (size_t i = 0; i < resumed.size(); ++i) {
    EXPECT_EQ(resumed[i].metric, uninterrupted[i].metric);
    EXPECT_EQ(resumed[i].value, uninterrupted[i].value) << resumed[i].metric;
  }
  for (const char* entry : {"sites-10m", "sites-14m"}) {
    EXPECT_EQ(ReadText(dir / "resumed" / "entries" / entry / "compare.json"),
              ReadText(dir / "whole" / "entries" / entry / "compare.json"))
        << entry;
  }
}

// SIGINT (Ctrl-C) once the first entry is complete: the gate says it was
// interrupted and exits with 130; the rerun takes the finished entry as it is
// and finishes the suite.
TEST_F(GateCommand, InterruptedItSaysSoExitsWith130AndTheRerunFinishes) {
  const fs::path dir = FreshTestDir();
  const fs::path suite = WriteSuite(dir);
  const fs::path loose = WriteThresholds(
      dir, "loose.json", {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", 90}}});
  const fs::path err_file = dir / "gate.err";
  const fs::path first = dir / "out" / "entries" / "sites-10m" / "compare.json";
  const int status = RunGateUntil({"--suite", suite.string(), "--thresholds", loose.string(), "--jobs", "1",
                                   "--quiet", "--out", (dir / "out").string()},
                                  first, SIGINT, err_file);
  ASSERT_TRUE(fs::exists(first)) << "the first entry never completed";
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  if (WEXITSTATUS(status) == 0) GTEST_SKIP() << "the gate finished before the interrupt reached it";
  EXPECT_EQ(WEXITSTATUS(status), 130);
  EXPECT_NE(ReadText(err_file).find("hdabench gate: interrupted by SIGINT: stopped"), std::string::npos)
      << ReadText(err_file);

  const CommandResult rerun = RunHdabench(
      {"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--jobs", "1", "--out",
       (dir / "out").string()},
      dir);
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  EXPECT_NE(rerun.err.find("sites-10m: complete from an earlier run"), std::string::npos) << rerun.err;
  EXPECT_TRUE(fs::exists(dir / "out" / "entries" / "sites-14m" / "compare.json"));
}

// A small lateral observability study as a gate entry: a worse
// triangulation input (noise on the matches) fails it by the metric's name.
TEST_F(GateCommand, AnObservabilityEntryFailsByNameWhenTheLateralCaseGetsWorse) {
  const fs::path dir = FreshTestDir();
  WriteText(dir / "suite.json",
            nlohmann::json({{"format", "hdabench-gate-suite"},
                            {"format_version", 1},
                            {"methods", {"flight"}},
                            {"entries",
                             {{{"name", "lateral"},
                               {"observability",
                                {{"geometry", {"lateral"}}, {"baselines_m", {20, 40}}, {"pixel_noise_px", {0.1}},
                                 {"trials", 400}}}}}}})
                .dump(1));
  const fs::path loose = WriteThresholds(
      dir, "loose.json", {{{"method", "flight"}, {"metric", "observability_p95_deg"}, {"max", 90}}});
  const CommandResult clean = RunHdabench({"gate", "--suite", (dir / "suite.json").string(), "--thresholds",
                                           loose.string(), "--out", (dir / "clean").string()},
                                          dir);
  ASSERT_EQ(clean.exit_code, 0) << clean.err;
  const double p95 = Metric(dir / "clean" / "metrics.json", "observability_p95_deg");
  const double median = Metric(dir / "clean" / "metrics.json", "observability_median_deg");
  const double ratio = Metric(dir / "clean" / "metrics.json", "observability_sigma_ratio");
  // 0.1 px at 20 m: a few degrees (docs/observability.md), the sigma within 20 %.
  EXPECT_GT(p95, 1.0);
  EXPECT_LT(p95, 10.0);
  EXPECT_LT(median, p95);
  EXPECT_GE(ratio, 1.0);
  EXPECT_LT(ratio, 1.2);
  // The entry's folder is the study's, linked from the page.
  EXPECT_TRUE(fs::exists(dir / "clean" / "entries" / "lateral" / "baselines.csv"));
  EXPECT_NE(ReadText(dir / "clean" / "gate.html").find("<a href=\"entries/lateral/settings.csv\">"),
            std::string::npos);

  const fs::path tight = WriteThresholds(
      dir, "tight.json",
      {{{"method", "flight"}, {"metric", "observability_p95_deg"}, {"max", p95 * 1.1}},
       {{"method", "flight"}, {"metric", "observability_median_deg"}, {"max", median * 1.1}},
       {{"method", "flight"}, {"metric", "observability_sigma_ratio"}, {"max", 1.25}}});
  const CommandResult worse =
      RunHdabench({"gate", "--suite", (dir / "suite.json").string(), "--thresholds", tight.string(), "--out",
                   (dir / "worse").string(), "--fault-match-noise-px", "0.2"},
                  dir);
  EXPECT_EQ(worse.exit_code, 1) << worse.err;
  EXPECT_NE(worse.err.find("FAILED flight observability_p95_deg = "), std::string::npos) << worse.err;
  EXPECT_NE(worse.err.find("FAILED flight observability_median_deg = "), std::string::npos) << worse.err;
  // The predicted sigma comes from the measured matching noise, so it grows
  // with the fault: the sigma ratio is not what fails here.
  EXPECT_EQ(worse.err.find("FAILED flight observability_sigma_ratio"), std::string::npos) << worse.err;
}

// The suite split in two shards, each into its own folder, then merged: the
// table, the verdict, the metrics (but for the flight time, a wall time) and
// every entry's results are those of one machine running the whole suite.
TEST_F(GateCommand, ShardsMergedGiveTheWholeSuitesTableAndVerdict) {
  const fs::path dir = FreshTestDir();
  nlohmann::json suite = nlohmann::json::parse(ReadText(WriteSuite(dir)));
  suite["entries"].push_back({{"name", "lateral"},
                              {"observability",
                               {{"geometry", {"lateral"}}, {"baselines_m", {30}}, {"pixel_noise_px", {0.1}},
                                {"trials", 200}}}});
  WriteText(dir / "suite.json", suite.dump(1));
  const std::string suite_file = (dir / "suite.json").string();
  // One threshold passes, one fails: the verdict has both kinds.
  const fs::path thresholds = WriteThresholds(
      dir, "thresholds.json",
      {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", 90}},
       {{"method", "flight"}, {"metric", "observability_p95_deg"}, {"max", 0.01}}});
  const CommandResult whole = RunHdabench(
      {"gate", "--suite", suite_file, "--thresholds", thresholds.string(), "--out", (dir / "whole").string()}, dir);
  ASSERT_EQ(whole.exit_code, 1) << whole.err;

  std::vector<std::string> shard_dirs;
  for (const std::string k : {"1", "2"}) {
    const fs::path out = dir / ("shard" + k);
    const CommandResult shard = RunHdabench({"gate", "--suite", suite_file, "--thresholds", thresholds.string(),
                                             "--out", out.string(), "--shard", k + "/2"},
                                            dir);
    ASSERT_EQ(shard.exit_code, 0) << shard.err;
    EXPECT_NE(shard.out.find("shard " + k + "/2: "), std::string::npos) << shard.out;
    EXPECT_FALSE(fs::exists(out / "gate.md"));  // no verdict from a slice
    shard_dirs.push_back(out.string());
  }
  // Entries 0 and 2 in shard 1, entry 1 in shard 2.
  EXPECT_TRUE(fs::exists(dir / "shard1" / "entries" / "sites-10m" / "compare.json"));
  EXPECT_TRUE(fs::exists(dir / "shard1" / "entries" / "lateral" / "settings.csv"));
  EXPECT_TRUE(fs::exists(dir / "shard2" / "entries" / "sites-14m" / "compare.json"));
  EXPECT_FALSE(fs::exists(dir / "shard2" / "entries" / "sites-10m"));

  const CommandResult merged =
      RunHdabench({"gate", "merge", shard_dirs[1], shard_dirs[0], "--suite", suite_file, "--thresholds",
                   thresholds.string(), "--out", (dir / "merged").string()},
                  dir);
  EXPECT_EQ(merged.exit_code, whole.exit_code) << merged.err;
  EXPECT_EQ(merged.out, whole.out);
  EXPECT_EQ(ReadText(dir / "merged" / "gate.md"), ReadText(dir / "whole" / "gate.md"));
  EXPECT_EQ(ReadText(dir / "merged" / "gate.html"), ReadText(dir / "whole" / "gate.html"));
  EXPECT_NE(merged.err.find("FAILED flight observability_p95_deg = "), std::string::npos) << merged.err;
  const std::vector<GateMetric> a = ReadGateMetrics((dir / "merged" / "metrics.json").string());
  const std::vector<GateMetric> b = ReadGateMetrics((dir / "whole" / "metrics.json").string());
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].metric, b[i].metric);
    EXPECT_EQ(a[i].value, b[i].value) << a[i].metric;
  }
  for (const char* file : {"sites-10m/compare.json", "sites-14m/compare.json", "lateral/settings.csv",
                           "lateral/study.json"}) {
    EXPECT_EQ(ReadText(dir / "merged" / "entries" / file), ReadText(dir / "whole" / "entries" / file)) << file;
  }

  // A shard missing, a shard given twice, another suite's shard: exit 3, named.
  CommandResult bad = RunHdabench({"gate", "merge", shard_dirs[0], "--suite", suite_file, "--thresholds",
                                   thresholds.string(), "--out", (dir / "bad").string()},
                                  dir);
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("shard 2/2 is missing"), std::string::npos) << bad.err;
  bad = RunHdabench({"gate", "merge", shard_dirs[0], shard_dirs[0], "--suite", suite_file, "--thresholds",
                     thresholds.string(), "--out", (dir / "bad").string()},
                    dir);
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("shard 1/2 is also in"), std::string::npos) << bad.err;
  suite["entries"].erase(2);
  WriteText(dir / "other.json", suite.dump(1));
  bad = RunHdabench({"gate", "merge", shard_dirs[0], shard_dirs[1], "--suite", (dir / "other.json").string(),
                     "--thresholds", thresholds.string(), "--out", (dir / "bad").string()},
                    dir);
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("whose contents differ from"), std::string::npos) << bad.err;
  bad = RunHdabench({"gate", "merge", (dir / "whole").string(), "--suite", suite_file, "--thresholds",
                     thresholds.string(), "--out", (dir / "bad").string()},
                    dir);
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("not a finished `hdabench gate --shard` folder"), std::string::npos) << bad.err;
  const CommandResult flag = RunHdabench(
      {"gate", "--suite", suite_file, "--thresholds", thresholds.string(), "--out", (dir / "x").string(),
       "--shard", "3/2"},
      dir);
  EXPECT_EQ(flag.exit_code, 2);
  EXPECT_NE(flag.err.find("--shard: shard '3/2': expected K/N with 1 <= K <= N"), std::string::npos) << flag.err;
}

// An entry under a sensor fault: pooled apart from the clean entries, with
// thresholds of its own that fail by the fault's name; the clean pool is the
// same as without it. LRF ranges 20 % long put the sites' triangulated
// points far off the plane the range implies: the method keeps no slope.
TEST_F(GateCommand, AFaultEntryIsPooledApartAndItsThresholdsFailByName) {
  const fs::path dir = FreshTestDir();
  const auto write_suite = [&](const std::string& name, bool with_fault) {
    nlohmann::json entries = {{{"name", "clean"}, {"dataset", scene_->string()}}};
    if (with_fault) {
      entries.push_back({{"name", "lrf-long"}, {"dataset", scene_->string()}, {"fault", "lrf-scale=0.2"}});
    }
    WriteText(dir / name, nlohmann::json({{"format", "hdabench-gate-suite"},
                                          {"format_version", 1},
                                          {"methods", {"flight"}},
                                          {"entries", entries}})
                              .dump(1));
    return dir / name;
  };
  const fs::path thresholds = WriteThresholds(
      dir, "t.json",
      {{{"method", "flight"}, {"metric", "rois_with_slope_share"}, {"min", 0.3}},
       {{"method", "flight"}, {"metric", "rois_with_slope_share"}, {"min", 0.3}, {"fault", "lrf-scale=0.2"}}});
  const CommandResult faulted = RunHdabench({"gate", "--suite", write_suite("faulted.json", true).string(),
                                             "--thresholds", thresholds.string(), "--out",
                                             (dir / "faulted").string(), "--write-baseline",
                                             (dir / "faulted.metrics.json").string()},
                                            dir);
  EXPECT_EQ(faulted.exit_code, 1) << faulted.err;
  EXPECT_NE(faulted.err.find("FAILED flight under lrf-scale=0.2 rois_with_slope_share = 0.000 < 0.300"),
            std::string::npos)
      << faulted.err;
  EXPECT_EQ(faulted.err.find("FAILED flight rois_with_slope_share"), std::string::npos) << faulted.err;
  EXPECT_NE(faulted.out.find("| flight under lrf-scale=0.2 | rois_with_slope_share | 0.000 | >= 0.300 |"),
            std::string::npos)
      << faulted.out;
  // The clean pool is the clean entry's alone.
  const CommandResult clean = RunHdabench({"gate", "--suite", write_suite("clean.json", false).string(),
                                           "--thresholds", thresholds.string(), "--out", (dir / "clean").string(),
                                           "--write-baseline", (dir / "clean.metrics.json").string()},
                                          dir);
  EXPECT_EQ(clean.exit_code, 1) << clean.err;  // the fault's threshold has no data here
  EXPECT_NE(clean.err.find("flight under lrf-scale=0.2 rois_with_slope_share: no value"), std::string::npos)
      << clean.err;
  std::vector<GateMetric> clean_pool;
  for (const GateMetric& m : ReadGateMetrics((dir / "faulted.metrics.json").string())) {
    if (m.fault.empty()) clean_pool.push_back(m);
  }
  const std::vector<GateMetric> alone = ReadGateMetrics((dir / "clean.metrics.json").string());
  ASSERT_EQ(clean_pool.size(), alone.size());
  for (size_t i = 0; i < alone.size(); ++i) {
    EXPECT_EQ(clean_pool[i].metric, alone[i].metric);
    EXPECT_EQ(clean_pool[i].value, alone[i].value) << alone[i].metric;
  }
  EXPECT_GE(Metric(dir / "clean.metrics.json", "rois_with_slope_share"), 0.3);
}

// Entries with the same synthetic source share one dataset, made once even
// when they run at the same time; an entry's own methods are the ones it runs.
TEST_F(GateCommand, EntriesOfOneSourceShareItsDataset) {
  const fs::path dir = FreshTestDir();
  const nlohmann::json synth = {{"preset", "novac-lateral"}, {"seed", 2}, {"image_size", 256}};
  WriteText(dir / "suite.json",
            nlohmann::json({{"format", "hdabench-gate-suite"},
                            {"format_version", 1},
                            {"methods", {"flight", "plane-nav"}},
                            {"entries",
                             {{{"name", "clean"}, {"synth", synth}},
                              {{"name", "no-lrf"}, {"synth", synth}, {"fault", "lrf-absent"}, {"methods", {"flight"}}},
                              {{"name", "late"}, {"synth", synth}, {"fault", "clock-offset=0.05"}}}}})
                .dump(1));
  const fs::path thresholds = WriteThresholds(
      dir, "t.json", {{{"method", "flight"}, {"metric", "failed_entries"}, {"max", 0}, {"fault", "lrf-absent"}}});
  const CommandResult run = RunHdabench({"gate", "--suite", (dir / "suite.json").string(), "--thresholds",
                                         thresholds.string(), "--jobs", "2", "--out", (dir / "out").string()},
                                        dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  int datasets = 0;
  for (const auto& item : fs::directory_iterator(dir / "out" / "datasets")) {
    ++datasets;
    EXPECT_EQ(item.path().filename().string().rfind("clean-", 0), 0u) << item.path();
  }
  EXPECT_EQ(datasets, 1);
  const nlohmann::json no_lrf = nlohmann::json::parse(ReadText(dir / "out" / "entries" / "no-lrf" / "compare.json"));
  ASSERT_EQ(no_lrf.at("methods").size(), 1u);
  EXPECT_EQ(no_lrf.at("methods")[0].at("name"), "flight");
  const nlohmann::json late = nlohmann::json::parse(ReadText(dir / "out" / "entries" / "late" / "compare.json"));
  EXPECT_EQ(late.at("methods").size(), 2u);
  // Each record says what the entry ran with.
  const nlohmann::json record =
      nlohmann::json::parse(ReadText(dir / "out" / "entries" / "late" / "gate_entry.json"));
  EXPECT_EQ(record.at("entry").at("fault"), "clock-offset=0.05");
  EXPECT_TRUE(nlohmann::json::parse(ReadText(dir / "out" / "entries" / "clean" / "gate_entry.json"))
                  .at("entry")
                  .at("fault")
                  .is_null());
}

// Both caches are keyed on the build: the same build reuses the dataset it
// made and the entry's folder; another build (a new scene generator, say)
// makes the dataset again, redoes the entry and removes the old dataset.
TEST(RunGateSuite, ANewBuildRegeneratesItsDatasetsAndTheSameBuildReusesThem) {
  const fs::path dir = FreshTestDir();
  WriteText(dir / "suite.json",
            nlohmann::json({{"format", "hdabench-gate-suite"},
                            {"format_version", 1},
                            {"methods", {"flight"}},
                            {"entries",
                             {{{"name", "scene"},
                               {"synth", {{"preset", "novac-lateral"}, {"seed", 3}, {"image_size", 128}}}}}}})
                .dump(1));
  const GateSuite suite = ReadGateSuite((dir / "suite.json").string());
  GateRunOptions options;
  options.out_dir = (dir / "out").string();
  options.jobs = 1;
  const auto run = [&](const std::string& build) {
    options.build_identity = build;
    const std::vector<GateEntryOutcome> outcomes = RunGateSuite(suite, options, nullptr);
    EXPECT_EQ(outcomes.size(), 1u);
    EXPECT_TRUE(outcomes.at(0).ok) << outcomes.at(0).error;
    return outcomes.at(0);
  };
  const auto datasets = [&] {
    std::vector<std::string> names;
    for (const auto& item : fs::directory_iterator(dir / "out" / "datasets")) {
      names.push_back(item.path().filename().string());
    }
    return names;
  };

  EXPECT_FALSE(run("build-a").reused);
  const std::vector<std::string> first = datasets();
  ASSERT_EQ(first.size(), 1u);
  // A mark in the made dataset: reuse keeps the folder as it is.
  const fs::path mark = dir / "out" / "datasets" / first[0] / "made-by-build-a";
  WriteText(mark, "");
  EXPECT_TRUE(run("build-a").reused);
  EXPECT_EQ(datasets(), first);
  EXPECT_TRUE(fs::exists(mark));

  // Another build: the entry is redone on a dataset made anew (the mark is
  // not in it), whose folder replaces the old one.
  EXPECT_FALSE(run("build-b").reused);
  const std::vector<std::string> second = datasets();
  ASSERT_EQ(second.size(), 1u);
  EXPECT_NE(second[0], first[0]);
  EXPECT_EQ(second[0].rfind("scene-", 0), 0u) << second[0];
  EXPECT_FALSE(fs::exists(dir / "out" / "datasets" / second[0] / "made-by-build-a"));
  EXPECT_TRUE(fs::exists(dir / "out" / "datasets" / second[0] / "manifest.json"));
  const nlohmann::json record = nlohmann::json::parse(ReadText(dir / "out" / "entries" / "scene" / "gate_entry.json"));
  EXPECT_EQ(record.at("build"), "build-b");
}

// A synthetic entry's scene has images for the default pair only, and for
// the frame after it too where an entry on that scene drops a frame (which
// puts the next frame in image 2's place).
TEST(RunGateSuite, ScenesRenderThePairAndTheNextFrameOnlyForADroppedFrame) {
  const fs::path dir = FreshTestDir();
  const nlohmann::json dropped_scene = {{"preset", "novac-lateral"}, {"seed", 3}, {"image_size", 128}};
  const nlohmann::json plain_scene = {{"preset", "novac-lateral"}, {"seed", 4}, {"image_size", 128}};
  WriteText(dir / "suite.json",
            nlohmann::json({{"format", "hdabench-gate-suite"},
                            {"format_version", 1},
                            {"methods", {"flight"}},
                            {"entries",
                             {{{"name", "clean"}, {"synth", dropped_scene}},
                              {{"name", "dropped"}, {"synth", dropped_scene}, {"fault", "frame-dropped"}},
                              {{"name", "plain"}, {"synth", plain_scene}}}}})
                .dump(1));
  GateRunOptions options;
  options.out_dir = (dir / "out").string();
  options.jobs = 1;
  for (const GateEntryOutcome& outcome : RunGateSuite(ReadGateSuite((dir / "suite.json").string()), options, nullptr)) {
    EXPECT_TRUE(outcome.ok) << outcome.error;
  }
  std::map<std::string, int> images;  // dataset owner -> image files
  for (const auto& item : fs::directory_iterator(dir / "out" / "datasets")) {
    const std::string name = item.path().filename().string();
    const std::string owner = name.substr(0, name.rfind('-'));
    for (const auto& image : fs::directory_iterator(item.path() / "images")) {
      if (image.is_regular_file()) ++images[owner];
    }
  }
  EXPECT_EQ(images, (std::map<std::string, int>{{"clean", 3}, {"plain", 2}}));
}

// Without a build given, the running program's identity keys the caches: the
// GNU build ID the linker wrote into the test binary.
TEST(BuildIdentity, IsTheProgramsBuildIdAndStable) {
  const std::string& id = util::BuildIdentity();
  EXPECT_EQ(id.rfind("gnu-build-id:", 0), 0u) << id;
  EXPECT_GT(id.size(), std::string("gnu-build-id:").size() + 16) << id;
  EXPECT_EQ(util::BuildIdentity(), id);
}

TEST_F(GateCommand, BadFilesAndFlagsHaveTheirExitCodes) {
  const fs::path dir = FreshTestDir();
  const fs::path suite = WriteSuite(dir);
  CommandResult result = RunHdabench(
      {"gate", "--suite", (dir / "none.json").string(), "--thresholds", suite.string(), "--out",
       (dir / "o").string()},
      dir);
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("none.json: cannot read the file"), std::string::npos) << result.err;
  result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", suite.string(), "--out",
                        (dir / "o").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_NE(result.err.find("field 'format' must be \"hdabench-gate-thresholds\""), std::string::npos)
      << result.err;
  result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", suite.string(), "--out",
                        (dir / "o").string(), "--jobs", "0"},
                       dir);
  EXPECT_EQ(result.exit_code, 2);
  for (const char* noise : {"inf", "nan", "-1"}) {
    result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", suite.string(), "--out",
                          (dir / "o").string(), "--fault-match-noise-px", noise},
                         dir);
    EXPECT_EQ(result.exit_code, 2) << noise << ": " << result.err;
    EXPECT_NE(result.err.find(std::string("--fault-match-noise-px ") + noise + ": expected a finite number >= 0"),
              std::string::npos)
        << result.err;
  }
  // The gate's own flags given to gate merge are refused, not dropped.
  result = RunHdabench({"gate", "--jobs", "2", "merge", (dir / "o").string(), "--suite", suite.string(),
                        "--thresholds", suite.string(), "--out", (dir / "m").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("hdabench gate merge: --jobs was given before 'merge' and is a flag of gate, not of "
                            "gate merge"),
            std::string::npos)
      << result.err;
  EXPECT_FALSE(fs::exists(dir / "m"));
  result = RunHdabench({"gate", "--quiet", "merge", (dir / "o").string(), "--suite", suite.string(),
                        "--thresholds", suite.string(), "--out", (dir / "m").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 2) << result.err;
  EXPECT_NE(result.err.find("hdabench gate merge: --quiet was given before 'merge': give it after 'merge'"),
            std::string::npos)
      << result.err;
  EXPECT_FALSE(fs::exists(dir / "m"));
  // A baseline that could not be written is refused before any entry runs.
  const fs::path loose = WriteThresholds(
      dir, "loose.json", {{{"method", "flight"}, {"metric", "slope_error_median_deg"}, {"max", 90}}});
  testing_support::WriteText(dir / "afile", "");
  result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--out",
                        (dir / "b").string(), "--write-baseline", (dir / "afile" / "b.json").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_NE(result.err.find("--write-baseline " + (dir / "afile" / "b.json").string() + ": cannot create its folder"),
            std::string::npos)
      << result.err;
  EXPECT_FALSE(fs::exists(dir / "b" / "entries"));
  // An output folder whose entries/ cannot be made is named, exit 3.
  fs::create_directories(dir / "e");
  testing_support::WriteText(dir / "e" / "entries", "");
  result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--out",
                        (dir / "e").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_NE(result.err.find((dir / "e" / "entries").string() + ": cannot create the folder"), std::string::npos)
      << result.err;
  // Nor into a dataset's folder.
  ASSERT_EQ(RunHdabench({"dataset", "create", (dir / "d").string()}, dir).exit_code, 0);
  result = RunHdabench({"gate", "--suite", suite.string(), "--thresholds", loose.string(), "--out",
                        (dir / "d").string()},
                       dir);
  EXPECT_EQ(result.exit_code, 3) << result.err;
  EXPECT_NE(result.err.find("holds a dataset"), std::string::npos) << result.err;
  EXPECT_FALSE(fs::exists(dir / "d" / "entries"));
}

}  // namespace
}  // namespace hdabench::reference
