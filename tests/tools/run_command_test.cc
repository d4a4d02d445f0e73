// `hdabench run` as a user meets it: the files it writes, their determinism,
// and its errors, on a small synthetic dataset.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_support.h"
#include "tests/tools/small_dataset.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;
using hdabench::testing_support::SplitLines;

using hdabench::testing_support::RunInOwnFolder;
using hdabench::testing_support::SmallSyntheticDataset;

TEST(RunCommand, WritesEveryFileAndTheSameResultOnEveryRun) {
  const fs::path dir = FreshTestDir();
  // The default budget: it counts work, so the three runs' bytes are the same
  // whatever the machine's load.
  const CommandResult first =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", (dir / "a").string()});
  ASSERT_EQ(first.exit_code, 0) << first.out << first.err;
  EXPECT_NE(first.err.find("hdabench run: loading"), std::string::npos) << first.err;
  EXPECT_EQ(first.out.rfind("hda: ", 0), 0u) << first.out;
  EXPECT_NE(first.out.find("frames 0,6"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("truth slope (deg)"), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("slope error"), std::string::npos) << first.out;

  for (const char* name : {"result.json", "timings.json", "rois.csv", "figures/quadtree.png",
                           "figures/matches.png"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / "a" / name)) << name;
  }
  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "a" / "result.json"));
  EXPECT_EQ(result["format"], "hdabench-flight-result");
  EXPECT_EQ(result["frames"], nlohmann::json::array({0, 6}));
  const size_t num_rois = result["rois"].size();
  EXPECT_GT(num_rois, 0u);
  EXPECT_EQ(SplitLines(ReadText(dir / "a" / "rois.csv")).size(), num_rois + 1);
  size_t clouds = 0;
  for (const nlohmann::json& roi : result["rois"]) {
    if (roi["ply"].is_null()) continue;
    ++clouds;
    EXPECT_TRUE(fs::is_regular_file(dir / "a" / roi["ply"].get<std::string>())) << roi["ply"];
  }
  EXPECT_GT(clouds, 0u);
  EXPECT_TRUE(nlohmann::json::parse(ReadText(dir / "a" / "timings.json")).contains("stages"));

  // A second run into another folder gives the same result bytes; a third
  // into the first folder replaces its files with the same bytes.
  const CommandResult second =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", (dir / "b").string(), "--quiet", "--no-figures",
                "--budget-s", "10000"});
  ASSERT_EQ(second.exit_code, 0) << second.out << second.err;
  EXPECT_EQ(second.err, "");
  EXPECT_FALSE(fs::exists(dir / "b" / "figures"));
  const CommandResult third = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", (dir / "a").string(), "--quiet", "--budget-s", "10000"});
  ASSERT_EQ(third.exit_code, 0) << third.out << third.err;
  for (const char* name : {"result.json", "rois.csv"}) {
    EXPECT_EQ(ReadText(dir / "a" / name), ReadText(dir / "b" / name)) << name;
  }
  for (const auto& entry : fs::directory_iterator(dir / "a" / "points")) {
    EXPECT_EQ(ReadText(entry.path()), ReadText(dir / "b" / "points" / entry.path().filename()))
        << entry.path();
  }
}

// OpenCV's image codecs and libmrgingham (which needs them) bring some 140
// shared libraries; a run on the bench's own PNGs, with its figures and
// report, loads neither (tools/images/codecs.h). The dynamic loader lists what
// each process loads when LD_DEBUG=files.
TEST(RunCommand, LoadsNeitherOpenCvsImageCodecsNorMrgingham) {
  const fs::path dir = FreshTestDir();
  const CommandResult run = hdabench::testing_support::RunHdabench(
      {"run", SmallSyntheticDataset().string(), "--out", (dir / "out").string(), "--budget-s", "10000"}, dir,
      {"LD_DEBUG=files"});
  ASSERT_EQ(run.exit_code, 0) << run.out;
  EXPECT_NE(run.err.find("file=libopencv_core.so"), std::string::npos) << "no LD_DEBUG output to check";
  EXPECT_TRUE(fs::is_regular_file(dir / "out" / "report.html"));
  EXPECT_TRUE(fs::is_regular_file(dir / "out" / "figures" / "matches.png"));
  for (const char* library : {"file=libopencv_imgcodecs.so", "file=libmrgingham.so"}) {
    const size_t at = run.err.find(library);
    EXPECT_EQ(at, std::string::npos) << run.err.substr(at == std::string::npos ? 0 : at, 200);
  }
}

