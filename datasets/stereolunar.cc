#include "datasets/stereolunar.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/images/codecs.h"
#include "tools/util/files.h"
#include "tools/util/error.h"
#include "tools/util/text.h"
#include "datasets/internal/pair_frames.h"
#include "datasets/npz.h"

namespace hdabench::datasets {

namespace {

namespace fs = std::filesystem;

constexpr int kCamerasFields = 1 + 9 + 16;  // key, K, cam2world
constexpr double kOrthonormalTolerance = 1e-4;

// Parses a whole field as a finite double; false otherwise.
bool ParseFinite(const std::string& text, double* value) {
  const char* begin = text.c_str();
  char* end = nullptr;
  *value = std::strtod(begin, &end);
  return end != begin && *end == '\0' && std::isfinite(*value);
}

// The nearest rotation matrix (SVD projection).
Eigen::Matrix3d NearestRotation(const Eigen::Matrix3d& m) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(m, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d r = svd.matrixU() * svd.matrixV().transpose();
  if (r.determinant() < 0.0) {
    Eigen::Matrix3d u = svd.matrixU();
    u.col(2) = -u.col(2);
    r = u * svd.matrixV().transpose();
  }
  return r;
}

// One source frame of a pair folder.
struct SourceFrame {
  int number = 0;    // NNNNN of im_NNNNN
  std::string stem;  // "im_NNNNN"
};

// The im_NNNNN.jpg frames of `dir`, sorted by number; checked to be an even
// count of consecutive numbers.
std::vector<SourceFrame> ListFrames(const fs::path& dir) {
  std::vector<SourceFrame> frames;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const fs::path& path = it->path();
    if (path.extension() != ".jpg") continue;
    const std::string stem = path.stem().string();
    if (stem.size() < 4 || stem.compare(0, 3, "im_") != 0) continue;
    const std::string digits = stem.substr(3);
    if (!std::all_of(digits.begin(), digits.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
        digits.size() > 9) {
      continue;
    }
    frames.push_back({std::stoi(digits), stem});
  }
  if (ec) throw InputError(dir.string() + ": cannot list the folder: " + ec.message());
  std::sort(frames.begin(), frames.end(),
            [](const SourceFrame& a, const SourceFrame& b) { return a.number < b.number; });
  if (frames.empty()) {
    throw InputError(dir.string() +
                     ": no im_NNNNN.jpg frames; expected a StereoLunar pair folder (im_NNNNN.jpg "
                     "and .exr, two poses x sun positions)");
  }
  for (size_t i = 1; i < frames.size(); ++i) {
    if (frames[i].number != frames[i - 1].number + 1) {
      throw InputError(dir.string() + ": frame numbers are not consecutive: " +
                       frames[i - 1].stem + " is followed by " + frames[i].stem +
                       "; expected N, N+1, ... (two poses alternating under each sun position)");
    }
  }
  if (frames.size() % 2 != 0) {
    throw InputError(dir.string() + ": " + std::to_string(frames.size()) +
                     " frames (" + frames.front().stem + " .. " + frames.back().stem +
                     "); expected an even count: two poses under each sun position");
  }
  return frames;
}

// The grey image of a frame, CV_8UC1. A 3-channel JPEG (grey stored as
// colour) gives its first channel.
cv::Mat ReadImage(const fs::path& path) {
  std::string error;
  const cv::Mat raw = images::ReadWholeImage(path.string(), cv::IMREAD_UNCHANGED, &error);
  if (raw.empty()) throw InputError(path.string() + ": " + error);
  if (raw.depth() != CV_8U || (raw.channels() != 1 && raw.channels() != 3)) {
    throw InputError(path.string() + ": " + std::to_string(raw.channels()) +
                     " channel(s) of OpenCV depth " + std::to_string(raw.depth()) +
                     "; expected an 8-bit grey image (1 or 3 channels)");
  }
  if (raw.channels() == 1) return raw.clone();
  cv::Mat grey;
  cv::extractChannel(raw, grey, 0);
  return grey;
}

// The z-depth raster of a frame, CV_32FC1, metres.
cv::Mat ReadDepth(const fs::path& path) {
  if (std::string error; !util::IsReadableFile(path, &error)) {
    throw InputError(path.string() + ": " + error + " (the frame's z-depth)");
  }
  // OpenCV reads this variable once, at its first EXR decode.
  ::setenv("OPENCV_IO_ENABLE_OPENEXR", "1", 1);
  cv::Mat depth;
  try {
    depth = images::Read(path.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(path.string() + ": cannot be read as an OpenEXR depth: " + e.what());
  }
  if (depth.empty()) {
    throw InputError(path.string() +
                     ": cannot be decoded as an OpenEXR depth (corrupt file, or OpenCV's EXR "
                     "reader disabled: OPENCV_IO_ENABLE_OPENEXR must be 1 at the first read)");
  }
  if (depth.type() != CV_32FC1) {
    throw InputError(path.string() + ": " + std::to_string(depth.channels()) +
                     " channel(s) of OpenCV depth " + std::to_string(depth.depth()) +
                     "; expected a single-channel float z-depth");
  }
  return depth;
}

std::string FolderName(const fs::path& dir) {
  std::error_code ec;
  const fs::path canonical = fs::canonical(dir, ec);
  return (ec ? dir.lexically_normal() : canonical).filename().string();
}

const StereoLunarCamera& FindCamera(const std::vector<StereoLunarCamera>& cameras,
                                    const std::string& cameras_txt, const std::string& folder,
                                    const std::string& stem) {
  const std::string key = folder + "/" + stem;
  for (const StereoLunarCamera& camera : cameras) {
    if (camera.key == key || camera.key == stem) return camera;
  }
  throw InputError(cameras_txt + ": no line for " + key + " (nor " + stem + ")");
}

// The two frames of one sun position: their source names, cameras (lines of
// cameras.txt), grey images and z-depths.
struct PairFrames {
  SourceFrame source[2];
  const StereoLunarCamera* camera[2] = {nullptr, nullptr};
  cv::Mat image[2];
  cv::Mat depth[2];
};

// Throws unless the folder holds sun position `sun` (0-based; two frames each).
void RequireSun(const std::string& pair_dir, const std::vector<SourceFrame>& frames, int sun) {
  const int suns = static_cast<int>(frames.size()) / 2;
  if (sun >= suns) {
    throw InputError(pair_dir + ": sun " + std::to_string(sun) + " requested; the folder holds " +
                     std::to_string(suns) + " sun position(s) (0.." + std::to_string(suns - 1) +
                     ")");
  }
}

// Finds the cameras of both frames; they must share K, as a dataset has one
// camera model.
void FindPairCameras(const std::vector<StereoLunarCamera>& cameras,
                     const std::string& cameras_txt, const std::string& folder,
                     PairFrames* pair) {
  for (int i = 0; i < 2; ++i) {
    pair->camera[i] = &FindCamera(cameras, cameras_txt, folder, pair->source[i].stem);
  }
  const StereoLunarCamera* const* camera = pair->camera;
  if (camera[0]->k != camera[1]->k) {
    throw InputError(camera[1]->where + ": K of " + camera[1]->key + " differs from K of " +
                     camera[0]->key + " (" + camera[0]->where +
                     "); the bench needs one camera per dataset");
  }
}

// Reads the image and z-depth of both frames; all four rasters must have the
// size of frame 0's image.
void ReadPairRasters(const fs::path& dir, PairFrames* pair) {
  const SourceFrame* source = pair->source;
  for (int i = 0; i < 2; ++i) {
    pair->image[i] = ReadImage(dir / (source[i].stem + ".jpg"));
    pair->depth[i] = ReadDepth(dir / (source[i].stem + ".exr"));
  }
  const cv::Size size = pair->image[0].size();
  for (int i = 0; i < 2; ++i) {
    for (const std::pair<const cv::Mat*, const char*> raster :
         {std::make_pair(&pair->image[i], ".jpg"), std::make_pair(&pair->depth[i], ".exr")}) {
      if (raster.first->size() != size) {
        throw InputError((dir / (source[i].stem + raster.second)).string() + ": " +
                         std::to_string(raster.first->cols) + " x " +
                         std::to_string(raster.first->rows) + " px; expected " +
                         std::to_string(size.width) + " x " + std::to_string(size.height) +
                         " px like " + source[0].stem + ".jpg");
      }
    }
  }
}

// The pinhole intrinsics of the pair: K with the principal point moved to the
// mrcal convention.
struct Pinhole {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;

  // Ray of pixel (col, row), mrcal convention, with unit z: depth * ray is the
  // point in the camera frame.
  Eigen::Vector3d Ray(double col, double row) const {
    return Eigen::Vector3d((col - cx) / fx, (row - cy) / fy, 1.0);
  }
};

Pinhole PinholeFromK(const Eigen::Matrix3d& k) {
  Pinhole pinhole;
  pinhole.fx = k(0, 0);
  pinhole.fy = k(1, 1);
  pinhole.cx = k(0, 2) + kStereoLunarPrincipalPointShiftPx;
  pinhole.cy = k(1, 2) + kStereoLunarPrincipalPointShiftPx;
  return pinhole;
}

// A depth the renderer wrote for a surface: finite and positive.
bool ValidDepth(double d) { return std::isfinite(d) && d > 0.0; }

// moon_from_cam of a frame, rotation projected onto SO(3) (the source is float32).
Rigid3d MoonFromCam(const StereoLunarCamera& camera) {
  const Eigen::Matrix4d& m = camera.cam2world;
  return Rigid3d(Eigen::Quaterniond(NearestRotation(m.topLeftCorner<3, 3>())).normalized(),
                 m.topRightCorner<3, 1>());
}

// The depth of frame i at the centre pixel, which must be valid: it places the
// ILS and the LRF spot.
double CentreDepth(const fs::path& dir, const PairFrames& pair, int i,
                   const Eigen::Vector2d& centre) {
  const double depth = static_cast<double>(
      pair.depth[i].at<float>(static_cast<int>(centre.y()), static_cast<int>(centre.x())));
  if (!ValidDepth(depth)) {
    throw InputError((dir / (pair.source[i].stem + ".exr")).string() + ": depth " + util::ShortestText(depth) +
                     " at the centre pixel (" + util::ShortestText(centre.x()) + ", " + util::ShortestText(centre.y()) +
                     "); expected a finite depth > 0 (the ILS and LRF spot)");
  }
  return depth;
}

// The dataset's name and description, which documents the conventions of the
// conversion and the limits of the truth.
void DescribeDataset(const std::string& folder, int sun, const PairFrames& pair,
                     double centre_depth_m, double fx, Dataset* dataset) {
  const SourceFrame* source = pair.source;
  dataset->name = "stereolunar-" + folder + "-sun" + std::to_string(sun);
  dataset->description =
      "StereoLunar nadir pair " + folder + " (rendered with true z-depth and exact poses), sun " +
      "position " + std::to_string(sun) + ": frame 0 = " + source[0].stem + ", frame 1 = " +
      source[1].stem + ", times 0 s and 1 s by convention. Local frame: east-north-up at the "
      "ground point of frame 0's centre pixel (up radial from the Moon's centre). Body = camera; "
      "navigation = truth. Truth points from half-precision depth (steps of about 16 m at 30 km): "
      "truth for slopes over hundreds of metres, not for metre-scale roughness. Pixel footprint "
      "about " + util::FixedText(std::round(centre_depth_m / fx), 0) + " m: use a site size of several hundred "
      "metres (docs/stereolunar.md).";
}

// Adds frame i at time i * kPairFrameStepS: its record, its navigation sample
// (also the truth navigation: body = camera, exact poses) and the LRF sample
// along the centre pixel's ray.
void AddFrameRecords(int i, const cv::Mat& image, const Rigid3d& local_from_cam,
                     double centre_depth, const Eigen::Vector3d& centre_ray, Dataset* dataset) {
  dataset->truth.navigation.push_back(internal::AddPairFrame(
      i, image, local_from_cam, centre_depth * centre_ray.norm(), centre_ray.normalized(), dataset));
}

// The truth points of a frame: each pixel's depth along its ray, in the local
// frame; NaN where the depth is not valid.
cv::Mat TruthPointsFromDepth(const cv::Mat& depth, const Pinhole& pinhole,
                             const Rigid3d& local_from_cam) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const cv::Size size = depth.size();
  const Eigen::Matrix3d rotation = local_from_cam.RotationMatrix();
  const Eigen::Vector3d& translation = local_from_cam.translation;
  cv::Mat points(size, CV_32FC3);
  for (int row = 0; row < size.height; ++row) {
    for (int col = 0; col < size.width; ++col) {
      const double d = depth.at<float>(row, col);
      cv::Vec3f& point = points.at<cv::Vec3f>(row, col);
      if (!ValidDepth(d)) {
        point = cv::Vec3f(nan, nan, nan);
        continue;
      }
      const Eigen::Vector3d p = rotation * (d * pinhole.Ray(col, row)) + translation;
      point = cv::Vec3f(static_cast<float>(p.x()), static_cast<float>(p.y()),
                        static_cast<float>(p.z()));
    }
  }
  return points;
}

// Throws InputError "where: ..." unless K is [fx 0 cx; 0 fy cy; 0 0 1] with
// fx, fy > 0 and cam2world a rigid transform (last row 0 0 0 1, rotation
// orthonormal within kOrthonormalTolerance, det +1).
void CheckCamera(const StereoLunarCamera& camera, const std::string& where) {
  const Eigen::Matrix3d& k = camera.k;
  if (!(k(0, 0) > 0.0) || !(k(1, 1) > 0.0) || k(0, 1) != 0.0 || k(1, 0) != 0.0 ||
      k(2, 0) != 0.0 || k(2, 1) != 0.0 || k(2, 2) != 1.0) {
    throw InputError(where + ": K of " + camera.key +
                     " is not [fx 0 cx; 0 fy cy; 0 0 1] with fx, fy > 0 (no skew)");
  }
  // A focal length under a pixel or over ten million, or a principal point a
  // million pixels out, is no camera; positions beyond 1e7 m are not near the Moon.
  if (!(k(0, 0) >= 1.0 && k(0, 0) <= 1e7 && k(1, 1) >= 1.0 && k(1, 1) <= 1e7) ||
      !(std::abs(k(0, 2)) <= 1e6 && std::abs(k(1, 2)) <= 1e6)) {
    throw InputError(where + ": K of " + camera.key + " has fx " + util::ShortestText(k(0, 0)) + ", fy " +
                     util::ShortestText(k(1, 1)) + ", cx " + util::ShortestText(k(0, 2)) + ", cy " +
                     util::ShortestText(k(1, 2)) + "; expected focal lengths of 1 to 1e7 px and a principal point "
                     "within 1e6 px");
  }
  const Eigen::Matrix4d& m = camera.cam2world;
  if (!(m.topRightCorner<3, 1>().cwiseAbs().maxCoeff() <= 1e7)) {
    throw InputError(where + ": cam2world of " + camera.key + " places the camera " +
                     util::ShortestText(m.topRightCorner<3, 1>().norm()) + " m from the origin; expected within 1e7 m");
  }
  if (m(3, 0) != 0.0 || m(3, 1) != 0.0 || m(3, 2) != 0.0 || m(3, 3) != 1.0) {
    throw InputError(where + ": cam2world of " + camera.key + " has last row (" + util::ShortestText(m(3, 0)) +
                     " " + util::ShortestText(m(3, 1)) + " " + util::ShortestText(m(3, 2)) + " " + util::ShortestText(m(3, 3)) +
                     "); expected (0 0 0 1)");
  }
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double error = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(error <= kOrthonormalTolerance) || !(r.determinant() > 0.0)) {
    throw InputError(where + ": cam2world rotation of " + camera.key +
                     " is not a rotation (|R^T R - I| = " + util::ShortestText(error) + ", det " +
                     util::ShortestText(r.determinant()) + "); expected orthonormal within 1e-4, det +1");
  }
}

}  // namespace

