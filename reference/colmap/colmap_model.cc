#include "reference/colmap/colmap_model.h"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>

#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;

struct ModelInfo {
  const char* name;
  int id;
  int num_params;
};

// COLMAP 3.8's camera models (src/base/camera_models.h), id and parameter count.
constexpr ModelInfo kModels[] = {
    {"SIMPLE_PINHOLE", 0, 3},
    {"PINHOLE", 1, 4},
    {"SIMPLE_RADIAL", 2, 4},
    {"RADIAL", 3, 5},
    {"OPENCV", 4, 8},
    {"OPENCV_FISHEYE", 5, 8},
    {"FULL_OPENCV", 6, 12},
    {"FOV", 7, 5},
    {"SIMPLE_RADIAL_FISHEYE", 8, 4},
    {"RADIAL_FISHEYE", 9, 5},
    {"THIN_PRISM_FISHEYE", 10, 12},
};

constexpr std::uint64_t kInvalidPoint3DId = std::numeric_limits<std::uint64_t>::max();

std::string ReadWholeFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string() + ": cannot open: " + std::strerror(errno));
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path.string() + ": read error");
  return data;
}

// ---------------------------------------------------------------------------
// Text

class TextLines {
 public:
  explicit TextLines(const fs::path& path) : path_(path.string()), stream_(ReadWholeFile(path)) {}

  // The next non-empty, non-comment line, split on whitespace. False at the end.
  bool NextRecord(std::vector<std::string>* tokens) {
    std::string line;
    while (NextLine(&line)) {
      const size_t first = line.find_first_not_of(" \t\r");
      if (first == std::string::npos || line[first] == '#') continue;
      *tokens = Split(line);
      return true;
    }
    return false;
  }
  // The very next line, whatever it holds (images.txt's 2D point line).
  bool NextRawLine(std::vector<std::string>* tokens) {
    std::string line;
    if (!NextLine(&line)) return false;
    *tokens = Split(line);
    return true;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(path_ + ":" + std::to_string(line_number_) + ": " + what);
  }
  const std::string& Path() const { return path_; }
  int LineNumber() const { return line_number_; }

  double Double(const std::string& token, const char* field) const {
    const char* begin = token.c_str();
    char* end = nullptr;
    errno = 0;
    const double value = std::strtod(begin, &end);
    if (end == begin || *end != '\0' || !std::isfinite(value)) {
      Fail(std::string(field) + " '" + token + "' is not a finite number");
    }
    return value;
  }
  template <typename T>
  T Integer(const std::string& token, const char* field, long long min_value,
            long long max_value) const {
    long long value = 0;
    const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || end != token.data() + token.size() || value < min_value ||
        value > max_value) {
      Fail(std::string(field) + " '" + token + "' is not an integer in [" +
           std::to_string(min_value) + ", " + std::to_string(max_value) + "]");
    }
    return static_cast<T>(value);
  }

 private:
  bool NextLine(std::string* line) {
    if (!std::getline(stream_, *line)) return false;
    ++line_number_;
    return true;
  }
  static std::vector<std::string> Split(const std::string& line) {
    std::vector<std::string> tokens;
    std::istringstream in(line);
    std::string token;
    while (in >> token) tokens.push_back(token);
    return tokens;
  }

  std::string path_;
  std::istringstream stream_;
  int line_number_ = 0;
};

constexpr long long kMaxU32 = std::numeric_limits<std::uint32_t>::max();
constexpr long long kMaxI64 = std::numeric_limits<long long>::max();