TEST(RunCommand, BudgetFlagsReachTheResult) {
  const fs::path dir = FreshTestDir();
  const CommandResult run = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--quiet",
                                 "--no-figures", "--flight-rate", "5e8", "--budget-s", "4"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "result.json"));
  EXPECT_EQ(result["options"]["flight_instructions_per_s"], 5e8);
  EXPECT_EQ(result["options"]["compute_budget_s"], 4.0);
  EXPECT_EQ(result["budget_s"], 4.0);
  EXPECT_EQ(result["flight_computer"]["instructions_per_s"], 5e8);
  EXPECT_GT(result["flight_computer"]["total_s"].get<double>(), 0.0);
  EXPECT_NE(run.out.find("flight computer, predicted from the counted work at 5e+08 instructions/s: convert "),
            std::string::npos)
      << run.out;
  const CommandResult negative =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--flight-rate", "-1"});
  EXPECT_EQ(negative.exit_code, 2) << negative.out << negative.err;
  EXPECT_NE(negative.err.find("flight_instructions_per_s"), std::string::npos) << negative.err;
}

// --params, then the command's flags, then each --set; the lengths not given
// follow the geometry and are listed in result.json with their rule.
TEST(RunCommand, ParamsFileAndSetReachTheResult) {
  const fs::path dir = FreshTestDir();
  hdabench::testing_support::WriteText(
      dir / "p.json",
      R"({"format": "hdabench-flight-params", "parameters": {"max_relief_m": 20, "max_relief_m_why": "x",
          "matching": {"ratio_test": 0.7}, "min_points": 12}})");
  const CommandResult run = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", (dir / "a").string(), "--no-figures", "--no-report",
       "--params", (dir / "p.json").string(), "--set", "hda.min_points=15", "--set",
       "hda.prediction.sigma_multiplier=2.5"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "a" / "result.json"));
  const nlohmann::json& options = result["options"];
  EXPECT_EQ(options["max_relief_m"], 20.0);
  EXPECT_EQ(options["matching"]["ratio_test"], 0.7);
  EXPECT_EQ(options["min_points"], 15);  // --set over --params
  EXPECT_EQ(options["prediction"]["sigma_multiplier"], 2.5);
  std::vector<std::string> derived;
  for (const nlohmann::json& d : result["options_from_geometry"]) {
    derived.push_back(d["key"]);
    EXPECT_FALSE(d["rule"].get<std::string>().empty());
  }
  EXPECT_EQ(derived, (std::vector<std::string>{"quadtree.site_size_m", "max_hazard_height_m",
                                               "max_roughness_rms_m", "prediction.range_sigma_m",
                                               "prediction.nav_position_sigma_m"}));
  EXPECT_NE(run.err.find("from the geometry: prediction.range_sigma_m"), std::string::npos) << run.err;

  // The options a run used, written back as a parameter file, reproduce it.
  hdabench::testing_support::WriteText(dir / "used.json", options.dump());
  const CommandResult again = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", (dir / "b").string(),
                                        "--no-figures", "--no-report", "--quiet", "--params",
                                        (dir / "used.json").string()});
  ASSERT_EQ(again.exit_code, 0) << again.err;
  nlohmann::json a = result, b = nlohmann::json::parse(ReadText(dir / "b" / "result.json"));
  EXPECT_FALSE(b.contains("options_from_geometry"));
  a.erase("options_from_geometry");
  EXPECT_EQ(a.dump(), b.dump());
}

TEST(RunCommand, BadParamsAndSetAreNamed) {
  const fs::path dir = FreshTestDir();
  const CommandResult unknown = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--set", "hda.quadtree.site_sise_m=5"});
  EXPECT_EQ(unknown.exit_code, 2);
  EXPECT_NE(unknown.err.find("unknown flight-method parameter 'quadtree.site_sise_m'; known:"),
            std::string::npos) << unknown.err;
  EXPECT_NE(unknown.err.find("quadtree.site_size_m"), std::string::npos) << unknown.err;
  const CommandResult form =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--set", "max_relief_m=5"});
  EXPECT_EQ(form.exit_code, 2);
  EXPECT_NE(form.err.find("expected hda.KEY=VALUE"), std::string::npos) << form.err;
  const CommandResult value =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--set", "hda.max_relief_m=-5"});
  EXPECT_EQ(value.exit_code, 2);
  EXPECT_NE(value.err.find("max_relief_m = -5: expected >= 0"), std::string::npos) << value.err;
  const CommandResult missing = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--params", (dir / "nope.json").string()});
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_NE(missing.err.find("nope.json: cannot read the parameter file (file not found)"), std::string::npos)
      << missing.err;
  // A site the image cannot hold is named by its parameter.
  const CommandResult huge = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--site-size-m", "1e9"});
  EXPECT_EQ(huge.exit_code, 3);
  EXPECT_NE(huge.err.find("quadtree.site_size_m = 1e+09: a site of"), std::string::npos) << huge.err;
  const CommandResult folder = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--params", SmallSyntheticDataset().string()});
  EXPECT_EQ(folder.exit_code, 3);
  EXPECT_NE(folder.err.find("cannot read the parameter file (is a directory; expected a file)"), std::string::npos)
      << folder.err;
  hdabench::testing_support::WriteText(dir / "broken.json", "{\"min_points\": ");
  const CommandResult broken = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--params", (dir / "broken.json").string()});
  EXPECT_EQ(broken.exit_code, 3);
  EXPECT_NE(broken.err.find("broken.json: not valid JSON: parse error at line 1"), std::string::npos) << broken.err;
  EXPECT_EQ(broken.err.find("[json.exception"), std::string::npos) << broken.err;
  hdabench::testing_support::WriteText(dir / "bad.json", R"({"min_points": 2})");
  const CommandResult bad = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", dir.string(), "--params", (dir / "bad.json").string()});
  EXPECT_EQ(bad.exit_code, 3);
  EXPECT_NE(bad.err.find("bad.json"), std::string::npos) << bad.err;
  EXPECT_NE(bad.err.find("min_points = 2"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(dir / "result.json"));
}

TEST(RunCommand, EqualFramesAreAUsageError) {
  const fs::path dir = FreshTestDir();
  const CommandResult run = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--frames", "0,0", "--out", dir.string()});
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("--frames 0,0: the two frames must differ"), std::string::npos) << run.err;
  const CommandResult malformed =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--frames", "1-2", "--out", dir.string()});
  EXPECT_EQ(malformed.exit_code, 2) << malformed.out << malformed.err;
  EXPECT_NE(malformed.err.find("--frames"), std::string::npos) << malformed.err;
}