std::vector<StereoLunarCamera> ReadStereoLunarCameras(const std::string& path) {
  if (std::string error; !util::IsReadableFile(path, &error)) throw InputError(path + ": " + error);
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot be opened");
  std::vector<StereoLunarCamera> cameras;
  std::map<std::string, int> seen;
  std::string text;
  int line_number = 0;
  while (std::getline(in, text)) {
    ++line_number;
    if (!text.empty() && text.back() == '\r') text.pop_back();
    std::istringstream fields_in(text);
    std::vector<std::string> fields;
    std::string field;
    while (fields_in >> field) fields.push_back(field);
    if (fields.empty() || fields[0][0] == '#') continue;
    const std::string where = path + ":" + std::to_string(line_number);
    if (fields.size() != kCamerasFields) {
      throw InputError(where + ": " + std::to_string(fields.size()) +
                       " fields; expected " + std::to_string(kCamerasFields) +
                       ": image key, K (9 values), cam2world (16 values)");
    }
    std::vector<double> values(kCamerasFields - 1);
    for (int i = 1; i < kCamerasFields; ++i) {
      if (!ParseFinite(fields[static_cast<size_t>(i)], &values[static_cast<size_t>(i - 1)])) {
        throw InputError(where + ": field " + std::to_string(i + 1) + " '" +
                         fields[static_cast<size_t>(i)] + "' is not a finite number");
      }
    }
    StereoLunarCamera camera;
    camera.key = fields[0];
    camera.line = line_number;
    camera.where = path + ":" + std::to_string(line_number);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) camera.k(r, c) = values[static_cast<size_t>(3 * r + c)];
    }
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) camera.cam2world(r, c) = values[static_cast<size_t>(9 + 4 * r + c)];
    }
    CheckCamera(camera, where);
    const auto inserted = seen.emplace(camera.key, line_number);
    if (!inserted.second) {
      throw InputError(where + ": " + camera.key + " repeats line " +
                       std::to_string(inserted.first->second));
    }
    cameras.push_back(camera);
  }
  if (in.bad()) throw InputError(path + ": read error");
  if (cameras.empty()) throw InputError(path + ": no camera line");
  return cameras;
}

