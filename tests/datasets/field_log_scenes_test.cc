// Synthetic scenes through a field log (datasets/field_log.h,
// `hdabench export field` and `hdabench ingest field`): the flight method
// gives the same results on the ingested dataset as on the scene itself.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/flight_results.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;

// The synthetic truck and aircraft scenes written as field logs (WGS84
// navigation at White Sands, Euler angles, a 30 ms clock offset, the LRF log)
// and ingested back give the flight method the same ROIs, statuses and slopes
// as the synthetic datasets themselves: the only differences are the rounding
// of the image times to nanoseconds and of the geodetic round trip (1e-9 m).
// About 45 s on 2 cores: two scenes with every frame rendered (the log holds
// every image, and the runs compare frame indices), exported, ingested and run
// twice each.
TEST(FieldLog, SyntheticScenesThroughAFieldLogGiveTheSameFlightResults) {
  const fs::path dir = FreshTestDir();
  for (const std::string preset : {"truck", "aircraft"}) {
    SCOPED_TRACE(preset);
    // The scene is made once per build (and, under the sanitizers, taken from
    // the normal build: the same bytes); the export, ingest and runs are this
    // test's.
    const fs::path synth = testing_support::CachedDataset(
        HDABENCH_TEST_TMP, "field_log_" + preset, [&](const fs::path& out) {
          EXPECT_EQ(RunHdabench({"synth", "--preset", preset, "--seed", "3", "--image-size", "512", "--out",
                                 out.string(), "--quiet"},
                                dir)
                        .exit_code,
                    0);
        });
    ASSERT_TRUE(fs::is_regular_file(synth / "manifest.json"));
    const fs::path log = dir / (preset + "-log");
    const fs::path ingested = dir / (preset + "-ingested");
    // An origin whose height the WGS84 round trip cannot carry, or with an
    // empty item, is refused (1e308 had lost every altitude).
    for (const char* origin : {"32.38,-106.48,1e308", "32.38,-106.48,-6.4e6", "32.38,-106.48,1200,"}) {
      const testing_support::CommandResult refused =
          RunHdabench({"export", "field", synth.string(), "--out", log.string(), "--origin", origin}, dir);
      EXPECT_EQ(refused.exit_code, 2) << origin << ": " << refused.err;
      EXPECT_NE(refused.err.find("expected LAT,LON,HEIGHT"), std::string::npos) << refused.err;
      EXPECT_FALSE(fs::exists(log));
    }
    const testing_support::CommandResult exported =
        RunHdabench({"export", "field", synth.string(), "--out", log.string(), "--origin", "32.38,-106.48,1200",
                     "--clock-offset-s", "0.03"},
                    dir);
    ASSERT_EQ(exported.exit_code, 0) << exported.err;
    const testing_support::CommandResult ingest =
        RunHdabench({"ingest", "field", (log / "log.json").string(), "--out", ingested.string()}, dir);
    ASSERT_EQ(ingest.exit_code, 0) << ingest.err;
    std::vector<nlohmann::json> results;
    for (const fs::path& data : {synth, ingested}) {
      const fs::path out = dir / (data == synth ? preset + "-synth-run" : data.filename().string() + "-run");
      const testing_support::CommandResult run = RunHdabench(
          {"run", data.string(), "--out", out.string(), "--no-figures", "--no-report", "--quiet", "--budget-s", "10000"},
          dir);
      ASSERT_EQ(run.exit_code, 0) << run.err;
      results.push_back(nlohmann::json::parse(ReadText(out / "result.json")));
    }
    const nlohmann::json& a = results[0];
    const nlohmann::json& b = results[1];
    EXPECT_EQ(a["frames"], b["frames"]);
    EXPECT_NEAR(a["inputs"]["baseline_m"].get<double>(), b["inputs"]["baseline_m"].get<double>(), 1e-6);
    EXPECT_NEAR(a["inputs"]["lrf_range_m"].get<double>(), b["inputs"]["lrf_range_m"].get<double>(), 1e-6);
    ASSERT_EQ(a["rois"].size(), b["rois"].size());
    EXPECT_GT(testing_support::ExpectSameFlightRois(a, b, 1e-6), 5);
  }
}

}  // namespace
}  // namespace hdabench::datasets
