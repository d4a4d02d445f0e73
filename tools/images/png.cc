#include "tools/images/png.h"

#include <png.h>
#include <zlib.h>

#include <cstring>
#include <stdexcept>

namespace hdabench::images {

namespace {

// OpenCV's limits on a decoded image (CV_IO_MAX_IMAGE_WIDTH, _HEIGHT, _PIXELS).
constexpr png_uint_32 kMaxSidePx = 1U << 20;
constexpr unsigned long long kMaxPixels = 1ULL << 30;
// Deflate expands its input at most 1032 times: a PNG whose rows need more
// bytes than that of its whole file cannot hold them, and is refused before
// its image is allocated (a header of a few bytes cannot ask for gigabytes).
constexpr unsigned long long kMaxDeflateRatio = 1032;

// What libpng reports goes into the text of the call's state, as libpng's own
// handlers would have printed it; an error then returns to the setjmp of the
// call. Neither handler may throw through libpng's C frames.
struct Messages {
  std::string text;
  void Add(const char* prefix, const char* message) noexcept {
    try {
      text += prefix;
      text += message != nullptr ? message : "";
      text += ' ';
    } catch (...) {
      // Out of memory for the message: the failure is still reported.
    }
  }
};

struct WriteState {
  Messages messages;
  std::string* out = nullptr;
};

struct ReadState {
  Messages messages;
  const std::string* bytes = nullptr;
  size_t offset = 0;
};

void OnError(png_structp png, png_const_charp message) {
  static_cast<Messages*>(png_get_error_ptr(png))->Add("libpng error: ", message);
  png_longjmp(png, 1);
}

void OnWarning(png_structp png, png_const_charp message) {
  static_cast<Messages*>(png_get_error_ptr(png))->Add("libpng warning: ", message);
}

void OnWrite(png_structp png, png_bytep data, size_t length) {
  auto* state = static_cast<WriteState*>(png_get_io_ptr(png));
  bool appended = true;
  try {
    state->out->append(reinterpret_cast<const char*>(data), length);
  } catch (...) {
    appended = false;
  }
  if (!appended) png_error(png, "out of memory for the PNG's bytes");
}

void OnFlush(png_structp) {}

void OnRead(png_structp png, png_bytep data, size_t length) {
  auto* state = static_cast<ReadState*>(png_get_io_ptr(png));
  if (length > state->bytes->size() - state->offset) png_error(png, "PNG input buffer is incomplete");
  std::memcpy(data, state->bytes->data() + state->offset, length);
  state->offset += length;
}

// The error state lives in the caller (WriteState); this frame holds nothing
// with a destructor, so the longjmp of an error skips nothing.
bool WriteRows(WriteState* state, const cv::Mat* image, int compression_level) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state->messages, OnError, OnWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, state, OnWrite, OnFlush);
  if (compression_level >= 0) {
    png_set_compression_level(png, compression_level);
    png_set_compression_strategy(png, Z_DEFAULT_STRATEGY);
  } else {
    png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
    png_set_compression_level(png, Z_BEST_SPEED);
    png_set_compression_strategy(png, Z_RLE);
  }
  const int channels = image->channels();
  png_set_IHDR(png, info, static_cast<png_uint_32>(image->cols), static_cast<png_uint_32>(image->rows),
               image->depth() == CV_8U ? 8 : 16,
               channels == 1   ? PNG_COLOR_TYPE_GRAY
               : channels == 3 ? PNG_COLOR_TYPE_RGB
                               : PNG_COLOR_TYPE_RGBA,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_bgr(png);                                 // OpenCV's rows are BGR(A)
  if (image->depth() == CV_16U) png_set_swap(png);  // and little-endian
  for (int y = 0; y < image->rows; ++y) {
    png_write_row(png, const_cast<png_bytep>(image->ptr<unsigned char>(y)));
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return true;
}

// What a decoding accepts and gives.
enum class Decoded {
  kGrey,  // colour type 0, 8 or 16 bits: CV_8UC1 or CV_16UC1 (cv::IMREAD_UNCHANGED)
  kBgr8,  // colour type 2, 8 bits: CV_8UC3 in OpenCV's BGR order (cv::IMREAD_COLOR)
};

// As WriteRows: the state and the image live in the caller. The transforms are
// those OpenCV's PNG decoder (its readData) sets for the result.
bool ReadRows(ReadState* state, Decoded decoded, cv::Mat* image) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state->messages, OnError, OnWarning);
  if (png == nullptr) return false;
  png_infop info = png_create_info_struct(png);
  png_infop end_info = info != nullptr ? png_create_info_struct(png) : nullptr;
  if (end_info == nullptr) {
    png_destroy_read_struct(&png, info != nullptr ? &info : nullptr, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png)) != 0) {
    png_destroy_read_struct(&png, &info, &end_info);
    image->release();
    return false;
  }
  png_set_read_fn(png, state, OnRead);
  png_read_info(png, info);
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int bit_depth = 0;
  int color_type = 0;
  png_get_IHDR(png, info, &width, &height, &bit_depth, &color_type, nullptr, nullptr, nullptr);
  if (decoded == Decoded::kGrey && (color_type != PNG_COLOR_TYPE_GRAY || (bit_depth != 8 && bit_depth != 16))) {
    png_error(png, "not an 8-bit or 16-bit greyscale image");
  }
  if (decoded == Decoded::kBgr8 && (color_type != PNG_COLOR_TYPE_RGB || bit_depth != 8)) {
    png_error(png, "not an 8-bit RGB image");
  }
  if (width > kMaxSidePx || height > kMaxSidePx ||
      static_cast<unsigned long long>(width) * height > kMaxPixels) {
    png_error(png, "image too large (more than 2^20 px a side or 2^30 px in all)");
  }
  const unsigned long long row_bytes =
      1 + static_cast<unsigned long long>(width) * (decoded == Decoded::kBgr8 ? 3 : 1) * (bit_depth / 8);
  if (height * row_bytes > kMaxDeflateRatio * state->bytes->size() + 1024) {
    png_error(png, "Not enough image data for its size");
  }
  if (bit_depth == 16) png_set_swap(png);
  png_set_strip_alpha(png);
  if (decoded == Decoded::kGrey) {
    png_set_rgb_to_gray(png, PNG_ERROR_ACTION_NONE, 0.299, 0.587);
  } else {
    png_set_bgr(png);
  }
  const int passes = png_set_interlace_handling(png);
  png_read_update_info(png, info);
  bool allocated = true;
  try {
    image->create(static_cast<int>(height), static_cast<int>(width),
                  decoded == Decoded::kBgr8 ? CV_8UC3 : bit_depth == 16 ? CV_16UC1 : CV_8UC1);
  } catch (...) {
    allocated = false;
  }
  if (!allocated) png_error(png, "out of memory for the image");
  for (int pass = 0; pass < passes; ++pass) {
    for (int y = 0; y < image->rows; ++y) png_read_row(png, image->ptr<unsigned char>(y), nullptr);
  }
  png_read_end(png, end_info);
  png_destroy_read_struct(&png, &info, &end_info);
  return true;
}