StereoLunarCamera ReadStereoLunarNpzCamera(const std::string& path, const std::string& key) {
  const std::map<std::string, NpyDoubles> arrays = ReadNpzArrays(path);
  const auto array = [&](const std::string& name, std::int64_t rows, std::int64_t cols) {
    const auto it = arrays.find(name);
    if (it == arrays.end()) throw InputError(path + ": no array '" + name + "'");
    if (it->second.shape != std::vector<std::int64_t>{rows, cols}) {
      throw InputError(path + ": array '" + name + "' has shape " + FormatNpyShape(it->second.shape) +
                       "; expected (" + std::to_string(rows) + ", " + std::to_string(cols) + ")");
    }
    for (const double v : it->second.values) {
      if (!std::isfinite(v)) throw InputError(path + ": array '" + name + "' holds a value that is not finite");
    }
    return it->second.values;
  };
  const std::vector<double> k = array("intrinsics", 3, 3);
  const std::vector<double> m = array("cam2world", 4, 4);
  StereoLunarCamera camera;
  camera.key = key;
  camera.where = path;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) camera.k(r, c) = k[static_cast<size_t>(3 * r + c)];
  }
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) camera.cam2world(r, c) = m[static_cast<size_t>(4 * r + c)];
  }
  CheckCamera(camera, path);
  return camera;
}

