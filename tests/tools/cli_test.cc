// The hdabench binary as a user meets it: help, version, exit codes, a worker
// that throws. The demo's whole run is demo_command_test.cc.
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;

std::vector<std::string> SplitWords(const std::string& text) {
  std::vector<std::string> words;
  std::istringstream in(text);
  for (std::string word; in >> word;) words.push_back(word);
  return words;
}

// Runs `hdabench ARGS`; out holds stdout then stderr.
CommandResult RunHdabench(const std::vector<std::string>& args) {
  // Each test runs in its own process: name the scratch folder after the test.
  static int counter = 0;
  const fs::path dir = fs::path(HDABENCH_TEST_TMP) /
                       (hdabench::testing_support::CurrentTestName() + ".run" + std::to_string(counter++));
  fs::create_directories(dir);
  CommandResult result = hdabench::testing_support::RunHdabench(args, dir);
  result.out += result.err;
  return result;
}

TEST(Cli, HelpListsEveryCommandAndExitsZero) {
  const CommandResult run = RunHdabench({"--help"});
  EXPECT_EQ(run.exit_code, 0) << run.out;
  for (const char* command : {"version", "dataset", "demo", "run", "synth", "truth", "Exit codes"}) {
    EXPECT_NE(run.out.find(command), std::string::npos) << command << "\n" << run.out;
  }
}

TEST(Cli, EverySubcommandHasHelp) {
  for (const char* command : {"version", "dataset", "dataset check", "dataset create", "demo", "run", "synth", "truth"}) {
    const CommandResult run = RunHdabench(SplitWords(std::string(command) + " --help"));
    EXPECT_EQ(run.exit_code, 0) << command << "\n" << run.out;
    EXPECT_NE(run.out.find("Usage"), std::string::npos) << command << "\n" << run.out;
  }
}

TEST(Cli, VersionNamesTheLibraries) {
  const CommandResult run = RunHdabench({"version"});
  EXPECT_EQ(run.exit_code, 0);
  EXPECT_EQ(run.out.rfind("hdabench 0.1.0\n", 0), 0u) << run.out;
  EXPECT_NE(run.out.find("OpenCV 4."), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("libmrcal 2.2"), std::string::npos) << run.out;
}

TEST(Cli, UsageErrorsExitTwo) {
  EXPECT_EQ(RunHdabench({}).exit_code, 2);
  const CommandResult unknown = RunHdabench({"no-such-command"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("hdabench: unknown command 'no-such-command' (the commands: version, dataset,"),
            std::string::npos)
      << unknown.err;
  const CommandResult typo = RunHdabench({"dataset", "chek", "somewhere"});
  EXPECT_EQ(typo.exit_code, 2);
  EXPECT_NE(typo.err.find("hdabench dataset: unknown command 'chek' (the commands: check, create)"), std::string::npos)
      << typo.err;
  EXPECT_EQ(RunHdabench({"dataset", "check"}).exit_code, 2);  // DIR missing
  EXPECT_EQ(RunHdabench({"dataset", "check", "somewhere", "--no-such-flag"}).exit_code, 2);
  const CommandResult bad_frames = RunHdabench({"dataset", "check", "somewhere", "--frames", "1-2"});
  EXPECT_EQ(bad_frames.exit_code, 2);
  EXPECT_NE(bad_frames.out.find("--frames"), std::string::npos) << bad_frames.out;
  const CommandResult trailing = RunHdabench({"dataset", "check", "somewhere", "--frames", "1,2,"});
  EXPECT_EQ(trailing.exit_code, 2);
  EXPECT_NE(trailing.out.find("--frames"), std::string::npos) << trailing.out;
  EXPECT_EQ(RunHdabench({"dataset", "create", "somewhere", "--seed", "minus-one"}).exit_code, 2);
  // A seed is a whole number that fits 64 bits: not wrapped to another scene.
  for (const std::string command : {"dataset create somewhere", "synth --out somewhere", "demo", "faults somewhere",
                                    "observability --out somewhere", "calibrate somewhere"}) {
    std::vector<std::string> args;
    std::stringstream words(command);
    for (std::string word; words >> word;) args.push_back(word);
    for (const std::string seed : {"-1", "99999999999999999999999", "1.5"}) {
      std::vector<std::string> with_seed = args;
      with_seed.insert(with_seed.end(), {"--seed", seed});
      const CommandResult result = RunHdabench(with_seed);
      EXPECT_EQ(result.exit_code, 2) << command << " --seed " << seed;
      const std::string said = result.out + result.err;
      EXPECT_NE(said.find("--seed: expected a whole number in [0, 18446744073709551615], got '" + seed + "'"),
                std::string::npos)
          << command << ": " << said;
    }
  }
  EXPECT_FALSE(fs::exists("somewhere"));
  // Counts whose 0 means the default are whole numbers >= 0: -5 is refused,
  // not quietly the default.
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"synth", "--out", "somewhere", "--image-size", "-5"},
           {"synth", "--out", "somewhere", "--threads", "-7"},
           {"demo", "--image-size", "-5"},
           {"demo", "--threads", "1.5"},
           {"observability", "--out", "somewhere", "--threads", "-4"}}) {
    const CommandResult result = RunHdabench(args);
    EXPECT_EQ(result.exit_code, 2) << args[0] << " " << args[args.size() - 2];
    EXPECT_NE((result.out + result.err).find(args[args.size() - 2] + ": expected a whole number >= 0, got '" +
                                             args.back() + "'"),
              std::string::npos)
        << result.out << result.err;
  }
  EXPECT_FALSE(fs::exists("somewhere"));
}

