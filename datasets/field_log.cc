#include "datasets/field_log.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/images/codecs.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/text.h"
#include "datasets/internal/csv.h"

namespace hdabench::datasets {

namespace {

// The largest length a field log may give (positions, heights, offsets,
// ranges): ten thousand kilometres is beyond any campaign, and keeps every
// product and difference of them far from overflow.
constexpr double kMaxLengthM = 1e7;

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr double kWgs84A = 6378137.0;
constexpr double kWgs84F = 1.0 / 298.257223563;
constexpr double kWgs84E2 = kWgs84F * (2.0 - kWgs84F);
constexpr double kDegToRad = util::kDegToRad;
constexpr int kMaxListedProblems = 20;

// ---------------------------------------------------------------------------
// The description file

std::string Text(const std::string& path) {
  std::string bytes;
  std::string error;
  if (!util::ReadFileBytes(path, &bytes, &error)) throw InputError(path + ": " + error);
  return bytes;
}

// Field access that names the path of the field: "log.json: navigation.position.frame".
class Fields {
 public:
  // `root`: `where` is the file, and keys follow ": "; else a key path, and keys follow ".".
  Fields(const Json& j, std::string where, bool root = false) : j_(j), where_(std::move(where)), root_(root) {}
  bool Has(const std::string& key) const { return j_.contains(key); }
  std::string Where(const std::string& key) const { return where_ + (root_ ? ": " : ".") + key; }
  const Json& Value(const std::string& key) const { return j_.at(key); }
  const std::string& Path() const { return where_; }
  Fields Object(const std::string& key) const {
    if (!j_.contains(key) || !j_.at(key).is_object()) throw InputError(Where(key) + ": expected an object");
    return Fields(j_.at(key), Where(key));
  }
  std::string String(const std::string& key) const {
    if (!j_.contains(key) || !j_.at(key).is_string() || j_.at(key).get<std::string>().empty()) {
      throw InputError(Where(key) + ": expected a non-empty string");
    }
    return j_.at(key).get<std::string>();
  }
  double Number(const std::string& key) const {
    if (!j_.contains(key) || !j_.at(key).is_number() || !std::isfinite(j_.at(key).get<double>())) {
      throw InputError(Where(key) + ": expected a finite number");
    }
    return j_.at(key).get<double>();
  }
  double Number(const std::string& key, double fallback) const { return Has(key) ? Number(key) : fallback; }
  std::vector<std::string> Strings(const std::string& key, size_t count) const {
    if (!j_.contains(key) || !j_.at(key).is_array() || j_.at(key).size() != count) {
      throw InputError(Where(key) + ": expected a list of " + std::to_string(count) + " column names");
    }
    std::vector<std::string> out;
    for (const Json& v : j_.at(key)) {
      if (!v.is_string() || v.get<std::string>().empty()) {
        throw InputError(Where(key) + ": expected a list of " + std::to_string(count) + " column names");
      }
      out.push_back(v.get<std::string>());
    }
    return out;
  }
  // Vector3 of lengths, each within kMaxLengthM.
  Eigen::Vector3d Lengths(const std::string& key) const {
    const Eigen::Vector3d v = Vector3(key);
    if (v.cwiseAbs().maxCoeff() > kMaxLengthM) {
      throw InputError(Where(key) + ": expected lengths within +-" + util::ShortestText(kMaxLengthM) + " m");
    }
    return v;
  }
  Eigen::Vector3d Vector3(const std::string& key) const {
    if (!j_.contains(key) || !j_.at(key).is_array() || j_.at(key).size() != 3) {
      throw InputError(Where(key) + ": expected a list of 3 numbers");
    }
    Eigen::Vector3d v;
    for (int i = 0; i < 3; ++i) {
      if (!j_.at(key)[i].is_number() || !std::isfinite(j_.at(key)[i].get<double>())) {
        throw InputError(Where(key) + ": expected a list of 3 finite numbers");
      }
      v[i] = j_.at(key)[i].get<double>();
    }
    return v;
  }
  void OnlyKeys(const std::set<std::string>& allowed) const {
    for (const auto& item : j_.items()) {
      if (allowed.count(item.key()) == 0) {
        std::string list;
        for (const std::string& a : allowed) list += (list.empty() ? "" : ", ") + a;
        throw InputError(Where(item.key()) + ": unknown field; expected " + list);
      }
    }
  }
  std::string OneOf(const std::string& key, const std::vector<std::string>& choices) const {
    const std::string value = String(key);
    if (std::find(choices.begin(), choices.end(), value) == choices.end()) {
      std::string list;
      for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
      throw InputError(Where(key) + ": '" + value + "' is not a known convention; expected one of " + list);
    }
    return value;
  }

