// The bench's PNG codec against OpenCV's: the same bytes written, the same
// pixels read, nothing printed; and OpenCV's codecs loaded only when asked for.
#include "tools/images/png.h"

#include <png.h>
#include <zlib.h>

#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/images/codecs.h"
#include "tools/util/stderr_capture.h"

namespace hdabench::images {
namespace {

// An image with smooth parts, edges and noise, so that every PNG filter and
// zlib's matches are exercised.
cv::Mat TestImage(int rows, int cols, int type, std::uint64_t seed) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  const cv::Rect smooth(0, 0, cols / 2, rows / 2);
  for (int r = 0; r < smooth.height; ++r) {
    for (int c = 0; c < smooth.width * image.channels(); ++c) {
      if (CV_MAT_DEPTH(type) == CV_16U) {
        image.ptr<std::uint16_t>(r)[c] = static_cast<std::uint16_t>(r * 37 + c * 11);
      } else {
        image.ptr<std::uint8_t>(r)[c] = static_cast<std::uint8_t>(r + c / 3);
      }
    }
  }
  return image;
}

std::string OpenCvPng(const cv::Mat& image, int level) {
  std::vector<unsigned char> bytes;
  const std::vector<int> params = level < 0 ? std::vector<int>{} : std::vector<int>{cv::IMWRITE_PNG_COMPRESSION, level};
  EXPECT_TRUE(Encode(".png", image, &bytes, params));
  return std::string(bytes.begin(), bytes.end());
}

bool SamePixels(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && cv::norm(a, b, cv::NORM_INF) == 0;
}

// An interlaced (Adam7) greyscale PNG, written with libpng directly.
std::string InterlacedGreyPng(const cv::Mat& image) {
  std::string bytes;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    return {};
  }
  png_set_write_fn(
      png, &bytes,
      [](png_structp p, png_bytep data, size_t length) {
        static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(data), length);
      },
      [](png_structp) {});
  const int depth = image.depth() == CV_16U ? 16 : 8;
  png_set_IHDR(png, info, static_cast<png_uint_32>(image.cols), static_cast<png_uint_32>(image.rows), depth,
               PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_ADAM7, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (depth == 16) png_set_swap(png);
  std::vector<png_bytep> rows;
  for (int r = 0; r < image.rows; ++r) rows.push_back(const_cast<png_bytep>(image.ptr<png_byte>(r)));
  png_write_image(png, rows.data());
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return bytes;
}

TEST(EncodePng, WritesTheBytesOpenCvWrites) {
  std::uint64_t seed = 1;
  for (const int type : {CV_8UC1, CV_8UC3, CV_8UC4, CV_16UC1, CV_16UC3, CV_16UC4}) {
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(7, 3), cv::Size(301, 203)}) {
      const cv::Mat image = TestImage(size.height, size.width, type, seed++);
      for (const int level : {-1, 0, 1, 3, 6, 9}) {
        EXPECT_EQ(EncodePng(image, level), OpenCvPng(image, level))
            << "type " << type << ", " << size << ", level " << level;
      }
    }
  }
  // A view into a larger image (rows not contiguous).
  const cv::Mat large = TestImage(120, 160, CV_8UC3, 99);
  const cv::Mat view = large(cv::Rect(13, 7, 101, 77));
  EXPECT_EQ(EncodePng(view, 1), OpenCvPng(view, 1));
  EXPECT_EQ(EncodePng(view), OpenCvPng(view.clone(), -1));
}

TEST(EncodePng, RefusesWhatOpenCvWouldConvert) {
  EXPECT_THROW(EncodePng(cv::Mat()), std::invalid_argument);
  EXPECT_THROW(EncodePng(cv::Mat(4, 4, CV_32FC1, cv::Scalar(0))), std::invalid_argument);
  EXPECT_THROW(EncodePng(cv::Mat(4, 4, CV_8UC2, cv::Scalar(0))), std::invalid_argument);
  EXPECT_THROW(EncodePng(cv::Mat(4, 4, CV_8UC1, cv::Scalar(0)), 10), std::invalid_argument);
}

TEST(DecodeGreyPng, ReadsWhatOpenCvReads) {
  std::uint64_t seed = 7;
  for (const int type : {CV_8UC1, CV_16UC1}) {
    for (const cv::Size size : {cv::Size(1, 1), cv::Size(9, 2), cv::Size(257, 131)}) {
      const cv::Mat image = TestImage(size.height, size.width, type, seed++);
      for (const std::string& bytes : {EncodePng(image), EncodePng(image, 9), InterlacedGreyPng(image)}) {
        ASSERT_FALSE(bytes.empty());
        cv::Mat decoded;
        std::string error;
        ASSERT_TRUE(DecodeGreyPng(bytes, &decoded, &error)) << error;
        EXPECT_TRUE(SamePixels(decoded, image)) << "type " << type << ", " << size;
        EXPECT_TRUE(SamePixels(decoded, Decode(bytes, cv::IMREAD_UNCHANGED))) << "type " << type << ", " << size;
      }
    }
  }
}

