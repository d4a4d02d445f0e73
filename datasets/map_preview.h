// Previews of a synthetic dataset's maps (docs/dataset-format.md, maps/):
// each map shrunk so that its longer side is kMapPreviewSidePx, from which the
// report makes the smaller image it shows. `hdabench synth` writes them beside the maps
// (maps/preview/<map>.png), so that a report need not decode maps of tens of
// megapixels each time; a report makes the same bytes itself when a preview
// is missing.
#pragma once

#include <string>

#include <opencv2/core/mat.hpp>

namespace hdabench::datasets {

// Longer side of a map preview, pixels.
constexpr int kMapPreviewSidePx = 1024;
// A map's preview beside it: maps/preview/<the map's file name>.
constexpr const char* kMapPreviewFolder = "preview";

// The preview of an 8-bit image: area-averaged so that its longer side is
// max_side_px (each side rounded, at least 1 px), as PNG (compression 6).
// Empty when the image is no larger than that or cannot be encoded.
std::string PreviewPng(const cv::Mat& image, int max_side_px);

// The same from PNG bytes, decoded as 3-channel colour. Empty also when the
// bytes do not decode.
std::string PreviewPngOfBytes(const std::string& png_bytes, int max_side_px);

// True when the bytes start with the PNG signature and hold more after it.
bool IsPng(const std::string& bytes);

// Width and height from a PNG's header (its IHDR chunk); false when the bytes
// do not start like a PNG.
bool PngSizeOf(const std::string& png_bytes, int* width_px, int* height_px);

// The size of the preview of a width x height image (as PreviewPng makes it).
cv::Size PreviewSize(int width_px, int height_px, int max_side_px);

}  // namespace hdabench::datasets
