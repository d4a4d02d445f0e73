// `hdabench faults` as a user meets it: the study's files and table, the
// same bytes twice, a fault the method cannot run under named per case, and
// its errors.
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/flight_results.h"
#include "tests/support/test_support.h"
#include "tests/tools/small_dataset.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::ExpectSameFlightRois;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;
using hdabench::testing_support::RunInOwnFolder;
using hdabench::testing_support::SmallSyntheticDataset;
using hdabench::testing_support::SplitLines;

TEST(FaultsCommand, EachCaseIsMeasuredOrNamedAndTheBytesAreTheSameTwice) {
  const fs::path dir = FreshTestDir();
  const std::vector<std::string> faults = {"--fault", "lrf-absent", "--fault", "lrf-scale=0.05",
                                           "--fault", "attitude-bias=2", "--fault", "lrf-stuck=30"};
  std::vector<std::string> args = {"faults", SmallSyntheticDataset().string(), "--out", (dir / "a").string(),
                                   "--quiet"};
  args.insert(args.end(), faults.begin(), faults.end());
  const CommandResult first = RunInOwnFolder(args);
  ASSERT_EQ(first.exit_code, 0) << first.out << first.err;
  EXPECT_NE(first.out.find("attitude-bias=2"), std::string::npos) << first.out;
  const nlohmann::json json = nlohmann::json::parse(ReadText(dir / "a" / "faults.json"));
  EXPECT_EQ(json["format"], "hdabench-faults");
  const nlohmann::json& cases = json["cases"];
  ASSERT_EQ(cases.size(), 5u);
  EXPECT_EQ(cases[0]["case"], "clean");
  ASSERT_TRUE(cases[0]["ran"].get<bool>());
  EXPECT_GT(cases[0]["with_slope"].get<int>(), 0);
  EXPECT_EQ(cases[0]["range_source"], "lrf");
  // Without the LRF the range comes from the navigation (to the level ground through the ILS): slopes,
  // and the table says so.
  EXPECT_EQ(cases[1]["case"], "lrf-absent");
  ASSERT_TRUE(cases[1]["ran"].get<bool>()) << cases[1]["error"];
  EXPECT_EQ(cases[1]["range_source"], "navigation");
  EXPECT_GT(cases[1]["with_slope"].get<int>(), 0);
  EXPECT_NE(first.out.find("lrf-absent (range from nav)"), std::string::npos) << first.out;
  // The same ROIs as the clean run: the search for sites did not shrink.
  EXPECT_EQ(json["requirements"]["min_rois_vs_clean"], 0.5);
  EXPECT_EQ(cases[1]["rois_vs_clean"], 1.0);
  EXPECT_TRUE(cases[1]["meets"]["rois_vs_clean"].get<bool>());
  // A 5 % LRF bias and a 2 deg attitude bias still give slopes; the attitude bias moves them.
  EXPECT_TRUE(cases[2]["ran"].get<bool>());
  ASSERT_TRUE(cases[3]["ran"].get<bool>());
  EXPECT_GT(cases[3]["moved_count"].get<int>(), 0);
  EXPECT_GT(cases[3]["moved_median_deg"].get<double>(), 0.1);
  // Stuck 30 s before image 1 does not apply: the LRF log starts 0.2 s before it. Said, and not
  // counted as the method's failure.
  EXPECT_FALSE(cases[4]["applied"].get<bool>());
  EXPECT_NE(cases[4]["error"].get<std::string>().find("not applied: fault lrf-stuck=30: the LRF log does not reach back"),
            std::string::npos);
  EXPECT_EQ(SplitLines(ReadText(dir / "a" / "faults.csv")).size(), 6u);
  EXPECT_EQ(ReadText(dir / "a" / "faults.md"), first.out.substr(0, first.out.find("wrote ")));
  // The figure (Python with matplotlib, a Debian package of tools/debian-packages.txt).
  EXPECT_EQ(ReadText(dir / "a" / "faults.png").substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << first.err;

  args[3] = (dir / "b").string();
  const CommandResult second = RunInOwnFolder(args);
  ASSERT_EQ(second.exit_code, 0) << second.err;
  for (const char* name : {"faults.json", "faults.csv", "faults.md"}) {
    EXPECT_EQ(ReadText(dir / "a" / name), ReadText(dir / "b" / name)) << name;
  }
}

// A dropped image 2: the command reads the frame after it too, which takes its place; with image 2
// the last frame there is none, and the case says so.
TEST(FaultsCommand, ADroppedImageTwoIsTakenByTheNextFrame) {
  const fs::path dir = FreshTestDir();
  const std::string dataset = SmallSyntheticDataset().string();
  const CommandResult dropped = RunInOwnFolder(
      {"faults", dataset, "--out", (dir / "a").string(), "--quiet", "--no-figures", "--fault", "frame-dropped"});
  ASSERT_EQ(dropped.exit_code, 0) << dropped.err;
  const nlohmann::json cases = nlohmann::json::parse(ReadText(dir / "a" / "faults.json"))["cases"];
  ASSERT_EQ(cases.size(), 2u);
  EXPECT_EQ(cases[1]["case"], "frame-dropped");
  ASSERT_TRUE(cases[1]["ran"].get<bool>()) << cases[1]["error"];
  EXPECT_GT(cases[1]["with_slope"].get<int>(), 0);
  EXPECT_GT(cases[1]["moved_count"].get<int>(), 0);  // a longer baseline: the same sites, other points

  const CommandResult last = RunInOwnFolder({"faults", dataset, "--out", (dir / "b").string(), "--quiet",
                                             "--no-figures", "--frames", "0,12", "--fault", "frame-dropped"});
  ASSERT_EQ(last.exit_code, 0) << last.err;
  const nlohmann::json refused = nlohmann::json::parse(ReadText(dir / "b" / "faults.json"))["cases"][1];
  EXPECT_FALSE(refused["applied"].get<bool>());
  EXPECT_NE(refused["error"].get<std::string>().find("frame 12 is the last: no frame after it takes its place"),
            std::string::npos)
      << refused["error"];
}

// The generator with faults: applied to the pair `run` takes, written with
// the dataset (the truth the scene's), and the dataset is whole: without an
// LRF, `run` takes the range from the navigation.
TEST(SynthCommand, FaultsAreAppliedToThePairAndTheDatasetRunsWithThem) {
  const fs::path dir = FreshTestDir();
  const std::vector<std::string> scene = {"--image-size", "256", "--seed", "3", "--set", "horizontal_fov_deg=15",
                                          "--quiet"};
  std::vector<std::string> args = {"synth", "--out", (dir / "faulted").string(), "--fault", "lrf-absent",
                                   "--fault", "frame-dropped"};
  args.insert(args.end(), scene.begin(), scene.end());
  const CommandResult made = RunInOwnFolder(args);
  ASSERT_EQ(made.exit_code, 0) << made.err;
  EXPECT_NE(made.out.find("applied lrf-absent, frame-dropped to frames 0,6"), std::string::npos) << made.out;
  EXPECT_EQ(SplitLines(ReadText(dir / "faulted" / "lrf.csv")).size(), 1u);     // the header alone
  EXPECT_EQ(SplitLines(ReadText(dir / "faulted" / "frames.csv")).size(), 13u);  // 12 frames
  EXPECT_NE(ReadText(dir / "faulted" / "manifest.json").find("Sensor faults (docs/faults.md) on frames 0,6"),
            std::string::npos);
  const CommandResult check = RunInOwnFolder({"dataset", "check", (dir / "faulted").string()});
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  const CommandResult run =
      RunInOwnFolder({"run", (dir / "faulted").string(), "--out", (dir / "run").string(), "--no-figures", "--no-report"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "run" / "result.json"));
  EXPECT_EQ(result["inputs"]["range_source"], "navigation");

  // Through a field log without "lrf" (a campaign whose LRF gave nothing):
  // the same ROIs, statuses and slopes (the log rounds the image times to
  // nanoseconds and the positions through WGS84: 1e-6 deg is far above that).
  const CommandResult exported = RunInOwnFolder({"export", "field", (dir / "faulted").string(), "--out",
                                                 (dir / "log").string(), "--origin", "32.38,-106.48,1200"});
  ASSERT_EQ(exported.exit_code, 0) << exported.err;
  EXPECT_FALSE(fs::exists(dir / "log" / "lrf.csv"));
  EXPECT_EQ(ReadText(dir / "log" / "log.json").find("\"lrf\""), std::string::npos);
  const CommandResult ingested = RunInOwnFolder(
      {"ingest", "field", (dir / "log" / "log.json").string(), "--out", (dir / "ingested").string()});
  ASSERT_EQ(ingested.exit_code, 0) << ingested.err;
  EXPECT_NE((ingested.out + ingested.err).find("LRF: none"), std::string::npos) << ingested.out << ingested.err;
  const CommandResult rerun = RunInOwnFolder(
      {"run", (dir / "ingested").string(), "--out", (dir / "rerun").string(), "--no-figures", "--no-report"});
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  const nlohmann::json again = nlohmann::json::parse(ReadText(dir / "rerun" / "result.json"));
  EXPECT_EQ(again["inputs"]["range_source"], "navigation");
  EXPECT_EQ(again["frames"], result["frames"]);
  ASSERT_EQ(again["rois"].size(), result["rois"].size());
  EXPECT_GT(ExpectSameFlightRois(result, again, 1e-6), 0);

  // A sweep is not one fault; a fault that cannot apply writes nothing.
  args = {"synth", "--out", (dir / "sweep").string(), "--fault", "lrf-scale"};
  const CommandResult sweep = RunInOwnFolder(args);
  EXPECT_EQ(sweep.exit_code, 2);
  EXPECT_NE(sweep.err.find("--fault 'lrf-scale' is a sweep of 8 magnitudes: give one"), std::string::npos) << sweep.err;
  // A magnitude the fault never takes is refused before the scene is made.
  args = {"synth", "--out", (dir / "negative").string(), "--fault", "image-blur=-1"};
  const CommandResult negative = RunInOwnFolder(args);
  EXPECT_EQ(negative.exit_code, 2);
  EXPECT_NE(negative.err.find("--fault image-blur=-1: expected a sigma > 0 and at most 100 pixels"), std::string::npos)
      << negative.err;
  EXPECT_FALSE(fs::exists(dir / "negative"));
  // So is one out of the fault's range in faults, before the clean run (1e308 ended in OpenCV's assertion).
  const CommandResult huge = RunInOwnFolder({"faults", SmallSyntheticDataset().string(), "--out",
                                             (dir / "huge").string(), "--fault", "image-blur=1e308"});
  EXPECT_EQ(huge.exit_code, 2) << huge.err;
  EXPECT_NE(huge.err.find("image-blur=1e+308: expected a sigma > 0 and at most 100 pixels"), std::string::npos)
      << huge.err;
  EXPECT_FALSE(fs::exists(dir / "huge"));
  const CommandResult twice = RunInOwnFolder({"faults", SmallSyntheticDataset().string(), "--out",
                                              (dir / "twice").string(), "--fault", "lrf-offset=5,5"});
  EXPECT_EQ(twice.exit_code, 2) << twice.err;
  EXPECT_NE(twice.err.find("--fault lrf-offset=5 is given twice"), std::string::npos) << twice.err;
  EXPECT_FALSE(fs::exists(dir / "twice"));
  args = {"synth", "--out", (dir / "late").string(), "--fault", "clock-offset=100"};
  args.insert(args.end(), scene.begin(), scene.end());
  const CommandResult late = RunInOwnFolder(args);
  EXPECT_EQ(late.exit_code, 3);
  EXPECT_NE(late.err.find("fault clock-offset=100: frame 0 moves to"), std::string::npos) << late.err;
  EXPECT_FALSE(fs::exists(dir / "late" / "manifest.json"));
}

TEST(FaultsCommand, BadFlagsAndFoldersAreNamed) {
  const fs::path dir = FreshTestDir();
  const std::string dataset = SmallSyntheticDataset().string();
  const CommandResult unknown = RunInOwnFolder({"faults", dataset, "--out", (dir / "x").string(), "--fault", "lrf-gone"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("unknown fault 'lrf-gone': expected one of lrf-absent"), std::string::npos) << unknown.err;
  const CommandResult bad_number =
      RunInOwnFolder({"faults", dataset, "--out", (dir / "x").string(), "--fault", "lrf-scale=0.1,big"});
  EXPECT_EQ(bad_number.exit_code, 2);
  EXPECT_NE(bad_number.err.find("'big' is not a finite number (fraction)"), std::string::npos) << bad_number.err;
  const CommandResult inside = RunInOwnFolder({"faults", dataset, "--out", (fs::path(dataset) / "faults").string()});
  EXPECT_EQ(inside.exit_code, 3);
  EXPECT_NE(inside.err.find("is the dataset folder"), std::string::npos) << inside.err;
  EXPECT_FALSE(fs::exists(fs::path(dataset) / "faults"));
  // A requirement no case could be judged against: named, nothing written.
  const CommandResult requirements = RunInOwnFolder({"faults", dataset, "--out", (dir / "r").string(),
                                                     "--max-median-deg", "nan", "--min-share", "1.5",
                                                     "--min-roi-fraction", "-0.1"});
  EXPECT_EQ(requirements.exit_code, 2);
  for (const char* message : {"--max-median-deg = nan: expected finite and > 0", "--min-share = 1.5: expected in [0, 1]",
                              "--min-roi-fraction = -0.1: expected in [0, 1]"}) {
    EXPECT_NE(requirements.err.find(message), std::string::npos) << requirements.err;
  }
  EXPECT_EQ(requirements.err.find("--max-p90-deg"), std::string::npos) << requirements.err;
  EXPECT_FALSE(fs::exists(dir / "r"));
  const CommandResult nothing = RunInOwnFolder({"faults"});
  EXPECT_EQ(nothing.exit_code, 2);
  const CommandResult list = RunInOwnFolder({"faults", "--list"});
  EXPECT_EQ(list.exit_code, 0);
  for (const char* name : {"lrf-absent", "lrf-scale", "attitude-bias", "clock-offset", "frame-repeated", "frame-dropped"}) {
    EXPECT_NE(list.out.find(name), std::string::npos) << name;
  }
}

}  // namespace
