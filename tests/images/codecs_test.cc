// Images from outside the bench: a file cut short is refused, never decoded
// into a partly grey image, and nothing is printed.
#include "tools/images/codecs.h"

#include <sys/stat.h>

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/test_support.h"
#include "tools/images/png.h"
#include "tools/util/stderr_capture.h"

namespace hdabench::images {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::WriteText;

const fs::path kBoard = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard/left01.jpg";

// A small textured image as JPEG bytes, baseline or progressive.
std::string SmallJpeg(bool progressive) {
  cv::Mat image(48, 64, CV_8UC1);
  cv::RNG rng(7);
  rng.fill(image, cv::RNG::UNIFORM, 0, 256);
  std::vector<unsigned char> bytes;
  EXPECT_TRUE(Encode(".jpg", image, &bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, progressive ? 1 : 0}));
  return std::string(bytes.begin(), bytes.end());
}

TEST(CheckJpegComplete, AcceptsWholeFilesAndRefusesEveryShorterOne) {
  for (const std::string& jpeg : {SmallJpeg(false), SmallJpeg(true), ReadText(kBoard)}) {
    std::string error;
    ASSERT_TRUE(CheckJpegComplete(jpeg, &error)) << error;
    // What cameras append after the end-of-image marker is allowed.
    EXPECT_TRUE(CheckJpegComplete(jpeg + std::string(100, '\x5a'), &error)) << error;
    // Every cut, down to the start-of-image marker, is found.
    const size_t step = jpeg.size() > 5000 ? 97 : 1;
    for (size_t n = 2; n < jpeg.size(); n += step) {
      error.clear();
      EXPECT_FALSE(CheckJpegComplete(jpeg.substr(0, n), &error)) << n << " of " << jpeg.size() << " bytes";
      EXPECT_EQ(error.rfind("is truncated: ", 0), 0u) << error;
    }
    EXPECT_FALSE(CheckJpegComplete(jpeg.substr(0, jpeg.size() - 1), &error));
  }
  std::string error;
  EXPECT_FALSE(CheckJpegComplete("GIF89a", &error));
  EXPECT_EQ(error, "is not a JPEG file (no start-of-image marker)");
  // A segment whose length cannot hold itself is damage, not a short file.
  EXPECT_FALSE(CheckJpegComplete(std::string("\xff\xd8\xff\xe0\x00\x01rest\xff\xd9", 12), &error));
  EXPECT_EQ(error, "is corrupt: the segment at byte 2 gives a length of 1 bytes (at least 2)");
}

TEST(ReadWholeImage, ReadsWhatOpenCvReadsAndRefusesACutFileSilently) {
  const fs::path dir = FreshTestDir();
  std::string error;
  const cv::Mat whole = ReadWholeImage(kBoard.string(), cv::IMREAD_GRAYSCALE, &error);
  ASSERT_FALSE(whole.empty()) << error;
  EXPECT_EQ(cv::norm(whole, Read(kBoard.string(), cv::IMREAD_GRAYSCALE), cv::NORM_INF), 0.0);

  // The EXIF orientation is applied as cv::imread applies it (the bytes are
  // decoded from memory): an APP1 segment saying "rotate 90 degrees" (6).
  const std::string exif("\xff\xe1\x00\x22"
                         "Exif\x00\x00"
                         "MM\x00\x2a\x00\x00\x00\x08"
                         "\x00\x01"
                         "\x01\x12\x00\x03\x00\x00\x00\x01\x00\x06\x00\x00"
                         "\x00\x00\x00\x00",
                         36);
  const std::string small = SmallJpeg(false);
  WriteText(dir / "turned.jpg", small.substr(0, 2) + exif + small.substr(2));
  for (const int flags : {cv::IMREAD_GRAYSCALE, cv::IMREAD_COLOR, cv::IMREAD_UNCHANGED}) {
    const cv::Mat read = Read((dir / "turned.jpg").string(), flags);
    const cv::Mat checked = ReadWholeImage((dir / "turned.jpg").string(), flags, &error);
    ASSERT_EQ(checked.size(), read.size()) << flags << ": " << error;
    EXPECT_EQ(cv::norm(checked, read, cv::NORM_INF), 0.0) << flags;
  }
  EXPECT_EQ(Read((dir / "turned.jpg").string(), cv::IMREAD_GRAYSCALE).size(), cv::Size(48, 64));  // turned

  // OpenCV would decode these into partly grey images, with a warning on stderr.
  const std::string jpeg = ReadText(kBoard);
  WriteText(dir / "cut.jpg", jpeg.substr(0, jpeg.size() / 2));
  const std::string png = EncodePng(whole);
  WriteText(dir / "cut.png", png.substr(0, png.size() - 100));
  for (const char* name : {"cut.jpg", "cut.png"}) {
    cv::Mat image;
    const std::string printed = util::CaptureStderr(
        [&] { image = ReadWholeImage((dir / name).string(), cv::IMREAD_GRAYSCALE, &error); });
    EXPECT_TRUE(image.empty()) << name;
    EXPECT_EQ(error.rfind("is truncated: ", 0), 0u) << name << ": " << error;
    EXPECT_EQ(printed, "") << name;
  }
  // Bytes after a PNG's IEND are allowed, as libpng stops there.
  WriteText(dir / "tail.png", png + "appended");
  EXPECT_EQ(cv::norm(ReadWholeImage((dir / "tail.png").string(), cv::IMREAD_GRAYSCALE, &error), whole, cv::NORM_INF),
            0.0)
      << error;
  // A pipe would be empty when OpenCV opens it again.
  ASSERT_EQ(::mkfifo((dir / "pipe.png").c_str(), 0600), 0);
  EXPECT_TRUE(ReadWholeImage((dir / "pipe.png").string(), cv::IMREAD_GRAYSCALE, &error).empty());
  EXPECT_EQ(error, "is a pipe; expected an image file");
  EXPECT_TRUE(ReadWholeImage((dir / "none.png").string(), cv::IMREAD_GRAYSCALE, &error).empty());
  EXPECT_EQ(error, "file not found");
  EXPECT_TRUE(ReadWholeImage(dir.string(), cv::IMREAD_GRAYSCALE, &error).empty());
  EXPECT_EQ(error, "is a directory; expected a file");
  WriteText(dir / "text.jpg", "not an image");
  EXPECT_TRUE(ReadWholeImage((dir / "text.jpg").string(), cv::IMREAD_GRAYSCALE, &error).empty());
  EXPECT_EQ(error, "is not an image OpenCV can read");
}

}  // namespace
}  // namespace hdabench::images
