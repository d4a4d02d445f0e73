#include "tools/util/process.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::calib {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::WriteText;

TEST(RunProcess, ReportsTheExitCode) {
  const util::ProcessResult result = util::RunProcess({"/bin/sh", "-c", "exit 3"}, util::ProcessOptions());
  EXPECT_TRUE(result.started);
  EXPECT_EQ(result.exit_code, 3);
  EXPECT_FALSE(result.timed_out);
  EXPECT_FALSE(result.signaled);
  EXPECT_FALSE(result.Ok());
  EXPECT_NE(result.error.find("exited with code 3"), std::string::npos) << result.error;

  const util::ProcessResult ok = util::RunProcess({"true"}, util::ProcessOptions());
  EXPECT_TRUE(ok.Ok());
  EXPECT_EQ(ok.exit_code, 0);
  EXPECT_TRUE(ok.error.empty());
}

TEST(RunProcess, AMissingProgramIsNotStartedAndNamed) {
  const util::ProcessResult on_path = util::RunProcess({"hdabench-no-such-program", "x"}, util::ProcessOptions());
  EXPECT_FALSE(on_path.started);
  EXPECT_NE(on_path.error.find("hdabench-no-such-program"), std::string::npos) << on_path.error;
  EXPECT_NE(on_path.error.find("not found"), std::string::npos) << on_path.error;

  const util::ProcessResult absolute = util::RunProcess({"/nonexistent/colmap"}, util::ProcessOptions());
  EXPECT_FALSE(absolute.started);
  EXPECT_NE(absolute.error.find("/nonexistent/colmap"), std::string::npos) << absolute.error;

  // A file that is executable but no valid program: exec fails.
  const fs::path dir = FreshTestDir();
  const fs::path bogus = dir / "bogus";
  WriteText(bogus, std::string("\x7f"
                               "ELF garbage",
                               12));
  fs::permissions(bogus, fs::perms::owner_all);
  const util::ProcessResult bad = util::RunProcess({bogus.string()}, util::ProcessOptions());
  EXPECT_FALSE(bad.started);
  EXPECT_NE(bad.error.find("cannot be executed"), std::string::npos) << bad.error;
}

TEST(RunProcess, ATimeoutKillsTheWholeProcessGroup) {
  const fs::path dir = FreshTestDir();
  util::ProcessOptions options;
  options.timeout_s = 0.5;
  options.log_file = (dir / "log.txt").string();
  // The shell starts a child: both must go.
  const util::ProcessResult result =
      util::RunProcess({"/bin/sh", "-c", "sleep 5 & sleep 5; echo finished"}, options);
  EXPECT_TRUE(result.started);
  EXPECT_TRUE(result.timed_out);
  EXPECT_TRUE(result.signaled);
  EXPECT_FALSE(result.Ok());
  EXPECT_GE(result.wall_s, 0.5);
  EXPECT_LT(result.wall_s, 3.0);
  EXPECT_NE(result.error.find("timed out after 0.5 s"), std::string::npos) << result.error;
  EXPECT_EQ(ReadText(dir / "log.txt").find("finished"), std::string::npos);
  // No 'sleep 5' of this group is left: the group no longer exists.
}

TEST(RunProcess, TheLogReceivesStdoutAndStderrAppended) {
  const fs::path dir = FreshTestDir();
  util::ProcessOptions options;
  options.log_file = (dir / "log.txt").string();
  WriteText(dir / "log.txt", "before\n");
  const util::ProcessResult result =
      util::RunProcess({"/bin/sh", "-c", "echo to-stdout; echo to-stderr >&2"}, options);
  ASSERT_TRUE(result.Ok()) << result.error;
  EXPECT_EQ(ReadText(dir / "log.txt"), "before\nto-stdout\nto-stderr\n");
}

TEST(RunProcess, WorkingFolderAndEnvironment) {
  const fs::path dir = FreshTestDir();
  fs::create_directories(dir / "work");
  util::ProcessOptions options;
  options.working_dir = (dir / "work").string();
  options.log_file = (dir / "log.txt").string();
  options.environment = {{"HDABENCH_TEST_VALUE", "forty two"}, {"HOME", "/elsewhere"}};
  const util::ProcessResult result = util::RunProcess(
      {"/bin/sh", "-c", "pwd; echo \"$HDABENCH_TEST_VALUE\"; echo \"$HOME\"; cat - </dev/stdin"},
      options);
  ASSERT_TRUE(result.Ok()) << result.error;
  EXPECT_EQ(ReadText(dir / "log.txt"),
            fs::canonical(dir / "work").string() + "\nforty two\n/elsewhere\n");
}

TEST(RunProcess, ASignalIsReported) {
  const util::ProcessResult result = util::RunProcess({"/bin/sh", "-c", "kill -9 $$"}, util::ProcessOptions());
  EXPECT_TRUE(result.started);
  EXPECT_TRUE(result.signaled);
  EXPECT_EQ(result.signal, 9);
  EXPECT_EQ(result.exit_code, -1);
  EXPECT_NE(result.error.find("killed by signal 9"), std::string::npos) << result.error;
}

