// `hdabench gate` on real scenes: the verdict, the external method, resuming,
// interruption, shards, faults and shared datasets, the exit codes. The
// readers and the arithmetic are gate_unit_test.cc.
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
