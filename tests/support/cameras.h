// Cameras shared by the tests.
#pragma once

#include "calib/camera_model.h"

namespace hdabench::testing_support {

// Pinhole 1024 x 1024 with f = 1000 px and the principal point at the centre.
inline calib::CameraModel Pinhole1000() {
  return calib::CameraModel("LENSMODEL_PINHOLE", {1000.0, 1000.0, 511.5, 511.5}, 1024, 1024);
}

}  // namespace hdabench::testing_support
