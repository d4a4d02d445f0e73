#include "datasets/npy.h"

#include <algorithm>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>

namespace hdabench::datasets {

namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr size_t kMagicSize = 6;

bool IsLittleEndianHost() {
  const std::uint16_t probe = 1;
  unsigned char first = 0;
  std::memcpy(&first, &probe, 1);
  return first == 1;
}

// A strict reader for the header numpy writes: a Python dict literal with the
// keys 'descr', 'fortran_order' and 'shape', e.g.
// {'descr': '<f4', 'fortran_order': False, 'shape': (256, 256, 3), }
class HeaderParser {
 public:
  explicit HeaderParser(std::string_view text) : text_(text) {}

  bool Parse(std::string* descr, bool* fortran_order, std::vector<std::int64_t>* shape,
             std::string* error) {
    bool have_descr = false;
    bool have_order = false;
    bool have_shape = false;
    SkipBlank();
    if (!Consume('{')) return Fail("the header is not a Python dict", error);
    while (true) {
      SkipBlank();
      if (Consume('}')) break;
      std::string key;
      if (!ReadQuoted(&key)) return Fail("expected a quoted key in the header", error);
      SkipBlank();
      if (!Consume(':')) return Fail("expected ':' after '" + key + "' in the header", error);
      SkipBlank();
      if (key == "descr") {
        if (!ReadQuoted(descr)) return Fail("'descr' is not a string", error);
        have_descr = true;
      } else if (key == "fortran_order") {
        if (text_.substr(pos_, 4) == "True") {
          *fortran_order = true;
          pos_ += 4;
        } else if (text_.substr(pos_, 5) == "False") {
          *fortran_order = false;
          pos_ += 5;
        } else {
          return Fail("'fortran_order' is not True or False", error);
        }
        have_order = true;
      } else if (key == "shape") {
        if (!ReadShape(shape)) return Fail("'shape' is not a tuple of whole numbers", error);
        have_shape = true;
      } else {
        return Fail("unexpected key '" + key + "' in the header", error);
      }
      SkipBlank();
      if (Consume(',')) continue;
      SkipBlank();
      if (Consume('}')) break;
      return Fail("expected ',' or '}' in the header", error);
    }
    if (!have_descr || !have_order || !have_shape) {
      return Fail("the header lacks 'descr', 'fortran_order' or 'shape'", error);
    }
    return true;
  }