 private:
  const Json& j_;
  std::string where_;
  bool root_ = false;
};

// ---------------------------------------------------------------------------
// Tables

// A table's rows with the problems of every row collected; throws listing
// them (at most kMaxListedProblems) when there is any.
struct Table {
  std::string file;
  internal::CsvTable csv;
};

void ThrowProblems(const std::vector<Problem>& problems) {
  if (problems.empty()) return;
  std::string text = std::to_string(problems.size()) + " problem(s) in the field log:";
  for (size_t i = 0; i < problems.size() && i < static_cast<size_t>(kMaxListedProblems); ++i) {
    text += "\n  " + problems[i].ToString();
  }
  if (problems.size() > static_cast<size_t>(kMaxListedProblems)) {
    text += "\n  ... and " + std::to_string(problems.size() - kMaxListedProblems) + " more";
  }
  throw InputError(text);
}

Table ReadTable(const std::string& path, const std::vector<std::string>& columns) {
  Table table;
  table.file = path;
  internal::CsvSchema schema;
  schema.required = columns;
  schema.allow_other_columns = true;
  std::vector<Problem> problems;
  internal::ParseCsv(path, Text(path), schema, &table.csv, &problems);
  ThrowProblems(problems);
  if (table.csv.rows.empty()) throw InputError(path + ": no data row");
  return table;
}

// Times strictly increasing, each problem at its line.
void CheckIncreasing(const std::string& file, const std::vector<int>& lines, const std::vector<double>& times,
                     std::vector<Problem>* problems) {
  for (size_t i = 1; i < times.size(); ++i) {
    if (!(times[i] > times[i - 1])) {
      problems->push_back({file + ":" + std::to_string(lines[i]),
                           "time " + util::ShortestText(times[i]) + " s is not after the previous row's " +
                               util::ShortestText(times[i - 1]) + " s (line " + std::to_string(lines[i - 1]) +
                               "): times must increase"});
    }
  }
}

// ---------------------------------------------------------------------------
// Images and their times

struct ImageFile {
  std::string path;   // as found
  std::string where;  // file:line of its time, or the file name it was read from
  double camera_time_s = 0.0;
};

// Files of `folder` whose name matches `pattern` ("frame_{time_ns}.png"):
// one placeholder, {time_s} (a decimal number), {time_ms}, {time_us} or
// {time_ns} (whole numbers); the rest literal.
std::vector<ImageFile> ImagesFromPattern(const fs::path& folder, const std::string& pattern,
                                         const std::string& where) {
  static const std::vector<std::pair<std::string, double>> units = {
      {"{time_s}", 1.0}, {"{time_ms}", 1e-3}, {"{time_us}", 1e-6}, {"{time_ns}", 1e-9}};
  size_t at = std::string::npos;
  std::string placeholder;
  double scale = 1.0;
  for (const auto& [name, s] : units) {
    const size_t found = pattern.find(name);
    if (found == std::string::npos) continue;
    if (at != std::string::npos || pattern.find(name, found + 1) != std::string::npos) {
      throw InputError(where + ": '" + pattern + "' has more than one time placeholder");
    }
    at = found;
    placeholder = name;
    scale = s;
  }
  if (at == std::string::npos) {
    throw InputError(where + ": '" + pattern +
                     "' has no time placeholder; expected one of {time_s}, {time_ms}, {time_us}, {time_ns}");
  }
  const std::string prefix = pattern.substr(0, at);
  const std::string suffix = pattern.substr(at + placeholder.size());
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) throw InputError(folder.string() + ": no such folder (the images)");
  std::vector<ImageFile> images;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.size() <= prefix.size() + suffix.size() || name.compare(0, prefix.size(), prefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0) {
      continue;
    }
    const std::string digits = name.substr(prefix.size(), name.size() - prefix.size() - suffix.size());
    double value = 0.0;
    bool ok = false;
    if (placeholder == "{time_s}") {
      ok = util::ParseDouble(digits, &value) == util::ParseStatus::kOk;
    } else {
      // Whole numbers, optionally negative, within 64 bits (epoch nanoseconds have 19 digits).
      std::int64_t whole = 0;
      const char* digits_end = digits.data() + digits.size();
      const std::from_chars_result parsed = std::from_chars(digits.data(), digits_end, whole);
      ok = !digits.empty() && parsed.ec == std::errc() && parsed.ptr == digits_end;
      value = static_cast<double>(whole);
    }
    if (!ok) {
      throw InputError((folder / name).string() + ": the name matches '" + pattern + "' but '" + digits +
                       "' is not a time for " + placeholder);
    }
    images.push_back({(folder / name).string(), (folder / name).string(), value * scale});
  }
  if (images.empty()) throw InputError(folder.string() + ": no file matches '" + pattern + "'");
  std::sort(images.begin(), images.end(),
            [](const ImageFile& a, const ImageFile& b) { return a.camera_time_s < b.camera_time_s; });
  for (size_t i = 1; i < images.size(); ++i) {
    if (images[i].camera_time_s == images[i - 1].camera_time_s) {
      throw InputError(images[i].path + ": the same time as " + images[i - 1].path);
    }
  }
  return images;
}

std::vector<ImageFile> ImagesFromCsv(const fs::path& folder, const std::string& csv_path,
                                     const std::string& file_column, const std::string& time_column,
                                     double time_scale) {
  const Table table = ReadTable(csv_path, {file_column, time_column});
  std::vector<Problem> problems;
  std::vector<ImageFile> images;
  std::vector<int> lines;
  std::vector<double> times;
  std::set<std::string> listed;
  std::map<std::string, int> line_of_file;  // by the file's resolved path: one image, one frame
  for (const internal::CsvRow& row : table.csv.rows) {
    internal::CsvRowReader reader(csv_path, table.csv, row, &problems);
    const std::string file = reader.Text(file_column);
    const double time = reader.Double(time_column) * time_scale;
    if (!reader.ok()) continue;
    std::error_code ec;
    const fs::path path = folder / file;
    if (!fs::is_regular_file(path, ec)) {
      reader.Fail("image '" + file + "' not found in " + folder.string());
      continue;
    }
    const fs::path resolved = fs::weakly_canonical(path, ec);
    const auto [first, inserted] = line_of_file.emplace(ec ? path.string() : resolved.string(), row.line);
    if (!inserted) {
      reader.Fail("image '" + file + "' is listed already at line " + std::to_string(first->second) +
                  ": one image is one frame");
      continue;
    }
    listed.insert(fs::path(file).filename().string());
    images.push_back({path.string(), reader.Where(), time});
    lines.push_back(row.line);
    times.push_back(time);
  }
  CheckIncreasing(csv_path, lines, times, &problems);
  // An image of the folder that the table does not list has no time.
  std::error_code ec;
  static const std::set<std::string> kImageExtensions = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".pgm", ".bmp"};
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    std::string extension = it->path().extension().string();
    std::transform(extension.begin(), extension.end(), extension.begin(), [](unsigned char c) { return std::tolower(c); });
    if (kImageExtensions.count(extension) == 0) continue;
    if (listed.count(it->path().filename().string()) == 0) {
      problems.push_back({it->path().string(), "image without a time: not listed in " + csv_path});
    }
  }
  ThrowProblems(problems);
  return images;
}

