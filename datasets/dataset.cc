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

#include "tools/util/error.h"
#include "datasets/internal/csv.h"
#include "datasets/internal/files.h"
#include "tools/util/files.h"
#include "tools/util/parallel_for.h"
#include "datasets/internal/png.h"
#include "tools/util/text.h"
#include "datasets/npy.h"

namespace hdabench::datasets {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using internal::CsvRowReader;
using internal::CsvSchema;
using internal::CsvTable;

// Table schemas (docs/dataset-format.md, "Tables").
const CsvSchema kFramesSchema{{"frame", "time_s", "image"}, {}};
const CsvSchema kNavSchema{
    {"time_s", "x_m", "y_m", "z_m", "qw", "qx", "qy", "qz"},
    {{"vx_mps", "vy_mps", "vz_mps"},
     {"sigma_x_m", "sigma_y_m", "sigma_z_m", "sigma_rx_rad", "sigma_ry_rad", "sigma_rz_rad"}}};
const CsvSchema kLrfSchema{{"time_s", "range_m", "bx", "by", "bz"}, {}};
const CsvSchema kRocksSchema{{"x_m", "y_m", "z_m", "diameter_m", "height_above_ground_m"}, {}};
const std::vector<std::string> kTruthKeys = {"points_in_local", "dem", "navigation", "rocks", "imaging"};

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

// ---------------------------------------------------------------- problems

// The problems found so far, in the order found. Every per-table reader adds to
// the one collector, so that the report keeps the order of the checks.
class Problems {
 public:
  void Add(const std::string& where, const std::string& message) {
    list_.push_back({where, message});
  }
  void Add(Problem problem) { list_.push_back(std::move(problem)); }
  // A problem with a manifest field.
  void AddField(const std::string& field, const std::string& message) {
    Add(FieldWhere(field), message);
  }
  // How many so far: a reader compares counts to tell whether a step failed.
  size_t Count() const { return list_.size(); }
  // The list itself, for the CSV parser and row readers, which add to it.
  std::vector<Problem>* List() { return &list_; }
  std::vector<Problem> Take() { return std::move(list_); }

 private:
  std::vector<Problem> list_;
};

// What the per-table readers share: where the dataset is, how to load it, the
// problems found so far and the dataset under construction.
struct LoadContext {
  LoadContext(const std::string& dir, const LoadOptions& load_options)
      : root(dir), options(load_options) {}

  const fs::path root;
  const LoadOptions options;
  Problems problems;
  // The loaded camera model, when its file parsed.
  std::optional<calib::CameraModel> camera;
  // The dataset under construction; its placeholder camera is replaced by the
  // loaded one when no problem was found.
  Dataset dataset{PlaceholderCamera()};
  // The frames whose images and truth points are read whole
  // (LoadOptions::frames_used); none: every frame.
  std::optional<std::set<int>> used_frames;
  bool Uses(int frame) const { return !used_frames.has_value() || used_frames->count(frame) != 0; }
};

// Accepts a quaternion (w, x, y, z) with | |q| - 1 | <= kUnitNormTolerance.
// Returns what is wrong, or an empty string.
std::string CheckQuaternion(const Eigen::Vector4d& wxyz, const std::string& label,
                            Eigen::Quaterniond* rotation) {
  const double norm = wxyz.norm();
  if (!(std::abs(norm - 1.0) <= kUnitNormTolerance)) {
    return label + " " + util::VectorText(wxyz) + " has norm " + util::ShortestText(norm) +
           "; expected a unit quaternion (| |q| - 1 | <= 1e-6)";
  }
  *rotation = Eigen::Quaterniond(wxyz[0], wxyz[1], wxyz[2], wxyz[3]);
  if (std::abs(norm - 1.0) > kRenormaliseAbove) rotation->normalize();
  return std::string();
}

// --------------------------------------------------------- manifest fields

// Reads typed members of the manifest's JSON objects (the manifest itself and
// the objects inside it); each failure is a problem naming the field, the
// value found and what was expected.
class JsonFields {
 public:
  explicit JsonFields(Problems* problems) : problems_(problems) {}

  // A problem for each member of `object` not in `known`; `prefix` is the
  // object's field path followed by '.', or empty for the manifest itself.
  void CheckKeys(const json& object, const std::vector<std::string>& known,
                 const std::string& prefix) const {
    for (auto it = object.begin(); it != object.end(); ++it) {
      if (std::find(known.begin(), known.end(), it.key()) != known.end()) continue;
      std::string list;
      for (const std::string& key : known) list += (list.empty() ? "" : ", ") + key;
      problems_->AddField(
          prefix + it.key(),
          "is not a field of format_version " + std::to_string(kDatasetFormatVersion) +
              "; expected " +
              (prefix.empty() ? "" : "in " + prefix.substr(0, prefix.size() - 1) + " ") +
              "only " + list);
    }
  }

  // The member `key` of `object`, or nullptr (a problem when required).
  const json* Member(const json& object, const std::string& key, const std::string& field,
                     const std::string& expected, bool required) const {
    const auto it = object.find(key);
    if (it == object.end()) {
      if (required) problems_->AddField(field, "is missing; expected " + expected);
      return nullptr;
    }
    return &*it;
  }

  bool ReadString(const json& object, const std::string& key, const std::string& field,
                  bool required, std::string* value,
                  const std::string& expected = "a string") const {
    const json* member = Member(object, key, field, expected, required);
    if (member == nullptr) return false;
    if (!member->is_string()) {
      problems_->AddField(field, "is " + Describe(*member) + "; expected " + expected);
      return false;
    }
    *value = member->get<std::string>();
    return true;
  }

  bool ReadNumber(const json& value, const std::string& field, double* number) const {
    if (!value.is_number()) {
      problems_->AddField(field, "is " + Describe(value) + "; expected a number");
      return false;
    }
    *number = value.get<double>();
    if (!std::isfinite(*number)) {
      problems_->AddField(field,
                          "is " + util::ShortestText(*number) + "; expected a finite number");
      return false;
    }
    return true;
  }

