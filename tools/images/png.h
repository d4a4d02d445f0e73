// PNG through libpng, without OpenCV's image codecs (codecs.h says why). The
// encoder writes the bytes cv::imencode(".png", ...) writes (OpenCV 4, the same
// libpng and zlib), so files made before and after are identical; the decoder
// reads the single-channel PNGs of the bench's datasets as
// cv::imdecode(..., cv::IMREAD_UNCHANGED) does. Neither prints anything:
// libpng's messages come back as text. Thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include <opencv2/core/mat.hpp>

namespace hdabench::images {

// The PNG of a CV_8U or CV_16U image of 1, 3 (BGR) or 4 (BGRA) channels, as
// cv::imencode(".png", image, bytes, params) writes it: with
// `compression_level` 0-9 as {cv::IMWRITE_PNG_COMPRESSION, level}, and with -1
// as no parameters (OpenCV's default: zlib level 1, the Sub filter, the RLE
// strategy). Throws std::invalid_argument for another image type or level,
// std::runtime_error when libpng fails.
std::string EncodePng(const cv::Mat& image, int compression_level = -1);

// Decodes a greyscale PNG (colour type 0) of 8 or 16 bits into CV_8UC1 or
// CV_16UC1. On failure returns false, `image` empty, and `error` holds
// libpng's messages as libpng would have printed them ("libpng error: ...",
// warnings first, on one line), or what else is wrong.
bool DecodeGreyPng(const std::string& bytes, cv::Mat* image, std::string* error);

// cv::imdecode(bytes, cv::IMREAD_COLOR) of an 8-bit RGB PNG whose chunks are
// only IHDR, IDAT, IEND, text, time and pHYs (the bench's maps and figures):
// CV_8UC3 in BGR order. Returns false, `image` empty, for any other PNG or
// bytes libpng cannot decode; codecs.h's DecodeAsBgr then asks OpenCV.
bool DecodePlainRgbPng(const std::string& bytes, cv::Mat* image);

// What IHDR says of a PNG.
struct PngHeader {
  int width_px = 0;
  int height_px = 0;
  int bit_depth = 0;   // bits per sample
  int color_type = 0;  // 0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA
};

// Checks the container of a PNG: its signature, every
// chunk's length and CRC, IHDR first (once, with a valid size), at least one
// IDAT, IEND last with nothing after it (unless `allow_bytes_after_iend`:
// libpng stops reading at IEND). Fills `header` from IHDR. Returns false with
// `error` saying what is wrong, without the file name ("is truncated: chunk
// 'IDAT' at byte 33 needs ...").
bool CheckPngChunks(const std::string& bytes, PngHeader* header, std::string* error,
                    bool allow_bytes_after_iend = false);

// True when `bytes` begin with the 8 bytes of the PNG signature.
bool HasPngSignature(const std::string& bytes);

// The 4-byte big-endian number of a PNG at `offset` (a chunk's length or CRC,
// IHDR's width or height), as libpng reads it; the caller checks that the 4
// bytes are there.
std::uint32_t PngUint32(const std::string& bytes, std::size_t offset);

}  // namespace hdabench::images