 private:
  static bool Fail(const std::string& message, std::string* error) {
    *error = "has a malformed .npy header: " + message;
    return false;
  }
  void SkipBlank() {
    while (pos_ < text_.size() && (text_[pos_] == ' ' || text_[pos_] == '\n')) ++pos_;
  }
  bool Consume(char c) {
    if (pos_ < text_.size() && text_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  bool ReadQuoted(std::string* value) {
    if (pos_ >= text_.size() || (text_[pos_] != '\'' && text_[pos_] != '"')) return false;
    const char quote = text_[pos_++];
    const size_t end = text_.find(quote, pos_);
    if (end == std::string_view::npos) return false;
    *value = std::string(text_.substr(pos_, end - pos_));
    pos_ = end + 1;
    return true;
  }
  bool ReadShape(std::vector<std::int64_t>* shape) {
    shape->clear();
    if (!Consume('(')) return false;
    while (true) {
      SkipBlank();
      if (Consume(')')) return true;
      std::int64_t value = 0;
      size_t digits = 0;
      while (pos_ < text_.size() && text_[pos_] >= '0' && text_[pos_] <= '9') {
        if (value > (std::numeric_limits<std::int64_t>::max() - 9) / 10) return false;
        value = value * 10 + (text_[pos_] - '0');
        ++pos_;
        ++digits;
      }
      // numpy may write "3L" (Python 2).
      if (digits == 0) return false;
      if (pos_ < text_.size() && text_[pos_] == 'L') ++pos_;
      shape->push_back(value);
      SkipBlank();
      if (Consume(',')) continue;
      SkipBlank();
      return Consume(')');
    }
  }

  std::string_view text_;
  size_t pos_ = 0;
};

// The header of .npy bytes: shape, dtype (one of `dtypes`: '<f4' 4 bytes,
// '<f8' 8 bytes), where the data begin and how many values they hold
// (checked against the bytes). `expected` names the dtypes in messages.
struct NpyLayout {
  std::vector<std::int64_t> shape;
  std::string descr;
  size_t item_bytes = 4;
  size_t data_begin = 0;
  std::uint64_t count = 0;
};

// `bytes` holds the file from its start, at least its header; the file's
// size is `file_size` (bytes.size() when bytes holds it whole).
bool ParseNpyLayout(const std::string& bytes, std::uint64_t file_size, bool allow_f8, NpyLayout* layout,
                    std::string* error) {
  if (bytes.size() < kMagicSize + 4 || bytes.compare(0, kMagicSize, kMagic, kMagicSize) != 0) {
    *error = "is not a .npy file (no \\x93NUMPY magic)";
    return false;
  }
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_length = 0;
  size_t header_begin = 0;
  if (major == 1) {
    header_length = static_cast<unsigned char>(bytes[8]) |
                    (static_cast<size_t>(static_cast<unsigned char>(bytes[9])) << 8);
    header_begin = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) {
      *error = "is truncated inside the .npy header";
      return false;
    }
    for (size_t i = 0; i < 4; ++i) {
      header_length |= static_cast<size_t>(static_cast<unsigned char>(bytes[8 + i])) << (8 * i);
    }
    header_begin = 12;
  } else {
    *error = "has .npy format version " + std::to_string(major) + "; expected 1, 2 or 3";
    return false;
  }
  if (bytes.size() - header_begin < header_length) {
    *error = "is truncated inside the .npy header";
    return false;
  }
  bool fortran_order = false;
  HeaderParser parser(std::string_view(bytes).substr(header_begin, header_length));
  if (!parser.Parse(&layout->descr, &fortran_order, &layout->shape, error)) return false;
  if (layout->descr == "<f4") {
    layout->item_bytes = 4;
  } else if (allow_f8 && layout->descr == "<f8") {
    layout->item_bytes = 8;
  } else {
    *error = "has dtype '" + layout->descr + "'; expected " +
             (allow_f8 ? "'<f4' or '<f8' (little-endian float32 or float64)" : "'<f4' (little-endian float32)");
    return false;
  }
  if (fortran_order) {
    *error = "is stored in Fortran order; expected C order (fortran_order: False)";
    return false;
  }
  layout->data_begin = header_begin + header_length;
  const std::uint64_t data_bytes = file_size - layout->data_begin;
  // Product of the shape, refusing sizes beyond 2^60 values (and overflow).
  constexpr std::uint64_t kMaxValues = std::uint64_t{1} << 60;
  std::uint64_t count = 1;
  bool too_large = false;
  for (const std::int64_t extent : layout->shape) {
    const std::uint64_t e = static_cast<std::uint64_t>(extent);
    if (e != 0 && count > kMaxValues / e) {
      too_large = true;
    } else {
      count *= e;
    }
  }
  const std::uint64_t needed = count * layout->item_bytes;
  if (too_large || needed != data_bytes) {
    *error = "holds " + std::to_string(data_bytes) + " bytes of data; shape " +
             FormatNpyShape(layout->shape) + " of " + (layout->item_bytes == 4 ? "float32" : "float64") +
             " needs " + (too_large ? std::string("more than 2^62") : std::to_string(needed)) +
             (too_large || needed > data_bytes ? " (truncated file?)" : "");
    return false;
  }
  if (!IsLittleEndianHost()) {
    *error = "cannot be read: this build reads little-endian arrays only on little-endian hosts";
    return false;
  }
  layout->count = count;
  return true;
}

bool ParseNpy(const std::string& bytes, bool read_values, NpyFloat32* array, std::string* error) {
  array->shape.clear();
  array->values.clear();
  NpyLayout layout;
  if (!ParseNpyLayout(bytes, bytes.size(), false, &layout, error)) {
    array->shape = layout.shape;
    return false;
  }
  array->shape = layout.shape;
  if (read_values) {
    array->values.resize(static_cast<size_t>(layout.count));
    if (layout.count > 0) {
      std::memcpy(array->values.data(), bytes.data() + layout.data_begin, layout.count * 4);
    }
  }
  return true;
}

}  // namespace

bool ParseNpyAsDoubles(const std::string& bytes, NpyDoubles* array, std::string* error) {
  array->shape.clear();
  array->values.clear();
  NpyLayout layout;
  if (!ParseNpyLayout(bytes, bytes.size(), true, &layout, error)) return false;
  array->shape = layout.shape;
  array->values.resize(static_cast<size_t>(layout.count));
  const char* data = bytes.data() + layout.data_begin;
  for (size_t i = 0; i < array->values.size(); ++i) {
    if (layout.item_bytes == 4) {
      float v = 0;
      std::memcpy(&v, data + 4 * i, 4);
      array->values[i] = v;
    } else {
      std::memcpy(&array->values[i], data + 8 * i, 8);
    }
  }
  return true;
}

std::int64_t NpyFloat32::NumValues() const {
  std::int64_t count = 1;
  for (const std::int64_t extent : shape) count *= extent;
  return count;
}

std::string FormatNpyShape(const std::vector<std::int64_t>& shape) {
  std::string text = "(";
  for (size_t i = 0; i < shape.size(); ++i) {
    if (i > 0) text += ", ";
    text += std::to_string(shape[i]);
  }
  if (shape.size() == 1) text += ",";
  return text + ")";
}

bool ParseNpyFloat32(const std::string& bytes, NpyFloat32* array, std::string* error) {
  return ParseNpy(bytes, true, array, error);
}

bool ParseNpyFloat32Header(const std::string& bytes, NpyFloat32* array, std::string* error) {
  return ParseNpy(bytes, false, array, error);
}

bool ParseNpyFloat32FileHeader(const std::string& prefix, std::uint64_t file_size, NpyFloat32* array,
                               std::string* error) {
  array->shape.clear();
  array->values.clear();
  NpyLayout layout;
  const bool ok = ParseNpyLayout(prefix, std::max<std::uint64_t>(file_size, prefix.size()), false, &layout, error);
  array->shape = layout.shape;
  return ok;
}

std::string EncodeNpyFloat32(const std::vector<std::int64_t>& shape, const float* values,
                             std::size_t num_values) {
  std::uint64_t count = 1;
  for (const std::int64_t extent : shape) {
    if (extent < 0) throw std::invalid_argument("EncodeNpyFloat32: negative extent");
    count *= static_cast<std::uint64_t>(extent);
  }
  if (count != num_values) {
    throw std::invalid_argument("EncodeNpyFloat32: " + std::to_string(num_values) +
                                " values for shape " + FormatNpyShape(shape));
  }
  if (!IsLittleEndianHost()) {
    throw std::invalid_argument("EncodeNpyFloat32: big-endian hosts are not supported");
  }
  std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': " +
                       FormatNpyShape(shape) + ", }";
  // Pad with spaces and end with '\n' so that magic (6) + version (2) +
  // length (2) + header is a multiple of 64.
  const size_t unpadded = 10 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header += '\n';
  std::string bytes(kMagic, kMagicSize);
  bytes += '\x01';
  bytes += '\x00';
  bytes += static_cast<char>(header.size() & 0xffU);
  bytes += static_cast<char>((header.size() >> 8) & 0xffU);
  bytes += header;
  const size_t data_begin = bytes.size();
  bytes.resize(data_begin + num_values * sizeof(float));
  if (num_values > 0) std::memcpy(&bytes[data_begin], values, num_values * sizeof(float));
  return bytes;
}

}  // namespace hdabench::datasets