  bool ReadVector(const json& object, const std::string& key, const std::string& field, int size,
                  const std::string& expected, bool required, Eigen::VectorXd* vector) const {
    const json* member = Member(object, key, field, expected, required);
    if (member == nullptr) return false;
    if (!member->is_array() || member->size() != static_cast<size_t>(size)) {
      problems_->AddField(field, "is " + Describe(*member) + "; expected " +
                                     std::to_string(size) + " numbers: " + expected);
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

 private:
  Problems* problems_;
};

// ---------------------------------------------------------------- manifest

// Which of the files named by the manifest have a usable path: a table or model
// whose path is wrong is not read at all.
struct ManifestPaths {
  bool camera = false;
  bool frames = false;
  bool nav = false;
  bool lrf = false;
};

// Reads manifest.json into the dataset under construction: the format first,
// then the name, the file paths, the camera mount and the vectors.
class ManifestReader {
 public:
  explicit ManifestReader(LoadContext* context)
      : context_(context), problems_(&context->problems), fields_(&context->problems) {}

  // False when the manifest is unreadable, not an object or of another format:
  // then no other field means anything and nothing else is loaded.
  bool Read(json* manifest, ManifestPaths* paths) {
    std::vector<std::string> repeated;
    if (!Parse(manifest, &repeated)) return false;
    // The format must be understood before any other field means anything.
    if (!CheckFormat(*manifest)) return false;
    for (const std::string& key : repeated) {
      problems_->AddField(key, "appears twice; the last value would win");
    }
    fields_.CheckKeys(*manifest, kManifestKeys, "");
    ReadName(*manifest);
    ReadPaths(*manifest, paths);
    ReadMount(*manifest);
    ReadVectors(*manifest);
    return true;
  }

 private:
  // Reads and parses the file into `manifest`, which must be a JSON object;
  // `repeated` gets each key that appears twice in one object.
  bool Parse(json* manifest, std::vector<std::string>* repeated) {
    std::string text;
    std::string error;
    if (!util::ReadFileBytes(context_->root / kManifestFileName, &text, &error)) {
      problems_->Add(kManifestFileName, error);
      return false;
    }
    // nlohmann keeps the last of two equal keys; a repeated key is a mistake
    // worth reporting, so track the keys of each open object.
    std::vector<std::set<std::string>> open_objects;
    const json::parser_callback_t callback = [&](int /*depth*/, json::parse_event_t event,
                                                 json& parsed) {
      if (event == json::parse_event_t::object_start) {
        open_objects.emplace_back();
      } else if (event == json::parse_event_t::object_end) {
        if (!open_objects.empty()) open_objects.pop_back();
      } else if (event == json::parse_event_t::key && !open_objects.empty()) {
        const std::string key = parsed.get<std::string>();
        if (!open_objects.back().insert(key).second) repeated->push_back(key);
      }
      return true;
    };
    try {
      *manifest = json::parse(text, callback);
    } catch (const json::exception& e) {
      problems_->Add(kManifestFileName,
                     "is not valid JSON (" + util::JsonErrorText(e.what()) + ")");
      return false;
    }
    if (!manifest->is_object()) {
      problems_->Add(kManifestFileName,
                     "is " + Describe(*manifest) +
                         "; expected a JSON object {\"format\": \"hdabench-dataset\", ...}");
      return false;
    }
    return true;
  }

  // Checks "format" and "format_version"; both are checked (and reported)
  // before giving up.
  bool CheckFormat(const json& manifest) {
    bool format_ok = true;
    const json* format = fields_.Member(manifest, "format", "format",
                                        "the string \"" + std::string(kDatasetFormatName) + "\"",
                                        true);
    if (format == nullptr) {
      format_ok = false;
    } else if (!format->is_string() || format->get<std::string>() != kDatasetFormatName) {
      problems_->AddField("format", "is " + Describe(*format) + "; expected \"" +
                                        std::string(kDatasetFormatName) + "\"");
      format_ok = false;
    }
    const json* version =
        fields_.Member(manifest, "format_version", "format_version",
                       "the whole number " + std::to_string(kDatasetFormatVersion), true);
    if (version == nullptr) {
      format_ok = false;
    } else if (!version->is_number_integer() && !version->is_number_unsigned()) {
      problems_->AddField("format_version", "is " + Describe(*version) +
                                                "; expected the whole number " +
                                                std::to_string(kDatasetFormatVersion));
      format_ok = false;
    } else if (version->get<std::int64_t>() != kDatasetFormatVersion) {
      problems_->AddField("format_version", "is " + version->dump() +
                                                "; this build reads format_version " +
                                                std::to_string(kDatasetFormatVersion) + " only");
      format_ok = false;
    }
    return format_ok;
  }

  // The name (required, not empty) and the description (optional).
  void ReadName(const json& manifest) {
    Dataset& dataset = context_->dataset;
    fields_.ReadString(manifest, "name", "name", true, &dataset.name,
                       "a string: the name of the run");
    if (manifest.contains("name") && manifest["name"].is_string() && dataset.name.empty()) {
      problems_->AddField("name", "is empty; expected a name for the dataset");
    }
    fields_.ReadString(manifest, "description", "description", false, &dataset.description);
  }

  // The paths of the camera model and the tables; `paths` says which are usable.
  void ReadPaths(const json& manifest, ManifestPaths* paths) {
    Dataset& dataset = context_->dataset;
    paths->camera =
        ReadPath(manifest, "camera_model", "mrcal .cameramodel", &dataset.camera_model_file);
    paths->frames = ReadPath(manifest, "frames", "frames table", &dataset.frames_file);
    paths->nav = ReadPath(manifest, "navigation", "navigation table", &dataset.nav_file);
    paths->lrf = ReadPath(manifest, "lrf", "LRF table", &dataset.lrf_file);
  }

  // The required dataset path in `key`; false (with a problem) when absent or
  // not a valid path inside the dataset folder.
  bool ReadPath(const json& manifest, const std::string& key, const std::string& what,
                std::string* value) {
    std::string path;
    if (!fields_.ReadString(manifest, key, key, true, &path,
                            "a string: the path of the " + what +
                                ", relative to the dataset folder")) {
      return false;
    }
    const std::string error = internal::CheckDatasetPath(path);
    if (!error.empty()) {
      problems_->AddField(key, error);
      return false;
    }
    *value = path;
    return true;
  }

  // The camera mount "cam_from_body": a unit quaternion and a translation.
  void ReadMount(const json& manifest) {
    const json* mount = fields_.Member(manifest, "cam_from_body", "cam_from_body",
                                       "an object with quaternion_wxyz and translation_m", true);
    if (mount == nullptr) return;
    if (!mount->is_object()) {
      problems_->AddField("cam_from_body",
                          "is " + Describe(*mount) +
                              "; expected an object with quaternion_wxyz and translation_m");
      return;
    }
    Rigid3d& cam_from_body = context_->dataset.cam_from_body;
    fields_.CheckKeys(*mount, {"quaternion_wxyz", "translation_m"}, "cam_from_body.");
    Eigen::VectorXd q;
    if (fields_.ReadVector(*mount, "quaternion_wxyz", "cam_from_body.quaternion_wxyz", 4,
                           "[qw, qx, qy, qz], a unit quaternion rotating body vectors into the "
                           "camera frame",
                           true, &q)) {
      const std::string q_error = CheckQuaternion(q, "quaternion", &cam_from_body.rotation);
      if (!q_error.empty()) problems_->AddField("cam_from_body.quaternion_wxyz", q_error);
    }
    Eigen::VectorXd t;
    if (fields_.ReadVector(*mount, "translation_m", "cam_from_body.translation_m", 3,
                           "[x, y, z] in metres, the body origin in the camera frame", true, &t)) {
      cam_from_body.translation = t;
    }
  }

  // Gravity (required, not zero), the ILS (required) and the LRF origin
  // (optional).
  void ReadVectors(const json& manifest) {
    Dataset& dataset = context_->dataset;
    Eigen::VectorXd gravity;
    if (fields_.ReadVector(manifest, "gravity_in_local_mps2", "gravity_in_local_mps2", 3,
                           "[x, y, z] in m/s^2, e.g. [0, 0, -1.62]", true, &gravity)) {
      if (gravity.norm() == 0.0) {
        problems_->AddField(
            "gravity_in_local_mps2",
            "is (0, 0, 0), which has no direction; expected the gravity vector in the local "
            "frame, e.g. [0, 0, -1.62] on the Moon");
      } else {
        dataset.gravity_in_local_mps2 = gravity;
      }
    }
    Eigen::VectorXd ils;
    if (fields_.ReadVector(manifest, "ils_in_local_m", "ils_in_local_m", 3,
                           "[x, y, z] in metres", true, &ils)) {
      dataset.ils_in_local_m = ils;
    }
    Eigen::VectorXd lrf_origin;
    if (fields_.ReadVector(manifest, "lrf_origin_in_body_m", "lrf_origin_in_body_m", 3,
                           "[x, y, z] in metres", false, &lrf_origin)) {
      dataset.lrf_origin_in_body_m = lrf_origin;
    }
  }

  LoadContext* context_;
  Problems* problems_;
  JsonFields fields_;
};

// ------------------------------------------------------------------ camera

// Reads the mrcal camera model named by the manifest field 'camera_model'.
void LoadCamera(LoadContext* context) {
  const std::string& file = context->dataset.camera_model_file;
  std::string text;
  std::string error;
  if (!util::ReadFileBytes(context->root / file, &text, &error)) {
    context->problems.Add(file, error + " (manifest.json field 'camera_model')");
    return;
  }
  try {
    context->camera.emplace(calib::CameraModel::Parse(text, file));
  } catch (const std::exception& e) {
    context->problems.Add(CameraProblem(file, e.what()));
  }
}

// ------------------------------------------------------------------ tables
// Steps shared by the CSV table readers below.

// Reads a table file; false (with a problem) when missing or unreadable.
bool ReadTable(LoadContext* context, const std::string& file, const std::string& field,
               const CsvSchema& schema, CsvTable* table) {
  std::string text;
  std::string error;
  if (!util::ReadFileBytes(context->root / file, &text, &error)) {
    context->problems.Add(file, error + " (manifest.json field '" + field + "')");
    return false;
  }
  return internal::ParseCsv(file, text, schema, table, context->problems.List());
}

// Requires strictly increasing times; `previous` holds the last valid time.
void CheckIncreasing(CsvRowReader* reader, double time_s, const char* what,
                     std::optional<std::pair<double, int>>* previous) {
  if (previous->has_value() && !(time_s > (*previous)->first)) {
    reader->Fail("time_s " + util::ShortestText(time_s) + " is not after the previous " + what +
                 " time " + util::ShortestText((*previous)->first) + " s (line " +
                 std::to_string((*previous)->second) + "); times must strictly increase");
  }
  *previous = std::make_pair(time_s, reader->Line());
}

// A problem when `table` has fewer than `minimum` data lines.
void CheckEnoughRows(Problems* problems, const std::string& file, const CsvTable& table,
                     int minimum, const std::string& why) {
  const int n = table.num_data_lines;
  if (n < minimum) {
    problems->Add(file, "has " + Plural(static_cast<size_t>(n), "row", "rows") +
                            " after the header; expected at least " + std::to_string(minimum) +
                            " (" + why + ")");
  }
}

// ------------------------------------------------------------ frames table

// One row of the frames table; the flags say which of its values are usable.
struct FrameRow {
  int line = 0;
  FrameRecord record;
  bool time_ok = false;
  bool has_image = false;      // its image cell is not empty
  bool image_path_ok = false;  // ... and names a usable path
};

// The frames table as read.
struct FramesTable {
  bool header_ok = false;      // the table was parsed, so num_frames is known
  int num_frames = 0;          // its data lines, rejected ones included
  std::vector<FrameRow> rows;  // one per row with a value for every column
};

// Reads the frames table (frame, time_s, image): frames numbered 0, 1, 2, ...
// in row order, strictly increasing times, and for each frame a valid image
// path of its own.
class FramesTableReader {
 public:
  explicit FramesTableReader(LoadContext* context) : context_(context) {}

  void Read(FramesTable* frames) {
    const std::string& file = context_->dataset.frames_file;
    CsvTable table;
    if (!ReadTable(context_, file, "frames", kFramesSchema, &table)) return;
    frames->header_ok = true;
    frames->num_frames = table.num_data_lines;
    CheckEnoughRows(&context_->problems, file, table, 2, "a run needs two views");
    int with_image = 0;
    for (const internal::CsvRow& row : table.rows) {
      frames->rows.push_back(ReadRow(file, table, row));
      if (frames->rows.back().has_image) ++with_image;
    }
    if (table.num_data_lines >= 2 && with_image < 2) {
      context_->problems.Add(file, "gives an image for " + Plural(static_cast<size_t>(with_image), "frame", "frames") +
                                       "; expected at least 2 (a run needs two views)");
    }
  }

 private:
  // One frame; its flags say whether its time and image path are usable.
  FrameRow ReadRow(const std::string& file, const CsvTable& table, const internal::CsvRow& row) {
    Problems& problems = context_->problems;
    CsvRowReader reader(file, table, row, problems.List());
    FrameRow frame;
    frame.line = row.line;
    const int expected_index = row.line - 2;  // line 2 holds frame 0
    frame.record.index = reader.Int("frame");
    if (reader.ok() && frame.record.index != expected_index) {
      reader.Fail("frame " + std::to_string(frame.record.index) + " where " +
                  std::to_string(expected_index) +
                  " was expected; frames must be numbered 0, 1, 2, ... in row order");
    }
    const size_t before = problems.Count();
    frame.record.time_s = reader.Double("time_s");
    if (problems.Count() == before) {
      frame.time_ok = true;
      CheckIncreasing(&reader, frame.record.time_s, "frame", &previous_);
    }
    // An empty image cell: a frame of the trajectory without an image.
    const std::string image = reader.TextOrEmpty("image");
    if (!image.empty()) {
      frame.has_image = true;
      frame.record.image_path = image;
      frame.image_path_ok = CheckImagePath(&reader, expected_index, row.line, frame.record.image_path);
    }
    frame.record.index = expected_index;
    return frame;
  }

  // True when `path` is a valid dataset path that no earlier frame uses; it is
  // then recorded as used by frame `index` at `line`.
  bool CheckImagePath(CsvRowReader* reader, int index, int line, const std::string& path) {
    const std::string error = internal::CheckDatasetPath(path);
    if (!error.empty()) {
      reader->Fail("column 'image': " + error);
      return false;
    }
    const std::string normal = internal::NormalDatasetPath(path);
    const auto [it, inserted] = image_users_.emplace(normal, std::make_pair(index, line));
    if (!inserted) {
      reader->Fail("column 'image': '" + path + "' is also the image of frame " +
                   std::to_string(it->second.first) + " (line " +
                   std::to_string(it->second.second) +
                   "); each frame needs its own image file");
      return false;
    }
    return true;
  }

  LoadContext* context_;
  std::optional<std::pair<double, int>> previous_;          // last valid time and its line
  std::map<std::string, std::pair<int, int>> image_users_;  // normal path -> (frame, line)
};

// -------------------------------------------------------- navigation table

// Reads `column` of a navigation row as a standard deviation, which must not
// be negative.
double ReadSigma(Problems* problems, CsvRowReader* reader, const std::string& column) {
  const size_t before = problems->Count();
  const double sigma = reader->Double(column);
  if (problems->Count() == before && sigma < 0.0) {
    reader->Fail("column '" + column + "': value " + util::ShortestText(sigma) +
                 " is negative; expected a standard deviation >= 0");
  }
  return sigma;
}

// Reads one navigation row: time, position, attitude and, when the table has
// them, velocity and sigmas. `previous` holds the last valid time.
NavSample ReadNavRow(Problems* problems, CsvRowReader* reader, const std::string& what,
                     bool has_velocity, bool has_sigmas,
                     std::optional<std::pair<double, int>>* previous) {
  NavSample sample;
  const size_t before_time = problems->Count();
  sample.time_s = reader->Double("time_s");
  if (problems->Count() == before_time) {
    CheckIncreasing(reader, sample.time_s, what.c_str(), previous);
  }
  sample.local_from_body.translation =
      Eigen::Vector3d(reader->Double("x_m"), reader->Double("y_m"), reader->Double("z_m"));
  const size_t before_q = problems->Count();
  const Eigen::Vector4d q(reader->Double("qw"), reader->Double("qx"), reader->Double("qy"),
                          reader->Double("qz"));
  if (problems->Count() == before_q) {
    const std::string error =
        CheckQuaternion(q, "quaternion (qw, qx, qy, qz) =", &sample.local_from_body.rotation);
    if (!error.empty()) reader->Fail(error);
  }
  if (has_velocity) {
    sample.velocity_in_local_mps = Eigen::Vector3d(
        reader->Double("vx_mps"), reader->Double("vy_mps"), reader->Double("vz_mps"));
  }
  if (has_sigmas) {
    const char* const position[] = {"sigma_x_m", "sigma_y_m", "sigma_z_m"};
    const char* const attitude[] = {"sigma_rx_rad", "sigma_ry_rad", "sigma_rz_rad"};
    for (int i = 0; i < 3; ++i) {
      sample.sigma_position_in_local_m[i] = ReadSigma(problems, reader, position[i]);
      sample.sigma_attitude_in_body_rad[i] = ReadSigma(problems, reader, attitude[i]);
    }
  }
  return sample;
}

// Reads a table with the navigation schema (nav.csv or the truth
// navigation): `field` is its manifest field, `what` names it in messages.
// True when the file had no problem at all.
bool LoadNavTable(LoadContext* context, const std::string& file, const std::string& field,
                  const std::string& what, std::vector<NavSample>* samples, bool* has_velocity,
                  bool* has_sigmas) {
  Problems& problems = context->problems;
  CsvTable table;
  const size_t before = problems.Count();
  if (!ReadTable(context, file, field, kNavSchema, &table)) return false;
  CheckEnoughRows(&problems, file, table, 2, "frame times are interpolated between samples");
  *has_velocity = table.HasColumn("vx_mps");
  *has_sigmas = table.HasColumn("sigma_x_m");
  std::optional<std::pair<double, int>> previous;
  for (const internal::CsvRow& row : table.rows) {
    CsvRowReader reader(file, table, row, problems.List());
    const NavSample sample =
        ReadNavRow(&problems, &reader, what, *has_velocity, *has_sigmas, &previous);
    if (reader.ok()) samples->push_back(sample);
  }
  return problems.Count() == before;
}

// Reads the navigation table named by the manifest field 'navigation' into the
// dataset. True when it had no problem at all.
bool LoadNavigation(LoadContext* context) {
  Dataset& dataset = context->dataset;
  return LoadNavTable(context, dataset.nav_file, "navigation", "navigation", &dataset.nav,
                      &dataset.nav_has_velocity, &dataset.nav_has_sigmas);
}

// --------------------------------------------------------------- LRF table

// Reads the boresight (bx, by, bz) of an LRF row: a unit vector, kept bit for
// bit when its norm is 1 to rounding.
void ReadBoresight(Problems* problems, CsvRowReader* reader, LrfSample* sample) {
  const size_t before_boresight = problems->Count();
  const Eigen::Vector3d b(reader->Double("bx"), reader->Double("by"), reader->Double("bz"));
  if (problems->Count() != before_boresight) return;
  const double norm = b.norm();
  if (norm == 0.0) {
    reader->Fail("boresight (bx, by, bz) = " + util::VectorText(b) +
                 " has zero norm; expected a unit vector in the body frame");
  } else if (!(std::abs(norm - 1.0) <= kUnitNormTolerance)) {
    reader->Fail("boresight (bx, by, bz) = " + util::VectorText(b) + " has norm " +
                 util::ShortestText(norm) + "; expected a unit vector (| |b| - 1 | <= 1e-6)");
  } else {
    sample->boresight_in_body = std::abs(norm - 1.0) > kRenormaliseAbove ? b / norm : b;
  }
}

// Reads one LRF row: time, a positive slant range and the boresight.
// `previous` holds the last valid time.
LrfSample ReadLrfRow(Problems* problems, CsvRowReader* reader,
                     std::optional<std::pair<double, int>>* previous) {
  LrfSample sample;
  const size_t before_time = problems->Count();
  sample.time_s = reader->Double("time_s");
  if (problems->Count() == before_time) {
    CheckIncreasing(reader, sample.time_s, "LRF", previous);
  }
  const size_t before_range = problems->Count();
  sample.range_m = reader->Double("range_m");
  if (problems->Count() == before_range && !(sample.range_m > 0.0)) {
    reader->Fail("column 'range_m': value " + util::ShortestText(sample.range_m) +
                 " is not positive; expected a slant range > 0 m (leave out rows without a "
                 "return)");
  }
  ReadBoresight(problems, reader, &sample);
  return sample;
}

// Reads the LRF table named by the manifest field 'lrf' into the dataset. True
// when it had no problem at all.
bool LoadLrfTable(LoadContext* context) {
  Problems& problems = context->problems;
  const std::string& file = context->dataset.lrf_file;
  CsvTable table;
  const size_t before = problems.Count();
  if (!ReadTable(context, file, "lrf", kLrfSchema, &table)) return false;
  // A table with no row is a lander without a usable LRF: the flight method
  // takes the range from the navigation (docs/faults.md). One row cannot be
  // interpolated.
  if (table.num_data_lines != 0) {
    CheckEnoughRows(&problems, file, table, 2,
                    "frame times are interpolated between samples; none at all: no LRF, the range from the navigation");
  }
  std::optional<std::pair<double, int>> previous;
  for (const internal::CsvRow& row : table.rows) {
    CsvRowReader reader(file, table, row, problems.List());
    const LrfSample sample = ReadLrfRow(&problems, &reader, &previous);
    if (reader.ok()) context->dataset.lrf.push_back(sample);
  }
  return problems.Count() == before;
}

// ------------------------------------------------------------------ images

// Checks the image of one frame: readable, a sound PNG of the camera's imager
// size and, when asked, decodable; keeps the decoded image when asked.
void CheckImage(LoadContext* context, FrameRow* frame) {
  Problems& problems = context->problems;
  const Dataset& dataset = context->dataset;
  const std::optional<calib::CameraModel>& camera = context->camera;
  const LoadOptions& options = context->options;
  const std::string& path = frame->record.image_path;
  std::string bytes;
  std::string error;
  if (!util::ReadFileBytes(context->root / path, &bytes, &error)) {
    problems.Add(path, error + " (image of frame " + std::to_string(frame->record.index) + ", " +
                           dataset.frames_file + ":" + std::to_string(frame->line) + ")");
    return;
  }
  internal::PngHeader header;
  if (!internal::CheckPngStructure(bytes, &header, &error)) {
    problems.Add(path, error);
    return;
  }
  if (camera.has_value() &&
      (header.width_px != camera->WidthPx() || header.height_px != camera->HeightPx())) {
    problems.Add(path, "is " + std::to_string(header.width_px) + " x " +
                           std::to_string(header.height_px) + " px; the camera model (" +
                           dataset.camera_model_file + ") has a " +
                           std::to_string(camera->WidthPx()) + " x " +
                           std::to_string(camera->HeightPx()) + " px imager");
    return;
  }
  if ((!options.decode_images && !options.keep_images) || !context->Uses(frame->record.index)) return;
  cv::Mat image;
  if (!internal::DecodePngQuietly(bytes, &image, &error)) {
    problems.Add(path, error);
    return;
  }
  if (image.cols != header.width_px || image.rows != header.height_px) {
    problems.Add(path, "decoded to " + std::to_string(image.cols) + " x " +
                           std::to_string(image.rows) + " px but its header says " +
                           std::to_string(header.width_px) + " x " +
                           std::to_string(header.height_px) + " px");
    return;
  }
  if (options.keep_images) frame->record.image = image;
}

// The frames with an image, as "0, 6" ("none" when there is none).
std::string FramesText(const std::vector<FrameRow>& frame_rows) {
  std::vector<int> indices;
  for (const FrameRow& frame : frame_rows) {
    if (frame.has_image) indices.push_back(frame.record.index);
  }
  return util::JoinInts(indices);
}

// Checks the image of every frame whose image path is usable, then copies the
// frame records into the dataset.
void CheckImages(LoadContext* context, std::vector<FrameRow>* frame_rows) {
  for (FrameRow& frame : *frame_rows) {
    if (!frame.has_image && context->used_frames.has_value() && context->Uses(frame.record.index)) {
      context->problems.Add(context->dataset.frames_file + ":" + std::to_string(frame.line),
                            "frame " + std::to_string(frame.record.index) +
                                " has no image (its image cell is empty), but the command uses it; "
                                "frames with images: " +
                                FramesText(*frame_rows));
    }
    if (!frame.image_path_ok) continue;
    CheckImage(context, &frame);
  }
  for (FrameRow& frame : *frame_rows) context->dataset.frames.push_back(frame.record);
}

// ------------------------------------------------------------- frame times

// A problem when the frame's time lies outside the span of `nav` (the
// navigation or the truth navigation, `what`, read from `file`).
void CheckFrameInNavSpan(LoadContext* context, const FrameRow& frame,
                         const std::vector<NavSample>& nav, const std::string& what,
                         const std::string& file) {
  const double t = frame.record.time_s;
  if (t < nav.front().time_s || t > nav.back().time_s) {
    context->problems.Add(
        context->dataset.frames_file + ":" + std::to_string(frame.line),
        "time_s " + util::ShortestText(t) + " is outside the " + what + " span [" +
            util::ShortestText(nav.front().time_s) + ", " +
            util::ShortestText(nav.back().time_s) + "] s of " + file);
  }
}

// Every frame time must lie inside the navigation and LRF spans. Checked only
// against a table without problems, so that one bad row does not also make
// frames look out of span.
void CheckFrameTimes(LoadContext* context, const std::vector<FrameRow>& frame_rows,
                     bool nav_clean, bool lrf_clean) {
  const Dataset& dataset = context->dataset;
  const bool nav_usable = nav_clean && dataset.nav.size() >= 2;
  const bool lrf_usable = lrf_clean && dataset.lrf.size() >= 2;
  for (const FrameRow& frame : frame_rows) {
    if (!frame.time_ok) continue;
    const double t = frame.record.time_s;
    const std::string where = dataset.frames_file + ":" + std::to_string(frame.line);
    if (nav_usable) CheckFrameInNavSpan(context, frame, dataset.nav, "navigation", dataset.nav_file);
    if (lrf_usable && (t < dataset.lrf.front().time_s || t > dataset.lrf.back().time_s)) {
      context->problems.Add(where, "time_s " + util::ShortestText(t) + " is outside the LRF span [" +
                                       util::ShortestText(dataset.lrf.front().time_s) + ", " +
                                       util::ShortestText(dataset.lrf.back().time_s) + "] s of " +
                                       dataset.lrf_file);
    }
  }
}

// ------------------------------------------------------------------- truth
// Steps shared by the truth readers below.

// Whether truth arrays are read whole (to check or keep them) rather than only
// their headers.
bool ReadTruthValues(const LoadOptions& options) {
  return options.check_truth_values || options.keep_truth;
}

// Opens the .npy file `file` into `opened` and reads its header (the shape,
// checked against the file's size: the data fills the file after the header,
// so it is the file's last NumValues() * 4 bytes). The values are left to the
// caller, to read through `opened` (ReadNpyValues). `note` says in a read
// error what the file is.
bool ReadNpyHeader(LoadContext* context, const std::string& file, const std::string& note,
                   util::OpenedFile* opened, NpyFloat32* array) {
  std::string error;
  if (!opened->Open(context->root / file, &error)) {
    context->problems.Add(file, error + " (" + note + ")");
    return false;
  }
  // The start of the file, unless the header does not fit in it (then the
  // whole file).
  constexpr std::uint64_t kHeaderPrefixBytes = 1 << 16;
  const std::uint64_t size = opened->Size();
  std::string bytes(static_cast<size_t>(std::min(size, kHeaderPrefixBytes)), '\0');
  if (!opened->ReadAt(0, bytes.size(), bytes.data(), &error)) {
    context->problems.Add(file, error + " (" + note + ")");
    return false;
  }
  if (ParseNpyFloat32FileHeader(bytes, size, array, &error) || bytes.size() == size) {
    if (error.empty()) return true;
    context->problems.Add(file, error);
    return false;
  }
  error.clear();
  bytes.assign(static_cast<size_t>(size), '\0');
  if (!opened->ReadAt(0, size, bytes.data(), &error)) {
    context->problems.Add(file, error + " (" + note + ")");
    return false;
  }
  if (!ParseNpyFloat32Header(bytes, array, &error)) {
    context->problems.Add(file, error);
    return false;
  }
  return true;
}

// Reads the values of the .npy file opened by ReadNpyHeader into `values`,
// a matrix of exactly its NumValues() floats, with no copy between.
bool ReadNpyValues(LoadContext* context, const std::string& file, const std::string& note,
                   const util::OpenedFile& opened, cv::Mat* values) {
  const std::uint64_t bytes = values->total() * values->elemSize();
  const std::uint64_t offset = opened.Size() >= bytes ? opened.Size() - bytes : 0;
  std::string error;
  if (!opened.ReadAt(offset, bytes, values->ptr<char>(), &error)) {
    context->problems.Add(file, error + " (" + note + ")");
    return false;
  }
  return true;
}

// ------------------------------------------------------------ truth points

// Reads 'truth.points_in_local': per frame, an .npy array of the local point
// each pixel sees.
class TruthPointsReader {
 public:
  TruthPointsReader(LoadContext* context, const FramesTable& frames)
      : context_(context),
        problems_(&context->problems),
        fields_(&context->problems),
        frames_(frames) {}

  // Reads the array 'truth.points_in_local' of {"frame": index, "file": path}
  // entries, and the .npy file of each usable entry.
  void Read(const json& points) {
    const std::string field = "truth.points_in_local";
    if (!points.is_array()) {
      problems_->AddField(field, "is " + Describe(points) +
                                     "; expected an array of {\"frame\": index, \"file\": path}");
      return;
    }
    std::map<int, size_t> seen;  // frame -> entry index
    for (size_t i = 0; i < points.size(); ++i) {
      TruthPoints truth;
      if (!ReadPointsEntry(points[i], field, i, &seen, &truth)) continue;
      if (LoadPointsFile(&truth)) context_->dataset.truth.points.push_back(std::move(truth));
    }
  }

 private:
  // Reads entry `i` of the array `field` into `truth`; false (with problems)
  // when it is not a usable {"frame": index, "file": path}.
  bool ReadPointsEntry(const json& entry, const std::string& field, size_t i,
                       std::map<int, size_t>* seen, TruthPoints* truth) {
    const std::string entry_field = field + "[" + std::to_string(i) + "]";
    if (!entry.is_object()) {
      problems_->AddField(entry_field, "is " + Describe(entry) +
                                           "; expected {\"frame\": index, \"file\": path}");
      return false;
    }
    fields_.CheckKeys(entry, {"frame", "file"}, entry_field + ".");
    bool ok = ReadPointsFrame(entry, field, entry_field, i, seen, &truth->frame);
    std::string file;
    if (fields_.ReadString(entry, "file", entry_field + ".file", true, &file)) {
      const std::string error = internal::CheckDatasetPath(file);
      if (!error.empty()) {
        problems_->AddField(entry_field + ".file", error);
        ok = false;
      }
      truth->file = file;
    } else {
      ok = false;
    }
    return ok;
  }

  // Reads the frame index of entry `i`: a frame of the frames table (when its
  // header was read) that no earlier entry names. `seen` maps frames to entries.
  bool ReadPointsFrame(const json& entry, const std::string& field,
                       const std::string& entry_field, size_t i, std::map<int, size_t>* seen,
                       int* frame_index) {
    const json* frame =
        fields_.Member(entry, "frame", entry_field + ".frame", "a frame index", true);
    if (frame == nullptr) return false;
    if (!frame->is_number_integer() && !frame->is_number_unsigned()) {
      problems_->AddField(entry_field + ".frame",
                          "is " + Describe(*frame) + "; expected a frame index");
      return false;
    }
    const std::int64_t index = frame->get<std::int64_t>();
    if (frames_.header_ok && (index < 0 || index >= frames_.num_frames)) {
      problems_->AddField(entry_field + ".frame",
                          "is " + std::to_string(index) + "; " + context_->dataset.frames_file +
                              " has frames 0.." + std::to_string(frames_.num_frames - 1));
      return false;
    }
    *frame_index = static_cast<int>(index);
    const auto [it, inserted] = seen->emplace(*frame_index, i);
    if (!inserted) {
      problems_->AddField(entry_field + ".frame",
                          "frame " + std::to_string(*frame_index) + " already has truth points (" +
                              field + "[" + std::to_string(it->second) + "])");
      return false;
    }
    return true;
  }

  // Reads the .npy file of one entry: an (imager height, width, 3) array,
  // checked and kept when asked.
  bool LoadPointsFile(TruthPoints* truth) {
    const std::string& file = truth->file;
    const bool read_values = ReadTruthValues(context_->options) && context_->Uses(truth->frame);
    const std::string note = "truth points of frame " + std::to_string(truth->frame);
    // The header first; the values (12 MB at 1024 x 1024) then go straight
    // from the file into the matrix that keeps them, with no copy between.
    util::OpenedFile opened;
    NpyFloat32 array;
    if (!ReadNpyHeader(context_, file, note, &opened, &array)) return false;
    const std::optional<calib::CameraModel>& camera = context_->camera;
    if (!camera.has_value()) return false;  // the camera's problem is already reported
    const std::vector<std::int64_t> expected = {camera->HeightPx(), camera->WidthPx(), 3};
    if (array.shape != expected) {
      problems_->Add(file, "has shape " + FormatNpyShape(array.shape) + "; expected " +
                               FormatNpyShape(expected) +
                               " (imager height, width, then x, y, z in the local frame)");
      return false;
    }
    if (!read_values) return true;
    cv::Mat points(camera->HeightPx(), camera->WidthPx(), CV_32FC3);
    if (!ReadNpyValues(context_, file, note, opened, &points)) return false;
    if (!CheckPointValues(file, points.ptr<float>(), points.total())) return false;
    if (context_->options.keep_truth) truth->points_in_local_m = points;
    return true;
  }

  // Finite points, or all three NaN where the pixel's ray hits nothing; else a
  // problem with the count and the first bad point. `values` holds `count`
  // points of three coordinates.
  bool CheckPointValues(const std::string& file, const float* values, size_t count) {
    size_t bad = 0;
    size_t first_bad = 0;
    for (size_t p = 0; p < count; ++p) {
      const float* v = &values[3 * p];
      const bool all_finite = std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
      const bool all_nan = std::isnan(v[0]) && std::isnan(v[1]) && std::isnan(v[2]);
      if (!all_finite && !all_nan) {
        if (bad == 0) first_bad = p;
        ++bad;
      }
    }
    if (bad == 0) return true;
    const size_t width = static_cast<size_t>(context_->camera->WidthPx());
    const float* v = &values[3 * first_bad];
    problems_->Add(file, "has " + Plural(bad, "point", "points") +
                             " with an infinite or partly NaN coordinate, the first at row " +
                             std::to_string(first_bad / width) + ", column " +
                             std::to_string(first_bad % width) + ": " +
                             util::VectorText(Eigen::Vector3d(static_cast<double>(v[0]),
                                                              static_cast<double>(v[1]),
                                                              static_cast<double>(v[2]))) +
                             "; expected finite points, or (nan, nan, nan) where the ray hits "
                             "nothing");
    return false;
  }

  LoadContext* context_;
  Problems* problems_;
  JsonFields fields_;
  const FramesTable& frames_;
};

// --------------------------------------------------------------- truth DEM

// Reads 'truth.dem': a grid of heights in the local frame, its origin and
// spacing in the manifest, its heights in an .npy file.
class TruthDemReader {
 public:
  explicit TruthDemReader(LoadContext* context)
      : context_(context), problems_(&context->problems), fields_(&context->problems) {}

  // Reads the object 'truth.dem': its fields, then its .npy file of heights.
  void Read(const json& dem_json) {
    TruthDem dem;
    if (!ReadDemFields(dem_json, &dem)) return;
    if (!LoadDemFile(&dem)) return;
    context_->dataset.truth.dem = std::move(dem);
  }

 private:
  // Reads the DEM's file, origin_in_local_m and spacing_m; false (with
  // problems) when any is missing or wrong.
  bool ReadDemFields(const json& dem_json, TruthDem* dem) {
    const std::string field = "truth.dem";
    if (!dem_json.is_object()) {
      problems_->AddField(field, "is " + Describe(dem_json) +
                                     "; expected an object with file, origin_in_local_m and "
                                     "spacing_m");
      return false;
    }
    fields_.CheckKeys(dem_json, {"file", "origin_in_local_m", "spacing_m"}, field + ".");
    bool ok = true;
    if (fields_.ReadString(dem_json, "file", field + ".file", true, &dem->file)) {
      const std::string error = internal::CheckDatasetPath(dem->file);
      if (!error.empty()) {
        problems_->AddField(field + ".file", error);
        ok = false;
      }
    } else {
      ok = false;
    }
    Eigen::VectorXd origin;
    if (fields_.ReadVector(dem_json, "origin_in_local_m", field + ".origin_in_local_m", 2,
                           "[x, y] in metres, the centre of cell (0, 0)", true, &origin)) {
      dem->origin_in_local_m = origin;
    } else {
      ok = false;
    }
    if (!ReadDemSpacing(dem_json, field + ".spacing_m", &dem->spacing_m)) ok = false;
    return ok;
  }

  // Reads the DEM's cell size, which must be positive.
  bool ReadDemSpacing(const json& dem_json, const std::string& field, double* spacing_m) {
    const json* spacing =
        fields_.Member(dem_json, "spacing_m", field, "the cell size in metres (> 0)", true);
    if (spacing == nullptr) return false;
    if (!fields_.ReadNumber(*spacing, field, spacing_m)) return false;
    if (!(*spacing_m > 0.0)) {
      problems_->AddField(field,
                          "is " + util::ShortestText(*spacing_m) + "; expected a cell size > 0 m");
      return false;
    }
    return true;
  }

  // Reads the DEM's .npy file: a (rows, columns) array of heights, checked to
  // be finite and kept when asked.
  bool LoadDemFile(TruthDem* dem) {
    const bool read_values = ReadTruthValues(context_->options) && context_->options.read_dem;
    const std::string note = "manifest.json field 'truth.dem.file'";
    // The header first; the heights (50 MB for the default scene's DEM) then
    // go straight from the file into the matrix that keeps them, with no copy
    // between.
    util::OpenedFile opened;
    NpyFloat32 array;
    if (!ReadNpyHeader(context_, dem->file, note, &opened, &array)) return false;
    if (array.shape.size() != 2 || array.shape[0] < 1 || array.shape[1] < 1 ||
        array.shape[0] > std::numeric_limits<int>::max() ||
        array.shape[1] > std::numeric_limits<int>::max()) {
      problems_->Add(dem->file, "has shape " + FormatNpyShape(array.shape) +
                                    "; expected (rows, columns) of heights, each at least 1");
      return false;
    }
    dem->height_cells = static_cast<int>(array.shape[0]);
    dem->width_cells = static_cast<int>(array.shape[1]);
    if (!read_values) return true;
    cv::Mat heights(dem->height_cells, dem->width_cells, CV_32FC1);
    if (!ReadNpyValues(context_, dem->file, note, opened, &heights)) return false;
    if (!CheckHeightValues(*dem, heights.ptr<float>(), heights.total())) return false;
    if (context_->options.keep_truth) dem->height_in_local_m = heights;
    return true;
  }

  // Finite heights; else a problem with the count and the first bad cell.
  // `values` holds `count` heights.
  bool CheckHeightValues(const TruthDem& dem, const float* values, size_t count) {
    size_t bad = 0;
    size_t first_bad = 0;
    for (size_t i = 0; i < count; ++i) {
      if (!std::isfinite(values[i])) {
        if (bad == 0) first_bad = i;
        ++bad;
      }
    }
    if (bad == 0) return true;
    const size_t width = static_cast<size_t>(dem.width_cells);
    problems_->Add(dem.file, "has " + Plural(bad, "non-finite height", "non-finite heights") +
                                 ", the first at row " + std::to_string(first_bad / width) +
                                 ", column " + std::to_string(first_bad % width) + " (" +
                                 util::ShortestText(static_cast<double>(values[first_bad])) +
                                 "); expected finite heights in metres");
    return false;
  }

  LoadContext* context_;
  Problems* problems_;
  JsonFields fields_;
};

// ------------------------------------------------------------ truth object

// Reads the optional manifest object 'truth': the truth points and the DEM
// (each by its own reader), the truth navigation and the truth rocks tables.
class TruthLoader {
 public:
  TruthLoader(LoadContext* context, const FramesTable& frames)
      : context_(context),
        problems_(&context->problems),
        fields_(&context->problems),
        frames_(frames) {}

  void Load(const json& manifest) {
    const json* truth = fields_.Member(manifest, "truth", "truth", "", false);
    if (truth == nullptr) return;
    if (!truth->is_object()) {
      problems_->AddField("truth", "is " + Describe(*truth) +
                                       "; expected an object with points_in_local, dem, "
                                       "navigation and/or rocks");
      return;
    }
    fields_.CheckKeys(*truth, kTruthKeys, "truth.");
    if (const json* points =
            fields_.Member(*truth, "points_in_local", "truth.points_in_local", "", false)) {
      TruthPointsReader(context_, frames_).Read(*points);
    }
    if (const json* dem = fields_.Member(*truth, "dem", "truth.dem", "", false)) {
      TruthDemReader(context_).Read(*dem);
    }
    LoadNavigation(*truth);
    LoadRocks(*truth);
    LoadImaging(*truth);
  }

 private:
  // The path in optional member `key` of the truth object; false when absent
  // or wrong (a problem).
  bool ReadTruthPath(const json& truth, const std::string& key, const std::string& what,
                     std::string* path) {
    const std::string field = "truth." + key;
    if (!fields_.ReadString(truth, key, field, false, path,
                            "a string: the path of the " + what +
                                ", relative to the dataset folder")) {
      return false;
    }
    const std::string error = internal::CheckDatasetPath(*path);
    if (!error.empty()) {
      problems_->AddField(field, error);
      path->clear();
      return false;
    }
    return true;
  }

  // Reads the truth navigation table named by 'truth.navigation'; kept only
  // when it has no problem, and then every frame time must lie in its span.
  void LoadNavigation(const json& truth) {
    std::string file;
    if (!ReadTruthPath(truth, "navigation", "truth navigation table", &file)) return;
    std::vector<NavSample> samples;
    bool has_velocity = false;
    bool has_sigmas = false;
    const bool clean = LoadNavTable(context_, file, "truth.navigation", "truth navigation",
                                    &samples, &has_velocity, &has_sigmas);
    if (!clean) return;
    for (const FrameRow& frame : frames_.rows) {
      if (frame.time_ok) CheckFrameInNavSpan(context_, frame, samples, "truth navigation", file);
    }
    context_->dataset.truth.navigation_file = file;
    context_->dataset.truth.navigation = std::move(samples);
  }

  // Reads 'truth.imaging' (the sun and the sensor noise of a synthetic
  // dataset); kept only when every field is right.
  void LoadImaging(const json& truth) {
    const json* imaging = fields_.Member(truth, "imaging", "truth.imaging", "", false);
    if (imaging == nullptr) return;
    if (!imaging->is_object()) {
      problems_->AddField("truth.imaging", "is " + Describe(*imaging) +
                                               "; expected an object with sun_in_local, gain_electrons_per_dn "
                                               "and read_noise_dn");
      return;
    }
    fields_.CheckKeys(*imaging, {"sun_in_local", "gain_electrons_per_dn", "read_noise_dn"}, "truth.imaging.");
    TruthImaging result;
    bool ok = true;
    Eigen::VectorXd sun;
    if (fields_.ReadVector(*imaging, "sun_in_local", "truth.imaging.sun_in_local", 3,
                           "a unit vector toward the sun in the local frame", true, &sun)) {
      if (std::abs(sun.norm() - 1.0) > 1e-6) {
        problems_->AddField("truth.imaging.sun_in_local",
                            "has norm " + util::ShortestText(sun.norm()) + "; expected a unit vector");
        ok = false;
      } else {
        result.sun_in_local = sun;
      }
    } else {
      ok = false;
    }
    // From 0 to `max` (a finite value beyond it gave sums that overflow).
    const auto read_positive = [&](const std::string& key, double max, double* value) {
      const std::string field = "truth.imaging." + key;
      const json* member = fields_.Member(*imaging, key, field, "a number", true);
      if (member == nullptr || !fields_.ReadNumber(*member, field, value)) return false;
      if (!(*value >= 0.0 && *value <= max)) {
        problems_->AddField(field, "is " + util::ShortestText(*value) + "; expected 0 to " + util::ShortestText(max));
        return false;
      }
      return true;
    };
    ok = read_positive("gain_electrons_per_dn", kMaxGainElectronsPerDn, &result.gain_electrons_per_dn) && ok;
    ok = read_positive("read_noise_dn", kMaxReadNoiseDn, &result.read_noise_dn) && ok;
    if (ok) context_->dataset.truth.imaging = result;
  }

  // Reads the truth rocks table named by 'truth.rocks'; rows with a problem are
  // left out.
  void LoadRocks(const json& truth) {
    std::string file;
    if (!ReadTruthPath(truth, "rocks", "truth rocks table", &file)) return;
    CsvTable table;
    if (!ReadTable(context_, file, "truth.rocks", kRocksSchema, &table)) return;
    std::vector<TruthRock> rocks;
    for (const internal::CsvRow& row : table.rows) {
      CsvRowReader reader(file, table, row, problems_->List());
      const TruthRock rock = ReadRock(&reader);
      if (reader.ok()) rocks.push_back(rock);
    }
    context_->dataset.truth.rocks_file = file;
    context_->dataset.truth.rocks = std::move(rocks);
  }

  // Reads one rock: its centre, a positive diameter, and a positive height
  // above the ground no larger than the diameter.
  TruthRock ReadRock(CsvRowReader* reader) {
    TruthRock rock;
    rock.center_in_local_m =
        Eigen::Vector3d(reader->Double("x_m"), reader->Double("y_m"), reader->Double("z_m"));
    const size_t before_diameter = problems_->Count();
    rock.diameter_m = reader->Double("diameter_m");
    const bool diameter_ok = problems_->Count() == before_diameter && rock.diameter_m > 0.0;
    if (problems_->Count() == before_diameter && !diameter_ok) {
      reader->Fail("column 'diameter_m': value " + util::ShortestText(rock.diameter_m) +
                   " is not positive; expected a rock diameter > 0 m");
    }
    const size_t before_height = problems_->Count();
    rock.height_above_ground_m = reader->Double("height_above_ground_m");
    if (problems_->Count() == before_height) {
      if (!(rock.height_above_ground_m > 0.0)) {
        reader->Fail("column 'height_above_ground_m': value " +
                     util::ShortestText(rock.height_above_ground_m) +
                     " is not positive; expected a height above the ground > 0 m");
      } else if (diameter_ok && rock.height_above_ground_m > rock.diameter_m) {
        reader->Fail("column 'height_above_ground_m': value " +
                     util::ShortestText(rock.height_above_ground_m) +
                     " is larger than diameter_m " + util::ShortestText(rock.diameter_m) +
                     "; expected a height above the ground <= the rock's diameter");
      }
    }
    return rock;
  }

  LoadContext* context_;
  Problems* problems_;
  JsonFields fields_;
  const FramesTable& frames_;
};

// ----------------------------------------------------------------- loading

// Loads a dataset folder table by table, in a fixed order so that problems
// are reported in file order: the manifest, the camera model, the frames,
// navigation and LRF tables, the images, the frame times, then the truth.
class Loader {
 public:
  Loader(const std::string& dir, const LoadOptions& options)
      : dir_(dir), context_(dir, options) {}

  DatasetLoadResult Run() {
    DatasetLoadResult result;
    std::error_code ec;
    const fs::file_status status = fs::status(context_.root, ec);
    if (ec || !fs::exists(status)) {
      context_.problems.Add(dir_, "dataset folder not found");
    } else if (!fs::is_directory(status)) {
      context_.problems.Add(dir_,
                            "is not a folder; expected a dataset folder holding manifest.json");
    } else {
      LoadTables();
    }
    result.problems = context_.problems.Take();
    if (result.problems.empty() && context_.camera.has_value()) {
      context_.dataset.camera = *context_.camera;
      context_.dataset.dir = dir_;
      result.dataset = std::move(context_.dataset);
    }
    return result;
  }

 private:
  // Reads every file; a file whose manifest path is wrong is skipped, and
  // nothing is read after an unusable manifest.
  void LoadTables() {
    json manifest;
    ManifestPaths paths;
    if (!ManifestReader(&context_).Read(&manifest, &paths)) return;
    if (paths.camera) LoadCamera(&context_);
    FramesTable frames;
    if (paths.frames) FramesTableReader(&context_).Read(&frames);
    const bool nav_clean = paths.nav && LoadNavigation(&context_);
    const bool lrf_clean = paths.lrf && LoadLrfTable(&context_);
    ChooseFramesUsed(frames);
    CheckImages(&context_, &frames.rows);
    CheckFrameTimes(&context_, frames.rows, nav_clean, lrf_clean);
    TruthLoader(&context_, frames).Load(manifest);
  }

  // LoadOptions::frames_used on the tables read so far, when they are clean.
  void ChooseFramesUsed(const FramesTable& frames) {
    if (!context_.options.frames_used || context_.problems.Count() > 0) return;
    Dataset tables = context_.dataset;
    for (const FrameRow& row : frames.rows) tables.frames.push_back(row.record);
    try {
      const std::vector<int> used = context_.options.frames_used(tables);
      context_.used_frames.emplace(used.begin(), used.end());
    } catch (const std::exception&) {
      // Every frame then: the command reports its own error.
    }
  }

  const std::string dir_;
  LoadContext context_;
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
        {std::to_string(frame.index), util::ShortestText(frame.time_s), frame.image_path});
  }
  return text;
}

std::string NavCsv(const std::vector<NavSample>& nav, bool has_velocity, bool has_sigmas) {
  std::string text = NavHeader(has_velocity, has_sigmas);
  for (const NavSample& sample : nav) {
    const Eigen::Vector3d& p = sample.local_from_body.translation;
    const Eigen::Quaterniond& q = sample.local_from_body.rotation;
    std::vector<std::string> values = {util::ShortestText(sample.time_s), util::ShortestText(p.x()),
                                       util::ShortestText(p.y()),         util::ShortestText(p.z()),
                                       util::ShortestText(q.w()),         util::ShortestText(q.x()),
                                       util::ShortestText(q.y()),         util::ShortestText(q.z())};
    if (has_velocity) {
      for (int i = 0; i < 3; ++i) values.push_back(util::ShortestText(sample.velocity_in_local_mps[i]));
    }
    if (has_sigmas) {
      for (int i = 0; i < 3; ++i) {
        values.push_back(util::ShortestText(sample.sigma_position_in_local_m[i]));
      }
      for (int i = 0; i < 3; ++i) {
        values.push_back(util::ShortestText(sample.sigma_attitude_in_body_rad[i]));
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
        {util::ShortestText(rock.center_in_local_m.x()), util::ShortestText(rock.center_in_local_m.y()),
         util::ShortestText(rock.center_in_local_m.z()), util::ShortestText(rock.diameter_m),
         util::ShortestText(rock.height_above_ground_m)});
  }
  return text;
}

std::string LrfCsv(const Dataset& dataset) {
  std::string text = internal::CsvLine(kLrfSchema.required);
  for (const LrfSample& sample : dataset.lrf) {
    text += internal::CsvLine({util::ShortestText(sample.time_s), util::ShortestText(sample.range_m),
                               util::ShortestText(sample.boresight_in_body.x()),
                               util::ShortestText(sample.boresight_in_body.y()),
                               util::ShortestText(sample.boresight_in_body.z())});
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
    if (dataset.truth.imaging.has_value()) {
      const TruthImaging& imaging = *dataset.truth.imaging;
      truth["imaging"]["sun_in_local"] = JsonArray(imaging.sun_in_local);
      truth["imaging"]["gain_electrons_per_dn"] = imaging.gain_electrons_per_dn;
      truth["imaging"]["read_noise_dn"] = imaging.read_noise_dn;
    }
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
    if (!frame.HasImage()) {
      RequireWritable(frame.image.empty(), label + " has an image in memory but no image path");
      continue;
    }
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

std::vector<int> FramesWithImages(const std::vector<FrameRecord>& frames) {
  std::vector<int> indices;
  for (const FrameRecord& frame : frames) {
    if (frame.HasImage()) indices.push_back(frame.index);
  }
  return indices;
}

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
    util::WriteFileAtomically(staging / dataset.camera_model_file, dataset.camera.ToText());
    // The images are encoded on every core (each PNG depends on its frame
    // only), then written in frame order.
    std::vector<std::string> encoded(dataset.frames.size());
    util::ParallelFor("dataset images", static_cast<int>(dataset.frames.size()), util::WorkerThreads(0), [&](int i) {
      const FrameRecord& frame = dataset.frames[static_cast<size_t>(i)];
      if (frame.HasImage()) encoded[static_cast<size_t>(i)] = internal::EncodePng(frame.image);
    });
    for (size_t i = 0; i < dataset.frames.size(); ++i) {
      if (dataset.frames[i].HasImage()) util::WriteFileAtomically(staging / dataset.frames[i].image_path, encoded[i]);
    }
    util::WriteFileAtomically(staging / dataset.frames_file, FramesCsv(dataset));
    util::WriteFileAtomically(
        staging / dataset.nav_file,
        NavCsv(dataset.nav, dataset.nav_has_velocity, dataset.nav_has_sigmas));
    util::WriteFileAtomically(staging / dataset.lrf_file, LrfCsv(dataset));
    for (const TruthPoints& truth : dataset.truth.points) {
      util::WriteFileAtomically(staging / truth.file, NpyFromMat(truth.points_in_local_m));
    }
    if (dataset.truth.dem.has_value()) {
      util::WriteFileAtomically(staging / dataset.truth.dem->file,
                                    NpyFromMat(dataset.truth.dem->height_in_local_m));
    }
    if (!dataset.truth.navigation_file.empty()) {
      util::WriteFileAtomically(staging / dataset.truth.navigation_file,
                                    TruthNavCsv(dataset.truth.navigation));
    }
    if (!dataset.truth.rocks_file.empty()) {
      util::WriteFileAtomically(staging / dataset.truth.rocks_file,
                                    RocksCsv(dataset.truth.rocks));
    }
    util::WriteFileAtomically(staging / kManifestFileName, ManifestJson(dataset));
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
    throw std::out_of_range("time " + util::ShortestText(time_s) +
                            " s is outside the truth navigation span [" + util::ShortestText(first) +
                            ", " + util::ShortestText(last) + "] s");
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
