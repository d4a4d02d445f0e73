// `hdabench observability` as a user meets it: a small study whole and in two
// shards merged by the CLI into the same files, the figures, and the errors
// with their exit codes.
#include <algorithm>
#include <filesystem>
#include <string>
#include <utility>
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

// A small study into `out`, with `extra` flags; the study's own baselines,
// noises and trials where `extra` does not give them (a flag given twice is a
// usage error of its own).
std::vector<std::string> Study(const fs::path& out, const std::vector<std::string>& extra) {
  std::vector<std::string> args = {"observability", "--out", out.string(), "--quiet"};
  for (const auto& [flag, value] : std::vector<std::pair<std::string, std::string>>{
           {"--baseline", "10:30:10"}, {"--pixel-noise", "0.05,0.2"}, {"--trials", "30"}}) {
    if (std::find(extra.begin(), extra.end(), flag) == extra.end()) args.insert(args.end(), {flag, value});
  }
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

  // Not into a shard being merged, nor over a dataset.
  const std::string shard1 = ReadText(dir / "shard1" / "study.json");
  const CommandResult into_shard = Hdabench({"observability", "merge", (dir / "shard1").string(),
                                             (dir / "shard2").string(), "--out", (dir / "shard1").string()});
  EXPECT_EQ(into_shard.exit_code, 3) << into_shard.err;
  EXPECT_NE(into_shard.err.find("is, or is inside, the shard"), std::string::npos) << into_shard.err;
  EXPECT_EQ(ReadText(dir / "shard1" / "study.json"), shard1);
  ASSERT_EQ(Hdabench({"dataset", "create", (dir / "ds").string()}).exit_code, 0);
  const CommandResult into_dataset = Hdabench({"observability", "merge", (dir / "shard1").string(),
                                               (dir / "shard2").string(), "--out", (dir / "ds").string()});
  EXPECT_EQ(into_dataset.exit_code, 3) << into_dataset.err;
  EXPECT_FALSE(fs::exists(dir / "ds" / "study.json"));
}

TEST(ObservabilityCommand, BadFlagsAreUsageErrors) {
  const fs::path dir = FreshTestDir();
  for (const std::vector<std::string>& extra :
       std::vector<std::vector<std::string>>{{"--geometry", "diagonal"},
                                             {"--shard", "3/2"},
                                             {"--baseline", "10:5:1"},
                                             {"--pixel-noise", "0.1,x"},
                                             {"--baseline", "10,10"},
                                             {"--baseline", "10,20,"},
                                             {"--points", "2"},
                                             {"--trials", "0"},
                                             {"--trials", "20000000"},
                                             {"--set", "hda.no_such_key=1"}}) {
    const CommandResult result = Hdabench(Study(dir / "bad", extra));
    EXPECT_EQ(result.exit_code, 2) << extra[0] << " " << extra[1] << ": " << result.err;
    EXPECT_EQ(result.err.find("At Most 1"), std::string::npos) << result.err;  // refused for its value
    EXPECT_FALSE(fs::exists(dir / "bad")) << extra[0];
  }
  const CommandResult no_out = Hdabench({"observability", "--trials", "5"});
  EXPECT_EQ(no_out.exit_code, 2) << no_out.err;
  const CommandResult camera =
      Hdabench(Study(dir / "camera", {"--camera", (dir / "missing.cameramodel").string()}));
  EXPECT_EQ(camera.exit_code, 3) << camera.err;
  EXPECT_NE(camera.err.find("missing.cameramodel"), std::string::npos) << camera.err;
}

// The output folder is checked before the study runs: a file in its place,
// or a folder holding a dataset, is exit 3 with no trial run.
TEST(ObservabilityCommand, AnUnusableOutputFolderIsRefusedBeforeTheStudy) {
  const fs::path dir = FreshTestDir();
  hdabench::testing_support::WriteText(dir / "afile", "");
  const CommandResult file = Hdabench(Study(dir / "afile", {"--trials", "10000000"}));
  EXPECT_EQ(file.exit_code, 3) << file.err;
  EXPECT_NE(file.err.find((dir / "afile").string()), std::string::npos) << file.err;
  ASSERT_EQ(Hdabench({"dataset", "create", (dir / "dataset").string()}).exit_code, 0);
  const CommandResult dataset = Hdabench(Study(dir / "dataset", {"--trials", "10000000"}));
  EXPECT_EQ(dataset.exit_code, 3) << dataset.err;
  EXPECT_NE(dataset.err.find("holds a dataset"), std::string::npos) << dataset.err;
  EXPECT_FALSE(fs::exists(dir / "dataset" / "study.json"));
}

}  // namespace