TEST(DecodeGreyPng, ReportsWhatLibpngSaysAndPrintsNothing) {
  const std::string good = EncodePng(TestImage(40, 30, CV_8UC1, 3));
  cv::Mat decoded;
  std::string error;
  std::string printed = util::CaptureStderr([&] {
    EXPECT_FALSE(DecodeGreyPng(EncodePng(TestImage(4, 4, CV_8UC3, 4)), &decoded, &error));
  });
  EXPECT_EQ(error, "libpng error: not an 8-bit or 16-bit greyscale image");
  EXPECT_TRUE(decoded.empty());
  EXPECT_EQ(printed, "");

  // The data cut short: libpng's own message, as it would have printed it.
  printed = util::CaptureStderr([&] { EXPECT_FALSE(DecodeGreyPng(good.substr(0, good.size() / 2), &decoded, &error)); });
  EXPECT_EQ(error.rfind("libpng error: ", 0), 0u) << error;
  EXPECT_TRUE(decoded.empty());
  EXPECT_EQ(printed, "");

  // A header asking for 30000 x 30000 px over a few hundred bytes of data is
  // refused before the image is allocated.
  std::string huge = good;
  for (const size_t at : {size_t{16}, size_t{20}}) {
    huge[at] = 0;
    huge[at + 1] = 0;
    huge[at + 2] = static_cast<char>(30000 >> 8);
    huge[at + 3] = static_cast<char>(30000 & 0xff);
  }
  const std::uint32_t crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(huge.data() + 12), 17));  // IHDR's type and data
  for (int i = 0; i < 4; ++i) huge[29 + i] = static_cast<char>((crc >> (24 - 8 * i)) & 0xff);
  EXPECT_FALSE(DecodeGreyPng(huge, &decoded, &error));
  EXPECT_EQ(error, "libpng error: Not enough image data for its size");
  EXPECT_TRUE(DecodePlainRgbPng(EncodePng(TestImage(4, 4, CV_8UC3, 5)), &decoded));
  std::string huge_rgb = EncodePng(TestImage(40, 30, CV_8UC3, 6));
  huge_rgb.replace(16, 8, huge.substr(16, 8));
  const std::uint32_t rgb_crc = static_cast<std::uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(huge_rgb.data() + 12), 17));
  for (int i = 0; i < 4; ++i) huge_rgb[29 + i] = static_cast<char>((rgb_crc >> (24 - 8 * i)) & 0xff);
  EXPECT_FALSE(DecodePlainRgbPng(huge_rgb, &decoded));

  EXPECT_FALSE(DecodeGreyPng("", &decoded, &error));
  EXPECT_EQ(error.rfind("libpng error: ", 0), 0u) << error;
  EXPECT_FALSE(DecodeGreyPng("not a PNG at all, but long enough to read a header from", &decoded, &error));
  EXPECT_EQ(error.rfind("libpng error: ", 0), 0u) << error;
}

TEST(DecodeAsBgr, GivesWhatOpenCvGivesForEveryKindOfImage) {
  const cv::Mat bgr = TestImage(97, 143, CV_8UC3, 5);
  cv::Mat plain;
  ASSERT_TRUE(DecodePlainRgbPng(EncodePng(bgr), &plain));
  EXPECT_TRUE(SamePixels(plain, bgr));

  // What the plain path refuses goes to OpenCV, with OpenCV's result.
  std::vector<std::string> others = {EncodePng(TestImage(20, 30, CV_8UC1, 6)),
                                     EncodePng(TestImage(20, 30, CV_8UC4, 7)),
                                     EncodePng(TestImage(20, 30, CV_16UC3, 8)), std::string("not an image")};
  std::vector<unsigned char> jpeg;
  ASSERT_TRUE(Encode(".jpg", bgr, &jpeg));
  others.emplace_back(jpeg.begin(), jpeg.end());
  for (const std::string& bytes : others) {
    cv::Mat image;
    EXPECT_FALSE(DecodePlainRgbPng(bytes, &image));
    EXPECT_TRUE(image.empty());
    const cv::Mat expected = Decode(bytes, cv::IMREAD_COLOR);
    const cv::Mat got = DecodeAsBgr(bytes);
    EXPECT_EQ(got.empty(), expected.empty());
    if (!expected.empty()) {
      EXPECT_TRUE(SamePixels(got, expected));
    }
  }
  // A PNG with an ancillary chunk the plain path does not know (sBIT before
  // IDAT) is left to OpenCV.
  std::string with_sbit = EncodePng(bgr);
  const std::string sbit_chunk("\x00\x00\x00\x03sBIT\x08\x08\x08\x00\x00\x00\x00", 15);  // CRC not checked here
  with_sbit.insert(33, sbit_chunk);
  cv::Mat image;
  EXPECT_FALSE(DecodePlainRgbPng(with_sbit, &image));
}

TEST(Codecs, AreLoadedOnlyWhenAsked) {
  // This test runs in its own process under ctest; when the whole binary runs
  // in one process, an earlier test may have loaded them.
  if (CodecsLoaded()) GTEST_SKIP() << "an earlier test in this process loaded OpenCV's codecs";
  const cv::Mat grey = TestImage(20, 20, CV_16UC1, 11);
  cv::Mat decoded;
  std::string error;
  ASSERT_TRUE(DecodeGreyPng(EncodePng(grey), &decoded, &error));
  ASSERT_TRUE(DecodePlainRgbPng(EncodePng(TestImage(20, 20, CV_8UC3, 12)), &decoded));
  EXPECT_FALSE(CodecsLoaded());
  EXPECT_FALSE(Decode(EncodePng(grey), cv::IMREAD_UNCHANGED).empty());
  EXPECT_TRUE(CodecsLoaded());
}

}  // namespace
}  // namespace hdabench::images