std::string OneLine(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

}  // namespace

std::string EncodePng(const cv::Mat& image, int compression_level) {
  if (image.empty() || (image.depth() != CV_8U && image.depth() != CV_16U) ||
      (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)) {
    throw std::invalid_argument("EncodePng: expected a non-empty 8-bit or 16-bit image of 1, 3 or 4 channels");
  }
  if (compression_level < -1 || compression_level > 9) {
    throw std::invalid_argument("EncodePng: compression level " + std::to_string(compression_level) +
                                ", expected -1 (OpenCV's default) or 0-9");
  }
  std::string bytes;
  WriteState state;
  state.out = &bytes;
  if (!WriteRows(&state, &image, compression_level)) {
    throw std::runtime_error("EncodePng: libpng could not encode the image" +
                             (state.messages.text.empty() ? std::string() : " (" + OneLine(state.messages.text) + ")"));
  }
  return bytes;
}

bool DecodeGreyPng(const std::string& bytes, cv::Mat* image, std::string* error) {
  ReadState state;
  state.bytes = &bytes;
  if (ReadRows(&state, Decoded::kGrey, image)) return true;
  image->release();
  *error = state.messages.text.empty() ? "libpng could not start decoding" : OneLine(state.messages.text);
  return false;
}

bool DecodePlainRgbPng(const std::string& bytes, cv::Mat* image) {
  // The chunks whose presence cannot change what OpenCV decodes; a tRNS (an
  // alpha channel), an eXIf (an orientation) or anything else leaves the
  // bytes to OpenCV.
  static const char* const kPlain[] = {"IHDR", "IDAT", "IEND", "tEXt", "zTXt", "iTXt", "tIME", "pHYs"};
  constexpr size_t kSignatureSize = 8;
  if (bytes.size() < kSignatureSize + 12 + 13 || !HasPngSignature(bytes) || bytes.compare(12, 4, "IHDR") != 0 ||
      bytes[24] != 8 || bytes[25] != PNG_COLOR_TYPE_RGB) {
    return false;
  }
  for (size_t at = kSignatureSize; at < bytes.size();) {
    if (bytes.size() - at < 12) return false;
    const size_t length = PngUint32(bytes, at);
    const std::string name = bytes.substr(at + 4, 4);
    bool plain = false;
    for (const char* known : kPlain) plain = plain || name == known;
    if (!plain || length > bytes.size() - at - 12) return false;
    at += 12 + length;
    if (name == "IEND") break;
  }
  ReadState state;
  state.bytes = &bytes;
  if (ReadRows(&state, Decoded::kBgr8, image)) return true;
  image->release();
  return false;
}