cv::Mat ReadGreyImage(const ImageFile& image, std::vector<std::string>* notes) {
  std::string error;
  cv::Mat pixels = images::ReadWholeImage(image.path, cv::IMREAD_UNCHANGED, &error);
  if (pixels.empty()) throw InputError(image.path + ": " + error);
  if (pixels.depth() != CV_8U && pixels.depth() != CV_16U) {
    throw InputError(image.path + ": pixels are neither 8-bit nor 16-bit");
  }
  if (pixels.channels() == 3 || pixels.channels() == 4) {
    cv::Mat grey;
    cv::cvtColor(pixels, grey, pixels.channels() == 3 ? cv::COLOR_BGR2GRAY : cv::COLOR_BGRA2GRAY);
    if (notes->empty() || notes->back().find("colour") == std::string::npos) {
      notes->push_back("colour images converted to grey (OpenCV's BT.601 weights), first: " + image.path);
    }
    pixels = grey;
  } else if (pixels.channels() != 1) {
    throw InputError(image.path + ": " + std::to_string(pixels.channels()) + " channels; expected 1 or 3");
  }
  return pixels;
}

// ---------------------------------------------------------------------------
// Navigation

struct NavConvention {
  std::string position_frame;  // "wgs84", "enu", "ned"
  std::vector<std::string> position_columns;
  std::string attitude_kind;   // "euler_zyx_deg", "quaternion_wxyz", "quaternion_xyzw"
  std::string attitude_frame;  // "ned", "enu"
  std::vector<std::string> attitude_columns;
};

const Eigen::Matrix3d& EnuFromNed() {
  static const Eigen::Matrix3d m = (Eigen::Matrix3d() << 0, 1, 0, 1, 0, 0, 0, 0, -1).finished();
  return m;
}

Eigen::Quaterniond ProjectToRotation(const Eigen::Matrix3d& m) {
  return Eigen::Quaterniond(m).normalized();
}

std::string Resolve(const fs::path& base, const std::string& relative) {
  return (base / relative).lexically_normal().string();
}

double TimeScale(const Fields& f) {
  static const std::map<std::string, double> units = {{"s", 1.0}, {"ms", 1e-3}, {"us", 1e-6}, {"ns", 1e-9}};
  if (!f.Has("time_unit")) return 1.0;
  return units.at(f.OneOf("time_unit", {"s", "ms", "us", "ns"}));
}

// The camera on the body: "mount" as pointing angles or a matrix.
struct Mount {
  Eigen::Quaterniond body_from_cam = Eigen::Quaterniond::Identity();
  Eigen::Vector3d cam_in_body = Eigen::Vector3d::Zero();
};