std::vector<ColmapCamera> ReadCamerasText(const fs::path& path) {
  TextLines lines(path);
  std::vector<ColmapCamera> cameras;
  std::set<std::uint32_t> ids;
  std::vector<std::string> t;
  while (lines.NextRecord(&t)) {
    if (t.size() < 4)
      lines.Fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[], got " + std::to_string(t.size()) +
                 " fields");
    ColmapCamera camera;
    camera.id = lines.Integer<std::uint32_t>(t[0], "CAMERA_ID", 0, kMaxU32);
    camera.model = t[1];
    const int count = ColmapCameraParamCount(camera.model);
    if (count < 0) lines.Fail("unknown camera model '" + camera.model + "'");
    camera.width = lines.Integer<std::uint64_t>(t[2], "WIDTH", 1, kMaxI64);
    camera.height = lines.Integer<std::uint64_t>(t[3], "HEIGHT", 1, kMaxI64);
    if (static_cast<int>(t.size()) - 4 != count) {
      lines.Fail("camera model " + camera.model + " takes " + std::to_string(count) +
                 " parameters, got " + std::to_string(t.size() - 4));
    }
    for (size_t i = 4; i < t.size(); ++i) camera.params.push_back(lines.Double(t[i], "PARAMS"));
    if (!ids.insert(camera.id).second) lines.Fail("camera " + t[0] + " appears twice");
    cameras.push_back(std::move(camera));
  }
  return cameras;
}

std::vector<ColmapImage> ReadImagesText(const fs::path& path) {
  TextLines lines(path);
  std::vector<ColmapImage> images;
  std::set<std::uint32_t> ids;
  std::vector<std::string> t;
  while (lines.NextRecord(&t)) {
    if (t.size() != 10) {
      lines.Fail("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME, got " +
                 std::to_string(t.size()) + " fields");
    }
    ColmapImage image;
    image.id = lines.Integer<std::uint32_t>(t[0], "IMAGE_ID", 0, kMaxU32);
    for (int i = 0; i < 4; ++i) image.qvec[i] = lines.Double(t[1 + i], "quaternion");
    for (int i = 0; i < 3; ++i) image.tvec[i] = lines.Double(t[5 + i], "translation");
    const double norm = std::sqrt(image.qvec[0] * image.qvec[0] + image.qvec[1] * image.qvec[1] +
                                  image.qvec[2] * image.qvec[2] + image.qvec[3] * image.qvec[3]);
    if (norm < 1e-6) lines.Fail("image " + t[0] + " has a zero quaternion");
    image.camera_id = lines.Integer<std::uint32_t>(t[8], "CAMERA_ID", 0, kMaxU32);
    image.name = t[9];
    if (!ids.insert(image.id).second) lines.Fail("image " + t[0] + " appears twice");
    std::vector<std::string> p;
    if (!lines.NextRawLine(&p)) {
      lines.Fail("image " + t[0] + ": missing the POINTS2D line after it (file ends)");
    }
    if (p.size() % 3 != 0) {
      lines.Fail("image " + t[0] + ": POINTS2D holds " + std::to_string(p.size()) +
                 " values, expected triples X Y POINT3D_ID");
    }
    for (size_t i = 0; i < p.size(); i += 3) {
      ColmapPoint2D point;
      point.xy.x() = lines.Double(p[i], "X");
      point.xy.y() = lines.Double(p[i + 1], "Y");
      point.point3D_id = lines.Integer<std::int64_t>(p[i + 2], "POINT3D_ID", -1, kMaxI64);
      image.points2D.push_back(point);
    }
    images.push_back(std::move(image));
  }
  return images;
}

