// Reading files whole, by their start or by their end.
#include "tools/util/files.h"

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tools/util/process.h"

namespace hdabench::util {
namespace {

namespace fs = std::filesystem;

// Writes 100000 bytes of every value to `file` and returns them.
std::string WriteTestBytes(const fs::path& file) {
  std::string text;
  for (int i = 0; i < 100000; ++i) text += static_cast<char>(i * 7 + i / 256);
  std::ofstream(file, std::ios::binary) << text;
  return text;
}

TEST(ReadFilePrefix, ReadsTheStartAndTheSizeAndReadFileBytesTheWhole) {
  const TempFolder folder("files-test");
  const fs::path file = folder.path() / "data.bin";
  const std::string text = WriteTestBytes(file);

  std::string bytes, error;
  std::uint64_t size = 0;
  ASSERT_TRUE(ReadFilePrefix(file, 1000, &bytes, &size, &error)) << error;
  EXPECT_EQ(bytes, text.substr(0, 1000));
  EXPECT_EQ(size, text.size());
  ASSERT_TRUE(ReadFilePrefix(file, 1u << 20, &bytes, &size, &error)) << error;
  EXPECT_EQ(bytes, text);
  ASSERT_TRUE(ReadFileBytes(file, &bytes, &error)) << error;
  EXPECT_EQ(bytes, text);

  std::ofstream(folder.path() / "empty.bin", std::ios::binary);
  ASSERT_TRUE(ReadFileBytes(folder.path() / "empty.bin", &bytes, &error)) << error;
  EXPECT_TRUE(bytes.empty());
  EXPECT_FALSE(ReadFileBytes(folder.path() / "missing.bin", &bytes, &error));
  EXPECT_EQ(error, "file not found");
  EXPECT_FALSE(ReadFilePrefix(folder.path(), 10, &bytes, &size, &error));
  EXPECT_EQ(error, "is a directory; expected a file");
  // A device would never end; a pipe (the shell's <(...)) is a file to read.
  EXPECT_FALSE(ReadFileBytes("/dev/zero", &bytes, &error));
  EXPECT_EQ(error, "is a device or socket; expected a file");
  const fs::path fifo = folder.path() / "fifo";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_TRUE(IsReadableFile(fifo, &error)) << error;
}

// Reads at offsets of the file as it was opened: a file renamed over the
// path afterwards (a dataset regenerated while it is read) is not mixed in.
TEST(OpenedFile, ReadsAtOffsetsOfTheFileItOpenedAndNamesAShortOne) {
  const TempFolder folder("files-test");
  const fs::path file = folder.path() / "data.bin";
  const std::string text = WriteTestBytes(file);

  OpenedFile opened;
  std::string error;
  ASSERT_TRUE(opened.Open(file, &error)) << error;
  EXPECT_EQ(opened.Size(), text.size());
  std::vector<char> tail(1000, '\0');
  ASSERT_TRUE(opened.ReadAt(text.size() - 1000, tail.size(), tail.data(), &error)) << error;
  EXPECT_EQ(std::string(tail.begin(), tail.end()), text.substr(text.size() - 1000));
  std::vector<char> whole(text.size(), '\0');
  ASSERT_TRUE(opened.ReadAt(0, whole.size(), whole.data(), &error)) << error;
  EXPECT_EQ(std::string(whole.begin(), whole.end()), text);
  EXPECT_TRUE(opened.ReadAt(text.size(), 0, nullptr, &error)) << error;

  EXPECT_FALSE(opened.ReadAt(1, text.size(), whole.data(), &error));
  EXPECT_EQ(error, "holds 100000 bytes; expected at least 100001");
  EXPECT_FALSE(opened.ReadAt(text.size() + 1, 0, whole.data(), &error));
  EXPECT_EQ(error, "holds 100000 bytes; expected at least 100001");

  WriteFileAtomically(file, "replaced");
  ASSERT_TRUE(opened.ReadAt(0, whole.size(), whole.data(), &error)) << error;
  EXPECT_EQ(std::string(whole.begin(), whole.end()), text);
  ASSERT_TRUE(opened.Open(file, &error)) << error;
  EXPECT_EQ(opened.Size(), 8u);

  EXPECT_FALSE(opened.Open(folder.path() / "missing.bin", &error));
  EXPECT_EQ(error, "file not found");
  EXPECT_FALSE(opened.ReadAt(0, 1, tail.data(), &error));
  EXPECT_EQ(error, "cannot be read (not open)");
  EXPECT_FALSE(opened.Open(folder.path(), &error));
  EXPECT_EQ(error, "is a directory; expected a file");
}

std::vector<std::string> Names(const fs::path& folder) {
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

// The bytes in place, nothing else left beside them, a rewrite replacing
// them; a temporary left by a writer killed before its rename is hidden,
// named after its process, and neither disturbs a rerun nor shows in git.
TEST(WriteFileAtomically, WritesTheBytesAloneAndALeftTemporaryIsIgnored) {
  const TempFolder folder("files-test");
  const fs::path path = folder.path() / "results" / "result.json";
  WriteFileAtomically(path, "first");
  std::string bytes, error;
  ASSERT_TRUE(ReadFileBytes(path, &bytes, &error)) << error;
  EXPECT_EQ(bytes, "first");
  EXPECT_EQ(Names(path.parent_path()), std::vector<std::string>{"result.json"});

  const fs::path temporary = TemporaryPathFor(path);
  EXPECT_EQ(temporary.parent_path(), path.parent_path());
  EXPECT_EQ(temporary.filename().string(), ".result.json." + std::to_string(::getpid()) + ".tmp");
  const fs::path left = path.parent_path() / ".result.json.4000001.tmp";  // a killed writer's
  std::ofstream(left, std::ios::binary) << "half";
  WriteFileAtomically(path, "second, longer");
  ASSERT_TRUE(ReadFileBytes(path, &bytes, &error)) << error;
  EXPECT_EQ(bytes, "second, longer");
  EXPECT_EQ(Names(path.parent_path()), (std::vector<std::string>{".result.json.4000001.tmp", "result.json"}));

  // git, with the project's .gitignore, ignores the leftover and not the result.
  if (FindExecutable("git").empty()) GTEST_SKIP() << "git not installed";
  fs::copy_file(fs::path(HDABENCH_SOURCE_DIR) / ".gitignore", folder.path() / ".gitignore");
  ProcessOptions options;
  options.working_dir = folder.path().string();
  ASSERT_TRUE(RunProcess({"git", "init", "-q"}, options).Ok());
  EXPECT_TRUE(RunProcess({"git", "check-ignore", "-q", left.string()}, options).Ok());
  EXPECT_EQ(RunProcess({"git", "check-ignore", "-q", path.string()}, options).exit_code, 1);
}

// Writes 1 MB to `path` under a 4 KB file-size limit (standing in for a
// full disk: the write fails halfway with EFBIG) and exits 0 when the
// InputError names the path, the earlier file is whole and nothing else is
// left in `folder`; 1 when nothing was thrown, 2 when a check failed.
[[noreturn]] void WriteBeyondTheSizeLimit(const fs::path& folder, const fs::path& path) {
  std::signal(SIGXFSZ, SIG_IGN);  // a write past the limit then fails instead of killing
  rlimit limit{};
  limit.rlim_cur = 4096;
  limit.rlim_max = 4096;
  ::setrlimit(RLIMIT_FSIZE, &limit);
  try {
    WriteFileAtomically(path, std::string(1 << 20, 'x'));
  } catch (const InputError& e) {
    std::string bytes, error;
    const bool earlier = ReadFileBytes(path, &bytes, &error) && bytes == "earlier";
    const bool named = std::string(e.what()).find(path.string()) != std::string::npos;
    const bool nothing_left = Names(folder) == std::vector<std::string>{path.filename().string()};
    std::exit(earlier && named && nothing_left ? 0 : 2);
  }
  std::exit(1);
}

// A write that fails halfway is an InputError naming the path; the earlier
// file stays whole and no temporary is left.
TEST(WriteFileAtomically, AWriteThatFailsHalfwayKeepsTheEarlierFileAndLeavesNothing) {
  const TempFolder folder("files-test");
  const fs::path path = folder.path() / "result.bin";
  WriteFileAtomically(path, "earlier");
  EXPECT_EXIT(WriteBeyondTheSizeLimit(folder.path(), path), ::testing::ExitedWithCode(0), "");
}

}  // namespace
}  // namespace hdabench::util