Mount ReadMount(const Fields& top) {
  const Fields mount = top.Object("mount");
  mount.OnlyKeys({"azimuth_deg", "depression_deg", "roll_deg", "body_from_cam", "position_in_body_m"});
  Eigen::Matrix3d body_from_cam;
  if (mount.Has("body_from_cam")) {
    if (mount.Has("azimuth_deg") || mount.Has("depression_deg") || mount.Has("roll_deg")) {
      throw InputError(mount.Where("body_from_cam") + ": give either the pointing angles or the matrix");
    }
    const std::string bad = mount.Where("body_from_cam") + ": expected 3 rows of 3 numbers";
    const Json& m = mount.Value("body_from_cam");
    if (!m.is_array() || m.size() != 3) throw InputError(bad);
    for (int r = 0; r < 3; ++r) {
      if (!m[r].is_array() || m[r].size() != 3) throw InputError(bad);
      for (int c = 0; c < 3; ++c) {
        if (!m[r][c].is_number()) throw InputError(bad);
        body_from_cam(r, c) = m[r][c].get<double>();
      }
    }
    const double error = (body_from_cam.transpose() * body_from_cam - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
    if (!(error < 1e-6) || !(body_from_cam.determinant() > 0)) {
      throw InputError(mount.Where("body_from_cam") + ": not a rotation (orthonormal within 1e-6, det +1)");
    }
  } else {
    body_from_cam = BodyFromCamPointing(mount.Number("azimuth_deg"), mount.Number("depression_deg"),
                                        mount.Number("roll_deg", 0.0));
  }
  Mount out;
  out.body_from_cam = ProjectToRotation(body_from_cam);
  if (mount.Has("position_in_body_m")) out.cam_in_body = mount.Lengths("position_in_body_m");
  return out;
}

// One navigation row as logged: position and attitude in the table's conventions.
struct RawNav {
  int line;
  double time_s;
  Eigen::Vector3d position;  // geodetic (lat, lon, h) or local ENU/NED metres
  Eigen::Matrix3d frame_from_body;
};

struct NavLog {
  NavConvention convention;
  std::vector<RawNav> rows;  // strictly increasing times, at least 2
  double max_gap_s = 1.0;
};

// "navigation": its conventions and every row, each malformed row named.
NavLog ReadNavigation(const Fields& top, const fs::path& base) {
  const Fields nav_fields = top.Object("navigation");
  nav_fields.OnlyKeys({"csv", "time_column", "time_unit", "position", "attitude", "max_gap_s"});
  const Fields position_fields = nav_fields.Object("position");
  position_fields.OnlyKeys({"frame", "columns"});
  const Fields attitude = nav_fields.Object("attitude");
  attitude.OnlyKeys({"kind", "frame", "columns"});
  NavLog log;
  NavConvention& convention = log.convention;
  convention.position_frame = position_fields.OneOf("frame", {"wgs84", "enu", "ned"});
  convention.position_columns = position_fields.Strings("columns", 3);
  convention.attitude_kind = attitude.OneOf("kind", {"euler_zyx_deg", "quaternion_wxyz", "quaternion_xyzw"});
  convention.attitude_frame = attitude.OneOf("frame", {"ned", "enu"});
  convention.attitude_columns =
      attitude.Strings("columns", convention.attitude_kind == "euler_zyx_deg" ? 3 : 4);
  const double time_scale = TimeScale(nav_fields);
  log.max_gap_s = nav_fields.Number("max_gap_s", 1.0);
  if (!(log.max_gap_s > 0)) throw InputError(nav_fields.Where("max_gap_s") + ": expected > 0");
  const std::string path = Resolve(base, nav_fields.String("csv"));
  const std::string time_column = nav_fields.String("time_column");
  std::vector<std::string> columns = {time_column};
  columns.insert(columns.end(), convention.position_columns.begin(), convention.position_columns.end());
  columns.insert(columns.end(), convention.attitude_columns.begin(), convention.attitude_columns.end());
  const Table table = ReadTable(path, columns);

  std::vector<Problem> problems;
  for (const internal::CsvRow& row : table.csv.rows) {
    internal::CsvRowReader reader(path, table.csv, row, &problems);
    RawNav n;
    n.line = row.line;
    n.time_s = reader.Double(time_column) * time_scale;
    for (int i = 0; i < 3; ++i) n.position[i] = reader.Double(convention.position_columns[static_cast<size_t>(i)]);
    std::vector<double> a;
    for (const std::string& c : convention.attitude_columns) a.push_back(reader.Double(c));
    if (!reader.ok()) continue;
    if (convention.position_frame == "wgs84" && (std::abs(n.position[0]) > 90.0 || std::abs(n.position[1]) > 360.0)) {
      reader.Fail("latitude " + util::ShortestText(n.position[0]) + " or longitude " +
                  util::ShortestText(n.position[1]) + " deg out of range");
      continue;
    }
    const double length = convention.position_frame == "wgs84" ? std::abs(n.position[2]) : n.position.cwiseAbs().maxCoeff();
    if (length > kMaxLengthM) {
      reader.Fail("position " + util::ShortestText(length) + " m from the frame's origin; expected within " +
                  util::ShortestText(kMaxLengthM) + " m");
      continue;
    }
    if (convention.attitude_kind == "euler_zyx_deg") {
      n.frame_from_body = FrameFromBodyZyx(a[0], a[1], a[2]);
    } else {
      const bool w_first = convention.attitude_kind == "quaternion_wxyz";
      const Eigen::Quaterniond q = w_first ? Eigen::Quaterniond(a[0], a[1], a[2], a[3])
                                           : Eigen::Quaterniond(a[3], a[0], a[1], a[2]);
      if (!(std::abs(q.norm() - 1.0) <= 1e-3)) {
        reader.Fail("quaternion norm " + util::ShortestText(q.norm()) + "; expected 1 within 1e-3");
        continue;
      }
      n.frame_from_body = q.normalized().toRotationMatrix();
    }
    log.rows.push_back(n);
  }
  std::vector<int> lines;
  std::vector<double> times;
  for (const RawNav& n : log.rows) {
    lines.push_back(n.line);
    times.push_back(n.time_s);
  }
  CheckIncreasing(path, lines, times, &problems);
  ThrowProblems(problems);
  if (log.rows.size() < 2) {
    throw InputError(path + ": " + std::to_string(log.rows.size()) + " row(s); at least 2 needed");
  }
  return log;
}

// The local frame (ENU at the origin for wgs84, else the table's own axes),
// gravity there, and the navigation samples in it.
void PlaceNavigation(const Fields& top, const NavLog& log, FieldIngestReport* report, Dataset* dataset) {
  const NavConvention& convention = log.convention;
  Geodetic origin;
  Eigen::Matrix3d local_from_ecef = Eigen::Matrix3d::Identity();
  Eigen::Vector3d origin_ecef = Eigen::Vector3d::Zero();
  double gravity = 9.80665;
  std::string gravity_why = "standard gravity 9.80665 m/s^2 (positions in a local frame: no latitude)";
  if (convention.position_frame == "wgs84") {
    if (top.Has("origin")) {
      const Fields o = top.Object("origin");
      o.OnlyKeys({"lat_deg", "lon_deg", "height_m"});
      origin = {o.Number("lat_deg"), o.Number("lon_deg"), o.Number("height_m")};
      if (std::abs(origin.lat_deg) > 90.0) throw InputError(o.Where("lat_deg") + ": expected -90 to 90 degrees");
      if (std::abs(origin.lon_deg) > 360.0) throw InputError(o.Where("lon_deg") + ": expected -360 to 360 degrees");
      if (std::abs(origin.height_m) > kMaxLengthM) {
        throw InputError(o.Where("height_m") + ": expected within +-" + util::ShortestText(kMaxLengthM) + " m");
      }
    } else {
      const Eigen::Vector3d& first = log.rows.front().position;
      origin = {first[0], first[1], first[2]};
    }
    local_from_ecef = EnuFromEcef(origin.lat_deg, origin.lon_deg);
    origin_ecef = EcefFromGeodetic(origin);
    gravity = NormalGravityMps2(origin.lat_deg, origin.height_m);
    gravity_why = "WGS84 normal gravity at the origin: " + util::ShortestText(gravity) + " m/s^2";
    report->lines.push_back("local frame: east-north-up at lat " + util::ShortestText(origin.lat_deg) + " deg, lon " +
                            util::ShortestText(origin.lon_deg) + " deg, height " + util::ShortestText(origin.height_m) +
                            " m (WGS84)" + (top.Has("origin") ? "" : ", the first navigation sample"));
  } else {
    if (top.Has("origin")) throw InputError(top.Where("origin") + ": only for wgs84 positions");
    report->lines.push_back(std::string("local frame: east-north-up, the navigation table's ") +
                            (convention.position_frame == "ned" ? "north-east-down axes turned to ENU" : "axes"));
  }
  if (top.Has("gravity_mps2")) {
    gravity = top.Number("gravity_mps2");
    if (!(gravity > 0 && gravity <= 100)) throw InputError(top.Where("gravity_mps2") + ": expected > 0 and at most 100");
    gravity_why = "given: " + util::ShortestText(gravity) + " m/s^2";
  }
  report->lines.push_back("gravity: " + gravity_why);
  dataset->gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -gravity);

  for (const RawNav& n : log.rows) {
    NavSample s;
    s.time_s = n.time_s;
    Eigen::Vector3d position;
    Eigen::Matrix3d local_from_frame;
    if (convention.position_frame == "wgs84") {
      const Geodetic g{n.position[0], n.position[1], n.position[2]};
      position = local_from_ecef * (EcefFromGeodetic(g) - origin_ecef);
      // The attitude's NED or ENU axes are those at the sample's own position.
      const Eigen::Matrix3d ecef_from_enu_here = EnuFromEcef(g.lat_deg, g.lon_deg).transpose();
      local_from_frame = local_from_ecef * ecef_from_enu_here *
                         (convention.attitude_frame == "ned" ? EnuFromNed() : Eigen::Matrix3d::Identity());
    } else {
      position = convention.position_frame == "ned" ? Eigen::Vector3d(EnuFromNed() * n.position) : n.position;
      local_from_frame = convention.attitude_frame == "ned" ? EnuFromNed() : Eigen::Matrix3d::Identity();
    }
    s.local_from_body = Rigid3d(ProjectToRotation(local_from_frame * n.frame_from_body), position);
    dataset->nav.push_back(s);
  }
}