std::vector<ColmapPoint3D> ReadPoints3DText(const fs::path& path) {
  TextLines lines(path);
  std::vector<ColmapPoint3D> points;
  std::set<std::uint64_t> ids;
  std::vector<std::string> t;
  while (lines.NextRecord(&t)) {
    if (t.size() < 8 || (t.size() - 8) % 2 != 0) {
      lines.Fail(
          "expected POINT3D_ID X Y Z R G B ERROR TRACK[] (pairs IMAGE_ID POINT2D_IDX), "
          "got " +
          std::to_string(t.size()) + " fields");
    }
    ColmapPoint3D point;
    point.id = lines.Integer<std::uint64_t>(t[0], "POINT3D_ID", 0, kMaxI64);
    for (int i = 0; i < 3; ++i) point.xyz[i] = lines.Double(t[1 + i], "coordinate");
    for (int i = 0; i < 3; ++i)
      point.rgb[i] = lines.Integer<std::uint8_t>(t[4 + i], "colour", 0, 255);
    point.error = lines.Double(t[7], "ERROR");
    for (size_t i = 8; i < t.size(); i += 2) {
      ColmapTrackElement element;
      element.image_id = lines.Integer<std::uint32_t>(t[i], "IMAGE_ID", 0, kMaxU32);
      element.point2D_idx = lines.Integer<std::uint32_t>(t[i + 1], "POINT2D_IDX", 0, kMaxU32);
      point.track.push_back(element);
    }
    if (!ids.insert(point.id).second) lines.Fail("point " + t[0] + " appears twice");
    points.push_back(std::move(point));
  }
  return points;
}

// ---------------------------------------------------------------------------
// Binary

class BinaryReader {
 public:
  explicit BinaryReader(const fs::path& path) : path_(path.string()), data_(ReadWholeFile(path)) {}