Rigid3d LocalLevelFromMoon(const Eigen::Vector3d& ground_in_moon_m) {
  const Eigen::Vector3d up = ground_in_moon_m.normalized();
  const Eigen::Vector3d east_unnormalised = Eigen::Vector3d::UnitZ().cross(ground_in_moon_m);
  if (!(east_unnormalised.norm() >= 1.0)) {
    throw InputError("ground point (" + util::ShortestText(ground_in_moon_m.x()) + ", " +
                     util::ShortestText(ground_in_moon_m.y()) + ", " + util::ShortestText(ground_in_moon_m.z()) +
                     ") m is within 1 m of the Moon's spin axis: east is undefined there");
  }
  const Eigen::Vector3d east = east_unnormalised.normalized();
  const Eigen::Vector3d north = up.cross(east);
  Eigen::Matrix3d local_from_moon;
  local_from_moon.row(0) = east.transpose();
  local_from_moon.row(1) = north.transpose();
  local_from_moon.row(2) = up.transpose();
  const Eigen::Quaterniond rotation = Eigen::Quaterniond(local_from_moon).normalized();
  return Rigid3d(rotation, -(rotation * ground_in_moon_m));
}

Eigen::Vector2d StereoLunarCentrePixel(int width_px, int height_px) {
  return Eigen::Vector2d(width_px / 2, height_px / 2);
}