TEST(RunCommand, AFrameOutsideTheDatasetIsNamed) {
  const fs::path out = FreshTestDir() / "out";
  const CommandResult run =
      RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--frames", "0,99", "--out", out.string()});
  EXPECT_EQ(run.exit_code, 2) << run.out << run.err;
  EXPECT_NE(run.err.find("frame 99 is not in"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(out));  // the output folder it made is not left behind
  // Nor the parents it made for it; a folder that was there stays.
  const fs::path parent = out.parent_path();
  fs::create_directories(parent / "kept");
  const CommandResult nested = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--frames", "0,99", "--out",
                                               (parent / "kept" / "new" / "deeper" / "out/").string()});
  EXPECT_EQ(nested.exit_code, 2) << nested.out << nested.err;
  EXPECT_FALSE(fs::exists(parent / "kept" / "new"));
  EXPECT_TRUE(fs::is_directory(parent / "kept"));
}

// truth's --roi: a box the image cannot hold, or one too thin for a plane (a
// strip a pixel wide gave a slope near 90 deg), is the flag's problem.
TEST(TruthCommand, AnRoiOutsideTheImageOrTooThinIsAUsageError) {
  const std::string dataset = SmallSyntheticDataset().string();
  for (const char* roi : {"0,0,1,40", "5,5,40,2", "2147483000,2147483000,2000,2000", "-1,0,10,10"}) {
    const CommandResult result = RunInOwnFolder({"truth", dataset, "--roi", roi});
    EXPECT_EQ(result.exit_code, 2) << roi << ": " << result.err;
    EXPECT_NE(result.err.find("hdabench truth: --roi "), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("expected a box of at least 3 x 3 px inside the"), std::string::npos) << result.err;
  }
  const CommandResult fine = RunInOwnFolder({"truth", dataset, "--roi", "10,10,8,8", "--json"});
  ASSERT_EQ(fine.exit_code, 0) << fine.err;
  EXPECT_EQ(nlohmann::json::parse(fine.out).at("num_points"), 64);
}

TEST(RunCommand, AMissingDatasetIsAnInputErrorNamingIt) {
  const fs::path dir = FreshTestDir();
  const fs::path absent = dir / "absent";
  const CommandResult run = RunInOwnFolder({"run", absent.string(), "--out", (dir / "out").string()});
  EXPECT_EQ(run.exit_code, 3) << run.out << run.err;
  EXPECT_NE(run.err.find(absent.string()), std::string::npos) << run.err;
  // A folder that is not a dataset: its problems, the same exit code.
  fs::create_directories(dir / "empty");
  const CommandResult empty = RunInOwnFolder({"run", (dir / "empty").string(), "--out", (dir / "out").string()});
  EXPECT_EQ(empty.exit_code, 3) << empty.out << empty.err;
  EXPECT_NE(empty.err.find("problem(s) in"), std::string::npos) << empty.err;
  EXPECT_FALSE(fs::exists(dir / "out"));
}

TEST(RunCommand, AnOutputFolderUnderAFileIsAnInputError) {
  const fs::path file = FreshTestDir() / "file";
  hdabench::testing_support::WriteText(file, "x");
  const fs::path out = file / "out";
  const CommandResult run = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out", out.string()});
  EXPECT_EQ(run.exit_code, 3) << run.out << run.err;
  EXPECT_NE(run.err.find(out.string()), std::string::npos) << run.err;
}

