#include "tools/util/process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string_view>
#include <thread>

#include "tools/util/error.h"
#include "tools/util/options_check.h"

extern char** environ;

namespace hdabench::util {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// The process groups of the programs RunProcess is running, for the
// interrupt handler: lock-free slots (0: free), which a signal handler may read.
constexpr size_t kMaxLiveGroups = 256;
std::atomic<pid_t> g_live_groups[kMaxLiveGroups];
static_assert(std::atomic<pid_t>::is_always_lock_free, "the handler reads the slots");

size_t RegisterGroup(pid_t pid) {
  for (size_t i = 0; i < kMaxLiveGroups; ++i) {
    pid_t expected = 0;
    if (g_live_groups[i].compare_exchange_strong(expected, pid)) return i;
  }
  return kMaxLiveGroups;  // all taken: that program is not ended by an interrupt
}

void UnregisterGroup(size_t slot) {
  if (slot < kMaxLiveGroups) g_live_groups[slot].store(0);
}

// The handler's messages (0: SIGINT, 1: SIGTERM), composed before any
// signal: the handler may only write() them. Plain arrays, so that nothing
// destroys them while a signal may come.
constexpr size_t kMessageSize = 512;
char g_messages[2][kMessageSize];
size_t g_message_lengths[2] = {0, 0};

void OnInterrupt(int signal_number) {
  for (std::atomic<pid_t>& slot : g_live_groups) {
    const pid_t pid = slot.load();
    if (pid > 0) ::kill(-pid, SIGTERM);
  }
  const int which = signal_number == SIGINT ? 0 : 1;
  const ssize_t written = ::write(STDERR_FILENO, g_messages[which], g_message_lengths[which]);
  static_cast<void>(written);
  ::_exit(signal_number == SIGINT ? kExitInterrupted : kExitTerminated);
}

bool IsExecutableFile(const std::string& path) {
  struct stat info {};
  if (::stat(path.c_str(), &info) != 0) return false;
  return S_ISREG(info.st_mode) && ::access(path.c_str(), X_OK) == 0;
}

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// The caller's environment with `extra` added or replaced, as "NAME=value".
std::vector<std::string> MergedEnvironment(const std::vector<std::pair<std::string, std::string>>& extra) {
  std::vector<std::string> merged;
  for (char** entry = environ; entry != nullptr && *entry != nullptr; ++entry) {
    const std::string text(*entry);
    const std::string name = text.substr(0, text.find('='));
    bool replaced = false;
    for (const auto& [key, value] : extra) replaced = replaced || key == name;
    if (!replaced) merged.push_back(text);
  }
  for (const auto& [key, value] : extra) merged.push_back(key + "=" + value);
  return merged;
}

std::vector<char*> CStrings(std::vector<std::string>* strings) {
  std::vector<char*> pointers;
  for (std::string& s : *strings) pointers.push_back(s.data());
  pointers.push_back(nullptr);
  return pointers;
}

// Writes the whole buffer, retrying on EINTR (async-signal-safe).
void WriteAll(int fd, const void* data, size_t size) {
  const char* bytes = static_cast<const char*>(data);
  while (size > 0) {
    const ssize_t n = ::write(fd, bytes, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;
    bytes += n;
    size -= static_cast<size_t>(n);
  }
}

// Sends (step, errno) to the parent and ends the child (async-signal-safe).
[[noreturn]] void ReportAndExit(int report_fd, int step) {
  const int data[2] = {step, errno};
  WriteAll(report_fd, data, sizeof(data));
  ::_exit(127);
}

// In the child, after fork(): only async-signal-safe calls. On any failure the
// step name and errno go to `report_fd` and the child exits with 127.
[[noreturn]] void ExecChild(const char* path, char* const* argv, char* const* envp,
                            const char* working_dir, int log_fd, int report_fd) {
  ::setpgid(0, 0);
  const int null_fd = ::open("/dev/null", O_RDWR);
  if (null_fd < 0) ReportAndExit(report_fd, 1);
  if (::dup2(null_fd, STDIN_FILENO) < 0) ReportAndExit(report_fd, 1);
  const int out_fd = log_fd >= 0 ? log_fd : null_fd;
  if (::dup2(out_fd, STDOUT_FILENO) < 0 || ::dup2(out_fd, STDERR_FILENO) < 0)
    ReportAndExit(report_fd, 1);
  if (working_dir != nullptr && ::chdir(working_dir) != 0) ReportAndExit(report_fd, 2);
  // Default signal dispositions and an empty mask for the program.
  sigset_t none;
  sigemptyset(&none);
  ::sigprocmask(SIG_SETMASK, &none, nullptr);
  ::signal(SIGPIPE, SIG_DFL);
  ::signal(SIGINT, SIG_DFL);
  ::signal(SIGTERM, SIG_DFL);
  ::execve(path, argv, envp);
  ReportAndExit(report_fd, 3);
}

std::string ErrnoText(int error) { return std::strerror(error); }

// Throws InputError for what the caller got wrong: no program, invalid
// options, a working folder that is not there.
void CheckRunRequest(const std::vector<std::string>& argv, const ProcessOptions& options) {
  if (argv.empty()) throw InputError("RunProcess: empty argument vector: expected a program name");
  ThrowIfInvalid("RunProcess: invalid ProcessOptions: ", options.Validate());
  if (!options.working_dir.empty() && !fs::is_directory(options.working_dir)) {
    throw InputError(options.working_dir + ": working folder of " + argv[0] +
                     " does not exist or is not a folder");
  }
}

// The log file opened for appending (close-on-exec: the child gets it only as
// its stdout and stderr), or -1 when there is none. Throws when it cannot be
// opened, since the caller named it.
int OpenLogFile(const ProcessOptions& options, const std::string& program) {
  int log_fd = -1;
  if (!options.log_file.empty()) {
    log_fd = ::open(options.log_file.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (log_fd < 0) {
      throw InputError(options.log_file + ": cannot open the log file of " + program + ": " +
                       ErrnoText(errno));
    }
  }
  return log_fd;
}

// Reads the child's (step, errno) report into report_data; returns the bytes
// read. exec succeeded when the pipe closes without data (0 bytes).
size_t ReadExecReport(int report_fd, int (&report_data)[2]) {
  size_t got = 0;
  while (got < sizeof(report_data)) {
    const ssize_t n =
        ::read(report_fd, reinterpret_cast<char*>(report_data) + got, sizeof(report_data) - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  return got;
}

// The error line of a child that failed before exec, from its report.
std::string ExecFailureText(const std::string& path, const int (&report_data)[2]) {
  const char* step = report_data[0] == 1   ? "cannot redirect its output"
                     : report_data[0] == 2 ? "cannot enter the working folder"
                                           : "cannot be executed";
  return path + ": " + step + ": " + ErrnoText(report_data[1]);
}

// Waits for the started program, polling so that the time limit can end its
// process group (SIGTERM, then SIGKILL after the grace). Sets timed_out and
// wall_s; returns the wait status.
int WaitWithTimeout(pid_t pid, Clock::time_point start, const ProcessOptions& options,
                    ProcessResult* result) {
  int status = 0;
  bool terminated = false;
  Clock::time_point term_time;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) break;
    if (done < 0 && errno != EINTR) break;
    const double elapsed = SecondsSince(start);
    if (options.timeout_s > 0 && elapsed > options.timeout_s) {
      if (!terminated) {
        result->timed_out = true;
        ::kill(-pid, SIGTERM);
        terminated = true;
        term_time = Clock::now();
      } else if (SecondsSince(term_time) >= options.kill_grace_s) {
        ::kill(-pid, SIGKILL);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(elapsed < 1.0 ? 2 : 20));
  }
  // Stragglers of the group after a timeout.
  if (result->timed_out) ::kill(-pid, SIGKILL);
  result->wall_s = SecondsSince(start);
  return status;
}

// The exit code or signal from the wait status, and the one-line error that
// describes any failure (empty for a clean exit).
void RecordExit(int status, const std::string& path, const ProcessOptions& options,
                ProcessResult* result) {
  std::ostringstream error;
  if (WIFEXITED(status)) {
    result->exit_code = WEXITSTATUS(status);
  } else if (WIFSIGNALED(status)) {
    result->signaled = true;
    result->signal = WTERMSIG(status);
  }
  if (result->timed_out) {
    error << path << ": timed out after " << options.timeout_s << " s (process group killed)";
  } else if (result->signaled) {
    error << path << ": killed by signal " << result->signal << " (" << strsignal(result->signal)
          << ")";
  } else if (result->exit_code != 0) {
    error << path << ": exited with code " << result->exit_code;
  }
  result->error = error.str();
}

}  // namespace

std::vector<std::string> ProcessOptions::Validate() const {
  std::vector<std::string> errors;
  RequireOption(true, "timeout_s", timeout_s, "a finite number of seconds (<= 0: no limit)",
                &errors);
  RequireOption(kill_grace_s >= 0, "kill_grace_s", kill_grace_s, ">= 0", &errors);
  for (const auto& [key, value] : environment) {
    if (key.empty() || key.find('=') != std::string::npos) {
      errors.push_back("environment variable name '" + key +
                       "': expected a non-empty name without '='");
    }
  }
  return errors;
}

std::string FindExecutable(const std::string& name) {
  if (name.empty()) return "";
  if (name.find('/') != std::string::npos) {
    std::error_code ignored;
    const fs::path absolute = fs::absolute(name, ignored);
    return IsExecutableFile(absolute.string()) ? absolute.lexically_normal().string() : "";
  }
  const char* path_env = std::getenv("PATH");
  const std::string path_list = path_env != nullptr ? path_env : "/usr/local/bin:/usr/bin:/bin";
  std::stringstream folders(path_list);
  std::string folder;
  while (std::getline(folders, folder, ':')) {
    if (folder.empty()) folder = ".";
    std::error_code ignored;
    const fs::path candidate = fs::absolute(fs::path(folder) / name, ignored);
    if (IsExecutableFile(candidate.string())) return candidate.lexically_normal().string();
  }
  return "";
}

ProcessResult RunProcess(const std::vector<std::string>& argv, const ProcessOptions& options) {
  CheckRunRequest(argv, options);

  ProcessResult result;
  const std::string path = FindExecutable(argv[0]);
  if (path.empty()) {
    result.error = argv[0] + ": program not found" +
                   (argv[0].find('/') != std::string::npos ? " or not executable"
                                                           : " on PATH (or not executable)");
    return result;
  }

  const int log_fd = OpenLogFile(options, argv[0]);
  int report[2] = {-1, -1};
  if (::pipe2(report, O_CLOEXEC) != 0) {
    const int error = errno;
    if (log_fd >= 0) ::close(log_fd);
    result.error = argv[0] + ": cannot create a pipe: " + ErrnoText(error);
    return result;
  }

  // Everything the child needs is prepared before fork().
  std::vector<std::string> arg_strings = argv;
  std::vector<char*> arg_pointers = CStrings(&arg_strings);
  std::vector<std::string> env_strings = MergedEnvironment(options.environment);
  std::vector<char*> env_pointers = CStrings(&env_strings);
  const char* working_dir = options.working_dir.empty() ? nullptr : options.working_dir.c_str();

  const Clock::time_point start = Clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    const int error = errno;
    ::close(report[0]);
    ::close(report[1]);
    if (log_fd >= 0) ::close(log_fd);
    result.error = argv[0] + ": fork failed: " + ErrnoText(error);
    return result;
  }
  if (pid == 0) {
    ExecChild(path.c_str(), arg_pointers.data(), env_pointers.data(), working_dir, log_fd,
              report[1]);
  }
  ::setpgid(pid, pid);  // also done in the child: whichever runs first wins
  const size_t slot = RegisterGroup(pid);
  ::close(report[1]);
  if (log_fd >= 0) ::close(log_fd);

  int report_data[2] = {0, 0};
  const size_t got = ReadExecReport(report[0], report_data);
  ::close(report[0]);

  if (got > 0) {
    int status = 0;
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
    UnregisterGroup(slot);
    result.wall_s = SecondsSince(start);
    result.error = ExecFailureText(path, report_data);
    return result;
  }
  result.started = true;

  const int status = WaitWithTimeout(pid, start, options, &result);
  UnregisterGroup(slot);
  RecordExit(status, path, options, &result);
  return result;
}

void InstallInterruptHandlers(const std::string& what) {
  const std::string rest =
      ": stopped, with the programs it had started; every file written so far is whole, and a rerun "
      "does the rest\n";
  const std::string messages[2] = {what + ": interrupted by SIGINT" + rest, what + ": interrupted by SIGTERM" + rest};
  for (int i = 0; i < 2; ++i) {
    g_message_lengths[i] = std::min(messages[i].size(), kMessageSize);
    std::memcpy(g_messages[i], messages[i].data(), g_message_lengths[i]);
  }
  struct sigaction action {};
  action.sa_handler = OnInterrupt;
  sigemptyset(&action.sa_mask);
  // Both signals blocked while the handler runs: it exits before either could
  // run it a second time.
  sigaddset(&action.sa_mask, SIGINT);
  sigaddset(&action.sa_mask, SIGTERM);
  ::sigaction(SIGINT, &action, nullptr);
  ::sigaction(SIGTERM, &action, nullptr);
}

std::string LastLineOfLog(const std::string& log_file) {
  std::ifstream in(log_file, std::ios::binary);
  if (!in) return "";
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t end = text.find_last_not_of("\r\n \t");
  if (end == std::string::npos) return "";
  const size_t newline = text.rfind('\n', end);
  const size_t begin = newline == std::string::npos ? 0 : newline + 1;
  return text.substr(begin, end - begin + 1);
}

}  // namespace hdabench::util