// The pid of a process whose parent is `parent` and whose command line starts
// with `program` (from /proc), or 0.
pid_t ChildRunning(pid_t parent, const std::string& program) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string name = entry.path().filename().string();
    if (name.find_first_not_of("0123456789") != std::string::npos) continue;
    const std::string stat = ReadText(entry.path() / "stat");
    const size_t close = stat.rfind(')');
    if (close == std::string::npos) continue;
    int ppid = 0;
    char state = 0;
    if (std::sscanf(stat.c_str() + close + 1, " %c %d", &state, &ppid) != 2 || ppid != parent) continue;
    const std::string cmdline = ReadText(entry.path() / "cmdline");
    if (cmdline.compare(0, program.size(), program) == 0) return static_cast<pid_t>(std::stoi(name));
  }
  return 0;
}

// True once `pid` has ended: gone, or a zombie waiting for its new parent.
bool Ended(pid_t pid) {
  const std::string stat = ReadText(fs::path("/proc") / std::to_string(pid) / "stat");
  const size_t close = stat.rfind(')');
  return stat.empty() || close == std::string::npos || (close + 2 < stat.size() && stat[close + 2] == 'Z');
}

// A process that installed the interrupt handlers and is waiting in
// RunProcess for `sleep 60` gets `signal_number`: it ends the sleep's process
// group, says so on stderr and exits with `expected_code`.
void ExpectAnInterruptEndsTheProgramsStarted(int signal_number, int expected_code, const std::string& name) {
  int err[2];
  ASSERT_EQ(::pipe(err), 0);
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::dup2(err[1], STDERR_FILENO);
    ::close(err[0]);
    util::InstallInterruptHandlers("the test");
    util::RunProcess({"sleep", "60"}, util::ProcessOptions());
    ::_exit(0);  // the sleep ended some other way
  }
  ::close(err[1]);
  pid_t sleeper = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while ((sleeper = ChildRunning(child, "sleep")) == 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  // Past exec, the caller has long registered it; a little more for slow (sanitized) builds.
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  ::kill(child, signal_number);
  int status = 0;
  ::waitpid(child, &status, 0);
  std::string said;
  char buffer[512];
  ssize_t got = 0;
  while ((got = ::read(err[0], buffer, sizeof buffer)) > 0) said.append(buffer, static_cast<size_t>(got));
  ::close(err[0]);
  ASSERT_GT(sleeper, 0) << "the sleep never started";
  ASSERT_TRUE(WIFEXITED(status)) << name;
  EXPECT_EQ(WEXITSTATUS(status), expected_code) << name;
  EXPECT_EQ(said, "the test: interrupted by " + name +
                      ": stopped, with the programs it had started; every file written so far is whole, and a "
                      "rerun does the rest\n");
  const auto end_deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!Ended(sleeper) && std::chrono::steady_clock::now() < end_deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(Ended(sleeper)) << "the program started (sleep, pid " << sleeper << ") is still running after " << name;
}

TEST(InterruptHandlers, SigintAndSigtermEndTheProgramsStartedAndExitWith130And143) {
  ExpectAnInterruptEndsTheProgramsStarted(SIGINT, util::kExitInterrupted, "SIGINT");
  ExpectAnInterruptEndsTheProgramsStarted(SIGTERM, util::kExitTerminated, "SIGTERM");
}

TEST(RunProcess, InvalidCallsThrowInputError) {
  EXPECT_THROW(util::RunProcess({}, util::ProcessOptions()), InputError);
  util::ProcessOptions bad_dir;
  bad_dir.working_dir = "/nonexistent/folder";
  try {
    util::RunProcess({"true"}, bad_dir);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/folder"), std::string::npos) << e.what();
  }
  util::ProcessOptions bad_log;
  bad_log.log_file = "/nonexistent/folder/log.txt";
  EXPECT_THROW(util::RunProcess({"true"}, bad_log), InputError);
  util::ProcessOptions bad_env;
  bad_env.environment = {{"A=B", "c"}};
  EXPECT_THROW(util::RunProcess({"true"}, bad_env), InputError);
}

TEST(FindExecutable, SearchesPathAndAcceptsPaths) {
  const std::string sh = util::FindExecutable("sh");
  EXPECT_FALSE(sh.empty());
  EXPECT_EQ(sh.front(), '/');
  EXPECT_EQ(util::FindExecutable("/bin/sh"), "/bin/sh");
  EXPECT_EQ(util::FindExecutable("hdabench-no-such-program"), "");
  EXPECT_EQ(util::FindExecutable("/nonexistent/colmap"), "");
  const fs::path dir = FreshTestDir();
  WriteText(dir / "plain.txt", "not a program\n");
  fs::permissions(dir / "plain.txt", fs::perms::owner_read | fs::perms::owner_write);
  EXPECT_EQ(util::FindExecutable((dir / "plain.txt").string()), "");  // not executable
  EXPECT_EQ(util::FindExecutable("/bin"), "");                        // a folder
  EXPECT_EQ(util::FindExecutable(""), "");
}

TEST(LastLineOfLog, TheLastNonBlankLineWithoutItsEnd) {
  const fs::path dir = FreshTestDir();
  WriteText(dir / "log", "first\r\nsecond: the reason\r\n\n  \n");
  EXPECT_EQ(util::LastLineOfLog((dir / "log").string()), "second: the reason");
  WriteText(dir / "one", "only line");
  EXPECT_EQ(util::LastLineOfLog((dir / "one").string()), "only line");
  WriteText(dir / "blank", "\n\n");
  EXPECT_EQ(util::LastLineOfLog((dir / "blank").string()), "");
  EXPECT_EQ(util::LastLineOfLog((dir / "missing").string()), "");
}

}  // namespace
}  // namespace hdabench::calib
