#include "tools/images/codecs.h"

#include <filesystem>
#include <system_error>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/images/png.h"
#include "tools/util/files.h"
#include "tools/util/shared_library.h"

namespace hdabench::images {

namespace fs = std::filesystem;

namespace {

// The library, by its soname (from OpenCV's CMake package), and the C++
// symbols of the four functions, whose names CMakeLists.txt gives and checks the
// library defines.
constexpr const char* kLibrary = HDABENCH_IMGCODECS_SONAME;
constexpr const char* kImread = HDABENCH_IMREAD_SYMBOL;
constexpr const char* kImwrite = HDABENCH_IMWRITE_SYMBOL;
constexpr const char* kImdecode = HDABENCH_IMDECODE_SYMBOL;
constexpr const char* kImencode = HDABENCH_IMENCODE_SYMBOL;

using ImreadFn = cv::Mat (*)(const std::string&, int);
using ImwriteFn = bool (*)(const std::string&, const cv::_InputArray&, const std::vector<int>&);
using ImdecodeFn = cv::Mat (*)(const cv::_InputArray&, int);
using ImencodeFn = bool (*)(const std::string&, const cv::_InputArray&, std::vector<unsigned char>&,
                            const std::vector<int>&);

// The names are those of functions of these types: the casts compile only if
// <opencv2/imgcodecs.hpp> declares a function of exactly that type (an
// unevaluated operand, so nothing here links the library).
static_assert(sizeof(static_cast<ImreadFn>(&cv::imread)) > 0, "cv::imread's declaration changed");
static_assert(sizeof(static_cast<ImwriteFn>(&cv::imwrite)) > 0, "cv::imwrite's declaration changed");
static_assert(sizeof(static_cast<ImdecodeFn>(&cv::imdecode)) > 0, "cv::imdecode's declaration changed");
static_assert(sizeof(static_cast<ImencodeFn>(&cv::imencode)) > 0, "cv::imencode's declaration changed");

struct Codecs {
  ImreadFn imread = nullptr;
  ImwriteFn imwrite = nullptr;
  ImdecodeFn imdecode = nullptr;
  ImencodeFn imencode = nullptr;
};

Codecs Load() {
  void* library = util::LoadSharedLibrary(kLibrary, "OpenCV's image codecs");
  Codecs codecs;
  codecs.imread = util::SharedLibraryFunction<ImreadFn>(library, kLibrary, kImread, "cv::imread");
  codecs.imwrite = util::SharedLibraryFunction<ImwriteFn>(library, kLibrary, kImwrite, "cv::imwrite");
  codecs.imdecode = util::SharedLibraryFunction<ImdecodeFn>(library, kLibrary, kImdecode, "cv::imdecode");
  codecs.imencode = util::SharedLibraryFunction<ImencodeFn>(library, kLibrary, kImencode, "cv::imencode");
  return codecs;
}

const Codecs& TheCodecs() {
  static const Codecs codecs = Load();  // a failure throws, and the next call tries again
  return codecs;
}

}  // namespace

bool CodecsLoaded() { return util::SharedLibraryLoaded(kLibrary); }

cv::Mat Read(const std::string& path, int flags) { return TheCodecs().imread(path, flags); }

bool CheckJpegComplete(const std::string& bytes, std::string* error) {
  const auto byte = [&](size_t at) { return static_cast<unsigned char>(bytes[at]); };
  const size_t size = bytes.size();
  if (size < 2 || byte(0) != 0xFF || byte(1) != 0xD8) {
    *error = "is not a JPEG file (no start-of-image marker)";
    return false;
  }
  const auto truncated = [&](const std::string& what) {
    *error = "is truncated: " + what + " (file size " + std::to_string(size) + " bytes)";
    return false;
  };
  size_t at = 2;
  while (true) {
    // A marker: 0xFF, any fill 0xFF bytes, then its code. Stray bytes before
    // it are skipped, as libjpeg does (with a warning).
    while (at < size && byte(at) != 0xFF) ++at;
    while (at < size && byte(at) == 0xFF) ++at;
    if (at >= size) return truncated("the file ends without the end-of-image marker");
    const unsigned char code = byte(at);
    const size_t marker_at = at - 1;
    ++at;
    if (code == 0xD9) return true;  // end of image
    if ((code >= 0xD0 && code <= 0xD7) || code == 0x01 || code == 0x00) continue;  // no segment
    if (size - at < 2) return truncated("the file ends inside the segment at byte " + std::to_string(marker_at));
    const size_t length = (static_cast<size_t>(byte(at)) << 8) | byte(at + 1);
    if (length < 2) {
      *error = "is corrupt: the segment at byte " + std::to_string(marker_at) + " gives a length of " +
               std::to_string(length) + " bytes (at least 2)";
      return false;
    }
    if (size - at < length) {
      return truncated("the segment at byte " + std::to_string(marker_at) + " needs " + std::to_string(length + 2) +
                       " bytes but the file ends after " + std::to_string(size - marker_at));
    }
    at += length;
    if (code != 0xDA) continue;
    // After a start of scan, entropy-coded data up to the next marker: 0xFF
    // followed by neither 0x00 (a stuffed 0xFF) nor a restart marker.
    while (true) {
      while (at < size && byte(at) != 0xFF) ++at;
      if (at + 1 >= size) {
        return truncated("the image data of the scan at byte " + std::to_string(marker_at) +
                         " ends without the end-of-image marker");
      }
      const unsigned char next = byte(at + 1);
      if (next == 0x00 || (next >= 0xD0 && next <= 0xD7) || next == 0xFF) {
        at += next == 0xFF ? 1 : 2;
        continue;
      }
      break;
    }
  }
}

cv::Mat ReadWholeImage(const std::string& path, int flags, std::string* error) {
  // An image comes from a file: a pipe is refused rather than waited on.
  std::error_code ec;
  if (fs::is_fifo(path, ec)) {
    *error = "is a pipe; expected an image file";
    return cv::Mat();
  }
  std::string bytes;
  if (!util::ReadFileBytes(path, &bytes, error)) return cv::Mat();
  if (HasPngSignature(bytes)) {
    PngHeader header;
    if (!CheckPngChunks(bytes, &header, error, /*allow_bytes_after_iend=*/true)) return cv::Mat();
  } else if (bytes.size() >= 2 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
             static_cast<unsigned char>(bytes[1]) == 0xD8) {
    if (!CheckJpegComplete(bytes, error)) return cv::Mat();
  }
  // The bytes checked are the bytes decoded (cv::imdecode applies the EXIF
  // orientation as cv::imread does): the file is read once.
  cv::Mat image = Decode(bytes, flags);
  if (image.empty()) *error = bytes.empty() ? "is empty (0 bytes)" : "is not an image OpenCV can read";
  return image;
}

bool Write(const std::string& path, const cv::Mat& image, const std::vector<int>& params) {
  return TheCodecs().imwrite(path, image, params);
}

cv::Mat Decode(const std::string& bytes, int flags) {
  if (bytes.empty()) return cv::Mat();
  const cv::Mat buffer(1, static_cast<int>(bytes.size()), CV_8UC1, const_cast<char*>(bytes.data()));
  return TheCodecs().imdecode(buffer, flags);
}

cv::Mat DecodeAsBgr(const std::string& bytes) {
  cv::Mat image;
  if (DecodePlainRgbPng(bytes, &image)) return image;
  return Decode(bytes, cv::IMREAD_COLOR);
}

bool Encode(const std::string& extension, const cv::Mat& image, std::vector<unsigned char>* bytes,
            const std::vector<int>& params) {
  return TheCodecs().imencode(extension, image, *bytes, params);
}

}  // namespace hdabench::images
