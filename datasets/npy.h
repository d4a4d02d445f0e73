// Float32 arrays in numpy's .npy format (version 1.0 written; 1.0, 2.0 and 3.0
// read), the format of the dataset's truth rasters; small float32 or float64
// arrays read as doubles (the StereoLunar .npz members). Any numpy opens them with
// numpy.load(path). Only little-endian float32 ('<f4') in C order is accepted.
// https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hdabench::datasets {

struct NpyFloat32 {
  std::vector<std::int64_t> shape;  // numpy's shape, slowest axis first
  std::vector<float> values;        // C order (last axis fastest)

  std::int64_t NumValues() const;   // product of shape (1 for a 0-d array)
};

// Parses .npy bytes. Returns false with `error` (a message without the file
// name) when the magic, version or header is malformed, the dtype is not '<f4',
// fortran_order is True, or the data size does not match the shape. The shape
// is checked against the data size before anything is allocated.
bool ParseNpyFloat32(const std::string& bytes, NpyFloat32* array, std::string* error);

// The same, reading only the header: `array->values` stays empty. Also checks
// that the file holds exactly the bytes the shape needs.
bool ParseNpyFloat32Header(const std::string& bytes, NpyFloat32* array, std::string* error);

// The same from the start of a file (`prefix`, holding at least the header)
// and the file's size, without its data: what a check of a large array's
// header needs. A header longer than the prefix is reported as a truncated
// header; read more of the file then.
bool ParseNpyFloat32FileHeader(const std::string& prefix, std::uint64_t file_size, NpyFloat32* array,
                               std::string* error);

// A float array of either float dtype numpy writes ('<f4', '<f8'), as doubles.
struct NpyDoubles {
  std::vector<std::int64_t> shape;
  std::vector<double> values;  // C order
};

// Parses .npy bytes of dtype '<f4' or '<f8' in C order into doubles; false
// with `error` as ParseNpyFloat32.
bool ParseNpyAsDoubles(const std::string& bytes, NpyDoubles* array, std::string* error);

// Encodes a float32 array as .npy version 1.0 bytes. The header is padded so
// the data starts at a multiple of 64 bytes, as numpy does. Throws
// std::invalid_argument when values.size() != the product of shape.
std::string EncodeNpyFloat32(const std::vector<std::int64_t>& shape, const float* values,
                             std::size_t num_values);

// "(256, 256, 3)", numpy's spelling of a shape.
std::string FormatNpyShape(const std::vector<std::int64_t>& shape);

}  // namespace hdabench::datasets
