// Conversion of a StereoLunar nadir pair (rendered lunar stereo images with
// true z-depth and exact poses; /work/shared/data/README.md, section
// stereolunar-nadir) into an in-memory Dataset (docs/dataset-format.md).
// docs/stereolunar.md describes the source layout and every choice below.
//
// Source: a pair folder `paireN/` holds 2*S frames im_NNNNN.{jpg,exr} with
// consecutive numbers N, N+1, ...: the same two camera poses rendered under S
// sun positions (N, N+2, ... share pose A; N+1, N+3, ... pose B). A cameras.txt
// holds one line per frame:
//   <pair folder>/im_NNNNN  K (9 values, row-major)  cam2world (16 values,
//   row-major, OpenCV camera axes, Moon-centred metres)
// ('#' starts a comment line; the key may also be the bare im_NNNNN).
//
// Result: 2 frames, sun `sun`: frame 0 = im_{N+2*sun} (pose A, time 0 s),
// frame 1 = im_{N+2*sun+1} (pose B, time 1 s).
//   local     local-level frame at the ground point G seen by frame 0's centre
//             pixel: z up = G / |G| (radial from the Moon's centre), x east =
//             unit(spin axis x up) with the spin axis the z axis of the
//             Moon-centred frame, y north = z x x; origin G. ILS = origin.
//   gravity   (0, 0, -1.62) m/s^2.
//   camera    LENSMODEL_PINHOLE (fx, fy, cx - 0.5, cy - 0.5): K's principal
//             point is taken in the corner-origin pixel convention (the top-left
//             corner of the image at (0, 0); cx = cy = 256 is the exact centre
//             of a 512 px image there) and moved to mrcal's (centre of the
//             top-left pixel at (0, 0)).
//   body      the camera itself: cam_from_body = identity.
//   nav       the true poses (cam2world mapped into local) at 0 s and 1 s;
//             truth navigation the same (rendered data: measured = true).
//   LRF       along the ray of the centre pixel (column W/2, row H/2), range =
//             z-depth * |K^-1 (u, v, 1)|, from frame 0's depth at 0 s and frame
//             1's at 1 s.
//   truth     per-pixel points depth * K^-1 (u, v, 1) mapped into local; NaN
//             where the depth is not finite or not > 0. No DEM, no rocks. The
//             depth is stored at half precision (steps of about 16 m at 30 km):
//             truth for slopes over hundreds of metres, not for metre-scale
//             roughness.
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>

#include "calib/rigid3.h"
#include "datasets/dataset.h"

namespace hdabench::datasets {

// Lunar surface gravity, m/s^2.
constexpr double kMoonGravityMps2 = 1.62;
// Added to the source principal point to get mrcal's, pixels (corner-origin to
// pixel-centre origin).
constexpr double kStereoLunarPrincipalPointShiftPx = -0.5;

// One line of cameras.txt.
struct StereoLunarCamera {
  std::string key;          // first field, e.g. "paire1/im_00594"
  int line = 0;             // 1-based line in the file (0: from a .npz)
  std::string where;        // "path:line" of cameras.txt, or the .npz path
  Eigen::Matrix3d k;        // intrinsics, pixels, source pixel convention
  Eigen::Matrix4d cam2world;  // moon_from_cam: OpenCV camera axes, Moon-centred metres
};

// Reads every camera line of a cameras.txt. Throws InputError "path:line: ..."
// for a line without exactly 26 fields, a value that is not a finite number, a
// K that is not [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0, a cam2world whose
// last row is not (0 0 0 1) or whose rotation is not orthonormal within 1e-4,
// or a repeated key; and "path: ..." when the file cannot be read or holds no
// camera line.
std::vector<StereoLunarCamera> ReadStereoLunarCameras(const std::string& path);

// The camera of one frame from its .npz, as the dataset ships it: arrays
// `intrinsics` (3 x 3) and `cam2world` (4 x 4), float32 or float64, checked as
// ReadStereoLunarCameras checks a line. `key` names the frame
// ("paire1/im_00594"). Throws InputError "path: ..." for an unreadable
// archive, a missing array, a wrong shape, a value that is not finite, or a
// K or cam2world that fails the checks.
StereoLunarCamera ReadStereoLunarNpzCamera(const std::string& path, const std::string& key);

// local_from_moon of the local-level frame at ground point `ground_in_moon_m`
// (Moon-centred metres): x east, y north, z radial up, origin the point (see
// the header comment). Throws InputError when the point is within 1 m of the
// spin axis (east undefined there).
Rigid3d LocalLevelFromMoon(const Eigen::Vector3d& ground_in_moon_m);

// The centre pixel of a width x height image, mrcal convention: (W/2, H/2) in
// whole pixels (for even sizes the pixel down-right of the image centre).
Eigen::Vector2d StereoLunarCentrePixel(int width_px, int height_px);

// Converts sun position `sun` (0-based) of the pair in `pair_dir` with the
// poses of `cameras_txt` (see the header comment); when `cameras_txt` is
// empty, with each frame's .npz (ReadStereoLunarNpzCamera) when the pair's
// frames have one, else with DefaultStereoLunarCamerasFile. Throws std::invalid_argument
// when sun < 0; InputError naming the file (and line) when the folder is
// missing or holds no usable frame sequence, sun is beyond the folder's sun
// positions, an image or depth file is missing or unreadable (a non-8-bit
// JPEG, a depth that is not single-channel float, sizes that differ), a frame
// has no line in cameras.txt, the two frames' K differ, or the centre pixel
// has no valid depth. Sets OPENCV_IO_ENABLE_OPENEXR=1 in the environment
// before the first depth read (OpenCV reads that variable once).
Dataset ConvertStereoLunarPair(const std::string& pair_dir, const std::string& cameras_txt = "",
                               int sun = 0);

// The cameras.txt used when none is given: pair_dir/cameras.txt when that file
// exists, else cameras.txt in the pair folder's parent (the shared data layout).
std::string DefaultStereoLunarCamerasFile(const std::string& pair_dir);

}  // namespace hdabench::datasets