// The output disk full: `hdabench run` under a file-size limit of 64 KB (with
// SIGXFSZ ignored, a write past it fails with EFBIG, as on a full disk) stops
// with exit 3 and a message naming the file it could not write; no temporary
// file is left and no result.json claims a run. The rerun with room gives the
// same files as a run that never met the limit.
TEST(RunCommand, ADiskThatFillsUpHalfwayIsNamedAndTheRerunGivesTheSameResults) {
  const fs::path dir = FreshTestDir();
  const auto run = [&](const fs::path& out, const std::string& limit) {
    const std::string command = "trap '' XFSZ; " + limit + "exec " +
                                hdabench::testing_support::ShellQuote(HDABENCH_EXE) + " run " +
                                hdabench::testing_support::ShellQuote(SmallSyntheticDataset().string()) + " --out " +
                                hdabench::testing_support::ShellQuote(out.string()) +
                                " --no-report --budget-s 10000 >" +
                                hdabench::testing_support::ShellQuote((dir / "out.txt").string()) + " 2>" +
                                hdabench::testing_support::ShellQuote((dir / "err.txt").string());
    const int status = std::system(("bash -c " + hdabench::testing_support::ShellQuote(command)).c_str());
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  ASSERT_EQ(run(dir / "room", ""), 0) << ReadText(dir / "err.txt");
  EXPECT_EQ(run(dir / "full", "ulimit -f 64; "), 3) << ReadText(dir / "err.txt");
  const std::string err = ReadText(dir / "err.txt");
  EXPECT_NE(err.find("File too large"), std::string::npos) << err;
  EXPECT_NE(err.find((dir / "full").string()), std::string::npos) << err;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir / "full")) {
    EXPECT_NE(entry.path().extension(), ".tmp") << entry.path();
  }
  EXPECT_FALSE(fs::exists(dir / "full" / "result.json"));
  ASSERT_EQ(run(dir / "full", ""), 0) << ReadText(dir / "err.txt");
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir / "room")) {
    if (!entry.is_regular_file() || entry.path().filename() == "timings.json") continue;
    const fs::path twin = dir / "full" / fs::relative(entry.path(), dir / "room");
    EXPECT_TRUE(ReadText(entry.path()) == ReadText(twin)) << twin;
  }
}

// The figures are drawn on every core (util::ParallelFor, "flight figures"):
// a worker that throws is the internal-error exit, not a crash, and the run
// folder holds no result.json, so nothing takes it for a whole run.
TEST(RunCommand, AWorkerThatThrowsWhileDrawingTheFiguresIsAnErrorNotACrash) {
  const fs::path dir = FreshTestDir();
  const CommandResult r = hdabench::testing_support::RunHdabench(
      {"run", SmallSyntheticDataset().string(), "--out", (dir / "out").string(), "--quiet", "--budget-s", "10000"},
      dir, {"HDABENCH_FAULT_IN_WORKER=flight figures"});
  EXPECT_EQ(r.exit_code, 70) << r.err;
  EXPECT_NE(r.err.find("hdabench: internal error: a fault injected into a worker of flight figures "
                       "(HDABENCH_FAULT_IN_WORKER)\n"),
            std::string::npos)
      << r.err;
  EXPECT_TRUE(fs::is_regular_file(dir / "out" / "rois.csv"));
  EXPECT_FALSE(fs::exists(dir / "out" / "result.json"));
  EXPECT_FALSE(fs::exists(dir / "out" / "report.html"));
}

// A folder of the run that cannot be looked at (here figures/, a symbolic
// link to itself) is the report's problem, named: run keeps its exit code
// with a warning, and report exits 3.
TEST(RunCommand, AReportThatCannotReadTheFolderIsAWarningAndReportExits3) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "out";
  fs::create_directories(out);
  fs::create_directory_symlink("figures", out / "figures");
  const CommandResult run = hdabench::testing_support::RunHdabench(
      {"run", SmallSyntheticDataset().string(), "--out", out.string(), "--quiet", "--no-figures", "--budget-s",
       "10000"},
      dir);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.err.find("hdabench run: warning: report: " + (out / "figures").string() + ": cannot be read ("),
            std::string::npos)
      << run.err;
  EXPECT_TRUE(fs::is_regular_file(out / "result.json"));
  const CommandResult report = hdabench::testing_support::RunHdabench({"report", out.string()}, dir);
  EXPECT_EQ(report.exit_code, 3) << report.err;
  EXPECT_NE(report.err.find("hdabench report: " + (out / "figures").string() + ": cannot be read ("),
            std::string::npos)
      << report.err;
  // A file given as the dataset folder is named as what it is.
  fs::remove(out / "figures");
  hdabench::testing_support::WriteText(dir / "afile", "");
  const CommandResult file = hdabench::testing_support::RunHdabench(
      {"report", out.string(), "--dataset", (dir / "afile").string()}, dir);
  EXPECT_EQ(file.exit_code, 3) << file.err;
  EXPECT_NE(file.err.find((dir / "afile").string() + ": is not a folder; expected a dataset folder"), std::string::npos)
      << file.err;
}