  template <typename T>
  T Read(const char* what) {
    if (data_.size() - offset_ < sizeof(T)) {
      Fail("truncated: " + std::string(what) + " needs " + std::to_string(sizeof(T)) + " bytes, " +
           std::to_string(data_.size() - offset_) + " left");
    }
    T value;
    std::memcpy(&value, data_.data() + offset_, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }
  double ReadFinite(const char* what) {
    const size_t at = offset_;
    const double value = Read<double>(what);
    if (!std::isfinite(value)) FailAt(at, std::string(what) + " is not finite");
    return value;
  }
  std::string ReadName() {
    const size_t end = data_.find('\0', offset_);
    if (end == std::string::npos) Fail("truncated: image name without its terminating NUL");
    std::string name = data_.substr(offset_, end - offset_);
    offset_ = end + 1;
    return name;
  }
  // A count of records of at least min_record_bytes each: more than the bytes
  // left can hold means a garbled file (and avoids huge allocations).
  std::uint64_t ReadCount(const char* what, size_t min_record_bytes) {
    const size_t at = offset_;
    const std::uint64_t count = Read<std::uint64_t>(what);
    if (min_record_bytes > 0 && count > (data_.size() - offset_) / min_record_bytes) {
      FailAt(at, "truncated or garbled: " + std::string(what) + " " + std::to_string(count) +
                     " needs at least " + std::to_string(min_record_bytes) + " bytes each, " +
                     std::to_string(data_.size() - offset_) + " left");
    }
    return count;
  }
  void ExpectEnd() const {
    if (offset_ != data_.size()) {
      Fail(std::to_string(data_.size() - offset_) + " unexpected bytes after the last record");
    }
  }
  size_t Offset() const { return offset_; }
  [[noreturn]] void Fail(const std::string& what) const { FailAt(offset_, what); }
  [[noreturn]] void FailAt(size_t at, const std::string& what) const {
    throw InputError(path_ + ": byte " + std::to_string(at) + ": " + what);
  }

 private:
  std::string path_;
  std::string data_;
  size_t offset_ = 0;
};

std::vector<ColmapCamera> ReadCamerasBinary(const fs::path& path) {
  BinaryReader in(path);
  std::vector<ColmapCamera> cameras;
  std::set<std::uint32_t> ids;
  const std::uint64_t count = in.ReadCount("number of cameras", 24);
  for (std::uint64_t i = 0; i < count; ++i) {
    const size_t start = in.Offset();
    ColmapCamera camera;
    camera.id = in.Read<std::uint32_t>("camera_id");
    const size_t model_at = in.Offset();
    const int model_id = in.Read<std::int32_t>("model_id");
    camera.model = ColmapCameraModelName(model_id);
    if (camera.model.empty()) {
      in.FailAt(model_at, "unknown camera model id " + std::to_string(model_id));
    }
    camera.width = in.Read<std::uint64_t>("width");
    camera.height = in.Read<std::uint64_t>("height");
    const int num_params = ColmapCameraParamCount(camera.model);
    for (int k = 0; k < num_params; ++k) camera.params.push_back(in.ReadFinite("camera parameter"));
    if (!ids.insert(camera.id).second) {
      in.FailAt(start, "camera " + std::to_string(camera.id) + " appears twice");
    }
    cameras.push_back(std::move(camera));
  }
  in.ExpectEnd();
  return cameras;
}

std::vector<ColmapImage> ReadImagesBinary(const fs::path& path) {
  BinaryReader in(path);
  std::vector<ColmapImage> images;
  std::set<std::uint32_t> ids;
  const std::uint64_t count = in.ReadCount("number of images", 4 + 7 * 8 + 4 + 1 + 8);
  for (std::uint64_t i = 0; i < count; ++i) {
    const size_t start = in.Offset();
    ColmapImage image;
    image.id = in.Read<std::uint32_t>("image_id");
    for (double& q : image.qvec) q = in.ReadFinite("quaternion");
    for (double& v : image.tvec) v = in.ReadFinite("translation");
    image.camera_id = in.Read<std::uint32_t>("camera_id");
    image.name = in.ReadName();
    const std::uint64_t num_points = in.ReadCount("number of 2D points", 24);
    image.points2D.reserve(num_points);
    for (std::uint64_t k = 0; k < num_points; ++k) {
      ColmapPoint2D point;
      point.xy.x() = in.ReadFinite("2D point x");
      point.xy.y() = in.ReadFinite("2D point y");
      const size_t id_at = in.Offset();
      const std::uint64_t id = in.Read<std::uint64_t>("point3D_id");
      if (id != kInvalidPoint3DId && id > static_cast<std::uint64_t>(kMaxI64)) {
        in.FailAt(id_at, "point3D_id " + std::to_string(id) + " out of range");
      }
      point.point3D_id = id == kInvalidPoint3DId ? -1 : static_cast<std::int64_t>(id);
      image.points2D.push_back(point);
    }
    if (!ids.insert(image.id).second) {
      in.FailAt(start, "image " + std::to_string(image.id) + " appears twice");
    }
    images.push_back(std::move(image));
  }
  in.ExpectEnd();
  return images;
}

std::vector<ColmapPoint3D> ReadPoints3DBinary(const fs::path& path) {
  BinaryReader in(path);
  std::vector<ColmapPoint3D> points;
  std::set<std::uint64_t> ids;
  const std::uint64_t count = in.ReadCount("number of points", 8 + 24 + 3 + 8 + 8);
  points.reserve(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    const size_t start = in.Offset();
    ColmapPoint3D point;
    point.id = in.Read<std::uint64_t>("point3D_id");
    for (int k = 0; k < 3; ++k) point.xyz[k] = in.ReadFinite("point coordinate");
    for (std::uint8_t& c : point.rgb) c = in.Read<std::uint8_t>("colour");
    point.error = in.ReadFinite("reprojection error");
    const std::uint64_t length = in.ReadCount("track length", 8);
    point.track.reserve(length);
    for (std::uint64_t k = 0; k < length; ++k) {
      ColmapTrackElement element;
      element.image_id = in.Read<std::uint32_t>("track image_id");
      element.point2D_idx = in.Read<std::uint32_t>("track point2D_idx");
      point.track.push_back(element);
    }
    if (!ids.insert(point.id).second) {
      in.FailAt(start, "point " + std::to_string(point.id) + " appears twice");
    }
    points.push_back(std::move(point));
  }
  in.ExpectEnd();
  return points;
}

// References between the three files.
void CheckReferences(const ColmapModel& model, const fs::path& dir, const std::string& ext) {
  const std::string images_file = (dir / ("images" + ext)).string();
  const std::string points_file = (dir / ("points3D" + ext)).string();
  std::set<std::uint64_t> point_ids;
  for (const ColmapPoint3D& p : model.points3D) point_ids.insert(p.id);
  for (const ColmapImage& image : model.images) {
    if (model.FindCamera(image.camera_id) == nullptr) {
      throw InputError(images_file + ": image " + std::to_string(image.id) + " uses camera " +
                       std::to_string(image.camera_id) + ", which cameras" + ext + " lacks");
    }
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      const std::int64_t id = image.points2D[k].point3D_id;
      if (id >= 0 && point_ids.count(static_cast<std::uint64_t>(id)) == 0) {
        throw InputError(images_file + ": image " + std::to_string(image.id) + ", 2D point " +
                         std::to_string(k) + " refers to 3D point " + std::to_string(id) +
                         ", which points3D" + ext + " lacks");
      }
    }
  }
  for (const ColmapPoint3D& point : model.points3D) {
    for (const ColmapTrackElement& element : point.track) {
      const ColmapImage* image = model.FindImage(element.image_id);
      if (image == nullptr) {
        throw InputError(points_file + ": point " + std::to_string(point.id) +
                         " is seen in image " + std::to_string(element.image_id) +
                         ", which images" + ext + " lacks");
      }
      if (element.point2D_idx >= image->points2D.size()) {
        throw InputError(points_file + ": point " + std::to_string(point.id) +
                         " refers to 2D point " + std::to_string(element.point2D_idx) +
                         " of image " + std::to_string(element.image_id) + ", which has " +
                         std::to_string(image->points2D.size()));
      }
    }
  }
}

