// The gate's files and arithmetic: the suite and threshold readers, the
// metrics pooled over hand-written entries, the checks against thresholds and
// a baseline, the build identity. The command on real scenes is gate_test.cc.
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
      EXPECT_TRUE(SuiteGivesThresholdPool(suite, threshold)) << threshold.method << " " << threshold.metric;
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

// `gate --entries`: the named entries in the suite's order, and the
// thresholds of the pools they give; an unknown name lists the suite's.
TEST(SelectGateEntries, KeepsTheNamedEntriesAndThePoolsTheyGive) {
  const fs::path gate = fs::path(HDABENCH_SOURCE_DIR) / "gate";
  const GateSuite suite = ReadGateSuite((gate / "suite-ci.json").string());
  const GateThresholds thresholds = ReadGateThresholds((gate / "thresholds-ci.json").string());
  const GateSuite steep = SelectGateEntries(suite, {"flank-s1"});
  ASSERT_EQ(steep.entries.size(), 1u);
  EXPECT_EQ(steep.entries[0].name, "flank-s1");
  EXPECT_EQ(steep.methods, suite.methods);
  size_t kept = 0;
  for (const GateThreshold& t : thresholds.thresholds) {
    const bool given = SuiteGivesThresholdPool(steep, t);
    EXPECT_EQ(given, t.pool == "steep" && t.fault.empty()) << t.method << " " << t.metric;
    kept += given ? 1 : 0;
  }
  EXPECT_GT(kept, 0u);
  // The observability entry gives the flight method's main pool, no other.
  const GateSuite study = SelectGateEntries(suite, {"observability-lateral", "lateral-cratered-s1-lrf-absent"});
  ASSERT_EQ(study.entries.size(), 2u);
  EXPECT_EQ(study.entries[0].name, "lateral-cratered-s1-lrf-absent");  // the suite's order
  GateThreshold t;
  t.method = "flight";
  EXPECT_TRUE(SuiteGivesThresholdPool(study, t));
  t.method = "colmap-nav";
  EXPECT_FALSE(SuiteGivesThresholdPool(study, t));
  t.method = "flight";
  t.fault = "lrf-absent";
  EXPECT_TRUE(SuiteGivesThresholdPool(study, t));
  t.pool = "steep";
  EXPECT_FALSE(SuiteGivesThresholdPool(study, t));
  const std::string error = ErrorOf([&] { SelectGateEntries(suite, {"flank-s1", "flank-s9"}); });
  EXPECT_NE(error.find("no entry named 'flank-s9'"), std::string::npos) << error;
  EXPECT_NE(error.find("lateral-cratered-s3"), std::string::npos) << error;
}

// `gate --methods`: each entry keeps the named methods of its own and the
// flight method, and only the thresholds of the methods left are checked; an
// unknown name lists the suite's methods.
TEST(SelectGateMethods, KeepsTheNamedMethodsOfEachEntryAndTheirThresholds) {
  const fs::path gate = fs::path(HDABENCH_SOURCE_DIR) / "gate";
  const GateSuite suite = ReadGateSuite((gate / "suite-ci.json").string());
  const GateThresholds thresholds = ReadGateThresholds((gate / "thresholds-ci.json").string());
  const GateSuite flight = SelectGateMethods(SelectGateEntries(suite, {"flank-s1"}), {"flight"});
  ASSERT_EQ(flight.entries.size(), 1u);
  EXPECT_EQ(flight.methods, std::vector<std::string>{"flight"});
  size_t kept = 0;
  for (const GateThreshold& t : thresholds.thresholds) {
    const bool given = SuiteGivesThresholdPool(flight, t);
    EXPECT_EQ(given, t.method == "flight" && t.pool == "steep" && t.fault.empty()) << t.method << " " << t.metric;
    kept += given ? 1 : 0;
  }
  EXPECT_GT(kept, 0u);
  // The fault entries compare the flight method alone and keep it; the
  // others compare it and COLMAP, in the suite's order.
  const GateSuite colmap = SelectGateMethods(suite, {"colmap-nav"});
  for (const GateEntry& e : colmap.entries) {
    if (e.observability) continue;
    const std::vector<std::string>& methods = e.methods.empty() ? colmap.methods : e.methods;
    const std::vector<std::string> expected =
        e.fault ? std::vector<std::string>{"flight"} : std::vector<std::string>{"flight", "colmap-nav"};
    EXPECT_EQ(methods, expected) << e.name;
  }
  const std::string error = ErrorOf([&] { SelectGateMethods(suite, {"flight", "colmap-free"}); });
  EXPECT_NE(error.find("no entry compares a method named 'colmap-free'"), std::string::npos) << error;
  EXPECT_NE(error.find("dense-nav"), std::string::npos) << error;
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

// Without a build given, the running program's identity keys the caches: the
// GNU build ID the linker wrote into the test binary.
TEST(BuildIdentity, IsTheProgramsBuildIdAndStable) {
  const std::string& id = util::BuildIdentity();
  EXPECT_EQ(id.rfind("gnu-build-id:", 0), 0u) << id;
  EXPECT_GT(id.size(), std::string("gnu-build-id:").size() + 16) << id;
  EXPECT_EQ(util::BuildIdentity(), id);
}

}  // namespace
}  // namespace hdabench::reference