std::string DefaultStereoLunarCamerasFile(const std::string& pair_dir) {
  const fs::path inside = fs::path(pair_dir) / "cameras.txt";
  std::error_code ec;
  if (fs::exists(inside, ec)) return inside.string();
  std::error_code canon_ec;
  fs::path dir = fs::canonical(pair_dir, canon_ec);
  if (canon_ec) dir = fs::path(pair_dir).lexically_normal();
  if (!dir.has_filename()) dir = dir.parent_path();
  return (dir.parent_path() / "cameras.txt").string();
}

Dataset ConvertStereoLunarPair(const std::string& pair_dir, const std::string& cameras_txt,
                               int sun) {
  if (sun < 0) throw std::invalid_argument("ConvertStereoLunarPair: sun must be >= 0");
  const fs::path dir(pair_dir);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError(pair_dir + (fs::exists(dir, ec) ? ": is not a folder" : ": no such folder"));
  }
  const std::vector<SourceFrame> frames = ListFrames(dir);
  RequireSun(pair_dir, frames, sun);
  const std::string folder = FolderName(dir);

  PairFrames pair;
  pair.source[0] = frames[static_cast<size_t>(2 * sun)];
  pair.source[1] = frames[static_cast<size_t>(2 * sun + 1)];
  // The cameras: the given cameras.txt; else each frame's .npz, as the
  // dataset ships; else the default cameras.txt.
  std::string camera_source = cameras_txt;
  std::vector<StereoLunarCamera> cameras;
  if (cameras_txt.empty()) {
    std::error_code npz_ec;
    const fs::path npz0 = dir / (pair.source[0].stem + ".npz");
    const fs::path npz1 = dir / (pair.source[1].stem + ".npz");
    if (fs::exists(npz0, npz_ec) || fs::exists(npz1, npz_ec)) {
      for (const fs::path& npz : {npz0, npz1}) {
        if (!fs::exists(npz, npz_ec)) throw InputError(npz.string() + ": no such file");
        cameras.push_back(ReadStereoLunarNpzCamera(npz.string(), folder + "/" + npz.stem().string()));
      }
      camera_source = npz0.string();
    } else {
      camera_source = DefaultStereoLunarCamerasFile(pair_dir);
    }
  }
  if (cameras.empty()) cameras = ReadStereoLunarCameras(camera_source);
  FindPairCameras(cameras, camera_source, folder, &pair);
  ReadPairRasters(dir, &pair);
  const cv::Size size = pair.image[0].size();

  const Pinhole pinhole = PinholeFromK(pair.camera[0]->k);
  Dataset dataset(calib::CameraModel("LENSMODEL_PINHOLE",
                                     {pinhole.fx, pinhole.fy, pinhole.cx, pinhole.cy},
                                     size.width, size.height, {}, camera_source));
  Rigid3d moon_from_cam[2];
  for (int i = 0; i < 2; ++i) moon_from_cam[i] = MoonFromCam(*pair.camera[i]);

  // The local frame is level at the ground point of frame 0's centre pixel.
  const Eigen::Vector2d centre = StereoLunarCentrePixel(size.width, size.height);
  const Eigen::Vector3d centre_ray = pinhole.Ray(centre.x(), centre.y());
  double centre_depth[2];
  for (int i = 0; i < 2; ++i) centre_depth[i] = CentreDepth(dir, pair, i, centre);
  const Eigen::Vector3d ground_in_moon = moon_from_cam[0] * (centre_depth[0] * centre_ray);
  const Rigid3d local_from_moon = LocalLevelFromMoon(ground_in_moon);

  DescribeDataset(folder, sun, pair, centre_depth[0], pinhole.fx, &dataset);
  dataset.cam_from_body = Rigid3d();
  dataset.gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -kMoonGravityMps2);
  dataset.ils_in_local_m = Eigen::Vector3d::Zero();
  dataset.lrf_origin_in_body_m = Eigen::Vector3d::Zero();

  for (int i = 0; i < 2; ++i) {
    const Rigid3d local_from_cam = local_from_moon * moon_from_cam[i];
    AddFrameRecords(i, pair.image[i], local_from_cam, centre_depth[i], centre_ray, &dataset);
    TruthPoints truth;
    truth.frame = i;
    truth.file = "truth/points_00000" + std::to_string(i) + ".npy";
    truth.points_in_local_m = TruthPointsFromDepth(pair.depth[i], pinhole, local_from_cam);
    dataset.truth.points.push_back(truth);
  }
  dataset.truth.navigation_file = "truth/navigation.csv";
  return dataset;
}

}  // namespace hdabench::datasets