// When no thread can be had for the figures (HDABENCH_FAULT_NO_THREAD stands
// for a process at its thread limit), the caller draws them all: the same
// files as on every core.
TEST(RunCommand, WithoutThreadsForTheFiguresTheFilesAreTheSame) {
  const fs::path dir = FreshTestDir();
  const auto run = [&](const fs::path& out, const std::vector<std::string>& env) {
    return hdabench::testing_support::RunHdabench({"run", SmallSyntheticDataset().string(), "--out", out.string(),
                                                   "--quiet", "--no-report", "--budget-s", "10000"},
                                                  dir, env);
  };
  const CommandResult threaded = run(dir / "threaded", {});
  ASSERT_EQ(threaded.exit_code, 0) << threaded.err;
  const CommandResult threadless = run(dir / "threadless", {"HDABENCH_FAULT_NO_THREAD=flight figures"});
  ASSERT_EQ(threadless.exit_code, 0) << threadless.err;
  int figures = 0;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir / "threaded")) {
    if (!entry.is_regular_file() || entry.path().filename() == "timings.json") continue;
    const fs::path twin = dir / "threadless" / fs::relative(entry.path(), dir / "threaded");
    EXPECT_TRUE(ReadText(entry.path()) == ReadText(twin)) << twin;
    if (entry.path().extension() == ".png") ++figures;
  }
  EXPECT_GT(figures, 2);
}

// An output folder that is the dataset or lies inside it (however it is
// spelled) is refused before anything is written, by run and compare alike
// (both prepare their folders in LoadDatasetPair): the dataset's files stay
// as they were. A sibling folder whose name starts with the dataset's is
// not inside it.
TEST(RunCommand, AnOutputFolderInsideTheDatasetIsRefusedAndNothingIsWritten) {
  const fs::path dir = FreshTestDir();
  const fs::path dataset = dir / "dataset";
  fs::copy(SmallSyntheticDataset(), dataset, fs::copy_options::recursive);
  const auto listing = [&dataset] {
    std::vector<std::string> files;
    for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dataset)) {
      files.push_back(entry.path().string() + " " +
                      (entry.is_regular_file() ? std::to_string(entry.file_size()) : "folder"));
    }
    std::sort(files.begin(), files.end());
    return files;
  };
  const std::vector<std::string> before = listing();
  fs::create_directories(dir / "elsewhere");
  fs::create_directory_symlink(dataset, dir / "link");
  const std::vector<fs::path> inside = {dataset, dataset / "results", dataset.string() + "/",
                                        dataset / "images" / ".." / "out", dir / "elsewhere" / ".." / "dataset",
                                        dir / "link" / "results"};
  for (const fs::path& out : inside) {
    for (const std::string command : {"run", "compare"}) {
      std::vector<std::string> args = {command, dataset.string(), "--out", out.string(), "--no-figures",
                                       "--no-report"};
      if (command == "compare") args.insert(args.end(), {"--methods", "flight"});
      const CommandResult refused = RunInOwnFolder(args);
      EXPECT_EQ(refused.exit_code, 3) << command << " --out " << out << "\n" << refused.out << refused.err;
      EXPECT_NE(refused.err.find("is the dataset folder"), std::string::npos) << refused.err;
      EXPECT_NE(refused.err.find(out.string()), std::string::npos) << refused.err;
    }
  }
  EXPECT_EQ(listing(), before);
  const CommandResult beside = RunInOwnFolder({"run", dataset.string(), "--out", (dir / "dataset-results").string(),
                                         "--no-figures", "--no-report", "--budget-s", "10000"});
  EXPECT_EQ(beside.exit_code, 0) << beside.out << beside.err;
  EXPECT_TRUE(fs::exists(dir / "dataset-results" / "result.json"));
}

