// Helpers shared by every test suite: per-test folders, seeds from test
// names, file edits and running the hdabench binary.
#pragma once

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <functional>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "tools/util/error.h"

namespace hdabench::testing_support {

namespace fs = std::filesystem;

// The message of the InputError `f` throws; empty when it throws none.
inline std::string InputErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

// FNV-1a of a string: seeds derived from a test's name are stable across
// runs, machines and standard libraries (std::hash is not).
inline std::uint64_t SeedFromName(const std::string& name) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (const char c : name) {
    hash ^= static_cast<unsigned char>(c);
    hash *= 0x100000001b3ULL;
  }
  return hash;
}

// A random unit quaternion (uniform 4-vector, normalised) and a random vector
// with components uniform in [-scale, scale], from a seeded generator.
inline Eigen::Quaterniond RandomRotation(std::mt19937_64* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double w = unit(*rng), x = unit(*rng), y = unit(*rng), z = unit(*rng);
  return Eigen::Quaterniond(w, x, y, z).normalized();
}
inline Eigen::Vector3d RandomVector(std::mt19937_64* rng, double scale) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  const double x = unit(*rng), y = unit(*rng), z = unit(*rng);
  return Eigen::Vector3d(scale * x, scale * y, scale * z);
}

// "Suite.Test" (with the parameter suffix for TEST_P), file-name safe.
inline std::string CurrentTestName() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = std::string(info->test_suite_name()) + "." + info->name();
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  return name;
}

inline std::uint64_t CurrentTestSeed() { return SeedFromName(CurrentTestName()); }

// Removes the folder of a test that passed; a failed test keeps its folder
// (named after the test) for inspection.
class RemovePassedTestDirs : public ::testing::EmptyTestEventListener {
 public:
  void OnTestEnd(const ::testing::TestInfo& info) override {
    if (!info.result()->Passed()) return;
    std::string name = std::string(info.test_suite_name()) + "." + info.name();
    for (char& c : name) {
      if (c == '/') c = '_';
    }
    std::error_code ignored;
    fs::remove_all(fs::path(HDABENCH_TEST_TMP) / name, ignored);
  }
};

// A fresh, empty folder for the current test under the build tree; removed
// after the test if it passes.
inline fs::path FreshTestDir() {
  static const bool registered = [] {
    ::testing::UnitTest::GetInstance()->listeners().Append(new RemovePassedTestDirs);
    return true;
  }();
  (void)registered;
  const fs::path dir = fs::path(HDABENCH_TEST_TMP) / CurrentTestName();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

inline std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

inline std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) lines.push_back(line);
  return lines;
}

inline std::string JoinLines(const std::vector<std::string>& lines) {
  std::string text;
  for (const std::string& line : lines) text += line + "\n";
  return text;
}

// Replaces line `line_number` (1-based) of a text file.
inline void ReplaceLine(const fs::path& path, int line_number, const std::string& line) {
  std::vector<std::string> lines = SplitLines(ReadText(path));
  lines.at(static_cast<size_t>(line_number - 1)) = line;
  WriteText(path, JoinLines(lines));
}

inline std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> fields;
  std::stringstream in(line);
  std::string field;
  while (std::getline(in, field, ',')) fields.push_back(field);
  return fields;
}

inline std::string JoinCsv(const std::vector<std::string>& fields) {
  std::string line;
  for (size_t i = 0; i < fields.size(); ++i) line += (i > 0 ? "," : "") + fields[i];
  return line;
}

// Sets the value of `column` (by header name) on line `line_number` of a CSV file.
inline void SetCsvValue(const fs::path& path, int line_number, const std::string& column,
                        const std::string& value) {
  std::vector<std::string> lines = SplitLines(ReadText(path));
  const std::vector<std::string> header = SplitCsv(lines.at(0));
  std::vector<std::string> fields = SplitCsv(lines.at(static_cast<size_t>(line_number - 1)));
  for (size_t i = 0; i < header.size(); ++i) {
    if (header[i] == column) fields.at(i) = value;
  }
  lines[static_cast<size_t>(line_number - 1)] = JoinCsv(fields);
  WriteText(path, JoinLines(lines));
}

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

inline std::string ShellQuote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) {
    if (c == '\'') {
      quoted += "'\\''";
    } else {
      quoted += c;
    }
  }
  return quoted + "'";
}

