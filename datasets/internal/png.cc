#include "datasets/internal/png.h"

#include <cstdint>
#include <stdexcept>

#include <zlib.h>

#include "tools/images/png.h"

namespace hdabench::datasets::internal {

namespace {

// CRC-32 as the PNG specification defines it (ISO 3309, polynomial
// 0xedb88320): zlib's, as the .npz reader's (npz.cc). `length` is at most
// 2^31 + 3 (CheckPngStructure refuses longer chunks), so it fits zlib's uInt.
std::uint32_t Crc32(const std::string& bytes, size_t begin, size_t length) {
  return static_cast<std::uint32_t>(crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(bytes.data() + begin),
                                          static_cast<uInt>(length)));
}

std::string ChunkName(const std::string& bytes, size_t offset) {
  std::string name = bytes.substr(offset, 4);
  for (char& c : name) {
    if (c < 32 || c > 126) c = '?';
  }
  return name;
}

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
    const std::uint32_t length = images::PngUint32(bytes, offset);
    const std::string name = ChunkName(bytes, offset + 4);
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
    const std::uint32_t stored_crc = images::PngUint32(bytes, offset + 8 + length);
    if (Crc32(bytes, offset + 4, length + 4U) != stored_crc) {
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
      const std::uint32_t width = images::PngUint32(bytes, offset + 8);
      const std::uint32_t height = images::PngUint32(bytes, offset + 12);
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
      if (offset != size) {
        *error = "has " + std::to_string(size - offset) +
                 " bytes after the IEND chunk; expected the file to end there";
        return false;
      }
      break;
    }
  }
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
