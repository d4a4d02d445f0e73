// `hdabench compare` when its run is cut: the real `colmap` dying by a signal
// in the middle of the comparison (as the kernel's OOM killer would end it),
// and SIGTERM or SIGINT to the command itself while colmap runs. Each is
// named, has its exit code, leaves nothing a later run trusts, and a rerun
// into the same folder finishes with the results of a comparison that never
// met the fault.
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/test_support.h"
#include "tests/tools/small_dataset.h"
#include "tools/util/process.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;
using hdabench::testing_support::RunInOwnFolder;
using hdabench::testing_support::SmallSyntheticDataset;
using hdabench::testing_support::WriteText;

nlohmann::json MethodNamed(const nlohmann::json& compare, const std::string& name) {
  for (const nlohmann::json& m : compare.at("methods")) {
    if (m.at("name") == name) return m;
  }
  ADD_FAILURE() << "no method " << name;
  return {};
}

TEST(CompareCommand, ColmapKilledBySignalMidRunFailsItsColumnAndTheRerunFinishes) {
  const std::string colmap = hdabench::util::FindExecutable("colmap");
  ASSERT_FALSE(colmap.empty()) << "colmap is not installed";
  const fs::path dir = FreshTestDir();
  // The real colmap, ended by SIGKILL as it imports the matches: its feature
  // extraction has run and written the database, and the bench's matching.
  const fs::path killed = dir / "colmap-killed";
  WriteText(killed, "#!/bin/sh\nif [ \"$1\" = matches_importer ]; then kill -KILL $$; fi\nexec \"" + colmap +
                        "\" \"$@\"\n");
  fs::permissions(killed, fs::perms::owner_all);
  const std::string dataset = SmallSyntheticDataset().string();
  const std::vector<std::string> args = {"compare", dataset, "--methods", "flight,colmap-nav,plane-nav",
                                         "--out", (dir / "cmp").string(), "--no-figures", "--no-report",
                                         "--quiet"};
  std::vector<std::string> first_args = args;
  first_args.insert(first_args.end(), {"--colmap", killed.string()});
  const CommandResult first = RunInOwnFolder(first_args);
  EXPECT_EQ(first.exit_code, 4) << first.err;
  EXPECT_NE(first.err.find("killed by signal 9"), std::string::npos) << first.err;
  const nlohmann::json broken = nlohmann::json::parse(ReadText(dir / "cmp" / "compare.json"));
  const nlohmann::json nav = MethodNamed(broken, "colmap-nav");
  EXPECT_FALSE(nav.at("ok").get<bool>());
  const std::string failure = nav.at("failure").get<std::string>();
  EXPECT_NE(failure.find("colmap matches_importer failed"), std::string::npos) << failure;
  EXPECT_NE(failure.find("killed by signal 9 (Killed)"), std::string::npos) << failure;
  EXPECT_TRUE(MethodNamed(broken, "flight").at("ok").get<bool>());
  EXPECT_TRUE(MethodNamed(broken, "plane-nav").at("ok").get<bool>());
  const std::string flight_result = ReadText(dir / "cmp" / "flight" / "result.json");

  // The rerun with colmap whole: every column, and the other methods' bytes unchanged.
  std::vector<std::string> rerun_args = args;
  rerun_args.insert(rerun_args.end(), {"--colmap", colmap});
  const CommandResult rerun = RunInOwnFolder(rerun_args);
  ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
  const nlohmann::json whole = nlohmann::json::parse(ReadText(dir / "cmp" / "compare.json"));
  EXPECT_TRUE(MethodNamed(whole, "colmap-nav").at("ok").get<bool>()) << MethodNamed(whole, "colmap-nav");
  EXPECT_EQ(ReadText(dir / "cmp" / "flight" / "result.json"), flight_result);
  // The same as a comparison into a new folder that never met the fault
  // (COLMAP's matcher is not deterministic: its column is compared by status only).
  std::vector<std::string> fresh_args = rerun_args;
  fresh_args[5] = (dir / "fresh").string();
  const CommandResult fresh = RunInOwnFolder(fresh_args);
  ASSERT_EQ(fresh.exit_code, 0) << fresh.err;
  const nlohmann::json clean = nlohmann::json::parse(ReadText(dir / "fresh" / "compare.json"));
  EXPECT_EQ(ReadText(dir / "fresh" / "flight" / "result.json"), flight_result);
  ASSERT_EQ(clean.at("rois").size(), whole.at("rois").size());
  for (size_t i = 0; i < clean.at("rois").size(); ++i) {
    for (const char* method : {"flight", "plane-nav"}) {
      EXPECT_EQ(whole["rois"][i]["methods"][method], clean["rois"][i]["methods"][method]) << method << " ROI " << i;
    }
    EXPECT_EQ(whole["rois"][i]["methods"]["colmap-nav"]["status"], clean["rois"][i]["methods"]["colmap-nav"]["status"])
        << "ROI " << i;
  }
}

