// What the command tests share. The small synthetic dataset they run on: 256 x 256 px with a
// 15 deg field of view, so that a 10 m site is about 17 px and the quadtree
// finds a few dozen ROIs of every kind (a few seconds to generate). CTest runs
// each test in its own process: the first one generates it into a staging
// folder renamed into place, the others reuse it. The folder name carries the
// binary's time stamp, so a rebuilt generator makes a new dataset.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/test_support.h"

namespace hdabench::testing_support {

inline const std::filesystem::path& SmallSyntheticDataset() {
  static const std::filesystem::path dir =
      CachedDataset(HDABENCH_TEST_TMP, "run_dataset", [](const std::filesystem::path& out) {
        const CommandResult synth =
            RunHdabench({"synth", "--out", out.string(), "--image-size", "256", "--seed", "3", "--set",
                         "horizontal_fov_deg=15", "--quiet"},
                        out.parent_path());
        EXPECT_EQ(synth.exit_code, 0) << synth.out << synth.err;
      });
  return dir;
}

// Runs `hdabench ARGS` with its output files in the current test's own folder.
inline CommandResult RunInOwnFolder(const std::vector<std::string>& args) {
  const std::filesystem::path scratch = std::filesystem::path(HDABENCH_TEST_TMP) / (CurrentTestName() + ".run");
  std::filesystem::create_directories(scratch);
  return RunHdabench(args, scratch);
}

}  // namespace hdabench::testing_support
