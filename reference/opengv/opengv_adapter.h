// OpenGV adapter: the one place where OpenGV's conventions meet hdabench's.
//
// OpenGV's relative pose (R12, t12), as a 3x4 transformation_t [R12 | t12],
// maps view-2 coordinates into view 1: X1 = R12 X2 + t12. That is
// cam1_from_cam2 in hdabench's naming; its solvers return t12 with unit norm
// (scale unknown). hdabench works with cam2_from_cam1 in metres.
#pragma once

#include <opengv/types.hpp>

#include "calib/rigid3.h"

namespace hdabench::reference {

// OpenGV's [R12 | t12] to cam2_from_cam1, with the translation rescaled so
// that the distance between the camera centres is baseline_m (metres).
// Precondition: t12 is non-zero when baseline_m > 0, baseline_m >= 0.
Rigid3d Cam2FromCam1FromOpenGv(const opengv::transformation_t& transformation_12,
                               double baseline_m);
// cam2_from_cam1 to OpenGV's [R12 | t12] (metric, not normalised).
opengv::transformation_t OpenGvFromCam2FromCam1(const Rigid3d& cam2_from_cam1);

}  // namespace hdabench::reference