// "lrf": the samples, the beam (default: the optical axis) and its origin
// (default: the camera's centre).
void ReadLrf(const Fields& top, const fs::path& base, const Mount& mount, FieldIngestReport* report,
             Dataset* dataset) {
  const Fields lrf_fields = top.Object("lrf");
  lrf_fields.OnlyKeys({"csv", "time_column", "time_unit", "range_column", "beam_in_body", "origin_in_body_m"});
  const std::string path = Resolve(base, lrf_fields.String("csv"));
  const std::string time_column = lrf_fields.String("time_column");
  const std::string range_column = lrf_fields.String("range_column");
  const double time_scale = TimeScale(lrf_fields);
  Eigen::Vector3d beam = mount.body_from_cam * Eigen::Vector3d::UnitZ();
  if (lrf_fields.Has("beam_in_body")) {
    beam = lrf_fields.Vector3("beam_in_body");
    if (!(beam.cwiseAbs().maxCoeff() > 0)) throw InputError(lrf_fields.Where("beam_in_body") + ": a zero vector");
    beam /= beam.cwiseAbs().maxCoeff();  // a direction: scaled first, so that its norm cannot overflow
    beam.normalize();
  }
  dataset->lrf_origin_in_body_m =
      lrf_fields.Has("origin_in_body_m") ? lrf_fields.Lengths("origin_in_body_m") : mount.cam_in_body;
  const Table table = ReadTable(path, {time_column, range_column});
  std::vector<Problem> problems;
  std::vector<int> lines;
  std::vector<double> times;
  for (const internal::CsvRow& row : table.csv.rows) {
    internal::CsvRowReader reader(path, table.csv, row, &problems);
    LrfSample s;
    s.time_s = reader.Double(time_column) * time_scale;
    s.range_m = reader.Double(range_column);
    s.boresight_in_body = beam;
    if (!reader.ok()) continue;
    if (!(s.range_m > 0 && s.range_m <= kMaxLengthM)) {
      reader.Fail("range " + util::ShortestText(s.range_m) + " m; expected > 0 and at most " +
                  util::ShortestText(kMaxLengthM) + " m");
      continue;
    }
    dataset->lrf.push_back(s);
    lines.push_back(row.line);
    times.push_back(s.time_s);
  }
  CheckIncreasing(path, lines, times, &problems);
  ThrowProblems(problems);
  report->lines.push_back(
      "LRF: " + std::to_string(dataset->lrf.size()) + " samples, beam in body (" + util::ShortestText(beam.x()) + ", " +
      util::ShortestText(beam.y()) + ", " + util::ShortestText(beam.z()) + ")" +
      (lrf_fields.Has("beam_in_body") ? "" : " (the camera's optical axis)"));
}

// Why a frame at navigation time t is left out (empty: kept): outside the
// navigation or LRF span, or in a navigation gap longer than max_gap_s.
std::string WhyLeftOut(const Dataset& dataset, double t, double max_gap_s) {
  const double nav_begin = dataset.nav.front().time_s, nav_end = dataset.nav.back().time_s;
  if (t < nav_begin || t > nav_end) {
    return "outside the navigation span [" + util::ShortestText(nav_begin) + ", " + util::ShortestText(nav_end) + "] s";
  }
  // Without LRF samples (a log without "lrf") there is no LRF span to leave.
  if (!dataset.lrf.empty()) {
    const double lrf_begin = dataset.lrf.front().time_s, lrf_end = dataset.lrf.back().time_s;
    if (t < lrf_begin || t > lrf_end) {
      return "outside the LRF span [" + util::ShortestText(lrf_begin) + ", " + util::ShortestText(lrf_end) + "] s";
    }
  }
  const auto after = std::lower_bound(dataset.nav.begin(), dataset.nav.end(), t,
                                      [](const NavSample& s, double time) { return s.time_s < time; });
  if (after != dataset.nav.begin() && after->time_s != t && after->time_s - (after - 1)->time_s > max_gap_s) {
    return "in a navigation gap of " + util::ShortestText(after->time_s - (after - 1)->time_s) + " s (" +
           util::ShortestText((after - 1)->time_s) + " to " + util::ShortestText(after->time_s) +
           " s; max_gap_s " + util::ShortestText(max_gap_s) + ")";
  }
  return "";
}

