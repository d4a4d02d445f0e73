// The .npy reader and writer.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "datasets/npy.h"

namespace hdabench::datasets {
namespace {

TEST(EncodeNpyFloat32, RoundTripsValuesAndShape) {
  const std::vector<float> values = {1.5f, -2.0f, std::nanf(""), 3.25f, 0.0f, 1e-30f};
  const std::string bytes = EncodeNpyFloat32({1, 2, 3}, values.data(), values.size());
  // numpy's layout: magic, version 1.0, header padded so the data is 64-aligned.
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x93NUMPY\x01\x00", 8));
  EXPECT_EQ((bytes.size() - values.size() * 4) % 64, 0U);
  EXPECT_NE(bytes.find("{'descr': '<f4', 'fortran_order': False, 'shape': (1, 2, 3), }"),
            std::string::npos);
  NpyFloat32 array;
  std::string error;
  ASSERT_TRUE(ParseNpyFloat32(bytes, &array, &error)) << error;
  EXPECT_EQ(array.shape, (std::vector<std::int64_t>{1, 2, 3}));
  ASSERT_EQ(array.values.size(), values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    if (std::isnan(values[i])) {
      EXPECT_TRUE(std::isnan(array.values[i]));
    } else {
      EXPECT_EQ(array.values[i], values[i]);
    }
  }
  EXPECT_EQ(FormatNpyShape({7}), "(7,)");
}

TEST(ParseNpyFloat32, RejectsWrongDtypeOrderAndTruncation) {
  const std::vector<float> values(12, 1.0f);
  const std::string good = EncodeNpyFloat32({4, 3}, values.data(), values.size());
  NpyFloat32 array;
  std::string error;

  std::string f8 = good;
  f8.replace(f8.find("<f4"), 3, "<f8");
  EXPECT_FALSE(ParseNpyFloat32(f8, &array, &error));
  EXPECT_EQ(error, "has dtype '<f8'; expected '<f4' (little-endian float32)");

  std::string fortran = good;
  fortran.replace(fortran.find("False"), 5, "True ");
  EXPECT_FALSE(ParseNpyFloat32(fortran, &array, &error));
  EXPECT_EQ(error, "is stored in Fortran order; expected C order (fortran_order: False)");

  EXPECT_FALSE(ParseNpyFloat32(good.substr(0, good.size() - 5), &array, &error));
  EXPECT_EQ(error, "holds 43 bytes of data; shape (4, 3) of float32 needs 48 (truncated file?)");

  EXPECT_FALSE(ParseNpyFloat32("PK\x03\x04 a zip file", &array, &error));
  EXPECT_EQ(error, "is not a .npy file (no \\x93NUMPY magic)");

  std::string huge = good;
  // Same header length: take the 20 extra characters out of the padding.
  huge.replace(huge.find("(4, 3)"), 6, "(99999999999, 99999999999)");
  huge.erase(huge.find("}") + 1, 20);
  EXPECT_FALSE(ParseNpyFloat32Header(huge, &array, &error));
  EXPECT_EQ(error.rfind("holds 48 bytes of data; shape (99999999999, 99999999999)", 0), 0U)
      << error;
}

// A header read from the start of a file and its size: the same checks as
// from the whole file, without its data.
TEST(ParseNpyFloat32FileHeader, ChecksTheSizeWithoutTheData) {
  const std::vector<float> values(12, 1.0f);
  const std::string good = EncodeNpyFloat32({4, 3}, values.data(), values.size());
  const std::string header = good.substr(0, good.size() - 48);
  NpyFloat32 array;
  std::string error;
  ASSERT_TRUE(ParseNpyFloat32FileHeader(header, good.size(), &array, &error)) << error;
  EXPECT_EQ(array.shape, (std::vector<std::int64_t>{4, 3}));
  EXPECT_TRUE(array.values.empty());
  EXPECT_FALSE(ParseNpyFloat32FileHeader(header, good.size() - 5, &array, &error));
  EXPECT_EQ(error, "holds 43 bytes of data; shape (4, 3) of float32 needs 48 (truncated file?)");
  // A prefix that ends inside the header: reported as such (read more then).
  EXPECT_FALSE(ParseNpyFloat32FileHeader(good.substr(0, 20), good.size(), &array, &error));
  EXPECT_EQ(error, "is truncated inside the .npy header");
}

}  // namespace
}  // namespace hdabench::datasets