// An empty value (an unset shell variable) is refused for every option that
// takes one: an empty --out meant the current folder, which export field
// wrote into, over a dataset's nav.csv when run inside it.
TEST(Cli, EmptyValuesAreUsageErrors) {
  const fs::path dir = FreshTestDir();
  ASSERT_EQ(hdabench::testing_support::RunHdabench({"dataset", "create", (dir / "d").string()}, dir).exit_code, 0);
  const std::string nav = ReadText(dir / "d" / "nav.csv");
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"export", "field", ".", "--out", ""},
           {"ingest", "field", "log.json", "--out", ""},
           {"dataset", "create", ""},
           {"run", ".", "--out", "r", "--frames", ""},
           {"gate", "merge", "", "--suite", "s", "--thresholds", "t", "--out", "m"}}) {
    const CommandResult result = hdabench::testing_support::RunHdabench(args, dir / "d");
    EXPECT_EQ(result.exit_code, 2) << args[0] << " " << args[1] << ": " << result.err;
    EXPECT_NE(result.err.find(": an empty value"), std::string::npos) << result.err;
  }
  EXPECT_EQ(ReadText(dir / "d" / "nav.csv"), nav);
  EXPECT_FALSE(fs::exists(dir / "d" / "log.json"));
  EXPECT_FALSE(fs::exists(dir / "d" / "r"));
}

TEST(Cli, MissingDatasetFolderExitsThree) {
  const fs::path dir = FreshTestDir() / "absent";
  const CommandResult run = RunHdabench({"dataset", "check", dir.string()});
  EXPECT_EQ(run.exit_code, 3) << run.out;
  EXPECT_NE(run.out.find(dir.string()), std::string::npos) << run.out;
}

// The demo replaces its dataset/ only when synth made it: a folder of the
// user's own there (a dataset of theirs, or anything else) is refused, exit 3,
// and left as it was.
TEST(Cli, DemoLeavesADatasetFolderItDidNotMakeAlone) {
  const fs::path dir = FreshTestDir();
  for (const std::string kind : {"files", "dataset"}) {
    const fs::path out = dir / kind;
    if (kind == "dataset") {
      ASSERT_EQ(RunHdabench({"dataset", "create", (out / "dataset").string()}).exit_code, 0);
    } else {
      fs::create_directories(out / "dataset");
    }
    hdabench::testing_support::WriteText(out / "dataset" / "notes.txt", "mine");
    const CommandResult result = RunHdabench({"demo", "--out", out.string(), "--image-size", "96"});
    EXPECT_EQ(result.exit_code, 3) << result.err;
    EXPECT_NE(result.err.find((out / "dataset").string() + " exists and is not a synthetic scene hdabench made"),
              std::string::npos)
        << result.err;
    EXPECT_EQ(ReadText(out / "dataset" / "notes.txt"), "mine");
    EXPECT_FALSE(fs::exists(out / "compare"));
  }
}

// A worker that throws, in the terrain generator, the renderer or the gate,
// gives the internal-error exit code and one line naming the fault, not a
// crash (an exception escaping a std::thread aborts, exit 134), and no output
// that looks complete. HDABENCH_FAULT_IN_WORKER (util::ParallelFor) makes the
// named loop's first item on a thread other than the caller throw (on the
// caller when the loop runs on one thread).
CommandResult RunWithWorkerFault(const std::string& loop, const std::vector<std::string>& args,
                                 const fs::path& dir) {
  return hdabench::testing_support::RunHdabench(args, dir, {"HDABENCH_FAULT_IN_WORKER=" + loop});
}

std::string FaultLine(const std::string& loop) {
  return "hdabench: internal error: a fault injected into a worker of " + loop +
         " (HDABENCH_FAULT_IN_WORKER)\n";
}

TEST(Cli, AWorkerThatThrowsInTheTerrainGeneratorIsAnErrorNotACrash) {
  const fs::path dir = FreshTestDir();
  const CommandResult r = RunWithWorkerFault(
      "terrain blocks", {"synth", "--out", (dir / "ds").string(), "--threads", "2", "--quiet"}, dir);
  EXPECT_EQ(r.exit_code, 70) << r.err;
  EXPECT_EQ(r.err, FaultLine("terrain blocks"));
  EXPECT_FALSE(fs::exists(dir / "ds" / "manifest.json"));
}

TEST(Cli, AWorkerThatThrowsInTheRendererIsAnErrorNotACrash) {
  const fs::path dir = FreshTestDir();
  const CommandResult r = RunWithWorkerFault(
      "render rows", {"synth", "--out", (dir / "ds").string(), "--threads", "2", "--quiet"}, dir);
  EXPECT_EQ(r.exit_code, 70) << r.err;
  EXPECT_EQ(r.err, FaultLine("render rows"));
  EXPECT_FALSE(fs::exists(dir / "ds" / "manifest.json"));
}

// One job, so the fault comes before any entry's work (with two, the caller
// would first finish its own entry).
TEST(Cli, AWorkerThatThrowsInTheGateIsAnErrorNotACrash) {
  const fs::path dir = FreshTestDir();
  const fs::path gate = fs::path(HDABENCH_SOURCE_DIR) / "gate";
  const CommandResult r = RunWithWorkerFault(
      "gate entries",
      {"gate", "--suite", (gate / "suite-ci.json").string(), "--thresholds",
       (gate / "thresholds-ci.json").string(), "--out", (dir / "gate").string(), "--jobs", "1"},
      dir);
  EXPECT_EQ(r.exit_code, 70) << r.err;
  EXPECT_NE(r.err.find(FaultLine("gate entries")), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir / "gate" / "gate.json"));
}

}  // namespace
