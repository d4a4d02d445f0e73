// Running an external program (COLMAP, mrcal's tools) without a shell: an
// argument vector, a working folder, a log file that receives the program's
// stdout and stderr, a time limit and extra environment variables. The program
// runs in its own process group so that a timeout ends it and every process it
// started. Failures of the program are reported in the result, never thrown.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace hdabench::util {

struct ProcessOptions {
  // Working folder of the program; empty: the caller's.
  std::string working_dir;
  // File that receives the program's stdout and stderr, appended (created when
  // missing). Empty: both go to /dev/null. stdin is always /dev/null.
  std::string log_file;
  // Wall-time limit, seconds; <= 0: none. On expiry the whole process group
  // gets SIGTERM, then SIGKILL after kill_grace_s.
  double timeout_s = 0.0;
  double kill_grace_s = 1.0;  // seconds between SIGTERM and SIGKILL, >= 0
  // Variables added to (or replacing those of) the caller's environment.
  std::vector<std::pair<std::string, std::string>> environment;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

struct ProcessResult {
  bool started = false;    // false: the program could not be found or executed (see error)
  int exit_code = -1;      // the program's exit status when it exited normally, else -1
  bool timed_out = false;  // killed because it ran longer than ProcessOptions::timeout_s
  bool signaled = false;   // ended by a signal (including the timeout's)
  int signal = 0;          // that signal's number
  double wall_s = 0.0;    // wall time from start to end, seconds
  std::string error;       // one line describing any failure; empty when exit_code == 0

  // True when the program started, exited on its own and returned 0.
  bool Ok() const { return started && !timed_out && !signaled && exit_code == 0; }
};

// The absolute path of an executable: `name` as is when it contains a '/'
// (relative paths are resolved against the current folder), otherwise the
// first match in the folders of PATH. Empty when there is no such regular,
// executable file.
std::string FindExecutable(const std::string& name);

// Runs argv[0] (looked up with FindExecutable) with arguments argv[1..] and
// waits for it. Throws InputError when argv is empty or the options are
// invalid, or when the log file or the working folder cannot be used (the
// message names it). Everything that goes wrong with the program itself (not
// found, not executable, non-zero exit, signal, timeout) is in the result.
ProcessResult RunProcess(const std::vector<std::string>& argv, const ProcessOptions& options);

// Ending the program on SIGINT (Ctrl-C) or SIGTERM (kill, a batch
// scheduler). RunProcess puts each program in its own process group, so a
// signal to the bench does not reach them: without this, COLMAP would go on
// running after the bench that started it was stopped. After
// InstallInterruptHandlers either signal sends SIGTERM to the process group
// of every program RunProcess is running (a child hdabench does the same with
// its own), prints "<what>: interrupted by SIGINT: ..." (or SIGTERM) on
// stderr and exits with kExitInterrupted or kExitTerminated, the codes a
// shell gives a program those signals end. Files written with
// WriteFileAtomically are whole or absent (a temporary left behind is ignored
// by a rerun); a rerun does what was not finished.
constexpr int kExitInterrupted = 130;  // 128 + SIGINT
constexpr int kExitTerminated = 143;   // 128 + SIGTERM
void InstallInterruptHandlers(const std::string& what);

// The last non-blank line of a program's log (ProcessOptions::log_file),
// without its line end: what a failing program said last. Empty when the file
// is missing, unreadable or blank.
std::string LastLineOfLog(const std::string& log_file);

}  // namespace hdabench::util