// An output folder that holds another command's results (or a dataset) is
// refused before anything is written, and what it holds is left as it was;
// a rerun into a command's own results goes on.
TEST(RunCommand, AnOutputFolderHoldingAnotherCommandsResultsIsRefused) {
  const fs::path dir = FreshTestDir();
  // An ample budget for run: its bytes are compared across two runs.
  const auto command = [&](const std::string& name, const fs::path& out) {
    std::vector<std::string> args = {name, SmallSyntheticDataset().string(), "--out", out.string(), "--no-figures",
                                     "--no-report"};
    if (name == "compare") args.insert(args.end(), {"--methods", "flight"});
    if (name == "run") args.insert(args.end(), {"--budget-s", "10000"});
    return RunInOwnFolder(args);
  };
  ASSERT_EQ(command("compare", dir / "compared").exit_code, 0);
  ASSERT_EQ(command("run", dir / "ran").exit_code, 0);
  const std::string compared = ReadText(dir / "compared" / "compare.json");
  const std::string ran = ReadText(dir / "ran" / "result.json");

  const CommandResult run = command("run", dir / "compared");
  EXPECT_EQ(run.exit_code, 3) << run.out << run.err;
  EXPECT_NE(run.err.find("holds the results of hdabench compare"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir / "compared" / "result.json"));
  EXPECT_EQ(ReadText(dir / "compared" / "compare.json"), compared);

  const CommandResult compare = command("compare", dir / "ran");
  EXPECT_EQ(compare.exit_code, 3) << compare.out << compare.err;
  EXPECT_NE(compare.err.find("holds the results of hdabench run"), std::string::npos) << compare.err;
  EXPECT_FALSE(fs::exists(dir / "ran" / "compare.json"));
  EXPECT_EQ(ReadText(dir / "ran" / "result.json"), ran);

  fs::copy(SmallSyntheticDataset(), dir / "another-dataset", fs::copy_options::recursive);
  const CommandResult into_dataset = command("run", dir / "another-dataset");
  EXPECT_EQ(into_dataset.exit_code, 3) << into_dataset.out << into_dataset.err;
  EXPECT_NE(into_dataset.err.find("holds a dataset"), std::string::npos) << into_dataset.err;
  EXPECT_FALSE(fs::exists(dir / "another-dataset" / "result.json"));

  // Its own results: rewritten, the same bytes.
  const CommandResult again = command("run", dir / "ran");
  EXPECT_EQ(again.exit_code, 0) << again.out << again.err;
  EXPECT_EQ(ReadText(dir / "ran" / "result.json"), ran);
}