void WriteFileOrThrow(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(path.string() + ": cannot write: " + std::strerror(errno));
  out << text;
  out.close();
  if (!out) throw InputError(path.string() + ": write failed");
}

}  // namespace

int ColmapCameraParamCount(const std::string& model) {
  for (const ModelInfo& info : kModels) {
    if (model == info.name) return info.num_params;
  }
  return -1;
}

int ColmapCameraModelId(const std::string& model) {
  for (const ModelInfo& info : kModels) {
    if (model == info.name) return info.id;
  }
  return -1;
}

std::string ColmapCameraModelName(int model_id) {
  for (const ModelInfo& info : kModels) {
    if (model_id == info.id) return info.name;
  }
  return "";
}

const ColmapCamera* ColmapModel::FindCamera(std::uint32_t id) const {
  for (const ColmapCamera& camera : cameras) {
    if (camera.id == id) return &camera;
  }
  return nullptr;
}

const ColmapImage* ColmapModel::FindImage(std::uint32_t id) const {
  for (const ColmapImage& image : images) {
    if (image.id == id) return &image;
  }
  return nullptr;
}

const ColmapImage* ColmapModel::FindImageByName(const std::string& name) const {
  for (const ColmapImage& image : images) {
    if (image.name == name) return &image;
  }
  return nullptr;
}

ColmapModelFormat DetectColmapModelFormat(const std::string& dir) {
  const fs::path d(dir);
  const auto all = [&d](const char* ext) {
    for (const char* stem : {"cameras", "images", "points3D"}) {
      if (!fs::is_regular_file(d / (std::string(stem) + ext))) return false;
    }
    return true;
  };
  if (all(".bin")) return ColmapModelFormat::kBinary;
  if (all(".txt")) return ColmapModelFormat::kText;
  if (!fs::is_directory(d)) throw InputError(dir + ": COLMAP model folder does not exist");
  throw InputError(dir +
                   ": no COLMAP model: expected cameras, images and points3D as "
                   ".bin (all three) or .txt (all three)");
}

ColmapModel ReadColmapModel(const std::string& dir) {
  return DetectColmapModelFormat(dir) == ColmapModelFormat::kBinary ? ReadColmapBinaryModel(dir)
                                                                    : ReadColmapTextModel(dir);
}

