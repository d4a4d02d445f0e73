#include "calib/pixel_convention.h"

#include <gtest/gtest.h>

namespace hdabench::calib {
namespace {

TEST(ConvertPixel, MrcalToColmapAddsHalfAPixel) {
  // The centre of the top-left pixel: (0,0) for mrcal, (0.5,0.5) for COLMAP.
  const Eigen::Vector2d colmap = ConvertPixel(Eigen::Vector2d(0.0, 0.0), PixelOrigin::kCenterOfTopLeftPixelIsZero,
                                              PixelOrigin::kTopLeftCornerIsZero);
  EXPECT_EQ(colmap, Eigen::Vector2d(0.5, 0.5));
  // The top-left corner of the imager: (-0.5,-0.5) for mrcal, (0,0) for COLMAP.
  EXPECT_EQ(ConvertPixel(Eigen::Vector2d(-0.5, -0.5), PixelOrigin::kCenterOfTopLeftPixelIsZero,
                         PixelOrigin::kTopLeftCornerIsZero),
            Eigen::Vector2d(0.0, 0.0));
}

TEST(ConvertPixel, RoundTripIsExactAndSameConventionIsIdentity) {
  const Eigen::Vector2d q(123.25, 977.75);
  const Eigen::Vector2d there = ConvertPixel(q, PixelOrigin::kCenterOfTopLeftPixelIsZero,
                                             PixelOrigin::kTopLeftCornerIsZero);
  EXPECT_EQ(ConvertPixel(there, PixelOrigin::kTopLeftCornerIsZero,
                         PixelOrigin::kCenterOfTopLeftPixelIsZero),
            q);
  EXPECT_EQ(ConvertPixel(q, PixelOrigin::kTopLeftCornerIsZero, PixelOrigin::kTopLeftCornerIsZero), q);
  EXPECT_EQ(PixelOriginOffset(PixelOrigin::kTopLeftCornerIsZero, PixelOrigin::kCenterOfTopLeftPixelIsZero),
            -0.5);
}

}  // namespace
}  // namespace hdabench::calib
