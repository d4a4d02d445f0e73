#include "calib/pixel_convention.h"

namespace hdabench::calib {

namespace {
// Position of the centre of the top-left pixel in each convention.
double TopLeftPixelCenter(PixelOrigin origin) {
  switch (origin) {
    case PixelOrigin::kCenterOfTopLeftPixelIsZero:
      return 0.0;
    case PixelOrigin::kTopLeftCornerIsZero:
      return 0.5;
  }
  return 0.0;
}
}  // namespace

double PixelOriginOffset(PixelOrigin from, PixelOrigin to) {
  return TopLeftPixelCenter(to) - TopLeftPixelCenter(from);
}

Eigen::Vector2d ConvertPixel(const Eigen::Vector2d& q_from, PixelOrigin from, PixelOrigin to) {
  const double offset = PixelOriginOffset(from, to);
  return q_from + Eigen::Vector2d(offset, offset);
}

}  // namespace hdabench::calib