ColmapModel ReadColmapTextModel(const std::string& dir) {
  const fs::path d(dir);
  ColmapModel model;
  model.cameras = ReadCamerasText(d / "cameras.txt");
  model.images = ReadImagesText(d / "images.txt");
  model.points3D = ReadPoints3DText(d / "points3D.txt");
  CheckReferences(model, d, ".txt");
  return model;
}

ColmapModel ReadColmapBinaryModel(const std::string& dir) {
  const fs::path d(dir);
  ColmapModel model;
  model.cameras = ReadCamerasBinary(d / "cameras.bin");
  model.images = ReadImagesBinary(d / "images.bin");
  model.points3D = ReadPoints3DBinary(d / "points3D.bin");
  CheckReferences(model, d, ".bin");
  return model;
}

void WriteColmapTextModel(const ColmapModel& model, const std::string& dir) {
  const fs::path d(dir);
  if (!fs::is_directory(d)) throw InputError(dir + ": cannot write a COLMAP model: not a folder");

  std::ostringstream cameras;
  cameras << "# Camera list with one line of data per camera:\n"
          << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
          << "# Number of cameras: " << model.cameras.size() << "\n";
  for (const ColmapCamera& camera : model.cameras) {
    const int count = ColmapCameraParamCount(camera.model);
    if (count < 0 || static_cast<size_t>(count) != camera.params.size()) {
      throw InputError((d / "cameras.txt").string() + ": camera " + std::to_string(camera.id) +
                       ": model '" + camera.model + "' with " +
                       std::to_string(camera.params.size()) + " parameters cannot be written");
    }
    cameras << camera.id << ' ' << camera.model << ' ' << camera.width << ' ' << camera.height;
    for (double p : camera.params) cameras << ' ' << util::ShortestText(p);
    cameras << '\n';
  }

  std::ostringstream images;
  images << "# Image list with two lines of data per image:\n"
         << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
         << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
         << "# Number of images: " << model.images.size() << "\n";
  for (const ColmapImage& image : model.images) {
    bool bad_name = image.name.empty();
    for (char c : image.name) bad_name = bad_name || std::isspace(static_cast<unsigned char>(c));
    if (bad_name) {
      throw InputError((d / "images.txt").string() + ": image " + std::to_string(image.id) +
                       ": name '" + image.name + "' is empty or contains whitespace");
    }
    images << image.id;
    for (double q : image.qvec) images << ' ' << util::ShortestText(q);
    for (double t : image.tvec) images << ' ' << util::ShortestText(t);
    images << ' ' << image.camera_id << ' ' << image.name << '\n';
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      const ColmapPoint2D& p = image.points2D[k];
      images << (k > 0 ? " " : "") << util::ShortestText(p.xy.x()) << ' ' << util::ShortestText(p.xy.y()) << ' '
             << p.point3D_id;
    }
    images << '\n';
  }

  std::ostringstream points;
  points << "# 3D point list with one line of data per point:\n"
         << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
         << "# Number of points: " << model.points3D.size() << "\n";
  for (const ColmapPoint3D& p : model.points3D) {
    points << p.id << ' ' << util::ShortestText(p.xyz.x()) << ' ' << util::ShortestText(p.xyz.y()) << ' '
           << util::ShortestText(p.xyz.z()) << ' ' << int{p.rgb[0]} << ' ' << int{p.rgb[1]} << ' '
           << int{p.rgb[2]} << ' ' << util::ShortestText(p.error);
    for (const ColmapTrackElement& e : p.track) points << ' ' << e.image_id << ' ' << e.point2D_idx;
    points << '\n';
  }

  WriteFileOrThrow(d / "cameras.txt", cameras.str());
  WriteFileOrThrow(d / "images.txt", images.str());
  WriteFileOrThrow(d / "points3D.txt", points.str());
}

}  // namespace hdabench::reference