namespace {

// CRC-32 as the PNG specification defines it (ISO 3309, polynomial
// 0xedb88320): zlib's, as datasets' .npz reader's. `length` is at most
// 2^31 + 3 (CheckPngChunks refuses longer chunks), so it fits zlib's uInt.
std::uint32_t PngCrc32(const std::string& bytes, size_t begin, size_t length) {
  return static_cast<std::uint32_t>(crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(bytes.data() + begin),
                                          static_cast<uInt>(length)));
}

std::string PngChunkName(const std::string& bytes, size_t offset) {
  std::string name = bytes.substr(offset, 4);
  for (char& c : name) {
    if (c < 32 || c > 126) c = '?';
  }
  return name;
}

}  // namespace

bool CheckPngChunks(const std::string& bytes, PngHeader* header, std::string* error, bool allow_bytes_after_iend) {
  if (!HasPngSignature(bytes)) {
    *error = "is not a PNG file (no PNG signature)";
    return false;
  }
  const size_t size = bytes.size();
  size_t offset = 8;
  bool seen_ihdr = false;
  bool seen_idat = false;
  while (true) {
    if (offset == size) {
      *error = "is truncated: the file ends after " + std::to_string(size) +
               " bytes without the IEND chunk";
      return false;
    }
    if (size - offset < 12) {
      *error = "is truncated: the file ends inside a chunk header at byte " +
               std::to_string(offset) + " (file size " + std::to_string(size) + " bytes)";
      return false;
    }
    const std::uint32_t length = PngUint32(bytes, offset);
    const std::string name = PngChunkName(bytes, offset + 4);
    if (length > 0x7fffffffU) {
      *error = "is corrupt: chunk '" + name + "' at byte " + std::to_string(offset) +
               " has an invalid length " + std::to_string(length);
      return false;
    }
    if (size - offset - 12 < length) {
      *error = "is truncated: chunk '" + name + "' at byte " + std::to_string(offset) + " needs " +
               std::to_string(length + 12U) + " bytes but the file ends after " +
               std::to_string(size - offset) + " (file size " + std::to_string(size) + " bytes)";
      return false;
    }
    const std::uint32_t stored_crc = PngUint32(bytes, offset + 8 + length);
    if (PngCrc32(bytes, offset + 4, length + 4U) != stored_crc) {
      *error = "is corrupt: CRC mismatch in chunk '" + name + "' at byte " + std::to_string(offset);
      return false;
    }
    if (!seen_ihdr) {
      if (name != "IHDR" || length != 13) {
        *error = "is corrupt: the first chunk is '" + name + "' of " + std::to_string(length) +
                 " bytes; expected 'IHDR' of 13 bytes";
        return false;
      }
      seen_ihdr = true;
      const std::uint32_t width = PngUint32(bytes, offset + 8);
      const std::uint32_t height = PngUint32(bytes, offset + 12);
      if (width == 0 || height == 0 || width > 0x7fffffffU || height > 0x7fffffffU) {
        *error = "is corrupt: IHDR gives an invalid size " + std::to_string(width) + " x " +
                 std::to_string(height) + " px";
        return false;
      }
      header->width_px = static_cast<int>(width);
      header->height_px = static_cast<int>(height);
      header->bit_depth = static_cast<unsigned char>(bytes[offset + 16]);
      header->color_type = static_cast<unsigned char>(bytes[offset + 17]);
    } else if (name == "IHDR") {
      *error = "is corrupt: a second IHDR chunk at byte " + std::to_string(offset);
      return false;
    }
    if (name == "IDAT") seen_idat = true;
    offset += 12U + length;
    if (name == "IEND") {
      if (!seen_idat) {
        *error = "is corrupt: no IDAT (image data) chunk before IEND";
        return false;
      }
      if (offset != size && !allow_bytes_after_iend) {
        *error = "has " + std::to_string(size - offset) +
                 " bytes after the IEND chunk; expected the file to end there";
        return false;
      }
      break;
    }
  }
  return true;
}

bool HasPngSignature(const std::string& bytes) {
  return bytes.size() >= 8 && png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) == 0;
}

std::uint32_t PngUint32(const std::string& bytes, std::size_t offset) {
  return png_get_uint_32(reinterpret_cast<png_const_bytep>(bytes.data() + offset));
}

}  // namespace hdabench::images
