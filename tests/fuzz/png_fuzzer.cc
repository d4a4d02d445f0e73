// PNG frames from arbitrary bytes: the container check, then decoding of what
// passes it (datasets/internal/png.h): false with a reason or an 8- or 16-bit
// single-channel image, never a crash. And the decoding of the maps and
// figures a report embeds (tools/images/png.h, DecodePlainRgbPng): false or a
// 3-channel 8-bit image. And the check that an outside JPEG is whole
// (tools/images/codecs.h, CheckJpegComplete): true, or false with a reason.
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

#include "datasets/internal/png.h"
#include "tests/fuzz/fuzz_support.h"
#include "tools/images/codecs.h"
#include "tools/images/png.h"

// With HDABENCH_FUZZ_SEEDS naming a folder: seeds there, an 8-bit and a 16-bit
// greyscale PNG and an 8-bit RGB one (tools/fuzz.sh adds two of the
// repository's JPEGs).
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* seeds = std::getenv("HDABENCH_FUZZ_SEEDS");
  if (seeds == nullptr || *seeds == '\0') return 0;
  cv::Mat gradient8(9, 13, CV_8UC1), gradient16(7, 5, CV_16UC1);
  for (int r = 0; r < gradient8.rows; ++r) {
    for (int c = 0; c < gradient8.cols; ++c) gradient8.at<unsigned char>(r, c) = static_cast<unsigned char>(17 * r + c);
  }
  for (int r = 0; r < gradient16.rows; ++r) {
    for (int c = 0; c < gradient16.cols; ++c) gradient16.at<unsigned short>(r, c) = static_cast<unsigned short>(4099 * r + c);
  }
  hdabench::util::WriteFileAtomically(std::filesystem::path(seeds) / "grey8.png",
                                      hdabench::datasets::internal::EncodePng(gradient8));
  hdabench::util::WriteFileAtomically(std::filesystem::path(seeds) / "grey16.png",
                                      hdabench::datasets::internal::EncodePng(gradient16));
  cv::Mat colour(6, 11, CV_8UC3);
  for (int r = 0; r < colour.rows; ++r) {
    for (int c = 0; c < colour.cols; ++c) colour.at<cv::Vec3b>(r, c) = cv::Vec3b(static_cast<unsigned char>(40 * r), static_cast<unsigned char>(20 * c), 99);
  }
  hdabench::util::WriteFileAtomically(std::filesystem::path(seeds) / "rgb8.png", hdabench::images::EncodePng(colour));
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace hdabench::datasets;
  const std::string bytes = hdabench::fuzz::Bytes(data, size);
  cv::Mat colour;
  if (hdabench::images::DecodePlainRgbPng(bytes, &colour) && colour.type() != CV_8UC3) __builtin_trap();
  std::string error;
  if (!hdabench::images::CheckJpegComplete(bytes, &error) && error.empty()) __builtin_trap();
  error.clear();
  internal::PngHeader header;
  if (!internal::CheckPngStructure(bytes, &header, &error)) return 0;
  cv::Mat image;
  if (internal::DecodePngQuietly(bytes, &image, &error)) {
    if (image.type() != CV_8UC1 && image.type() != CV_16UC1) __builtin_trap();
  }
  return 0;
}
