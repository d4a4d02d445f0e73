// COLMAP sparse models (COLMAP 3.8 layout): reading the text form
// (cameras.txt, images.txt, points3D.txt) and the binary form (cameras.bin,
// images.bin, points3D.bin), detected per folder, and writing the text form
// (the input of `colmap point_triangulator`).
//
// Values are kept in COLMAP's own conventions, exactly as in the files:
// images hold cam_from_world as qvec (w, x, y, z) and tvec (metres of the
// model), 2D points are COLMAP pixels (centre of the top-left pixel at
// (0.5, 0.5)). reference/colmap/colmap_adapter.h converts poses and pixels to
// hdabench's conventions.
//
// Binary layout (little-endian):
//   cameras.bin   uint64 count; per camera: uint32 camera_id, int32 model_id,
//                 uint64 width, uint64 height, double params[n(model)]
//   images.bin    uint64 count; per image: uint32 image_id, double qvec[4],
//                 double tvec[3], uint32 camera_id, name (bytes up to a NUL),
//                 uint64 num_points2D, per point: double x, double y,
//                 uint64 point3D_id (2^64 - 1: none)
//   points3D.bin  uint64 count; per point: uint64 point3D_id, double xyz[3],
//                 uint8 rgb[3], double error, uint64 track_length, per
//                 element: uint32 image_id, uint32 point2D_idx
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace hdabench::reference {

struct ColmapCamera {
  std::uint32_t id = 0;
  std::string model;           // COLMAP model name: "PINHOLE", "OPENCV", "FULL_OPENCV", ...
  std::uint64_t width = 0;     // pixels
  std::uint64_t height = 0;    // pixels
  std::vector<double> params;  // COLMAP's order for the model (fx fy cx cy ... for PINHOLE/OPENCV)
};

struct ColmapPoint2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // COLMAP pixels
  std::int64_t point3D_id = -1;                  // -1: not part of a 3D point
};

struct ColmapImage {
  std::uint32_t id = 0;
  std::array<double, 4> qvec{1.0, 0.0, 0.0, 0.0};  // cam_from_world rotation, w x y z
  std::array<double, 3> tvec{0.0, 0.0, 0.0};       // cam_from_world translation
  std::uint32_t camera_id = 0;
  std::string name;  // file name relative to the image folder, no whitespace
  std::vector<ColmapPoint2D> points2D;
};

struct ColmapTrackElement {
  std::uint32_t image_id = 0;
  std::uint32_t point2D_idx = 0;  // index into that image's points2D
};

struct ColmapPoint3D {
  std::uint64_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  // model's world frame
  std::array<std::uint8_t, 3> rgb{0, 0, 0};
  double error = 0.0;  // mean reprojection error, pixels (-1 when unknown)
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::vector<ColmapCamera> cameras;    // in file order
  std::vector<ColmapImage> images;      // in file order
  std::vector<ColmapPoint3D> points3D;  // in file order

  // Lookups by id; nullptr when there is none.
  const ColmapCamera* FindCamera(std::uint32_t id) const;
  const ColmapImage* FindImage(std::uint32_t id) const;
  const ColmapImage* FindImageByName(const std::string& name) const;
};

// Number of parameters of a COLMAP 3.8 camera model, -1 for an unknown name.
int ColmapCameraParamCount(const std::string& model);
// COLMAP 3.8's numeric model id of a name (cameras.bin), -1 for an unknown
// name; and the reverse ("" for an unknown id).
int ColmapCameraModelId(const std::string& model);
std::string ColmapCameraModelName(int model_id);

enum class ColmapModelFormat { kText, kBinary };

// Which form folder `dir` holds: binary when cameras.bin, images.bin and
// points3D.bin are all there, else text when the three .txt files are. Throws
// InputError naming the folder when it holds neither complete set.
ColmapModelFormat DetectColmapModelFormat(const std::string& dir);

// Reads the model in folder `dir` (form detected as above). Throws InputError
// for a missing or unreadable file, and for malformed content: the message
// starts with the file path and the line (text: "path:line: ...") or the byte
// offset (binary: "path: byte N: ...") and says what is wrong (a truncated
// record, a bad number, a wrong parameter count, an unknown camera model,
// trailing bytes, a repeated id). References between the files (an image's
// camera, a track's image and 2D point, a 2D point's 3D point) are checked too.
ColmapModel ReadColmapModel(const std::string& dir);
ColmapModel ReadColmapTextModel(const std::string& dir);
ColmapModel ReadColmapBinaryModel(const std::string& dir);

// Writes cameras.txt, images.txt and points3D.txt into existing folder `dir`,
// with COLMAP's header comments and every double printed so that it reads back
// identical. Throws InputError when a file cannot be written, and when the
// model cannot be written as text (an image name that is empty or contains
// whitespace, a camera with the wrong parameter count).
void WriteColmapTextModel(const ColmapModel& model, const std::string& dir);

}  // namespace hdabench::reference
