#include "datasets/dataset.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <set>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <utility>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "calib/error.h"
#include "datasets/internal/csv.h"
#include "datasets/internal/files.h"
#include "datasets/internal/png.h"
#include "datasets/internal/text.h"
#include "datasets/npy.h"

namespace hdabench::datasets {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using internal::CsvRowReader;
using internal::CsvSchema;
using internal::CsvTable;
using internal::FormatDouble;
using internal::FormatVector;

// Table schemas (docs/dataset-format.md, "Tables").
const CsvSchema kFramesSchema{{"frame", "time_s", "image"}, {}};
const CsvSchema kNavSchema{
    {"time_s", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"},
    {{"vx_mps", "vy_mps", "vz_mps"},
     {"sigma_x_m", "sigma_y_m", "sigma_z_m", "sigma_rx_rad", "sigma_ry_rad", "sigma_rz_rad"}}};
const CsvSchema kLrfSchema{{"time_s", "range_m", "bx", "by", "bz"}, {}};
const CsvSchema kRocksSchema{{"x_m", "y_m", "z_m", "diameter_m", "height_above_ground_m"}, {}};
const std::vector<std::string> kTruthKeys = {"points_in_local", "dem", "navigation", "rocks"};

const std::vector<std::string> kManifestKeys = {
    "format",         "format_version",        "name",           "description",
    "camera_model",   "frames",                "navigation",     "lrf",
    "cam_from_body",  "gravity_in_local_mps2", "ils_in_local_m", "lrf_origin_in_body_m",
    "truth"};

// A unit vector or quaternion whose norm is 1 to rounding is kept bit for bit,
// so that write -> load is exact; a larger (accepted) deviation is renormalised.
constexpr double kRenormaliseAbove = 1e-15;

std::string FieldWhere(const std::string& field) {
  return std::string(kManifestFileName) + ": field '" + field + "'";
}

std::string Plural(size_t n, const std::string& singular, const std::string& plural) {
  return std::to_string(n) + " " + (n == 1 ? singular : plural);
}

std::string Describe(const json& value) {
  switch (value.type()) {
    case json::value_t::null:
      return "null";
    case json::value_t::boolean:
      return std::string("a boolean (") + (value.get<bool>() ? "true" : "false") + ")";
    case json::value_t::number_integer:
    case json::value_t::number_unsigned:
    case json::value_t::number_float:
      return "a number (" + value.dump() + ")";
    case json::value_t::string: {
      std::string text = value.get<std::string>();
      if (text.size() > 40) text = text.substr(0, 40) + "...";
      return "a string (\"" + text + "\")";
    }
    case json::value_t::array:
      return "an array of " + Plural(value.size(), "element", "elements");
    case json::value_t::object:
      return "an object";
    default:
      return "an unsupported JSON value";
  }
}

std::string StripJsonExceptionPrefix(const std::string& what) {
  // "[json.exception.parse_error.101] parse error at ..." -> "parse error at ..."
  if (!what.empty() && what.front() == '[') {
    const size_t close = what.find("] ");
    if (close != std::string::npos) return what.substr(close + 2);
  }
  return what;
}

// Splits a CameraModel error "origin:12:3: what" or "origin: what" into a
// location and a message.
Problem CameraProblem(const std::string& origin, const std::string& what) {
  if (what.compare(0, origin.size(), origin) == 0) {
    const std::string rest = what.substr(origin.size());
    if (rest.size() > 2 && rest[0] == ':') {
      const size_t separator = rest.find(": ");
      if (separator != std::string::npos) {
        const std::string position = rest.substr(1, separator - 1);
        const bool is_position =
            !position.empty() && position.find_first_not_of("0123456789:") == std::string::npos;
        if (is_position) return {origin + ":" + position, rest.substr(separator + 2)};
      }
    }
    if (rest.compare(0, 2, ": ") == 0) return {origin, rest.substr(2)};
  }
  return {origin, what};
}

calib::CameraModel PlaceholderCamera() {
  return calib::CameraModel("LENSMODEL_PINHOLE", {1.0, 1.0, 0.0, 0.0}, 1, 1);
}

struct FrameRow {
  int line = 0;
  FrameRecord record;
  bool time_ok = false;
  bool image_path_ok = false;
};

class Loader {
 public:
  Loader(const std::string& dir, const LoadOptions& options) : dir_(dir), root_(dir), options_(options) {}

  DatasetLoadResult Run() {
    DatasetLoadResult result;
    std::error_code ec;
    const fs::file_status status = fs::status(root_, ec);
    if (ec || !fs::exists(status)) {
      Add(dir_, "dataset folder not found");
    } else if (!fs::is_directory(status)) {
      Add(dir_, "is not a folder; expected a dataset folder holding manifest.json");
    } else if (ReadManifest()) {
      LoadCamera();
      LoadFrames();
      LoadNav();
      LoadLrf();
      CheckImages();
      CheckFrameTimes();
      LoadTruth();
    }
    result.problems = std::move(problems_);
    if (result.problems.empty() && camera_.has_value()) {
      dataset_.camera = *camera_;
      dataset_.dir = dir_;
      result.dataset = std::move(dataset_);
    }
    return result;
  }

 private:
  void Add(const std::string& where, const std::string& message) {
    problems_.push_back({where, message});
  }
  void AddField(const std::string& field, const std::string& message) {
    Add(FieldWhere(field), message);
  }

  // ---------------------------------------------------------------- manifest

  bool ReadManifest() {
    std::string text;
    std::string error;
    if (!internal::ReadFileBytes(root_ / kManifestFileName, &text, &error)) {
      Add(kManifestFileName, error);
      return false;
    }
    // nlohmann keeps the last of two equal keys; a repeated key is a mistake
    // worth reporting, so track the keys of each open object.
    std::vector<std::set<std::string>> open_objects;
    std::vector<std::string> repeated;
    const json::parser_callback_t callback = [&](int /*depth*/, json::parse_event_t event,
                                                 json& parsed) {
      if (event == json::parse_event_t::object_start) {
        open_objects.emplace_back();
      } else if (event == json::parse_event_t::object_end) {
        if (!open_objects.empty()) open_objects.pop_back();
      } else if (event == json::parse_event_t::key && !open_objects.empty()) {
        const std::string key = parsed.get<std::string>();
        if (!open_objects.back().insert(key).second) repeated.push_back(key);
      }
      return true;
    };
    try {
      manifest_ = json::parse(text, callback);
    } catch (const json::exception& e) {
      Add(kManifestFileName, "is not valid JSON (" + StripJsonExceptionPrefix(e.what()) + ")");
      return false;
    }
    if (!manifest_.is_object()) {
      Add(kManifestFileName, "is " + Describe(manifest_) +
                                 "; expected a JSON object {\"format\": \"hdabench-dataset\", ...}");
      return false;
    }
    // The format must be understood before any other field means anything.
    bool format_ok = true;
    const json* format = Member(manifest_, "format", "format",
                                "the string \"" + std::string(kDatasetFormatName) + "\"", true);
    if (format == nullptr) {
      format_ok = false;
    } else if (!format->is_string() || format->get<std::string>() != kDatasetFormatName) {
      AddField("format", "is " + Describe(*format) + "; expected \"" +
                             std::string(kDatasetFormatName) + "\"");
      format_ok = false;
    }
    const json* version =
        Member(manifest_, "format_version", "format_version",
               "the whole number " + std::to_string(kDatasetFormatVersion), true);
    if (version == nullptr) {
      format_ok = false;
    } else if (!version->is_number_integer() && !version->is_number_unsigned()) {
      AddField("format_version", "is " + Describe(*version) + "; expected the whole number " +
                                     std::to_string(kDatasetFormatVersion));
      format_ok = false;
    } else if (version->get<std::int64_t>() != kDatasetFormatVersion) {
      AddField("format_version", "is " + version->dump() + "; this build reads format_version " +
                                     std::to_string(kDatasetFormatVersion) + " only");
      format_ok = false;
    }
    if (!format_ok) return false;
    for (const std::string& key : repeated) AddField(key, "appears twice; the last value would win");

    CheckKeys(manifest_, kManifestKeys, "");
    ReadString(manifest_, "name", "name", true, &dataset_.name, "a string: the name of the run");
    if (manifest_.contains("name") && manifest_["name"].is_string() && dataset_.name.empty()) {
      AddField("name", "is empty; expected a name for the dataset");
    }
    ReadString(manifest_, "description", "description", false, &dataset_.description);
    camera_path_ok_ = ReadPath("camera_model", "mrcal .cameramodel", &dataset_.camera_model_file);
    frames_path_ok_ = ReadPath("frames", "frames table", &dataset_.frames_file);
    nav_path_ok_ = ReadPath("navigation", "navigation table", &dataset_.nav_file);
    lrf_path_ok_ = ReadPath("lrf", "LRF table", &dataset_.lrf_file);

    if (const json* mount = Member(manifest_, "cam_from_body", "cam_from_body",
                                   "an object with quaternion_wxyz and translation_m", true)) {
      if (!mount->is_object()) {
        AddField("cam_from_body", "is " + Describe(*mount) +
                                      "; expected an object with quaternion_wxyz and translation_m");
      } else {
        CheckKeys(*mount, {"quaternion_wxyz", "translation_m"}, "cam_from_body.");
        Eigen::VectorXd q;
        if (ReadVector(*mount, "quaternion_wxyz", "cam_from_body.quaternion_wxyz", 4,
                       "[qw, qx, qy, qz], a unit quaternion rotating body vectors into the camera "
                       "frame",
                       true, &q)) {
          const std::string q_error =
              CheckQuaternion(q, "quaternion", &dataset_.cam_from_body.rotation);
          if (!q_error.empty()) AddField("cam_from_body.quaternion_wxyz", q_error);
        }
        Eigen::VectorXd t;
        if (ReadVector(*mount, "translation_m", "cam_from_body.translation_m", 3,
                       "[x, y, z] in metres, the body origin in the camera frame", true, &t)) {
          dataset_.cam_from_body.translation = t;
        }
      }
    }
    Eigen::VectorXd gravity;
    if (ReadVector(manifest_, "gravity_in_local_mps2", "gravity_in_local_mps2", 3,
                   "[x, y, z] in m/s^2, e.g. [0, 0, -1.62]", true, &gravity)) {
      if (gravity.norm() == 0.0) {
        AddField("gravity_in_local_mps2",
                 "is (0, 0, 0), which has no direction; expected the gravity vector in the local "
                 "frame, e.g. [0, 0, -1.62] on the Moon");
      } else {
        dataset_.gravity_in_local_mps2 = gravity;
      }
    }
    Eigen::VectorXd ils;
    if (ReadVector(manifest_, "ils_in_local_m", "ils_in_local_m", 3, "[x, y, z] in metres", true,
                   &ils)) {
      dataset_.ils_in_local_m = ils;
    }
    Eigen::VectorXd lrf_origin;
    if (ReadVector(manifest_, "lrf_origin_in_body_m", "lrf_origin_in_body_m", 3,
                   "[x, y, z] in metres", false, &lrf_origin)) {
      dataset_.lrf_origin_in_body_m = lrf_origin;
    }
    return true;
  }

  void CheckKeys(const json& object, const std::vector<std::string>& known,
                 const std::string& prefix) {
    for (auto it = object.begin(); it != object.end(); ++it) {
      if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
      std::string list;
      for (const std::string& key : known) list += (list.empty() ? "" : ", ") + key;
      AddField(prefix + it.key(), "is not a field of format_version " +
                                      std::to_string(kDatasetFormatVersion) + "; expected " +
                                      (prefix.empty() ? "" : "in " + prefix.substr(0, prefix.size() - 1) + " ") +
                                      "only " + list);
    }
  }

  // The member `key` of `object`, or nullptr (a problem when required).
  const json* Member(const json& object, const std::string& key, const std::string& field,
                     const std::string& expected, bool required) {
    const auto it = object.find(key);
    if (it == object.end()) {
      if (required) AddField(field, "is missing; expected " + expected);
      return nullptr;
    }
    return &*it;
  }

  bool ReadString(const json& object, const std::string& key, const std::string& field,
                  bool required, std::string* value,
                  const std::string& expected = "a string") {
    const json* member = Member(object, key, field, expected, required);
    if (member == nullptr) return false;
    if (!member->is_string()) {
      AddField(field, "is " + Describe(*member) + "; expected " + expected);
      return false;
    }
    *value = member->get<std::string>();
    return true;
  }

  bool ReadPath(const std::string& key, const std::string& what, std::string* value) {
    std::string path;
    if (!ReadString(manifest_, key, key, true, &path,
                    "a string: the path of the " + what + ", relative to the dataset folder")) {
      return false;
    }
    const std::string error = internal::CheckDatasetPath(path);
    if (!error.empty()) {
      AddField(key, error);
      return false;
    }
    *value = path;
    return true;
  }

  bool ReadNumber(const json& value, const std::string& field, double* number) {
    if (!value.is_number()) {
      AddField(field, "is " + Describe(value) + "; expected a number");
      return false;
    }
    *number = value.get<double>();
    if (!std::isfinite(*number)) {
      AddField(field, "is " + FormatDouble(*number) + "; expected a finite number");
      return false;
    }
    return true;
  }

  bool ReadVector(const json& object, const std::string& key, const std::string& field, int size,
                  const std::string& expected, bool required, Eigen::VectorXd* vector) {
    const json* member = Member(object, key, field, expected, required);
    if (member == nullptr) return false;
    if (!member->is_array() || member->size() != static_cast<size_t>(size)) {
      AddField(field, "is " + Describe(*member) + "; expected " + std::to_string(size) +
                          " numbers: " + expected);
      return false;
    }
    vector->resize(size);
    bool ok = true;
    for (int i = 0; i < size; ++i) {
      ok = ReadNumber((*member)[static_cast<size_t>(i)], field + "[" + std::to_string(i) + "]",
                      &(*vector)[i]) &&
           ok;
    }
    return ok;
  }

  // Accepts a quaternion (w, x, y, z) with | |q| - 1 | <= kUnitNormTolerance.
  // Returns what is wrong, or an empty string.
  static std::string CheckQuaternion(const Eigen::Vector4d& wxyz, const std::string& label,
                                     Eigen::Quaterniond* rotation) {
    const double norm = wxyz.norm();
    if (!(std::abs(norm - 1.0) <= kUnitNormTolerance)) {
      return label + " " + FormatVector(wxyz) + " has norm " + FormatDouble(norm) +
             "; expected a unit quaternion (| |q| - 1 | <= 1e-6)";
    }
    *rotation = Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
    if (std::abs(norm - 1.0) > kRenormaliseAbove) rotation->normalize();
    return std::string();
  }

  // ------------------------------------------------------------------ camera

  void LoadCamera() {
    if (!camera_path_ok_) return;
    const std::string& file = dataset_.camera_model_file;
    std::string text;
    std::string error;
    if (!internal::ReadFileBytes(root_ / file, &text, &error)) {
      Add(file, error + " (manifest.json field 'camera_model')");
      return;
    }
    try {
      camera_.emplace(calib::CameraModel::Parse(text, file));
    } catch (const std::exception& e) {
      problems_.push_back(CameraProblem(file, e.what()));
    }
  }

  // ------------------------------------------------------------------ tables

  // Reads a table file; false (with a problem) when missing or unreadable.
  bool ReadTable(const std::string& file, const std::string& field, const CsvSchema& schema,
                 CsvTable* table) {
    std::string text;
    std::string error;
    if (!internal::ReadFileBytes(root_ / file, &text, &error)) {
      Add(file, error + " (manifest.json field '" + field + "')");
      return false;
    }
    return internal::ParseCsv(file, text, schema, table, &problems_);
  }

  // Requires strictly increasing times; `previous` holds the last valid time.
  void CheckIncreasing(CsvRowReader* reader, double time_s, const char* what,
                       std::optional<std::pair<double, int>>* previous) {
    if (previous->has_value() && !(time_s > (*previous)->first)) {
      reader->Fail("time_s " + FormatDouble(time_s) + " is not after the previous " + what +
                   " time " + FormatDouble((*previous)->first) + " s (line " +
                   std::to_string((*previous)->second) + "); times must strictly increase");
    }
    *previous = std::make_pair(time_s, reader->Line());
  }

  void CheckEnoughRows(const std::string& file, const CsvTable& table, int minimum,
                       const std::string& why) {
    const int n = table.num_data_lines;
    if (n < minimum) {
      Add(file, "has " + Plural(static_cast<size_t>(n), "row", "rows") +
                    " after the header; expected at least " + std::to_string(minimum) + " (" + why +
                    ")");
    }
  }

  void LoadFrames() {
    if (!frames_path_ok_) return;
    const std::string& file = dataset_.frames_file;
    CsvTable table;
    if (!ReadTable(file, "frames", kFramesSchema, &table)) return;
    frames_header_ok_ = true;
    num_frames_ = table.num_data_lines;
    CheckEnoughRows(file, table, 2, "a run needs two views");
    std::optional<std::pair<double, int>> previous;
    std::map<std::string, std::pair<int, int>> image_users;  // normal path -> (frame, line)
    for (const internal::CsvRow& row : table.rows) {
      CsvRowReader reader(file, table, row, &problems_);
      FrameRow frame;
      frame.line = row.line;
      const int expected_index = row.line - 2;  // line 2 holds frame 0
      frame.record.index = reader.Int("frame");
      if (reader.ok() && frame.record.index != expected_index) {
        reader.Fail("frame " + std::to_string(frame.record.index) + " where " +
                    std::to_string(expected_index) +
                    " was expected; frames must be numbered 0, 1, 2, ... in row order");
      }
      const size_t before = problems_.size();
      frame.record.time_s = reader.Double("time_s");
      if (problems_.size() == before) {
        frame.time_ok = true;
        CheckIncreasing(&reader, frame.record.time_s, "frame", &previous);
      }
      const size_t before_image = problems_.size();
      frame.record.image_path = reader.Text("image");
      if (problems_.size() == before_image) {
        const std::string error = internal::CheckDatasetPath(frame.record.image_path);
        if (!error.empty()) {
          reader.Fail("column 'image': " + error);
        } else {
          const std::string normal = internal::NormalDatasetPath(frame.record.image_path);
          const auto [it, inserted] =
              image_users.emplace(normal, std::make_pair(expected_index, row.line));
          if (!inserted) {
            reader.Fail("column 'image': '" + frame.record.image_path +
                        "' is also the image of frame " + std::to_string(it->second.first) +
                        " (line " + std::to_string(it->second.second) +
                        "); each frame needs its own image file");
          } else {
            frame.image_path_ok = true;
          }
        }
      }
      frame.record.index = expected_index;
      frame_rows_.push_back(std::move(frame));
    }
  }

  void LoadNav() {
    if (!nav_path_ok_) return;
    nav_clean_ = LoadNavTable(dataset_.nav_file, "navigation", "navigation", &dataset_.nav,
                              &dataset_.nav_has_velocity, &dataset_.nav_has_sigmas);
  }

  // Reads a table with the navigation schema (nav.csv or the truth
  // navigation): `field` is its manifest field, `what` names it in messages.
  // True when the file had no problem at all.
  bool LoadNavTable(const std::string& file, const std::string& field, const std::string& what,
                    std::vector<NavSample>* samples, bool* has_velocity, bool* has_sigmas) {
    CsvTable table;
    const size_t before = problems_.size();
    if (!ReadTable(file, field, kNavSchema, &table)) return false;
    CheckEnoughRows(file, table, 2, "frame times are interpolated between samples");
    *has_velocity = table.HasColumn("vx_mps");
    *has_sigmas = table.HasColumn("sigma_x_m");
    std::optional<std::pair<double, int>> previous;
    for (const internal::CsvRow& row : table.rows) {
      CsvRowReader reader(file, table, row, &problems_);
      NavSample sample;
      const size_t before_time = problems_.size();
      sample.time_s = reader.Double("time_s");
      if (problems_.size() == before_time) {
        CheckIncreasing(&reader, sample.time_s, what.c_str(), &previous);
      }
      sample.local_from_body.translation =
          Eigen::Vector3d(reader.Double("x_m"), reader.Double("y_m"), reader.Double("z_m"));
      const size_t before_q = problems_.size();
      const Eigen::Vector4d q(reader.Double("qw"), reader.Double("qx"), reader.Double("qy"),
                              reader.Double("qz"));
      if (problems_.size() == before_q) {
        const std::string error =
            CheckQuaternion(q, "quaternion (qw, qx, qy, qz) =", &sample.local_from_body.rotation);
        if (!error.empty()) reader.Fail(error);
      }
      if (*has_velocity) {
        sample.velocity_in_local_mps = Eigen::Vector3d(
            reader.Double("vx_mps"), reader.Double("vy_mps"), reader.Double("vz_mps"));
      }
      if (*has_sigmas) {
        const char* const position[] = {"sigma_x_m", "sigma_y_m", "sigma_z_m"};
        const char* const attitude[] = {"sigma_rx_rad", "sigma_ry_rad", "sigma_rz_rad"};
        for (int i = 0; i < 3; ++i) {
          sample.sigma_position_in_local_m[i] = ReadSigma(&reader, position[i]);
          sample.sigma_attitude_in_body_rad[i] = ReadSigma(&reader, attitude[i]);
        }
      }
      if (reader.ok()) samples->push_back(sample);
    }
    return problems_.size() == before;
  }

  double ReadSigma(CsvRowReader* reader, const std::string& column) {
    const size_t before = problems_.size();
    const double sigma = reader->Double(column);
    if (problems_.size() == before && sigma < 0.0) {
      reader->Fail("column '" + column + "': value " + FormatDouble(sigma) +
                   " is negative; expected a standard deviation >= 0");
    }
    return sigma;
  }

  void LoadLrf() {
    if (!lrf_path_ok_) return;
    const std::string& file = dataset_.lrf_file;
    CsvTable table;
    const size_t before = problems_.size();
    if (!ReadTable(file, "lrf", kLrfSchema, &table)) return;
    CheckEnoughRows(file, table, 2, "frame times are interpolated between samples");
    std::optional<std::pair<double, int>> previous;
    for (const internal::CsvRow& row : table.rows) {
      CsvRowReader reader(file, table, row, &problems_);
      LrfSample sample;
      const size_t before_time = problems_.size();
      sample.time_s = reader.Double("time_s");
      if (problems_.size() == before_time) {
        CheckIncreasing(&reader, sample.time_s, "LRF", &previous);
      }
      const size_t before_range = problems_.size();
      sample.range_m = reader.Double("range_m");
      if (problems_.size() == before_range && !(sample.range_m > 0.0)) {
        reader.Fail("column 'range_m': value " + FormatDouble(sample.range_m) +
                    " is not positive; expected a slant range > 0 m (leave out rows without a "
                    "return)");
      }
      const size_t before_boresight = problems_.size();
      const Eigen::Vector3d b(reader.Double("bx"), reader.Double("by"), reader.Double("bz"));
      if (problems_.size() == before_boresight) {
        const double norm = b.norm();
        if (norm == 0.0) {
          reader.Fail("boresight (bx, by, bz) = " + FormatVector(b) +
                      " has zero norm; expected a unit vector in the body frame");
        } else if (!(std::abs(norm - 1.0) <= kUnitNormTolerance)) {
          reader.Fail("boresight (bx, by, bz) = " + FormatVector(b) + " has norm " +
                      FormatDouble(norm) + "; expected a unit vector (| |b| - 1 | <= 1e-6)");
        } else {
          sample.boresight_in_body = std::abs(norm - 1.0) > kRenormaliseAbove ? b / norm : b;
        }
      }
      if (reader.ok()) dataset_.lrf.push_back(sample);
    }
    lrf_clean_ = problems_.size() == before;
  }

  // ------------------------------------------------------------------ images

  void CheckImages() {
    for (FrameRow& frame : frame_rows_) {
      if (!frame.image_path_ok) continue;
      const std::string& path = frame.record.image_path;
      std::string bytes;
      std::string error;
      if (!internal::ReadFileBytes(root_ / path, &bytes, &error)) {
        Add(path, error + " (image of frame " + std::to_string(frame.record.index) + ", " +
                      dataset_.frames_file + ":" + std::to_string(frame.line) + ")");
        continue;
      }
      internal::PngHeader header;
      if (!internal::CheckPngStructure(bytes, &header, &error)) {
        Add(path, error);
        continue;
      }
      if (camera_.has_value() &&
          (header.width_px != camera_->WidthPx() || header.height_px != camera_->HeightPx())) {
        Add(path, "is " + std::to_string(header.width_px) + " x " +
                      std::to_string(header.height_px) + " px; the camera model (" +
                      dataset_.camera_model_file + ") has a " +
                      std::to_string(camera_->WidthPx()) + " x " +
                      std::to_string(camera_->HeightPx()) + " px imager");
        continue;
      }
      if (!options_.decode_images && !options_.keep_images) continue;
      cv::Mat image;
      if (!internal::DecodePngQuietly(bytes, &image, &error)) {
        Add(path, error);
        continue;
      }
      if (image.cols != header.width_px || image.rows != header.height_px) {
        Add(path, "decoded to " + std::to_string(image.cols) + " x " + std::to_string(image.rows) +
                      " px but its header says " + std::to_string(header.width_px) + " x " +
                      std::to_string(header.height_px) + " px");
        continue;
      }
      if (options_.keep_images) frame.record.image = image;
    }
    for (FrameRow& frame : frame_rows_) dataset_.frames.push_back(frame.record);
  }

  // Every frame time must lie inside the navigation and LRF spans. Checked only
  // against a table without problems, so that one bad row does not also make
  // frames look out of span.
  void CheckFrameTimes() {
    const bool nav_usable = nav_clean_ && dataset_.nav.size() >= 2;
    const bool lrf_usable = lrf_clean_ && dataset_.lrf.size() >= 2;
    for (const FrameRow& frame : frame_rows_) {
      if (!frame.time_ok) continue;
      const double t = frame.record.time_s;
      const std::string where = dataset_.frames_file + ":" + std::to_string(frame.line);
      if (nav_usable) CheckFrameInNavSpan(frame, dataset_.nav, "navigation", dataset_.nav_file);
      if (lrf_usable && (t < dataset_.lrf.front().time_s || t > dataset_.lrf.back().time_s)) {
        Add(where, "time_s " + FormatDouble(t) + " is outside the LRF span [" +
                       FormatDouble(dataset_.lrf.front().time_s) + ", " +
                       FormatDouble(dataset_.lrf.back().time_s) + "] s of " + dataset_.lrf_file);
      }
    }
  }

  void CheckFrameInNavSpan(const FrameRow& frame, const std::vector<NavSample>& nav,
                           const std::string& what, const std::string& file) {
    const double t = frame.record.time_s;
    if (t < nav.front().time_s || t > nav.back().time_s) {
      Add(dataset_.frames_file + ":" + std::to_string(frame.line),
          "time_s " + FormatDouble(t) + " is outside the " + what + " span [" +
              FormatDouble(nav.front().time_s) + ", " + FormatDouble(nav.back().time_s) +
              "] s of " + file);
    }
  }

  // ------------------------------------------------------------------- truth

  void LoadTruth() {
    const json* truth = Member(manifest_, "truth", "truth", "", false);
    if (truth == nullptr) return;
    if (!truth->is_object()) {
      AddField("truth", "is " + Describe(*truth) +
                            "; expected an object with points_in_local, dem, navigation and/or "
                            "rocks");
      return;
    }
    CheckKeys(*truth, kTruthKeys, "truth.");
    if (const json* points = Member(*truth, "points_in_local", "truth.points_in_local", "", false)) {
      LoadTruthPoints(*points);
    }
    if (const json* dem = Member(*truth, "dem", "truth.dem", "", false)) LoadTruthDem(*dem);
    LoadTruthNavigation(*truth);
    LoadTruthRocks(*truth);
  }

  // The path in optional member `key` of the truth object; false when absent
  // or wrong (a problem).
  bool ReadTruthPath(const json& truth, const std::string& key, const std::string& what,
                     std::string* path) {
    const std::string field = "truth." + key;
    if (!ReadString(truth, key, field, false, path,
                    "a string: the path of the " + what + ", relative to the dataset folder")) {
      return false;
    }
    const std::string error = internal::CheckDatasetPath(*path);
    if (!error.empty()) {
      AddField(field, error);
      path->clear();
      return false;
    }
    return true;
  }

  void LoadTruthNavigation(const json& truth) {
    std::string file;
    if (!ReadTruthPath(truth, "navigation", "truth navigation table", &file)) return;
    std::vector<NavSample> samples;
    bool has_velocity = false;
    bool has_sigmas = false;
    const bool clean = LoadNavTable(file, "truth.navigation", "truth navigation", &samples,
                                    &has_velocity, &has_sigmas);
    if (!clean) return;
    for (const FrameRow& frame : frame_rows_) {
      if (frame.time_ok) CheckFrameInNavSpan(frame, samples, "truth navigation", file);
    }
    dataset_.truth.navigation_file = file;
    dataset_.truth.navigation = std::move(samples);
  }

  void LoadTruthRocks(const json& truth) {
    std::string file;
    if (!ReadTruthPath(truth, "rocks", "truth rocks table", &file)) return;
    CsvTable table;
    if (!ReadTable(file, "truth.rocks", kRocksSchema, &table)) return;
    std::vector<TruthRock> rocks;
    for (const internal::CsvRow& row : table.rows) {
      CsvRowReader reader(file, table, row, &problems_);
      TruthRock rock;
      rock.center_in_local_m =
          Eigen::Vector3d(reader.Double("x_m"), reader.Double("y_m"), reader.Double("z_m"));
      const size_t before_diameter = problems_.size();
      rock.diameter_m = reader.Double("diameter_m");
      const bool diameter_ok = problems_.size() == before_diameter && rock.diameter_m > 0.0;
      if (problems_.size() == before_diameter && !diameter_ok) {
        reader.Fail("column 'diameter_m': value " + FormatDouble(rock.diameter_m) +
                    " is not positive; expected a rock diameter > 0 m");
      }
      const size_t before_height = problems_.size();
      rock.height_above_ground_m = reader.Double("height_above_ground_m");
      if (problems_.size() == before_height) {
        if (!(rock.height_above_ground_m > 0.0)) {
          reader.Fail("column 'height_above_ground_m': value " +
                      FormatDouble(rock.height_above_ground_m) +
                      " is not positive; expected a height above the ground > 0 m");
        } else if (diameter_ok && rock.height_above_ground_m > rock.diameter_m) {
          reader.Fail("column 'height_above_ground_m': value " +
                      FormatDouble(rock.height_above_ground_m) + " is larger than diameter_m " +
                      FormatDouble(rock.diameter_m) +
                      "; expected a height above the ground <= the rock's diameter");
        }
      }
      if (reader.ok()) rocks.push_back(rock);
    }
    dataset_.truth.rocks_file = file;
    dataset_.truth.rocks = std::move(rocks);
  }

  void LoadTruthPoints(const json& points) {
    const std::string field = "truth.points_in_local";
    if (!points.is_array()) {
      AddField(field, "is " + Describe(points) +
                          "; expected an array of {\"frame\": index, \"file\": path}");
      return;
    }
    std::map<int, size_t> seen;  // frame -> entry index
    for (size_t i = 0; i < points.size(); ++i) {
      const std::string entry_field = field + "[" + std::to_string(i) + "]";
      const json& entry = points[i];
      if (!entry.is_object()) {
        AddField(entry_field, "is " + Describe(entry) +
                                  "; expected {\"frame\": index, \"file\": path}");
        continue;
      }
      CheckKeys(entry, {"frame", "file"}, entry_field + ".");
      TruthPoints truth;
      bool ok = true;
      if (const json* frame = Member(entry, "frame", entry_field + ".frame",
                                     "a frame index", true)) {
        if (!frame->is_number_integer() && !frame->is_number_unsigned()) {
          AddField(entry_field + ".frame", "is " + Describe(*frame) + "; expected a frame index");
          ok = false;
        } else {
          const std::int64_t index = frame->get<std::int64_t>();
          if (frames_header_ok_ && (index < 0 || index >= num_frames_)) {
            AddField(entry_field + ".frame",
                     "is " + std::to_string(index) + "; " + dataset_.frames_file +
                         " has frames 0.." + std::to_string(num_frames_ - 1));
            ok = false;
          } else {
            truth.frame = static_cast<int>(index);
            const auto [it, inserted] = seen.emplace(truth.frame, i);
            if (!inserted) {
              AddField(entry_field + ".frame",
                       "frame " + std::to_string(truth.frame) + " already has truth points (" +
                           field + "[" + std::to_string(it->second) + "])");
              ok = false;
            }
          }
        }
      } else {
        ok = false;
      }
      std::string file;
      if (ReadString(entry, "file", entry_field + ".file", true, &file)) {
        const std::string error = internal::CheckDatasetPath(file);
        if (!error.empty()) {
          AddField(entry_field + ".file", error);
          ok = false;
        }
        truth.file = file;
      } else {
        ok = false;
      }
      if (!ok) continue;
      if (LoadTruthPointsFile(&truth)) dataset_.truth.points.push_back(std::move(truth));
    }
  }

  bool LoadTruthPointsFile(TruthPoints* truth) {
    const std::string& file = truth->file;
    std::string bytes;
    std::string error;
    if (!internal::ReadFileBytes(root_ / file, &bytes, &error)) {
      Add(file, error + " (truth points of frame " + std::to_string(truth->frame) + ")");
      return false;
    }
    const bool read_values = options_.check_truth_values || options_.keep_truth;
    NpyFloat32 array;
    const bool parsed = read_values ? ParseNpyFloat32(bytes, &array, &error)
                                    : ParseNpyFloat32Header(bytes, &array, &error);
    if (!parsed) {
      Add(file, error);
      return false;
    }
    if (!camera_.has_value()) return false;  // the camera's problem is already reported
    const std::vector<std::int64_t> expected = {camera_->HeightPx(), camera_->WidthPx(), 3};
    if (array.shape != expected) {
      Add(file, "has shape " + FormatNpyShape(array.shape) + "; expected " +
                    FormatNpyShape(expected) +
                    " (imager height, width, then x, y, z in the local frame)");
      return false;
    }
    if (!read_values) return true;
    // Finite points, or all three NaN where the pixel's ray hits nothing.
    size_t bad = 0;
    size_t first_bad = 0;
    for (size_t p = 0; p < array.values.size() / 3; ++p) {
      const float* v = &array.values[3 * p];
      const bool all_finite = std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
      const bool all_nan = std::isnan(v[0]) && std::isnan(v[1]) && std::isnan(v[2]);
      if (!all_finite && !all_nan) {
        if (bad == 0) first_bad = p;
        ++bad;
      }
    }
    if (bad > 0) {
      const size_t width = static_cast<size_t>(camera_->WidthPx());
      const float* v = &array.values[3 * first_bad];
      Add(file, "has " + Plural(bad, "point", "points") +
                    " with an infinite or partly NaN coordinate, the first at row " +
                    std::to_string(first_bad / width) + ", column " +
                    std::to_string(first_bad % width) + ": " +
                    FormatVector(Eigen::Vector3d(static_cast<double>(v[0]), static_cast<double>(v[1]),
                                                 static_cast<double>(v[2]))) +
                    "; expected finite points, or (nan, nan, nan) where the ray hits nothing");
      return false;
    }
    if (options_.keep_truth) {
      truth->points_in_local_m.create(camera_->HeightPx(), camera_->WidthPx(), CV_32FC3);
      std::memcpy(truth->points_in_local_m.data, array.values.data(),
                  array.values.size() * sizeof(float));
    }
    return true;
  }

  void LoadTruthDem(const json& dem_json) {
    const std::string field = "truth.dem";
    if (!dem_json.is_object()) {
      AddField(field, "is " + Describe(dem_json) +
                          "; expected an object with file, origin_in_local_m and spacing_m");
      return;
    }
    CheckKeys(dem_json, {"file", "origin_in_local_m", "spacing_m"}, field + ".");
    TruthDem dem;
    bool ok = true;
    if (ReadString(dem_json, "file", field + ".file", true, &dem.file)) {
      const std::string error = internal::CheckDatasetPath(dem.file);
      if (!error.empty()) {
        AddField(field + ".file", error);
        ok = false;
      }
    } else {
      ok = false;
    }
    Eigen::VectorXd origin;
    if (ReadVector(dem_json, "origin_in_local_m", field + ".origin_in_local_m", 2,
                   "[x, y] in metres, the centre of cell (0, 0)", true, &origin)) {
      dem.origin_in_local_m = origin;
    } else {
      ok = false;
    }
    if (const json* spacing = Member(dem_json, "spacing_m", field + ".spacing_m",
                                     "the cell size in metres (> 0)", true)) {
      if (ReadNumber(*spacing, field + ".spacing_m", &dem.spacing_m)) {
        if (!(dem.spacing_m > 0.0)) {
          AddField(field + ".spacing_m", "is " + FormatDouble(dem.spacing_m) +
                                             "; expected a cell size > 0 m");
          ok = false;
        }
      } else {
        ok = false;
      }
    } else {
      ok = false;
    }
    if (!ok) return;

    std::string bytes;
    std::string error;
    if (!internal::ReadFileBytes(root_ / dem.file, &bytes, &error)) {
      Add(dem.file, error + " (manifest.json field 'truth.dem.file')");
      return;
    }
    const bool read_values = options_.check_truth_values || options_.keep_truth;
    NpyFloat32 array;
    const bool parsed = read_values ? ParseNpyFloat32(bytes, &array, &error)
                                    : ParseNpyFloat32Header(bytes, &array, &error);
    if (!parsed) {
      Add(dem.file, error);
      return;
    }
    if (array.shape.size() != 2 || array.shape[0] < 1 || array.shape[1] < 1 ||
        array.shape[0] > std::numeric_limits<int>::max() ||
        array.shape[1] > std::numeric_limits<int>::max()) {
      Add(dem.file, "has shape " + FormatNpyShape(array.shape) +
                        "; expected (rows, columns) of heights, each at least 1");
      return;
    }
    dem.height_cells = static_cast<int>(array.shape[0]);
    dem.width_cells = static_cast<int>(array.shape[1]);
    if (read_values) {
      size_t bad = 0;
      size_t first_bad = 0;
      for (size_t i = 0; i < array.values.size(); ++i) {
        if (!std::isfinite(array.values[i])) {
          if (bad == 0) first_bad = i;
          ++bad;
        }
      }
      if (bad > 0) {
        const size_t width = static_cast<size_t>(dem.width_cells);
        Add(dem.file, "has " + Plural(bad, "non-finite height", "non-finite heights") +
                          ", the first at row " + std::to_string(first_bad / width) + ", column " +
                          std::to_string(first_bad % width) + " (" +
                          FormatDouble(static_cast<double>(array.values[first_bad])) +
                          "); expected finite heights in metres");
        return;
      }
    }
    if (options_.keep_truth) {
      dem.height_in_local_m.create(dem.height_cells, dem.width_cells, CV_32FC1);
      std::memcpy(dem.height_in_local_m.data, array.values.data(),
                  array.values.size() * sizeof(float));
    }
    dataset_.truth.dem = std::move(dem);
  }

  const std::string dir_;
  const fs::path root_;
  const LoadOptions options_;
  std::vector<Problem> problems_;
  json manifest_;
  std::optional<calib::CameraModel> camera_;
  bool camera_path_ok_ = false;
  bool frames_path_ok_ = false;
  bool nav_path_ok_ = false;
  bool lrf_path_ok_ = false;
  bool frames_header_ok_ = false;
  int num_frames_ = 0;
  bool nav_clean_ = false;
  bool lrf_clean_ = false;
  std::vector<FrameRow> frame_rows_;
  // The dataset under construction; its placeholder camera is replaced by the
  // loaded one when no problem was found.
  Dataset dataset_{PlaceholderCamera()};
};


// ------------------------------------------------------------------- writing

std::string NavHeader(bool has_velocity, bool has_sigmas) {
  std::vector<std::string> columns = kNavSchema.required;
  if (has_velocity) {
    columns.insert(columns.end(), kNavSchema.optional_groups[0].begin(),
                   kNavSchema.optional_groups[0].end());
  }
  if (has_sigmas) {
    columns.insert(columns.end(), kNavSchema.optional_groups[1].begin(),
                   kNavSchema.optional_groups[1].end());
  }
  return internal::CsvLine(columns);
}

std::string FramesCsv(const Dataset& dataset) {
  std::string text = internal::CsvLine(kFramesSchema.required);
  for (const FrameRecord& frame : dataset.frames) {
    text += internal::CsvLine(
        {std::to_string(frame.index), FormatDouble(frame.time_s), frame.image_path});
  }
  return text;
}

std::string NavCsv(const std::vector<NavSample>& nav, bool has_velocity, bool has_sigmas) {
  std::string text = NavHeader(has_velocity, has_sigmas);
  for (const NavSample& sample : nav) {
    const Eigen::Vector3d& p = sample.local_from_body.translation;
    const Eigen::Quaterniond& q = sample.local_from_body.rotation;
    std::vector<std::string> values = {FormatDouble(sample.time_s), FormatDouble(p.x()),
                                       FormatDouble(p.y()),         FormatDouble(p.z()),
                                       FormatDouble(q.w()),         FormatDouble(q.x()),
                                       FormatDouble(q.y()),         FormatDouble(q.z())};
    if (has_velocity) {
      for (int i = 0; i < 3; ++i) values.push_back(FormatDouble(sample.velocity_in_local_mps[i]));
    }
    if (has_sigmas) {
      for (int i = 0; i < 3; ++i) {
        values.push_back(FormatDouble(sample.sigma_position_in_local_m[i]));
      }
      for (int i = 0; i < 3; ++i) {
        values.push_back(FormatDouble(sample.sigma_attitude_in_body_rad[i]));
      }
    }
    text += internal::CsvLine(values);
  }
  return text;
}

// The truth navigation has no column flags: a group is written when it holds
// a non-zero value (a table loaded without it holds zeros).
std::string TruthNavCsv(const std::vector<NavSample>& nav) {
  bool has_velocity = false;
  bool has_sigmas = false;
  for (const NavSample& sample : nav) {
    has_velocity = has_velocity || !sample.velocity_in_local_mps.isZero(0.0);
    has_sigmas = has_sigmas || !sample.sigma_position_in_local_m.isZero(0.0) ||
                 !sample.sigma_attitude_in_body_rad.isZero(0.0);
  }
  return NavCsv(nav, has_velocity, has_sigmas);
}

std::string RocksCsv(const std::vector<TruthRock>& rocks) {
  std::string text = internal::CsvLine(kRocksSchema.required);
  for (const TruthRock& rock : rocks) {
    text += internal::CsvLine(
        {FormatDouble(rock.center_in_local_m.x()), FormatDouble(rock.center_in_local_m.y()),
         FormatDouble(rock.center_in_local_m.z()), FormatDouble(rock.diameter_m),
         FormatDouble(rock.height_above_ground_m)});
  }
  return text;
}

std::string LrfCsv(const Dataset& dataset) {
  std::string text = internal::CsvLine(kLrfSchema.required);
  for (const LrfSample& sample : dataset.lrf) {
    text += internal::CsvLine({FormatDouble(sample.time_s), FormatDouble(sample.range_m),
                               FormatDouble(sample.boresight_in_body.x()),
                               FormatDouble(sample.boresight_in_body.y()),
                               FormatDouble(sample.boresight_in_body.z())});
  }
  return text;
}

json JsonArray(const Eigen::VectorXd& values) {
  json array = json::array();
  for (Eigen::Index i = 0; i < values.size(); ++i) array.push_back(values[i]);
  return array;
}

std::string ManifestJson(const Dataset& dataset) {
  using ordered_json = nlohmann::ordered_json;
  ordered_json manifest;
  manifest["format"] = kDatasetFormatName;
  manifest["format_version"] = kDatasetFormatVersion;
  manifest["name"] = dataset.name;
  manifest["description"] = dataset.description;
  manifest["camera_model"] = dataset.camera_model_file;
  manifest["frames"] = dataset.frames_file;
  manifest["navigation"] = dataset.nav_file;
  manifest["lrf"] = dataset.lrf_file;
  const Eigen::Quaterniond& q = dataset.cam_from_body.rotation;
  manifest["cam_from_body"]["quaternion_wxyz"] = JsonArray(Eigen::Vector4d(q.w(), q.x(), q.y(), q.z()));
  manifest["cam_from_body"]["translation_m"] = JsonArray(dataset.cam_from_body.translation);
  manifest["gravity_in_local_mps2"] = JsonArray(dataset.gravity_in_local_mps2);
  manifest["ils_in_local_m"] = JsonArray(dataset.ils_in_local_m);
  manifest["lrf_origin_in_body_m"] = JsonArray(dataset.lrf_origin_in_body_m);
  if (!dataset.truth.Empty()) {
    ordered_json truth = ordered_json::object();
    if (!dataset.truth.points.empty()) {
      ordered_json points = ordered_json::array();
      for (const TruthPoints& entry : dataset.truth.points) {
        ordered_json item;
        item["frame"] = entry.frame;
        item["file"] = entry.file;
        points.push_back(item);
      }
      truth["points_in_local"] = points;
    }
    if (dataset.truth.dem.has_value()) {
      const TruthDem& dem = *dataset.truth.dem;
      truth["dem"]["file"] = dem.file;
      truth["dem"]["origin_in_local_m"] = JsonArray(dem.origin_in_local_m);
      truth["dem"]["spacing_m"] = dem.spacing_m;
    }
    if (!dataset.truth.navigation_file.empty()) {
      truth["navigation"] = dataset.truth.navigation_file;
    }
    if (!dataset.truth.rocks_file.empty()) truth["rocks"] = dataset.truth.rocks_file;
    manifest["truth"] = truth;
  }
  return manifest.dump(2) + "\n";
}

void RequireWritable(bool condition, const std::string& message) {
  if (!condition) throw std::invalid_argument("WriteDataset: " + message);
}

// Checks what the writer itself needs; the rest is LoadDataset's job.
void CheckWritable(const Dataset& dataset) {
  std::set<std::string> paths;
  auto claim = [&](const std::string& path, const std::string& what) {
    const std::string error = internal::CheckDatasetPath(path);
    RequireWritable(error.empty(), what + " path " + error);
    const std::string normal = internal::NormalDatasetPath(path);
    RequireWritable(normal != kManifestFileName && paths.insert(normal).second,
                    what + " path '" + path + "' is used twice");
  };
  claim(dataset.camera_model_file, "camera model");
  claim(dataset.frames_file, "frames table");
  claim(dataset.nav_file, "navigation table");
  claim(dataset.lrf_file, "LRF table");
  const int width = dataset.camera.WidthPx();
  const int height = dataset.camera.HeightPx();
  for (size_t i = 0; i < dataset.frames.size(); ++i) {
    const FrameRecord& frame = dataset.frames[i];
    const std::string label = "frame " + std::to_string(i);
    RequireWritable(frame.index == static_cast<int>(i), label + " has index " +
                                                             std::to_string(frame.index));
    claim(frame.image_path, label + " image");
    RequireWritable(!frame.image.empty(), label + " has no image in memory");
    RequireWritable(frame.image.type() == CV_8UC1 || frame.image.type() == CV_16UC1,
                    label + " image is not CV_8UC1 or CV_16UC1");
    RequireWritable(frame.image.cols == width && frame.image.rows == height,
                    label + " image size differs from the camera imager");
  }
  for (const TruthPoints& truth : dataset.truth.points) {
    const std::string label = "truth points of frame " + std::to_string(truth.frame);
    claim(truth.file, label);
    RequireWritable(truth.points_in_local_m.type() == CV_32FC3 &&
                        truth.points_in_local_m.cols == width &&
                        truth.points_in_local_m.rows == height,
                    label + " are not a CV_32FC3 array of the camera imager size");
  }
  if (dataset.truth.dem.has_value()) {
    const TruthDem& dem = *dataset.truth.dem;
    claim(dem.file, "DEM");
    RequireWritable(dem.height_in_local_m.type() == CV_32FC1 && !dem.height_in_local_m.empty(),
                    "the DEM is not a non-empty CV_32FC1 array");
  }
  const Truth& truth = dataset.truth;
  if (!truth.navigation_file.empty()) {
    claim(truth.navigation_file, "truth navigation");
  } else {
    RequireWritable(truth.navigation.empty(), "the truth navigation has samples but no file name");
  }
  if (!truth.rocks_file.empty()) {
    claim(truth.rocks_file, "truth rocks");
  } else {
    RequireWritable(truth.rocks.empty(), "the truth rocks table has rows but no file name");
  }
}

std::string NpyFromMat(const cv::Mat& mat) {
  const cv::Mat continuous = mat.isContinuous() ? mat : mat.clone();
  std::vector<std::int64_t> shape = {continuous.rows, continuous.cols};
  if (continuous.channels() > 1) shape.push_back(continuous.channels());
  return EncodeNpyFloat32(shape, continuous.ptr<float>(),
                          continuous.total() * static_cast<size_t>(continuous.channels()));
}

}  // namespace

std::string DatasetLoadResult::Summary() const {
  if (Ok()) {
    return "ok: " + dataset->name + ", " + Plural(dataset->frames.size(), "frame", "frames");
  }
  return Plural(problems.size(), "problem", "problems");
}

DatasetLoadResult LoadDataset(const std::string& dir, const LoadOptions& options) {
  try {
    Loader loader(dir, options);
    return loader.Run();
  } catch (const std::exception& e) {
    // Nothing on disk should get here; if something does, it is still a
    // report, not a crash.
    DatasetLoadResult result;
    result.problems.push_back({dir, std::string("unexpected error while loading: ") + e.what()});
    return result;
  }
}

void WriteDataset(const Dataset& dataset, const std::string& dir) {
  CheckWritable(dataset);
  fs::path target = fs::absolute(fs::path(dir)).lexically_normal();
  if (!target.has_filename()) target = target.parent_path();
  std::error_code ec;
  if (fs::exists(target, ec)) {
    if (!fs::is_directory(target, ec) || !fs::is_empty(target, ec)) {
      throw InputError(dir + ": exists and is not an empty folder; the dataset needs a new folder");
    }
  }
  fs::create_directories(target.parent_path(), ec);
  if (ec) {
    throw InputError(target.parent_path().string() + ": cannot create the folder (" +
                     ec.message() + ")");
  }
  const fs::path staging = target.parent_path() /
                           ("." + target.filename().string() + ".partial-" +
                            std::to_string(static_cast<long long>(::getpid())));
  fs::remove_all(staging, ec);
  try {
    fs::create_directory(staging, ec);
    if (ec) {
      throw InputError(staging.string() + ": cannot create the folder (" + ec.message() + ")");
    }
    internal::WriteFileAtomically(staging / dataset.camera_model_file, dataset.camera.ToText());
    for (const FrameRecord& frame : dataset.frames) {
      internal::WriteFileAtomically(staging / frame.image_path, internal::EncodePng(frame.image));
    }
    internal::WriteFileAtomically(staging / dataset.frames_file, FramesCsv(dataset));
    internal::WriteFileAtomically(
        staging / dataset.nav_file,
        NavCsv(dataset.nav, dataset.nav_has_velocity, dataset.nav_has_sigmas));
    internal::WriteFileAtomically(staging / dataset.lrf_file, LrfCsv(dataset));
    for (const TruthPoints& truth : dataset.truth.points) {
      internal::WriteFileAtomically(staging / truth.file, NpyFromMat(truth.points_in_local_m));
    }
    if (dataset.truth.dem.has_value()) {
      internal::WriteFileAtomically(staging / dataset.truth.dem->file,
                                    NpyFromMat(dataset.truth.dem->height_in_local_m));
    }
    if (!dataset.truth.navigation_file.empty()) {
      internal::WriteFileAtomically(staging / dataset.truth.navigation_file,
                                    TruthNavCsv(dataset.truth.navigation));
    }
    if (!dataset.truth.rocks_file.empty()) {
      internal::WriteFileAtomically(staging / dataset.truth.rocks_file,
                                    RocksCsv(dataset.truth.rocks));
    }
    internal::WriteFileAtomically(staging / kManifestFileName, ManifestJson(dataset));
    // rename(2) replaces an empty folder.
    fs::rename(staging, target, ec);
    if (ec) {
      throw InputError(dir + ": cannot move the written dataset into place (" + ec.message() + ")");
    }
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(staging, ignored);
    throw;
  }
}

// -------------------------------------------------------------------- poses

namespace {

// cam_from_local of a frame with the body pose from `nav` (the measured or the
// truth navigation): cam_from_body * inverse(local_from_body(t_frame)).
Rigid3d CamFromLocalWith(const Dataset& dataset, const std::vector<NavSample>& nav,
                         Rigid3d (*local_from_body_at)(const std::vector<NavSample>&, double),
                         int frame) {
  if (frame < 0 || frame >= static_cast<int>(dataset.frames.size())) {
    throw std::out_of_range("frame " + std::to_string(frame) + " is not in 0.." +
                            std::to_string(static_cast<int>(dataset.frames.size()) - 1));
  }
  return dataset.cam_from_body *
         local_from_body_at(nav, dataset.frames[static_cast<size_t>(frame)].time_s).Inverse();
}

// InterpolateLocalFromBody on the truth navigation, whose errors name it.
Rigid3d TrueLocalFromBody(const std::vector<NavSample>& navigation, double time_s) {
  if (navigation.empty()) {
    throw std::out_of_range("the dataset has no truth navigation (manifest.json field "
                            "'truth.navigation')");
  }
  const double first = navigation.front().time_s;
  const double last = navigation.back().time_s;
  if (!(time_s >= first && time_s <= last)) {
    throw std::out_of_range("time " + FormatDouble(time_s) +
                            " s is outside the truth navigation span [" + FormatDouble(first) +
                            ", " + FormatDouble(last) + "] s");
  }
  return InterpolateLocalFromBody(navigation, time_s);
}

}  // namespace

Rigid3d Dataset::LocalFromBodyAt(double time_s) const {
  return InterpolateLocalFromBody(nav, time_s);
}

Rigid3d Dataset::CamFromLocal(int frame) const {
  return CamFromLocalWith(*this, nav, &InterpolateLocalFromBody, frame);
}

Rigid3d Dataset::Cam2FromCam1(int frame1, int frame2) const {
  return CamFromLocal(frame2) * CamFromLocal(frame1).Inverse();
}

Rigid3d Dataset::TrueLocalFromBodyAt(double time_s) const {
  return TrueLocalFromBody(truth.navigation, time_s);
}

Rigid3d Dataset::TrueCamFromLocal(int frame) const {
  return CamFromLocalWith(*this, truth.navigation, &TrueLocalFromBody, frame);
}

Rigid3d Dataset::TrueCam2FromCam1(int frame1, int frame2) const {
  return TrueCamFromLocal(frame2) * TrueCamFromLocal(frame1).Inverse();
}

Eigen::Vector3d Dataset::CameraCenterInLocal(int frame) const {
  return CamFromLocal(frame).Inverse().translation;
}

double Dataset::BaselineM(int frame1, int frame2) const {
  return (CameraCenterInLocal(frame2) - CameraCenterInLocal(frame1)).norm();
}

double Dataset::LrfRangeAt(double time_s) const { return InterpolateLrfRange(lrf, time_s); }

}  // namespace hdabench::datasets
