// OpenCV's image codecs (cv::imread, cv::imwrite, cv::imdecode, cv::imencode),
// loaded the first time one is called. Debian's libopencv_imgcodecs brings
// some 140 shared libraries (GDAL, GDCM, libraw, ...) that cost about 75 ms at
// the start of every process linking it, so the bench links none of it: a
// command that reads only the bench's own PNGs (png.h) never loads it. The
// functions behave as OpenCV's, flags and parameters included (the cv::IMREAD_*
// and cv::IMWRITE_* constants of <opencv2/imgcodecs.hpp>), and throw what
// OpenCV throws; when the library cannot be loaded, ExternalError naming it.
// Thread-safe.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

namespace hdabench::images {

// cv::imread: the image at `path`, or an empty Mat when OpenCV cannot read it.
cv::Mat Read(const std::string& path, int flags);

// Read of an image from outside the bench (a camera's JPEG or PNG):
// cv::imread's result, decoded from the file's bytes once they are checked to be whole, since OpenCV decodes a
// truncated JPEG or PNG into a partly grey image with only a warning on
// stderr. An empty Mat, with `error` saying why without the path, when the
// file is missing, a folder or a pipe ("file not found", ...), a PNG whose chunks are
// damaged (CheckPngChunks), a JPEG whose data ends before its end-of-image
// marker (CheckJpegComplete), or anything OpenCV cannot decode. Other formats
// are not checked beyond OpenCV's decoding.
cv::Mat ReadWholeImage(const std::string& path, int flags, std::string* error);

// Whether JPEG bytes run from the start-of-image marker to the end-of-image
// marker: each marker segment whole, and the entropy-coded data after each
// start-of-scan followed by a marker. Bytes after the end-of-image marker
// are allowed (cameras append some). False with `error` ("is truncated: ...",
// "is not a JPEG file ...") otherwise.
bool CheckJpegComplete(const std::string& bytes, std::string* error);

// cv::imwrite: false when OpenCV cannot write the file.
bool Write(const std::string& path, const cv::Mat& image, const std::vector<int>& params = {});

// cv::imdecode of `bytes`: an empty Mat when OpenCV cannot decode them.
cv::Mat Decode(const std::string& bytes, int flags);

// Decode(bytes, cv::IMREAD_COLOR), without loading OpenCV's codecs when the
// bytes are a plain 8-bit RGB PNG, as the bench's maps and figures are
// (png.h: DecodePlainRgbPng).
cv::Mat DecodeAsBgr(const std::string& bytes);

// cv::imencode with the format of `extension` (".png", ".jpg", ...).
bool Encode(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>* bytes,
            const std::vector<int>& params = {});

// Whether this process has loaded OpenCV's codecs, by any means.
bool CodecsLoaded();

}  // namespace hdabench::images
