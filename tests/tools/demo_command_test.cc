// `hdabench demo`: the default dataset made deterministically and compared on.
#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"

namespace {

namespace fs = std::filesystem;

using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;

// Runs `hdabench ARGS` in a scratch folder of its own (FreshTestDir would empty
// the test's); out holds stdout then stderr.
CommandResult RunHdabench(const std::vector<std::string>& args) {
  const fs::path dir = fs::path(HDABENCH_TEST_TMP) / (hdabench::testing_support::CurrentTestName() + ".run");
  fs::create_directories(dir);
  CommandResult result = hdabench::testing_support::RunHdabench(args, dir);
  result.out += result.err;
  return result;
}

TEST(DemoCommand, CreatesTheDefaultDatasetDeterministicallyAndComparesOnIt) {
  const fs::path dir = FreshTestDir();
  const CommandResult first = RunHdabench({"demo", "--out", (dir / "a").string(), "--image-size", "96"});
  ASSERT_EQ(first.exit_code, 0) << first.out;
  EXPECT_TRUE(fs::exists(dir / "a" / "dataset" / "manifest.json"));
  // The comparison ran on it and printed its table.
  EXPECT_TRUE(fs::exists(dir / "a" / "compare" / "compare.json"));
  EXPECT_NE(first.out.find("| ROI | truth | flight | flight-refined | colmap-nav | colmap-free |"),
            std::string::npos)
      << first.out;
  // A second run into the same folder replaces it with identical bytes.
  const CommandResult again = RunHdabench({"demo", "--out", (dir / "a").string(), "--image-size", "96"});
  ASSERT_EQ(again.exit_code, 0) << again.out;
  ASSERT_EQ(RunHdabench({"demo", "--out", (dir / "b").string(), "--image-size", "96", "--threads", "1"}).exit_code, 0);
  size_t files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "a" / "dataset")) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), dir / "a");
    EXPECT_EQ(ReadText(entry.path()), ReadText(dir / "b" / relative)) << relative;
    ++files;
  }
  EXPECT_GT(files, 3u);
}

}  // namespace