// Runs the hdabench binary with `args`; stdout and stderr go to files in `dir`.
// `environment`: variables set for that run only, as NAME=value.
inline CommandResult RunHdabench(const std::vector<std::string>& args, const fs::path& dir,
                                 const std::vector<std::string>& environment = {}) {
  std::string command;
  for (const std::string& assignment : environment) {
    const size_t equals = assignment.find('=');
    command += assignment.substr(0, equals) + "=" + ShellQuote(assignment.substr(equals + 1)) + " ";
  }
  command += ShellQuote(HDABENCH_EXE);
  for (const std::string& arg : args) command += " " + ShellQuote(arg);
  const fs::path out_file = dir / "cli.stdout";
  const fs::path err_file = dir / "cli.stderr";
  command += " >" + ShellQuote(out_file.string()) + " 2>" + ShellQuote(err_file.string());
  const int status = std::system(command.c_str());
  CommandResult result;
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  result.out = ReadText(out_file);
  result.err = ReadText(err_file);
  fs::remove(out_file);
  fs::remove(err_file);
  return result;
}

// Starts the hdabench binary with `args` (stdout to /dev/null, stderr to
// `err_file`, or /dev/null when it is empty), sends it `signal_number` once
// `file` exists (waiting at most 300 s), and returns its wait status.
inline int RunHdabenchUntil(const std::vector<std::string>& args, const fs::path& file, int signal_number,
                            const fs::path& err_file) {
  std::vector<std::string> argv_text = {HDABENCH_EXE};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  const pid_t child = ::fork();
  if (child < 0) return -1;
  if (child == 0) {
    std::vector<char*> argv;
    for (const std::string& a : argv_text) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const int null = ::open("/dev/null", O_WRONLY);
    const int err = err_file.empty() ? null : ::open(err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (null >= 0) ::dup2(null, 1);
    if (err >= 0) ::dup2(err, 2);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(300);
  while (!fs::exists(file) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  ::kill(child, signal_number);
  int status = 0;
  ::waitpid(child, &status, 0);
  return status;
}

// A dataset made once and shared by every test process that asks for it in
// `folder` (CTest runs each test in its own process): `make` writes it into
// the path it is given (a staging name that does not exist yet), which is
// then renamed to <folder>/<name>-<stamp>, stamp being the time stamp of the
// hdabench program. That program is rebuilt with the libraries, so a rebuilt
// generator never meets an old dataset, and the datasets of earlier builds
// are removed. A process never sees a half-written dataset; one that loses
// the race drops its own copy (the same bytes). Returns the folder.
//
// With HDABENCH_TEST_DATASETS_FROM naming another build folder of the same
// sources, a dataset that build's tests have made already is used as it is,
// read only: a dataset is the same bytes whichever build makes it, and under
// the sanitizers it takes several times as long to make. tools/bench.sh sets
// it to the normal build, just built and tested, for the sanitizer build's
// tests.
inline fs::path CachedDataset(const fs::path& folder, const std::string& name,
                              const std::function<void(const fs::path&)>& make) {
  const auto stamp = fs::last_write_time(HDABENCH_EXE).time_since_epoch().count();
  const fs::path target = folder / (name + "-" + std::to_string(static_cast<std::uint64_t>(stamp)));
  if (fs::exists(target / "manifest.json")) return target;
  if (const char* other = std::getenv("HDABENCH_TEST_DATASETS_FROM"); other != nullptr && *other != '\0') {
    const fs::path build = fs::path(HDABENCH_EXE).parent_path().parent_path();
    const fs::path relative = folder.lexically_relative(build);
    std::error_code ec;
    const auto other_stamp = fs::last_write_time(fs::path(other) / "tools" / "hdabench", ec);
    if (!ec && !relative.empty() && *relative.begin() != "..") {
      const fs::path made = fs::path(other) / relative /
                            (name + "-" + std::to_string(static_cast<std::uint64_t>(
                                              other_stamp.time_since_epoch().count())));
      if (fs::exists(made / "manifest.json", ec)) return made;
    }
  }
  const fs::path staging = target.string() + ".staging-" + std::to_string(::getpid());
  fs::remove_all(staging);
  fs::create_directories(folder);
  make(staging);
  std::error_code ec;
  fs::rename(staging, target, ec);
  if (ec) fs::remove_all(staging, ec);
  // Datasets of earlier builds are never used again.
  for (const auto& item : fs::directory_iterator(folder, ec)) {
    const std::string other = item.path().filename().string();
    if (item.path() != target && other.rfind(name + "-", 0) == 0 &&
        other.find(".staging-") == std::string::npos) {
      fs::remove_all(item.path(), ec);
    }
  }
  return target;
}

}  // namespace hdabench::testing_support
