// PNG checks for the frames of a dataset. A damaged PNG must be reported, not
// half-decoded, and decoding must print nothing: the chunk structure is checked
// first, and libpng's complaints come back as text (tools/images/png.h).
#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

#include "tools/images/png.h"

namespace hdabench::datasets::internal {

using PngHeader = images::PngHeader;

// Checks the PNG container: signature, then images::CheckPngChunks. Then requires a
// single-channel (greyscale, colour type 0) image of 8 or 16 bits. Returns false
// with `error` saying what is wrong (without the file name).
bool CheckPngStructure(const std::string& bytes, PngHeader* header, std::string* error);

// Decodes a PNG that passed CheckPngStructure into CV_8UC1 or CV_16UC1 without
// letting libpng print anything; what it would have printed goes into `error`
// on failure ("cannot be decoded as a PNG (libpng error: ...)").
bool DecodePngQuietly(const std::string& bytes, cv::Mat* image, std::string* error);

// Encodes a CV_8UC1 or CV_16UC1 image as PNG bytes (OpenCV's default
// encoding). Throws std::invalid_argument for another type.
std::string EncodePng(const cv::Mat& image);

}  // namespace hdabench::datasets::internal
