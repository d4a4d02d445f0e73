#include "tools/images/codecs.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/images/png.h"
#include "tools/util/shared_library.h"

namespace hdabench::images {

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
