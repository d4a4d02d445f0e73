#include "datasets/map_preview.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/images/codecs.h"
#include "tools/images/png.h"

namespace hdabench::datasets {

namespace {
// Signature, IHDR's length and type, then its width and height (big-endian).
constexpr size_t kPngWidthOffset = 16;
constexpr int kPreviewCompression = 6;
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
  return bytes.size() > 8 && images::HasPngSignature(bytes);
}

bool PngSizeOf(const std::string& png_bytes, int* width_px, int* height_px) {
  if (png_bytes.size() < kPngWidthOffset + 8 || !IsPng(png_bytes) || png_bytes.compare(12, 4, "IHDR") != 0) {
    return false;
  }
  *width_px = static_cast<int>(images::PngUint32(png_bytes, kPngWidthOffset));
  *height_px = static_cast<int>(images::PngUint32(png_bytes, kPngWidthOffset + 4));
  return true;
}

}  // namespace hdabench::datasets