// "images" and "clock_offset_s": the frames inside the logs, with their
// pixels; the others reported.
void AddFrames(const Fields& top, const fs::path& base, double max_gap_s, const std::string& model_path,
               FieldIngestReport* report, Dataset* dataset) {
  const Fields images = top.Object("images");
  images.OnlyKeys({"folder", "pattern", "times_csv", "file_column", "time_column", "time_unit"});
  const fs::path folder = Resolve(base, images.String("folder"));
  std::vector<ImageFile> files;
  if (images.Has("pattern") == images.Has("times_csv")) {
    throw InputError(images.Where("pattern") + ": give exactly one of 'pattern' and 'times_csv'");
  }
  if (images.Has("pattern")) {
    files = ImagesFromPattern(folder, images.String("pattern"), images.Where("pattern"));
  } else {
    files = ImagesFromCsv(folder, Resolve(base, images.String("times_csv")), images.String("file_column"),
                          images.String("time_column"), TimeScale(images));
  }
  const double offset_s = top.Number("clock_offset_s", 0.0);
  report->frames_found = static_cast<int>(files.size());
  report->lines.push_back("images: " + std::to_string(files.size()) + " in " + folder.string() +
                          "; navigation time = image time + " + util::ShortestText(offset_s) + " s");
  std::vector<std::string> notes;
  for (const ImageFile& file : files) {
    const double t = file.camera_time_s + offset_s;
    const std::string dropped = WhyLeftOut(*dataset, t, max_gap_s);
    if (!dropped.empty()) {
      report->lines.push_back("left out: " + file.where + " at " + util::ShortestText(t) + " s: " + dropped);
      continue;
    }
    FrameRecord frame;
    frame.index = static_cast<int>(dataset->frames.size());
    frame.time_s = t;
    char name[32];
    std::snprintf(name, sizeof(name), "images/frame_%06d.png", frame.index);
    frame.image_path = name;
    frame.image = ReadGreyImage(file, &notes);
    if (frame.image.cols != dataset->camera.WidthPx() || frame.image.rows != dataset->camera.HeightPx()) {
      throw InputError(file.path + ": " + std::to_string(frame.image.cols) + " x " + std::to_string(frame.image.rows) +
                       " px; the camera model " + model_path + " is " + std::to_string(dataset->camera.WidthPx()) +
                       " x " + std::to_string(dataset->camera.HeightPx()));
    }
    if (!dataset->frames.empty() && frame.image.type() != dataset->frames.front().image.type()) {
      throw InputError(file.path + ": a different bit depth from " + files.front().path);
    }
    dataset->frames.push_back(std::move(frame));
  }
  report->lines.insert(report->lines.end(), notes.begin(), notes.end());
  report->frames_kept = static_cast<int>(dataset->frames.size());
  if (dataset->frames.size() < 2) {
    throw InputError(top.Path() + ": " + std::to_string(dataset->frames.size()) + " of " +
                     std::to_string(files.size()) +
                     " image(s) fall inside the navigation and LRF spans; the flight method needs 2" +
                     (report->lines.empty() ? "" : " (" + report->lines.back() + ")"));
  }
}

}  // namespace

// ---------------------------------------------------------------------------

Eigen::Vector3d EcefFromGeodetic(const Geodetic& p) {
  const double lat = p.lat_deg * kDegToRad, lon = p.lon_deg * kDegToRad;
  const double s = std::sin(lat), c = std::cos(lat);
  const double n = kWgs84A / std::sqrt(1.0 - kWgs84E2 * s * s);
  return {(n + p.height_m) * c * std::cos(lon), (n + p.height_m) * c * std::sin(lon),
          (n * (1.0 - kWgs84E2) + p.height_m) * s};
}

Geodetic GeodeticFromEcef(const Eigen::Vector3d& e) {
  const double p = std::hypot(e.x(), e.y());
  Geodetic out;
  out.lon_deg = std::atan2(e.y(), e.x()) / kDegToRad;
  double lat = std::atan2(e.z(), p * (1.0 - kWgs84E2));
  double height = 0.0;
  for (int i = 0; i < 10; ++i) {
    const double s = std::sin(lat);
    const double n = kWgs84A / std::sqrt(1.0 - kWgs84E2 * s * s);
    height = std::abs(std::cos(lat)) > 1e-12 ? p / std::cos(lat) - n : std::abs(e.z()) - n * (1.0 - kWgs84E2);
    lat = std::atan2(e.z(), p * (1.0 - kWgs84E2 * n / (n + height)));
  }
  out.lat_deg = lat / kDegToRad;
  out.height_m = height;
  return out;
}

Eigen::Matrix3d EnuFromEcef(double lat_deg, double lon_deg) {
  const double lat = lat_deg * kDegToRad, lon = lon_deg * kDegToRad;
  const double sl = std::sin(lat), cl = std::cos(lat), so = std::sin(lon), co = std::cos(lon);
  Eigen::Matrix3d m;
  m << -so, co, 0.0,            //
      -sl * co, -sl * so, cl,   //
      cl * co, cl * so, sl;
  return m;
}