// A chessboard pair through `ingest target` and `run --roi`: the board is the
// one ROI, its plane within the predicted sigma; bad flags and inputs answer
// with their exit codes and write nothing.
TEST(RunCommand, PlanarTargetIngestedAndRunOnTheBoard) {
  const fs::path data = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard";
  const fs::path dir = FreshTestDir();
  const std::vector<std::string> ingest = {"ingest", "target", (data / "left01.jpg").string(),
                                           (data / "right01.jpg").string(), "--camera1",
                                           (data / "mrcal/camera-0.cameramodel").string(), "--camera2",
                                           (data / "mrcal/camera-1.cameramodel").string(), "--board", "9x6"};
  std::vector<std::string> args = ingest;
  args.insert(args.end(), {"--out", (dir / "target").string()});
  const CommandResult ingested = RunInOwnFolder(args);
  ASSERT_EQ(ingested.exit_code, 0) << ingested.out << ingested.err;
  EXPECT_NE(ingested.out.find("PnP reprojection RMS"), std::string::npos) << ingested.out;
  EXPECT_NE(ingested.out.find("against the models' extrinsics"), std::string::npos) << ingested.out;
  const size_t at = ingested.out.find("--roi ");
  ASSERT_NE(at, std::string::npos) << ingested.out;
  const std::string roi = ingested.out.substr(at + 6, ingested.out.find(' ', at + 6) - at - 6);

  const CommandResult run =
      RunInOwnFolder({"run", (dir / "target").string(), "--roi", roi, "--params",
                (fs::path(HDABENCH_SOURCE_DIR) / "params/planar-target.json").string(), "--out",
                (dir / "run").string(), "--no-figures", "--no-report", "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  const nlohmann::json result = nlohmann::json::parse(ReadText(dir / "run" / "result.json"));
  EXPECT_EQ(result["quadtree"]["given_rois"], true);
  ASSERT_EQ(result["rois"].size(), 1u);
  const nlohmann::json& board = result["rois"][0];
  EXPECT_EQ(board["status"], "evaluated") << board["reason"];
  EXPECT_LE(board["tilt_error_deg"].get<double>(), 3.0 * board["fit"]["slope_sigma_deg"].get<double>());
  EXPECT_EQ(result["options"]["matching"]["guide_radius_px"], 6);

  // An ROI outside image 1: exit 3, named. A malformed one: exit 2.
  const CommandResult outside = RunInOwnFolder({"run", (dir / "target").string(), "--roi", "600,400,100,100",
                                          "--out", (dir / "outside").string(), "--quiet"});
  EXPECT_EQ(outside.exit_code, 3) << outside.err;
  EXPECT_NE(outside.err.find("given ROI 1 (x 600, y 400, 100 x 100 px) is not inside image 1 (640 x 480 px)"),
            std::string::npos)
      << outside.err;
  const CommandResult malformed =
      RunInOwnFolder({"run", (dir / "target").string(), "--roi", "1,2,3", "--out", (dir / "bad").string()});
  EXPECT_EQ(malformed.exit_code, 2) << malformed.err;

  // ingest target: a bad board is a usage error, an image without the board
  // an input error; neither writes the folder.
  args = ingest;
  args[args.size() - 1] = "9by6";
  args.insert(args.end(), {"--out", (dir / "bad-board").string()});
  const CommandResult bad_board = RunInOwnFolder(args);
  EXPECT_EQ(bad_board.exit_code, 2) << bad_board.err;
  EXPECT_FALSE(fs::exists(dir / "bad-board"));
  args = ingest;
  args[3] = (fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard/README.md").string();
  args.insert(args.end(), {"--out", (dir / "no-image").string()});
  const CommandResult no_image = RunInOwnFolder(args);
  EXPECT_EQ(no_image.exit_code, 3) << no_image.err;
  EXPECT_NE(no_image.err.find("README.md: is not an image OpenCV can read"), std::string::npos) << no_image.err;
  EXPECT_FALSE(fs::exists(dir / "no-image") && !fs::is_empty(dir / "no-image"));
  // A JPEG cut short is refused, not read as a partly grey image.
  const std::string jpeg = ReadText(ingest[3]);
  hdabench::testing_support::WriteText(dir / "cut.jpg", jpeg.substr(0, jpeg.size() / 2));
  args = ingest;
  args[3] = (dir / "cut.jpg").string();
  args.insert(args.end(), {"--out", (dir / "cut").string()});
  const CommandResult cut = RunInOwnFolder(args);
  EXPECT_EQ(cut.exit_code, 3) << cut.err;
  EXPECT_NE(cut.err.find("cut.jpg: is truncated: "), std::string::npos) << cut.err;
  EXPECT_EQ(cut.err.find("Premature end of JPEG file"), std::string::npos) << cut.err;
}

TEST(RunCommand, HasHelp) {
  const CommandResult run = RunInOwnFolder({"run", "--help"});
  EXPECT_EQ(run.exit_code, 0);
  for (const char* text : {"Usage", "--frames", "--out", "--flight-rate", "--budget-s",
                           "--no-figures", "--quiet"}) {
    EXPECT_NE(run.out.find(text), std::string::npos) << text << "\n" << run.out;
  }
}

}  // namespace

// The calibration's term (docs/calibration.md): a synthetic scene's true
// camera holds no optimization_inputs, so its slopes carry no term and the
// outputs say so; the same scene seen through a calibration's own model (the
// OpenCV sample camera, mrcal's output with its optimization_inputs) gets a
// calibration sigma per fitted ROI, added in quadrature to the method's.
TEST(RunCommand, TheCalibrationTermIsThereExactlyWhenTheModelCarriesItsCalibration) {
  const fs::path dir = FreshTestDir();
  const CommandResult bare = RunInOwnFolder(
      {"run", SmallSyntheticDataset().string(), "--out", (dir / "bare").string(), "--quiet", "--no-figures"});
  ASSERT_EQ(bare.exit_code, 0) << bare.out << bare.err;
  const nlohmann::json without = nlohmann::json::parse(ReadText(dir / "bare" / "result.json"));
  EXPECT_EQ(without["calibration_term"]["available"], false);
  EXPECT_NE(without["calibration_term"]["why"].get<std::string>().find("optimization_inputs"), std::string::npos);
  EXPECT_NE(bare.out.find("calibration term: none ("), std::string::npos) << bare.out;
  for (const nlohmann::json& roi : without["rois"]) {
    if (roi["fit"].is_null()) continue;
    EXPECT_TRUE(roi["fit"]["slope_sigma_calibration_deg"].is_null());
    EXPECT_EQ(roi["fit"]["slope_sigma_combined_deg"], roi["fit"]["slope_sigma_deg"]);
  }

  const fs::path model =
      fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "opencv-stereo-chessboard" / "mrcal" / "camera-0.cameramodel";
  const CommandResult synth = RunInOwnFolder({"synth", "--out", (dir / "scene").string(), "--camera-model",
                                              model.string(), "--frames", "pair", "--quiet"});
  ASSERT_EQ(synth.exit_code, 0) << synth.out << synth.err;
  fs::copy_file(model, dir / "scene" / "camera.cameramodel", fs::copy_options::overwrite_existing);
  const CommandResult calibrated = RunInOwnFolder(
      {"run", (dir / "scene").string(), "--out", (dir / "calibrated").string(), "--quiet", "--no-figures"});
  ASSERT_EQ(calibrated.exit_code, 0) << calibrated.out << calibrated.err;
  const nlohmann::json with = nlohmann::json::parse(ReadText(dir / "calibrated" / "result.json"));
  const nlohmann::json& term = with["calibration_term"];
  ASSERT_EQ(term["available"], true) << term.dump();
  EXPECT_EQ(term["lens_model"], "LENSMODEL_OPENCV8");
  EXPECT_GE(term["modes"].size(), 1u);
  EXPECT_LE(term["modes"].size(), 12u);
  EXPECT_GE(term["variance_kept"].get<double>(), 0.999);
  EXPECT_NE(calibrated.out.find("calibration term ("), std::string::npos) << calibrated.out;
  // The report says it and shows each ROI's calibration sigma.
  EXPECT_NE(ReadText(dir / "calibrated" / "report.md").find("- calibration term: "), std::string::npos);
  EXPECT_NE(ReadText(dir / "calibrated" / "report.html").find("calib. sigma (deg)"), std::string::npos);
  EXPECT_NE(ReadText(dir / "bare" / "report.md").find("- calibration term: none ("), std::string::npos);
  int with_sigma = 0;
  for (const nlohmann::json& roi : with["rois"]) {
    if (roi["fit"].is_null()) continue;
    const nlohmann::json& fit = roi["fit"];
    if (fit["slope_sigma_calibration_deg"].is_null()) {
      EXPECT_TRUE(fit.contains("calibration_sigma_why")) << roi.dump();
      continue;
    }
    ++with_sigma;
    const double method = fit["slope_sigma_deg"].get<double>();
    const double calibration = fit["slope_sigma_calibration_deg"].get<double>();
    EXPECT_GE(calibration, 0.0);
    EXPECT_NEAR(fit["slope_sigma_combined_deg"].get<double>(), std::hypot(method, calibration), 1e-12);
  }
  EXPECT_GT(with_sigma, 0);
  EXPECT_EQ(term["rois_with_sigma"], with_sigma);
  const std::string csv = ReadText(dir / "calibrated" / "rois.csv");
  EXPECT_NE(csv.substr(0, csv.find('\n')).find(",slope_sigma_calibration_deg,slope_sigma_combined_deg"),
            std::string::npos);

  // The check: a few re-solves of the calibration, every ROI with a
  // prediction in calibration_check.json, and the report's scatter plot.
  const CommandResult checked =
      RunInOwnFolder({"run", (dir / "scene").string(), "--out", (dir / "checked").string(), "--quiet",
                      "--no-figures", "--calibration-check", "6"});
  ASSERT_EQ(checked.exit_code, 0) << checked.out << checked.err;
  const nlohmann::json check = nlohmann::json::parse(ReadText(dir / "checked" / "calibration_check.json"));
  EXPECT_EQ(check["format"], "hdabench-calibration-check");
  EXPECT_EQ(check["solved"], 6);
  EXPECT_EQ(static_cast<int>(check["rois"].size()), with_sigma);
  EXPECT_EQ(check["ratios"]["fixed_slope"]["rois"], with_sigma);
  // Six re-solves give a rough ratio, but one of the right order.
  EXPECT_GT(check["ratios"]["fixed_slope"]["median"].get<double>(), 0.3);
  EXPECT_LT(check["ratios"]["fixed_slope"]["median"].get<double>(), 3.0);
  EXPECT_NE(checked.out.find("calibration check, 6 of 6 re-solves"), std::string::npos) << checked.out;
  EXPECT_NE(ReadText(dir / "checked" / "report.md").find("Calibration sigma against the re-solved spread"),
            std::string::npos);
  // Without a calibration term the check cannot run: exit 3, the run's outputs kept, no stale check.
  fs::copy_file(dir / "checked" / "calibration_check.json", dir / "bare" / "calibration_check.json");
  const CommandResult refused = RunInOwnFolder({"run", SmallSyntheticDataset().string(), "--out",
                                                (dir / "bare").string(), "--quiet", "--no-figures",
                                                "--calibration-check", "3"});
  EXPECT_EQ(refused.exit_code, 3) << refused.out << refused.err;
  EXPECT_NE(refused.err.find("no calibration term to check"), std::string::npos) << refused.err;
  EXPECT_TRUE(fs::is_regular_file(dir / "bare" / "result.json"));
  EXPECT_FALSE(fs::exists(dir / "bare" / "calibration_check.json"));
}

// Chessboard views through the default camera, for calibrate; a board kept
// to the imager's top half leaves the rest without a corner.
TEST(ChessboardCommand, WritesViewsTheCameraAndKeepsToItsRegion) {
  const fs::path dir = FreshTestDir();
  const CommandResult run = RunInOwnFolder({"chessboard", "--out", (dir / "views").string(), "--views", "3",
                                            "--region", "0,1,0,0.5", "--quiet"});
  ASSERT_EQ(run.exit_code, 0) << run.out << run.err;
  for (const char* name : {"board-01.png", "board-03.png", "truth.csv", "poses.csv", "true.cameramodel"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / "views" / name)) << name;
  }
  const std::vector<std::string> rows = SplitLines(ReadText(dir / "views" / "truth.csv"));
  ASSERT_EQ(rows.size(), 1u + 3u * 54u);
  for (size_t i = 1; i < rows.size(); ++i) {
    const double y = std::stod(rows[i].substr(rows[i].rfind(',') + 1));
    EXPECT_LT(y, 0.5 * 1024 - 0.5) << rows[i];
  }
  EXPECT_EQ(RunInOwnFolder({"chessboard", "--out", (dir / "bad").string(), "--board", "9by6"}).exit_code, 2);
  EXPECT_EQ(RunInOwnFolder({"chessboard", "--out", (dir / "bad").string(), "--region", "0,1,0.6,0.5"}).exit_code, 2);
  EXPECT_EQ(RunInOwnFolder({"chessboard", "--out", (dir / "views").string()}).exit_code, 2);  // in use
}
