// `hdabench observability` as a user meets it: a small study whole and in two
// shards merged by the CLI into the same files, the figures, and the errors
// with their exit codes.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"
#include "tests/tools/small_dataset.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;

CommandResult Hdabench(const std::vector<std::string>& args) {
  return hdabench::testing_support::RunInOwnFolder(args);
}

std::vector<std::string> Study(const fs::path& out, const std::vector<std::string>& extra) {
  std::vector<std::string> args = {"observability", "--baseline", "10:30:10", "--pixel-noise", "0.05,0.2",
                                   "--trials",      "30",         "--out",      out.string(), "--quiet"};
  args.insert(args.end(), extra.begin(), extra.end());
  return args;
}

TEST(ObservabilityCommand, ShardsMergedByTheCommandEqualTheWholeStudy) {
  const fs::path dir = FreshTestDir();
  const CommandResult whole = Hdabench(Study(dir / "whole", {}));
  ASSERT_EQ(whole.exit_code, 0) << whole.out << whole.err;
  EXPECT_NE(whole.out.find("geometry,points,pixel_noise_px,smallest_baseline_m"), std::string::npos) << whole.out;
  for (const char* name : {"study.json", "settings.csv", "baselines.csv", "figures/slope_error_vs_baseline.png",
                           "figures/sigma_check.png"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / "whole" / name)) << name << "\n" << whole.err;
  }
  for (const char* k : {"1/2", "2/2"}) {
    const CommandResult shard =
        Hdabench(Study(dir / (std::string("shard") + k[0]), {"--shard", k, "--threads", "1"}));
    ASSERT_EQ(shard.exit_code, 0) << shard.err;
    EXPECT_FALSE(fs::exists(dir / (std::string("shard") + k[0]) / "baselines.csv"));
  }
  const CommandResult merged = Hdabench({"observability", "merge", (dir / "shard2").string(),
                                         (dir / "shard1").string(), "--out", (dir / "merged").string(),
                                         "--no-figures"});
  ASSERT_EQ(merged.exit_code, 0) << merged.err;
  for (const char* name : {"study.json", "settings.csv", "baselines.csv"}) {
    EXPECT_EQ(ReadText(dir / "merged" / name), ReadText(dir / "whole" / name)) << name;
  }
  EXPECT_FALSE(fs::exists(dir / "merged" / "figures"));

  // One shard alone is not a study: exit 3, named.
  const CommandResult partial =
      Hdabench({"observability", "merge", (dir / "shard1").string(), "--out", (dir / "partial").string()});
  EXPECT_EQ(partial.exit_code, 3) << partial.err;
  EXPECT_NE(partial.err.find("shard 2/2 is missing"), std::string::npos) << partial.err;
}

TEST(ObservabilityCommand, BadFlagsAreUsageErrors) {
  const fs::path dir = FreshTestDir();
  for (const std::vector<std::string>& extra :
       std::vector<std::vector<std::string>>{{"--geometry", "diagonal"},
                                             {"--shard", "3/2"},
                                             {"--baseline", "10:5:1"},
                                             {"--pixel-noise", "0.1,x"},
                                             {"--points", "2"},
                                             {"--trials", "0"},
                                             {"--set", "hda.no_such_key=1"}}) {
    const CommandResult result = Hdabench(Study(dir / "bad", extra));
    EXPECT_EQ(result.exit_code, 2) << extra[0] << " " << extra[1] << ": " << result.err;
    EXPECT_FALSE(fs::exists(dir / "bad")) << extra[0];
  }
  const CommandResult no_out = Hdabench({"observability", "--trials", "5"});
  EXPECT_EQ(no_out.exit_code, 2) << no_out.err;
  const CommandResult camera =
      Hdabench(Study(dir / "camera", {"--camera", (dir / "missing.cameramodel").string()}));
  EXPECT_EQ(camera.exit_code, 3) << camera.err;
  EXPECT_NE(camera.err.find("missing.cameramodel"), std::string::npos) << camera.err;
}

}  // namespace
