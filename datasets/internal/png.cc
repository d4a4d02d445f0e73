#include "datasets/internal/png.h"

#include <stdexcept>

#include "tools/images/png.h"

namespace hdabench::datasets::internal {

namespace {

std::string ColorTypeName(int color_type) {
  switch (color_type) {
    case 2:
      return "a 3-channel RGB PNG";
    case 3:
      return "a palette (colour-mapped) PNG";
    case 4:
      return "a 2-channel grey + alpha PNG";
    case 6:
      return "a 4-channel RGBA PNG";
    default:
      return "a PNG of invalid colour type " + std::to_string(color_type);
  }
}

}  // namespace

bool CheckPngStructure(const std::string& bytes, PngHeader* header, std::string* error) {
  const size_t size = bytes.size();
  if (size == 0) {
    *error = "is empty (0 bytes); expected a PNG image";
    return false;
  }
  if (!images::HasPngSignature(bytes)) {
    *error = "is not a PNG file (no PNG signature); expected an 8-bit or 16-bit greyscale PNG";
    return false;
  }
  if (!images::CheckPngChunks(bytes, header, error)) return false;
  if (header->color_type != 0) {
    *error = "is " + ColorTypeName(header->color_type) +
             "; expected a single-channel greyscale PNG (colour type 0)";
    return false;
  }
  if (header->bit_depth != 8 && header->bit_depth != 16) {
    *error = "is a " + std::to_string(header->bit_depth) +
             "-bit greyscale PNG; expected 8 or 16 bits per pixel";
    return false;
  }
  return true;
}

bool DecodePngQuietly(const std::string& bytes, cv::Mat* image, std::string* error) {
  std::string detail;
  if (images::DecodeGreyPng(bytes, image, &detail)) return true;
  *error = "cannot be decoded as a PNG (" + detail + ")";
  return false;
}

std::string EncodePng(const cv::Mat& image) {
  if (image.empty() || image.channels() != 1 ||
      (image.depth() != CV_8U && image.depth() != CV_16U)) {
    throw std::invalid_argument("EncodePng: expected a non-empty CV_8UC1 or CV_16UC1 image");
  }
  return images::EncodePng(image);
}

}  // namespace hdabench::datasets::internal
