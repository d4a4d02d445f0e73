#include "datasets/map_preview.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/images/codecs.h"
#include "tools/images/png.h"

namespace hdabench::datasets {

namespace {
constexpr char kPngSignature[] = "\x89PNG\r\n\x1a\n";
constexpr size_t kPngSignatureSize = 8;
// Signature, IHDR's length and type, then its width and height (big-endian).
constexpr size_t kPngWidthOffset = 16;
constexpr int kPreviewCompression = 6;

std::uint32_t BigEndian32(const std::string& bytes, size_t at) {
  std::uint32_t value = 0;
  for (size_t i = 0; i < 4; ++i) value = (value << 8) | static_cast<unsigned char>(bytes[at + i]);
  return value;
}
}  // namespace

cv::Size PreviewSize(int width_px, int height_px, int max_side_px) {
  const double scale = max_side_px / static_cast<double>(std::max(width_px, height_px));
  return cv::Size(std::max(1, static_cast<int>(std::lround(width_px * scale))),
                  std::max(1, static_cast<int>(std::lround(height_px * scale))));
}

std::string PreviewPng(const cv::Mat& image, int max_side_px) {
  if (image.empty() || std::max(image.cols, image.rows) <= max_side_px) return {};
  cv::Mat small;
  cv::resize(image, small, PreviewSize(image.cols, image.rows, max_side_px), 0, 0, cv::INTER_AREA);
  return images::EncodePng(small, kPreviewCompression);
}

std::string PreviewPngOfBytes(const std::string& png_bytes, int max_side_px) {
  if (png_bytes.empty()) return {};
  return PreviewPng(images::DecodeAsBgr(png_bytes), max_side_px);
}

bool IsPng(const std::string& bytes) {
  return bytes.size() > kPngSignatureSize &&
         bytes.compare(0, kPngSignatureSize, kPngSignature, kPngSignatureSize) == 0;
}

bool PngSizeOf(const std::string& png_bytes, int* width_px, int* height_px) {
  if (png_bytes.size() < kPngWidthOffset + 8 || !IsPng(png_bytes) || png_bytes.compare(12, 4, "IHDR") != 0) {
    return false;
  }
  *width_px = static_cast<int>(BigEndian32(png_bytes, kPngWidthOffset));
  *height_px = static_cast<int>(BigEndian32(png_bytes, kPngWidthOffset + 4));
  return true;
}

}  // namespace hdabench::datasets
