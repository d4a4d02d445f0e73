// Pixel-coordinate conventions: the one place where they are converted.
//
// hdabench, mrcal and OpenCV put the centre of the top-left pixel at (0, 0).
// COLMAP puts it at (0.5, 0.5): the top-left corner of the imager is (0, 0).
// So q_colmap = q_mrcal + (0.5, 0.5). See docs/conventions.md, "Pixels".
#pragma once

#include <Eigen/Core>

namespace hdabench::calib {

enum class PixelOrigin {
  kCenterOfTopLeftPixelIsZero,  // mrcal, OpenCV, hdabench
  kTopLeftCornerIsZero,         // COLMAP
};

// Offset added to a pixel given in `from` to express it in `to`, in pixels.
double PixelOriginOffset(PixelOrigin from, PixelOrigin to);

// Converts pixel coordinates between conventions: q_to = q_from + offset.
Eigen::Vector2d ConvertPixel(const Eigen::Vector2d& q_from, PixelOrigin from, PixelOrigin to);

}  // namespace hdabench::calib