double NormalGravityMps2(double lat_deg, double height_m) {
  constexpr double kGammaEquator = 9.7803253359;
  constexpr double kSomiglianaK = 0.00193185265241;
  constexpr double kM = 0.00344978650684;  // omega^2 a^2 b / GM
  const double s2 = std::pow(std::sin(lat_deg * kDegToRad), 2);
  const double surface = kGammaEquator * (1.0 + kSomiglianaK * s2) / std::sqrt(1.0 - kWgs84E2 * s2);
  return surface * (1.0 - 2.0 / kWgs84A * (1.0 + kWgs84F + kM - 2.0 * kWgs84F * s2) * height_m +
                    3.0 * height_m * height_m / (kWgs84A * kWgs84A));
}

Eigen::Matrix3d FrameFromBodyZyx(double yaw_deg, double pitch_deg, double roll_deg) {
  return (Eigen::AngleAxisd(yaw_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch_deg * kDegToRad, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d ZyxAnglesDeg(const Eigen::Matrix3d& r) {
  const double pitch = std::asin(std::clamp(-r(2, 0), -1.0, 1.0));
  const double yaw = std::atan2(r(1, 0), r(0, 0));
  const double roll = std::atan2(r(2, 1), r(2, 2));
  return Eigen::Vector3d(yaw, pitch, roll) / kDegToRad;
}

Eigen::Matrix3d BodyFromCamPointing(double azimuth_deg, double depression_deg, double roll_deg) {
  // A forward-looking camera: image x = body y, image y = body z, optical axis = body x.
  Eigen::Matrix3d forward;
  forward.col(0) = Eigen::Vector3d::UnitY();
  forward.col(1) = Eigen::Vector3d::UnitZ();
  forward.col(2) = Eigen::Vector3d::UnitX();
  return (Eigen::AngleAxisd(azimuth_deg * kDegToRad, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(-depression_deg * kDegToRad, Eigen::Vector3d::UnitY()))
             .toRotationMatrix() *
         forward * Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

Dataset IngestFieldLog(const std::string& config_path, FieldIngestReport* report) {
  FieldIngestReport local_report;
  if (report == nullptr) report = &local_report;
  Json j;
  try {
    j = Json::parse(Text(config_path));
  } catch (const Json::exception& e) {
    throw InputError(config_path + ": not valid JSON: " + util::JsonErrorText(e.what()));
  }
  if (!j.is_object()) throw InputError(config_path + ": expected a JSON object");
  const Fields top(j, config_path, true);
  top.OnlyKeys({"format", "format_version", "name", "description", "camera_model", "mount", "images",
                "clock_offset_s", "navigation", "origin", "ils_in_local_m", "gravity_mps2", "lrf"});
  if (top.String("format") != kFieldLogFormatName) {
    throw InputError(top.Where("format") + ": expected \"" + std::string(kFieldLogFormatName) + "\"");
  }
  if (top.Number("format_version") != kFieldLogFormatVersion) {
    throw InputError(top.Where("format_version") + ": expected " + std::to_string(kFieldLogFormatVersion));
  }
  const fs::path base = fs::path(config_path).parent_path();

  const std::string model_path = Resolve(base, top.String("camera_model"));
  const calib::CameraModel camera = calib::CameraModel::Load(model_path);  // its errors name the path
  const Mount mount = ReadMount(top);
  const NavLog nav = ReadNavigation(top, base);

  Dataset dataset(std::move(camera));
  dataset.name = top.Has("name") ? top.String("name") : fs::path(config_path).stem().string();
  dataset.description = top.Has("description") ? top.String("description") : "field log " + config_path;
  dataset.cam_from_body = Rigid3d(mount.body_from_cam, mount.cam_in_body).Inverse();
  PlaceNavigation(top, nav, report, &dataset);
  dataset.ils_in_local_m = top.Has("ils_in_local_m") ? top.Lengths("ils_in_local_m") : Eigen::Vector3d::Zero();
  if (top.Has("lrf")) {
    ReadLrf(top, base, mount, report, &dataset);
  } else {
    // A lander whose LRF gave nothing: the flight method takes the range
    // from the navigation (docs/faults.md, "Without the LRF").
    dataset.lrf_origin_in_body_m = mount.cam_in_body;
    report->lines.push_back("LRF: none (no \"lrf\" in the log): the flight method takes the range from the navigation");
  }
  AddFrames(top, base, nav.max_gap_s, model_path, report, &dataset);
  return dataset;
}

void WriteFieldLog(const Dataset& dataset, const std::string& dir, const Geodetic& origin, double clock_offset_s) {
  std::error_code ec;
  if (fs::exists(dir, ec) && (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec))) {
    throw InputError(dir + ": exists and is not an empty folder");
  }
  if (dataset.nav.empty()) throw InputError("the dataset has no navigation samples");
  // No LRF samples: a log without "lrf".
  const Eigen::Vector3d beam = dataset.lrf.empty() ? Eigen::Vector3d::Zero() : dataset.lrf.front().boresight_in_body;
  for (const LrfSample& s : dataset.lrf) {
    if ((s.boresight_in_body - beam).norm() > 1e-12) {
      throw InputError("the dataset's LRF beam changes between samples; a field log holds one beam");
    }
  }
  // A frame without an image (a scene rendered with only some frames) has no
  // place in a log, whose frames are its images.
  if (FramesWithImages(dataset.frames).size() < 2) {
    throw InputError("the dataset has fewer than 2 frames with an image; a field log needs two views");
  }
  for (const FrameRecord& frame : dataset.frames) {
    if (frame.HasImage() && frame.image.empty()) throw InputError("the dataset's images are not loaded");
  }
  // The images are named by their camera-clock time in whole nanoseconds:
  // each must fit a 64-bit count (about +-292 years) and be its own.
  std::vector<long long> image_ns;
  std::map<long long, size_t> frame_at_ns;
  for (size_t i = 0; i < dataset.frames.size(); ++i) {
    const double ns = (dataset.frames[i].time_s - clock_offset_s) * 1e9;
    if (!(std::abs(ns) < 9.2e18)) {
      throw InputError("frame " + std::to_string(i) + " at " + util::ShortestText(dataset.frames[i].time_s) +
                       " s with the clock offset " + util::ShortestText(clock_offset_s) +
                       " s is outside the camera clock's range (+-9.2e9 s in nanoseconds)");
    }
    image_ns.push_back(std::llround(ns));
    const auto [at, added] = frame_at_ns.emplace(image_ns.back(), i);
    if (!added) {
      throw InputError("frames " + std::to_string(at->second) + " and " + std::to_string(i) +
                       " fall on the same nanosecond of the camera clock; their images would share a name");
    }
  }
  fs::create_directories(fs::path(dir) / "images", ec);
  if (ec) throw InputError(dir + ": cannot be created: " + ec.message());
  const auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream out(fs::path(dir) / name, std::ios::binary);
    out << text;
    if (!out) throw InputError((fs::path(dir) / name).string() + ": cannot be written");
  };
  dataset.camera.Save((fs::path(dir) / "camera.cameramodel").string());
  for (size_t i = 0; i < dataset.frames.size(); ++i) {
    const FrameRecord& frame = dataset.frames[i];
    if (!frame.HasImage()) continue;
    const long long ns = image_ns[i];
    const fs::path path = fs::path(dir) / "images" / ("img_" + std::to_string(ns) + ".png");
    bool written = false;
    try {
      written = images::Write(path.string(), frame.image);
    } catch (const cv::Exception& e) {
      throw InputError(path.string() + ": cannot be written: " + e.what());
    }
    if (!written) throw InputError(path.string() + ": cannot be written");
  }
  const Eigen::Matrix3d local_from_ecef = EnuFromEcef(origin.lat_deg, origin.lon_deg);
  const Eigen::Vector3d origin_ecef = EcefFromGeodetic(origin);
  const auto text = [](double v) { return util::ShortestText(v); };
  std::string nav = "time_s,lat_deg,lon_deg,height_m,yaw_deg,pitch_deg,roll_deg\n";
  for (const NavSample& s : dataset.nav) {
    const Eigen::Vector3d ecef = origin_ecef + local_from_ecef.transpose() * s.local_from_body.translation;
    const Geodetic g = GeodeticFromEcef(ecef);
    const Eigen::Matrix3d ned_here_from_ecef = EnuFromNed().transpose() * EnuFromEcef(g.lat_deg, g.lon_deg);
    const Eigen::Vector3d ypr =
        ZyxAnglesDeg(ned_here_from_ecef * local_from_ecef.transpose() * s.local_from_body.rotation.toRotationMatrix());
    nav += text(s.time_s) + "," + text(g.lat_deg) + "," + text(g.lon_deg) + "," + text(g.height_m) + "," +
           text(ypr[0]) + "," + text(ypr[1]) + "," + text(ypr[2]) + "\n";
  }
  write("nav.csv", nav);
  if (!dataset.lrf.empty()) {
    std::string lrf = "time_s,range_m\n";
    for (const LrfSample& s : dataset.lrf) lrf += text(s.time_s) + "," + text(s.range_m) + "\n";
    write("lrf.csv", lrf);
  }
  const Rigid3d body_from_cam = dataset.cam_from_body.Inverse();
  const Eigen::Matrix3d r = body_from_cam.rotation.toRotationMatrix();
  Json log;
  log["format"] = kFieldLogFormatName;
  log["format_version"] = kFieldLogFormatVersion;
  log["name"] = dataset.name;
  log["description"] = "field log written from dataset " + dataset.name;
  log["camera_model"] = "camera.cameramodel";
  log["mount"] = {{"body_from_cam", {{r(0, 0), r(0, 1), r(0, 2)}, {r(1, 0), r(1, 1), r(1, 2)}, {r(2, 0), r(2, 1), r(2, 2)}}},
                  {"position_in_body_m", {body_from_cam.translation.x(), body_from_cam.translation.y(),
                                          body_from_cam.translation.z()}}};
  log["images"] = {{"folder", "images"}, {"pattern", "img_{time_ns}.png"}};
  log["clock_offset_s"] = clock_offset_s;
  log["navigation"] = {{"csv", "nav.csv"},
                       {"time_column", "time_s"},
                       {"position", {{"frame", "wgs84"}, {"columns", {"lat_deg", "lon_deg", "height_m"}}}},
                       {"attitude", {{"kind", "euler_zyx_deg"}, {"frame", "ned"}, {"columns", {"yaw_deg", "pitch_deg", "roll_deg"}}}}};
  log["origin"] = {{"lat_deg", origin.lat_deg}, {"lon_deg", origin.lon_deg}, {"height_m", origin.height_m}};
  log["ils_in_local_m"] = {dataset.ils_in_local_m.x(), dataset.ils_in_local_m.y(), dataset.ils_in_local_m.z()};
  log["gravity_mps2"] = dataset.gravity_in_local_mps2.norm();
  if (!dataset.lrf.empty()) {
    log["lrf"] = {{"csv", "lrf.csv"},
                  {"time_column", "time_s"},
                  {"range_column", "range_m"},
                  {"beam_in_body", {beam.x(), beam.y(), beam.z()}},
                  {"origin_in_body_m", {dataset.lrf_origin_in_body_m.x(), dataset.lrf_origin_in_body_m.y(),
                                        dataset.lrf_origin_in_body_m.z()}}};
  }
  write("log.json", log.dump(1) + "\n");
}

}  // namespace hdabench::datasets
