// Numbers as text.
#include "tools/util/text.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hdabench::util {
namespace {

TEST(FixedText, FixedDecimalsAndAnExponentForHugeValues) {
  EXPECT_EQ(FixedText(3.14159, 2), "3.14");
  EXPECT_EQ(FixedText(-0.5, 0), "-0");
  EXPECT_EQ(FixedText(123456789012345.0, 1), "123456789012345.0");
  EXPECT_EQ(FixedText(1e308, 2), "1.00e+308");
  EXPECT_EQ(FixedText(-2.5e20, 1), "-2.5e+20");
  EXPECT_EQ(FixedText(std::numeric_limits<double>::infinity(), 3), "inf");
  EXPECT_EQ(FixedText(std::nan(""), 3), "nan");
  EXPECT_EQ(FixedCell(1e308, 2), "1.00e+308");
  EXPECT_EQ(FixedCell(std::nan(""), 2), "-");
}

}  // namespace
}  // namespace hdabench::util
