// Reading files whole or by their start.
#include "tools/util/files.h"

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hdabench::util {
namespace {

namespace fs = std::filesystem;

TEST(ReadFilePrefix, ReadsTheStartAndTheSizeAndReadFileBytesTheWhole) {
  const TempFolder folder("files-test");
  const fs::path file = folder.path() / "data.bin";
  std::string text;
  for (int i = 0; i < 100000; ++i) text += static_cast<char>(i * 7 + i / 256);
  std::ofstream(file, std::ios::binary) << text;

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
}

}  // namespace
}  // namespace hdabench::util
