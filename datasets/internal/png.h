// PNG checks for the frames of a dataset. A damaged PNG must be reported, not
// half-decoded, and decoding must print nothing: libpng and OpenCV write their
// complaints to stderr, so the chunk structure is checked first and decoding
// runs with that output captured.
#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace hdabench::datasets::internal {

struct PngHeader {
  int width_px = 0;
  int height_px = 0;
  int bit_depth = 0;   // bits per sample
  int color_type = 0;  // 0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA
};

// Checks the PNG container: signature, every chunk's length and CRC, IHDR
// first, at least one IDAT, IEND last with nothing after it. Then requires a
// single-channel (greyscale, colour type 0) image of 8 or 16 bits. Returns false
// with `error` saying what is wrong (without the file name).
bool CheckPngStructure(const std::string& bytes, PngHeader* header, std::string* error);

// Decodes a PNG that passed CheckPngStructure into CV_8UC1 or CV_16UC1 without
// letting libpng or OpenCV print anything; what they would have printed goes
// into `error` on failure. Not thread-safe: it redirects file descriptor 2
// while decoding.
bool DecodePngQuietly(const std::string& bytes, cv::Mat* image, std::string* error);

// Encodes a CV_8UC1 or CV_16UC1 image as PNG bytes. Throws std::invalid_argument
// for another type.
std::string EncodePng(const cv::Mat& image);

}  // namespace hdabench::datasets::internal