// SIGTERM (and SIGINT) to compare while colmap runs: the command ends the
// programs it started, says so and exits 143 (130); the folder holds no
// compare.json, so nothing marks it as a whole comparison; the rerun
// finishes.
TEST(CompareCommand, SigtermOrSigintWhileColmapRunsIsNamedAndTheRerunFinishes) {
  const std::string colmap = hdabench::util::FindExecutable("colmap");
  ASSERT_FALSE(colmap.empty()) << "colmap is not installed";
  const fs::path dir = FreshTestDir();
  const std::string dataset = SmallSyntheticDataset().string();
  for (const auto& [signal_number, name, code] :
       std::vector<std::tuple<int, std::string, int>>{{SIGTERM, "SIGTERM", 143}, {SIGINT, "SIGINT", 130}}) {
    SCOPED_TRACE(name);
    // colmap's reconstruction step held up (its pid in a file) until the signal comes.
    const fs::path held = dir / (name + ".pid");
    const fs::path slow = dir / ("colmap-slow-" + name);
    WriteText(slow, "#!/bin/sh\nif [ \"$1\" = point_triangulator ]; then echo $$ > '" + held.string() +
                        ".tmp' && mv '" + held.string() + ".tmp' '" + held.string() + "'; sleep 120; fi\nexec \"" +
                        colmap + "\" \"$@\"\n");
    fs::permissions(slow, fs::perms::owner_all);
    const fs::path out = dir / ("cmp-" + name);
    std::vector<std::string> args = {"compare", dataset, "--methods", "flight,colmap-nav", "--out", out.string(),
                                     "--no-figures", "--no-report", "--quiet"};
    std::vector<std::string> cut = args;
    cut.insert(cut.end(), {"--colmap", slow.string()});
    const fs::path err = dir / (name + ".err");
    const int status = hdabench::testing_support::RunHdabenchUntil(cut, held, signal_number, err);
    ASSERT_TRUE(fs::exists(held)) << "colmap's reconstruction never started";
    ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
    EXPECT_EQ(WEXITSTATUS(status), code);
    EXPECT_NE(ReadText(err).find("hdabench compare: interrupted by " + name + ": stopped, with the programs it had started"),
              std::string::npos)
        << ReadText(err);
    EXPECT_FALSE(fs::exists(out / "compare.json"));
    // The held colmap (a sleep in its process group) is gone.
    const std::string pid = ReadText(held).substr(0, ReadText(held).find('\n'));
    bool ended = false;
    for (int i = 0; i < 2000 && !ended; ++i) {
      const std::string stat = ReadText(fs::path("/proc") / pid / "stat");
      ended = stat.empty() || stat.find(") Z") != std::string::npos;
      if (!ended) usleep(5000);
    }
    EXPECT_TRUE(ended) << "colmap (pid " << pid << ") still runs after " << name;

    args.insert(args.end(), {"--colmap", colmap});
    const CommandResult rerun = RunInOwnFolder(args);
    ASSERT_EQ(rerun.exit_code, 0) << rerun.err;
    const nlohmann::json whole = nlohmann::json::parse(ReadText(out / "compare.json"));
    EXPECT_TRUE(MethodNamed(whole, "colmap-nav").at("ok").get<bool>());
    EXPECT_TRUE(MethodNamed(whole, "flight").at("ok").get<bool>());
  }
}

}  // namespace

namespace {

// The external method through the command line: refused without a program
// (exit 2, before anything runs); run with the example program (exit 0, its
// folder in the output); a program that fails fails its column only (exit 4,
// compare.json written with the flight method's results and the reason).
TEST(CompareCommand, TheExternalMethodNeedsAProgramRunsItAndNamesItsFailure) {
  const fs::path dir = FreshTestDir();
  const fs::path dataset = SmallSyntheticDataset();
  const CommandResult without = RunInOwnFolder(
      {"compare", dataset.string(), "--out", (dir / "without").string(), "--methods", "external"});
  EXPECT_EQ(without.exit_code, 2) << without.err;
  EXPECT_NE(without.err.find("the external method needs a program (--external-program)"), std::string::npos)
      << without.err;
  const std::string example = std::string(HDABENCH_SOURCE_DIR) + "/tools/external/plane_fit.py";
  const CommandResult ok =
      RunInOwnFolder({"compare", dataset.string(), "--out", (dir / "ok").string(), "--methods", "external",
                      "--external-program", example, "--no-figures", "--no-report", "--quiet"});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_TRUE(fs::exists(dir / "ok" / "external" / "output.json"));
  EXPECT_TRUE(MethodNamed(nlohmann::json::parse(ReadText(dir / "ok" / "compare.json")), "external").at("ok").get<bool>());
  const CommandResult failing =
      RunInOwnFolder({"compare", dataset.string(), "--out", (dir / "failing").string(), "--methods", "external",
                      "--external-program", "/bin/false", "--no-figures", "--no-report", "--quiet"});
  EXPECT_EQ(failing.exit_code, 4) << failing.err;
  EXPECT_NE(failing.err.find("method external failed: /bin/false: exited with code 1"), std::string::npos)
      << failing.err;
  const nlohmann::json compare = nlohmann::json::parse(ReadText(dir / "failing" / "compare.json"));
  EXPECT_FALSE(MethodNamed(compare, "external").at("ok").get<bool>());
  EXPECT_TRUE(MethodNamed(compare, "flight").at("ok").get<bool>());
}

}  // namespace
