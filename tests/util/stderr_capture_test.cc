#include "tools/util/stderr_capture.h"

#include <cstdio>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

namespace hdabench {
namespace {

TEST(CaptureStderr, ReturnsWhatCCodeWroteAndRestoresStderr) {
  testing::internal::CaptureStderr();  // what reaches the real fd 2
  const std::string captured = util::CaptureStderr([] { std::fprintf(stderr, "parser(12): bad thing\n"); });
  std::fprintf(stderr, "after\n");
  const std::string reached_terminal = testing::internal::GetCapturedStderr();
  EXPECT_EQ(captured, "parser(12): bad thing\n");
  EXPECT_EQ(reached_terminal, "after\n");
}

TEST(CaptureStderr, RestoresStderrWhenFnThrowsAndTruncatesLongOutput) {
  testing::internal::CaptureStderr();
  EXPECT_THROW(util::CaptureStderr([] {
                 std::fprintf(stderr, "x");
                 throw std::runtime_error("boom");
               }),
               std::runtime_error);
  std::fprintf(stderr, "restored\n");
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "restored\n");
  const std::string long_output = util::CaptureStderr(
      [] {
        for (int i = 0; i < 1000; ++i) std::fprintf(stderr, "0123456789");
      },
      100);
  ASSERT_EQ(long_output.size(), 100u);
  EXPECT_EQ(long_output.substr(0, 20), "01234567890123456789");
}

}  // namespace
}  // namespace hdabench
