// COLMAP adapter: the one place where COLMAP's conventions meet hdabench's.
//
// COLMAP (3.8) images.txt / images.bin store, per image, cam_from_world as
//   QW QX QY QZ TX TY TZ   (Hamilton quaternion, w first; x_cam = R x_world + t)
// so a relative pose is x2 = R x1 + t, i.e. cam2_from_cam1, as in hdabench.
// COLMAP pixels have the top-left corner of the imager at (0,0), so the centre
// of the top-left pixel is (0.5,0.5): hdabench (mrcal) pixels + 0.5.
#pragma once

#include <array>

#include <Eigen/Core>

#include "calib/rigid3.h"

namespace hdabench::reference {

// COLMAP's 7 pose numbers (qw qx qy qz tx ty tz) to cam_from_world; the
// quaternion is normalised. Precondition: IsValidColmapPose(qvec_tvec).
Rigid3d CamFromWorldFromColmap(const std::array<double, 7>& qvec_tvec);
// The inverse: cam_from_world to COLMAP's 7 numbers (qw >= 0).
std::array<double, 7> ColmapFromCamFromWorld(const Rigid3d& cam_from_world);
// True when the 7 numbers are finite and the quaternion has a usable norm.
bool IsValidColmapPose(const std::array<double, 7>& qvec_tvec);

// Pixel from hdabench's convention to COLMAP's and back.
Eigen::Vector2d PixelToColmap(const Eigen::Vector2d& pixel);
Eigen::Vector2d PixelFromColmap(const Eigen::Vector2d& colmap_pixel);

}  // namespace hdabench::reference
