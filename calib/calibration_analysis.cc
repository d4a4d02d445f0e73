#include "calib/calibration_analysis.h"

#include <stdlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>
#include <utility>

#include "calib/camera_model.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/process.h"
#include "tools/util/python_script.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::calib {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr char kAnalysisFormat[] = "hdabench-calibration-analysis";
constexpr char kDiffFormat[] = "hdabench-calibration-diff";
constexpr char kModesFormat[] = "hdabench-calibration-modes";
constexpr char kResolvedFormat[] = "hdabench-calibration-resolved";
constexpr int kFormatVersion = 1;
// Exit code of the script for unusable input; its message is the last line
// of its output that starts with kScriptMessagePrefix.
constexpr int kScriptExitInput = 3;
constexpr char kScriptMessagePrefix[] = "hdabench-calibration-analysis: ";

// ---------------------------------------------------------------- files

std::string ReadText(const fs::path& path, bool* ok) {
  std::ifstream in(path, std::ios::binary);
  *ok = static_cast<bool>(in);
  if (!*ok) return "";
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void CreateFolder(const fs::path& folder, const std::string& what) {
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec || !fs::is_directory(folder)) {
    throw InputError(folder.string() + ": cannot create the " + what + " folder" +
                     (ec ? ": " + ec.message() : ""));
  }
}

void RemoveFile(const fs::path& path, const std::string& what) {
  std::error_code ec;
  fs::remove(path, ec);
  if (ec)
    throw InputError(path.string() + ": cannot remove the earlier " + what + ": " + ec.message());
}

// The last non-empty line of a log, and the last line the script wrote as its
// message (prefixed), if any.
void LogLines(const fs::path& log, std::string* last_line, std::string* script_message) {
  bool ok = false;
  const std::string text = ReadText(log, &ok);
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (line.empty()) continue;
    *last_line = line;
    if (line.rfind(kScriptMessagePrefix, 0) == 0) {
      *script_message = line.substr(sizeof(kScriptMessagePrefix) - 1);
    }
  }
}

// The script writes every file as ".<name>.<pid>.tmp" and renames it; a run
// killed on its timeout can leave such a temporary behind. Removes those of
// `target`, or (target a folder the analysis owns) every one in it.
void RemoveScriptTemporaries(const fs::path& target, bool whole_folder) {
  std::error_code ec;
  const fs::path folder = whole_folder ? target : target.parent_path();
  const std::string prefix = whole_folder ? "." : "." + target.filename().string() + ".";
  for (const auto& entry : fs::directory_iterator(folder.empty() ? fs::path(".") : folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.size() > prefix.size() + 4 && name.rfind(prefix, 0) == 0 &&
        name.compare(name.size() - 4, 4, ".tmp") == 0) {
      fs::remove(entry.path(), ec);
    }
  }
}

void RequireModelFile(const std::string& path) {
  std::error_code ec;
  if (path.empty()) throw InputError("camera model path is empty");
  if (!fs::exists(path, ec))
    throw InputError(path + ": no such file (expected a mrcal .cameramodel)");
  if (!fs::is_regular_file(path, ec)) {
    throw InputError(path + ": is not a file (expected a mrcal .cameramodel)");
  }
}

// Runs the script with `arguments` and turns every failure into an exception.
// `what` says what the script was doing ("the calibration analysis").
util::ProcessResult RunScript(const std::string& python, double timeout_s,
                              const std::vector<std::string>& arguments, const fs::path& log,
                              const std::string& what) {
  const util::PythonScript script("calibration", "calibration_analysis.py",
                                  CalibrationAnalysisScript());
  util::PythonScriptOptions run;
  run.python = python;
  run.log_file = log.string();
  run.timeout_s = timeout_s;
  run.single_threaded_math = true;  // repeatable sums
  const util::ProcessResult result = script.Run(arguments, run);
  if (result.Ok()) return result;

  std::string last_line, script_message;
  LogLines(log, &last_line, &script_message);
  if (result.started && !result.timed_out && !result.signaled &&
      result.exit_code == kScriptExitInput) {
    throw InputError(script_message.empty() ? last_line : script_message);
  }
  std::string message = python + " (" + what + ") failed: ";
  if (!result.started) {
    message += result.error +
               "; the calibration analysis needs Debian's python3 with "
               "python3-mrcal, python3-opencv and python3-matplotlib";
  } else {
    message += result.error;
  }
  message += "; log: " + log.string();
  if (!last_line.empty()) message += "; last line: " + last_line;
  throw ExternalError(message);
}

// ---------------------------------------------------------------- reading the JSON

// Reads the script's JSON; every problem is the script's (ExternalError).
class Reader {
 public:
  explicit Reader(const fs::path& path) : path_(path) {
    bool ok = false;
    const std::string text = ReadText(path, &ok);
    if (!ok) Fail("", "the script exited cleanly but wrote no file");
    try {
      root_ = Json::parse(text);
    } catch (const Json::exception& e) {
      Fail("", "not valid JSON (" + util::JsonErrorText(e.what()) + ")");
    }
  }

  const Json& root() const { return root_; }

  [[noreturn]] void Fail(const std::string& key, const std::string& problem) const {
    throw ExternalError(path_.string() + ": unusable calibration analysis output" +
                        (key.empty() ? "" : ": key \"" + key + "\"") + ": " + problem);
  }

  void CheckFormat(const char* format) const {
    if (!root_.is_object() || root_.value("format", "") != format) {
      Fail("format", std::string("expected \"") + format + "\"");
    }
    const Json& version = Member(root_, "format_version", "format_version");
    if (!version.is_number_integer() || version.get<int>() != kFormatVersion) {
      Fail("format_version", "expected " + std::to_string(kFormatVersion));
    }
  }

  // A member that must be present (any type).
  const Json& Member(const Json& object, const char* key, const std::string& where) const {
    if (!object.is_object() || !object.contains(key)) Fail(where, "missing");
    return object[key];
  }
  const Json& Object(const Json& object, const char* key, const std::string& where) const {
    const Json& value = Member(object, key, where);
    if (!value.is_object()) Fail(where, "expected an object");
    return value;
  }
  const Json& Array(const Json& object, const char* key, const std::string& where) const {
    const Json& value = Member(object, key, where);
    if (!value.is_array()) Fail(where, "expected an array");
    return value;
  }
  // Finite numbers only: the script writes null for a missing value.
  double Number(const Json& value, const std::string& where) const {
    if (!value.is_number()) Fail(where, "expected a number, got " + value.dump());
    const double number = value.get<double>();
    if (!std::isfinite(number)) Fail(where, "not a finite number");
    return number;
  }
  double Number(const Json& object, const char* key, const std::string& where) const {
    return Number(Member(object, key, where), where);
  }
  std::optional<double> OptionalNumber(const Json& object, const char* key,
                                       const std::string& where) const {
    if (!object.is_object() || !object.contains(key) || object[key].is_null()) return std::nullopt;
    return Number(object[key], where);
  }
  int Integer(const Json& object, const char* key, const std::string& where) const {
    const Json& value = Member(object, key, where);
    if (!value.is_number_integer()) Fail(where, "expected an integer, got " + value.dump());
    return value.get<int>();
  }
  std::string String(const Json& object, const char* key, const std::string& where) const {
    const Json& value = Member(object, key, where);
    if (!value.is_string()) Fail(where, "expected a string");
    return value.get<std::string>();
  }
  // The "error" member of a section: empty when null or absent.
  std::string Error(const Json& object, const std::string& where) const {
    if (!object.is_object() || !object.contains("error") || object["error"].is_null()) return "";
    if (!object["error"].is_string()) Fail(where + ".error", "expected a string or null");
    return object["error"].get<std::string>();
  }
  double Share(const Json& object, const char* key, const std::string& where) const {
    const double share = Number(object, key, where);
    if (share < 0.0 || share > 1.0) Fail(where, "expected a share in [0,1]");
    return share;
  }
  // An array of finite numbers.
  std::vector<double> Numbers(const Json& object, const char* key, const std::string& where) const {
    std::vector<double> numbers;
    for (const Json& value : Array(object, key, where)) numbers.push_back(Number(value, where));
    return numbers;
  }
  // An array of exactly three finite numbers.
  Eigen::Vector3d Vector3(const Json& object, const char* key, const std::string& where) const {
    const std::vector<double> numbers = Numbers(object, key, where);
    if (numbers.size() != 3) Fail(where, "expected 3 numbers");
    return Eigen::Vector3d(numbers[0], numbers[1], numbers[2]);
  }
  // A path the JSON gives relative to its own folder.
  std::string Path(const Json& object, const char* key, const std::string& where) const {
    return (path_.parent_path() / String(object, key, where)).lexically_normal().string();
  }

 private:
  fs::path path_;
  Json root_;
};

ProjectionDiffSummary ReadDiffSummary(const Reader& r, const Json& j, const std::string& where) {
  ProjectionDiffSummary d;
  d.median_px = r.Number(j, "median_px", where + ".median_px");
  d.p90_px = r.Number(j, "p90_px", where + ".p90_px");
  d.max_px = r.Number(j, "max_px", where + ".max_px");
  d.band_median_px = r.OptionalNumber(j, "band_median_px", where + ".band_median_px");
  d.band_max_px = r.OptionalNumber(j, "band_max_px", where + ".band_max_px");
  d.rotation_deg = r.Number(j, "rotation_deg", where + ".rotation_deg");
  const Json& grid = r.Array(j, "grid", where + ".grid");
  if (grid.size() != 2) r.Fail(where + ".grid", "expected [width, height]");
  d.grid_width = static_cast<int>(r.Number(grid[0], where + ".grid"));
  d.grid_height = static_cast<int>(r.Number(grid[1], where + ".grid"));
  return d;
}

ProjectionSpread ReadSpread(const Reader& r, const Json& j, const std::string& where) {
  ProjectionSpread s;
  s.rms_px = r.OptionalNumber(j, "rms_px", where + ".rms_px");
  s.worst_direction_stdev_px =
      r.OptionalNumber(j, "worst_direction_stdev_px", where + ".worst_direction_stdev_px");
  return s;
}

// The camera's identity, imager size and HDA band: the head of its section.
void ReadCameraHeader(const Reader& r, const Json& j, const std::string& where, CameraAnalysis* c) {
  c->index = r.Integer(j, "index", where + ".index");
  c->model = r.String(j, "model", where + ".model");
  c->icam_intrinsics = r.Integer(j, "icam_intrinsics", where + ".icam_intrinsics");
  c->lensmodel = r.String(j, "lensmodel", where + ".lensmodel");
  const Json& size = r.Array(j, "imager_size", where + ".imager_size");
  if (size.size() != 2) r.Fail(where + ".imager_size", "expected [width, height]");
  c->width_px = static_cast<int>(r.Number(size[0], where + ".imager_size"));
  c->height_px = static_cast<int>(r.Number(size[1], where + ".imager_size"));
  const Json& band = r.Object(j, "band_px", where + ".band_px");
  c->band_px = {
      r.Number(band, "x0", where + ".band_px.x0"), r.Number(band, "x1", where + ".band_px.x1"),
      r.Number(band, "y0", where + ".band_px.y0"), r.Number(band, "y1", where + ".band_px.y1")};
}

// The "residuals" section, with its per-image rows.
void ReadResiduals(const Reader& r, const Json& j, const std::string& where, ResidualSummary* s) {
  const std::string rw = where + ".residuals";
  const Json& res = r.Object(j, "residuals", rw);
  s->rms_px = r.Number(res, "rms_px", rw + ".rms_px");
  s->worst_px = r.Number(res, "worst_px", rw + ".worst_px");
  s->median_px = r.Number(res, "median_px", rw + ".median_px");
  s->noise_stdev_px = r.Number(res, "noise_stdev_px", rw + ".noise_stdev_px");
  s->mrcal_rms_px = r.Number(res, "mrcal_rms_px", rw + ".mrcal_rms_px");
  s->inliers = r.Integer(res, "inliers", rw + ".inliers");
  s->outliers = r.Integer(res, "outliers", rw + ".outliers");
  s->detected = r.Integer(res, "detected", rw + ".detected");
  s->board_points = r.Integer(res, "board_points", rw + ".board_points");
  const Json& images = r.Array(res, "per_image", rw + ".per_image");
  for (size_t i = 0; i < images.size(); ++i) {
    const std::string iw = rw + ".per_image[" + std::to_string(i) + "]";
    ImageResiduals image;
    image.image = r.String(images[i], "image", iw + ".image");
    image.observation = r.Integer(images[i], "observation", iw + ".observation");
    image.corners = r.Integer(images[i], "corners", iw + ".corners");
    image.inliers = r.Integer(images[i], "inliers", iw + ".inliers");
    image.outliers = r.Integer(images[i], "outliers", iw + ".outliers");
    image.rms_px = r.OptionalNumber(images[i], "rms_px", iw + ".rms_px");
    image.worst_px = r.OptionalNumber(images[i], "worst_px", iw + ".worst_px");
    s->images.push_back(std::move(image));
  }
}

// The "coverage" section; the count grid must match its stated cell size.
void ReadCoverage(const Reader& r, const Json& j, const std::string& where, CameraAnalysis* c) {
  const std::string cw = where + ".coverage";
  const Json& cov = r.Object(j, "coverage", cw);
  const Json& cells = r.Array(cov, "cells", cw + ".cells");
  if (cells.size() != 2) r.Fail(cw + ".cells", "expected [columns, rows]");
  c->coverage.cells_x = static_cast<int>(r.Number(cells[0], cw + ".cells"));
  c->coverage.cells_y = static_cast<int>(r.Number(cells[1], cw + ".cells"));
  c->coverage.share = r.Share(cov, "share", cw + ".share");
  c->coverage.band_cells = r.Integer(cov, "band_cells", cw + ".band_cells");
  c->coverage.band_share = r.Share(cov, "band_share", cw + ".band_share");
  const Json& counts = r.Array(cov, "counts", cw + ".counts");
  if (counts.size() != static_cast<size_t>(c->coverage.cells_y))
    r.Fail(cw + ".counts", "expected one row per cell row");
  for (const Json& row : counts) {
    if (!row.is_array() || row.size() != static_cast<size_t>(c->coverage.cells_x)) {
      r.Fail(cw + ".counts", "expected one count per cell column");
    }
    std::vector<int> values;
    for (const Json& v : row) {
      if (!v.is_number_integer() || v.get<int>() < 0)
        r.Fail(cw + ".counts", "expected counts >= 0");
      values.push_back(v.get<int>());
    }
    c->coverage.counts.push_back(std::move(values));
  }
  c->coverage.figure = r.Path(cov, "figure", cw + ".figure");
}

// The "uncertainty" section: its figures only when the script reports no error.
void ReadUncertainty(const Reader& r, const Json& j, const std::string& where, CameraAnalysis* c) {
  const std::string uw = where + ".uncertainty";
  const Json& unc = r.Object(j, "uncertainty", uw);
  c->uncertainty_error = r.Error(unc, uw);
  if (c->uncertainty_error.empty()) {
    UncertaintySummary u;
    u.band_median_px = r.Number(unc, "band_median_px", uw + ".band_median_px");
    u.band_max_px = r.Number(unc, "band_max_px", uw + ".band_max_px");
    u.band_centre_px = r.Number(unc, "band_centre_px", uw + ".band_centre_px");
    u.imager_centre_px = r.Number(unc, "imager_centre_px", uw + ".imager_centre_px");
    u.imager_median_px = r.Number(unc, "imager_median_px", uw + ".imager_median_px");
    u.imager_max_px = r.Number(unc, "imager_max_px", uw + ".imager_max_px");
    u.figure = r.Path(unc, "figure", uw + ".figure");
    c->uncertainty = u;
  }
}

// The "slope_error" section; its optional parts (failures, spreads, geometry)
// only when present, and its counts must agree with its statistics.
void ReadSlopeError(const Reader& r, const Json& j, const std::string& where,
                    SlopeErrorSummary* e) {
  const std::string sw = where + ".slope_error";
  const Json& slope = r.Object(j, "slope_error", sw);
  e->error = r.Error(slope, sw);
  e->samples = r.Integer(slope, "samples", sw + ".samples");
  e->ok = r.Integer(slope, "ok", sw + ".ok");
  e->failed = r.Integer(slope, "failed", sw + ".failed");
  if (slope.contains("failures")) {
    for (const Json& f : r.Array(slope, "failures", sw + ".failures")) {
      if (!f.is_string()) r.Fail(sw + ".failures", "expected strings");
      e->failures.push_back(f.get<std::string>());
    }
  }
  e->rms_deg = r.OptionalNumber(slope, "rms_deg", sw + ".rms_deg");
  e->median_deg = r.OptionalNumber(slope, "median_deg", sw + ".median_deg");
  e->p90_deg = r.OptionalNumber(slope, "p90_deg", sw + ".p90_deg");
  e->max_deg = r.OptionalNumber(slope, "max_deg", sw + ".max_deg");
  e->nominal_deg = r.OptionalNumber(slope, "nominal_deg", sw + ".nominal_deg");
  e->rotation_fit_median_deg =
      r.OptionalNumber(slope, "rotation_fit_median_deg", sw + ".rotation_fit_median_deg");
  e->noise_stdev_px = r.OptionalNumber(slope, "noise_stdev_px", sw + ".noise_stdev_px");
  e->mrcal_band_centre_stdev_px =
      r.OptionalNumber(slope, "mrcal_band_centre_stdev_px", sw + ".mrcal_band_centre_stdev_px");
  if (slope.contains("band_centre_spread")) {
    const Json& spread = r.Object(slope, "band_centre_spread", sw + ".band_centre_spread");
    e->fitted_rotation_spread = ReadSpread(
        r, r.Object(spread, "fitted_rotation", sw + ".band_centre_spread.fitted_rotation"),
        sw + ".band_centre_spread.fitted_rotation");
    e->board_rotation_spread =
        ReadSpread(r, r.Object(spread, "board_rotation", sw + ".band_centre_spread.board_rotation"),
                   sw + ".band_centre_spread.board_rotation");
  }
  if (slope.contains("geometry")) {
    e->convergence_deg = r.OptionalNumber(r.Object(slope, "geometry", sw + ".geometry"),
                                          "convergence_deg", sw + ".geometry.convergence_deg");
  }
  if (e->error.empty() && (e->ok + e->failed != e->samples || (e->ok > 0 && !e->rms_deg))) {
    r.Fail(sw, "inconsistent sample counts or missing statistics");
  }
}

// The "opencv" section: the cross-check only when the script reports no error.
void ReadOpenCv(const Reader& r, const Json& j, const std::string& where, CameraAnalysis* c) {
  const std::string ow = where + ".opencv";
  const Json& cv = r.Object(j, "opencv", ow);
  c->opencv_error = r.Error(cv, ow);
  if (c->opencv_error.empty()) {
    OpenCvCrossCheck o;
    o.model = r.Path(cv, "model", ow + ".model");
    o.images = r.Integer(cv, "images", ow + ".images");
    o.corners = r.Integer(cv, "corners", ow + ".corners");
    o.rms_px = r.Number(cv, "rms_px", ow + ".rms_px");
    o.rms_inliers_px = r.Number(cv, "rms_inliers_px", ow + ".rms_inliers_px");
    o.diff = ReadDiffSummary(r, r.Object(cv, "diff", ow + ".diff"), ow + ".diff");
    o.figure = r.Path(cv, "figure", ow + ".figure");
    if (cv.contains("inliers_only")) {
      const Json& in = r.Object(cv, "inliers_only", ow + ".inliers_only");
      if (r.Error(in, ow + ".inliers_only").empty()) {
        o.inliers_only_rms_px = r.Number(in, "rms_px", ow + ".inliers_only.rms_px");
        o.inliers_only_diff = ReadDiffSummary(r, in, ow + ".inliers_only");
      }
    }
    c->opencv = o;
  }
}

// One camera's section, read in the order of its parts: the first problem
// found is the one reported.
CameraAnalysis ReadCamera(const Reader& r, const Json& j, const std::string& where) {
  CameraAnalysis c;
  ReadCameraHeader(r, j, where, &c);
  ReadResiduals(r, j, where, &c.residuals);
  ReadCoverage(r, j, where, &c);
  ReadUncertainty(r, j, where, &c);
  ReadSlopeError(r, j, where, &c.slope);
  ReadOpenCv(r, j, where, &c);
  return c;
}

CalibrationAnalysis ReadAnalysis(const fs::path& json_path) {
  const Reader r(json_path);
  r.CheckFormat(kAnalysisFormat);
  CalibrationAnalysis analysis;
  const Json& cameras = r.Array(r.root(), "cameras", "cameras");
  for (size_t i = 0; i < cameras.size(); ++i) {
    analysis.cameras.push_back(ReadCamera(r, cameras[i], "cameras[" + std::to_string(i) + "]"));
  }
  const Json& poses = r.Array(r.root(), "relative_poses", "relative_poses");
  for (size_t i = 0; i < poses.size(); ++i) {
    const std::string where = "relative_poses[" + std::to_string(i) + "]";
    RelativePose pose;
    pose.camera = r.Integer(poses[i], "camera", where + ".camera");
    pose.relative_to = r.Integer(poses[i], "relative_to", where + ".relative_to");
    const Json& same = r.Member(poses[i], "same_solve", where + ".same_solve");
    if (!same.is_boolean()) r.Fail(where + ".same_solve", "expected true or false");
    pose.same_solve = same.get<bool>();
    pose.baseline = r.OptionalNumber(poses[i], "baseline", where + ".baseline");
    pose.rotation_deg = r.OptionalNumber(poses[i], "rotation_deg", where + ".rotation_deg");
    if (poses[i].contains("translation")) {
      const Json& t = r.Array(poses[i], "translation", where + ".translation");
      if (t.size() != 3) r.Fail(where + ".translation", "expected 3 numbers");
      pose.translation = std::array<double, 3>{r.Number(t[0], where + ".translation"),
                                               r.Number(t[1], where + ".translation"),
                                               r.Number(t[2], where + ".translation")};
    }
    if (pose.same_solve && (!pose.baseline || !pose.rotation_deg || !pose.translation)) {
      r.Fail(where, "a pose from one solve needs baseline, rotation_deg and translation");
    }
    analysis.relative_poses.push_back(pose);
  }
  return analysis;
}

ProjectionDiff ReadDiff(const fs::path& json_path, bool with_uncertainty) {
  const Reader r(json_path);
  r.CheckFormat(kDiffFormat);
  const Json& j = r.root();
  ProjectionDiff d;
  d.median_px = r.Number(j, "median_px", "median_px");
  d.p90_px = r.Number(j, "p90_px", "p90_px");
  d.max_px = r.Number(j, "max_px", "max_px");
  d.rotation_deg = r.Number(j, "rotation_deg", "rotation_deg");
  d.rotation_rad = r.Vector3(j, "rotation_rad", "rotation_rad");
  d.points = r.Integer(j, "points", "points");
  const Json& grid = r.Array(j, "grid", "grid");
  if (grid.size() != 2) r.Fail("grid", "expected [width, height]");
  d.grid_width = static_cast<int>(r.Number(grid[0], "grid"));
  d.grid_height = static_cast<int>(r.Number(grid[1], "grid"));
  d.rotation_fit = r.String(j, "rotation_fit", "rotation_fit");
  if (with_uncertainty) {
    const Json& u = r.Object(j, "uncertainty_of_a", "uncertainty_of_a");
    DiffUncertainty du;
    du.median_px = r.Number(u, "median_px", "uncertainty_of_a.median_px");
    du.max_px = r.Number(u, "max_px", "uncertainty_of_a.max_px");
    du.points = r.Integer(u, "points", "uncertainty_of_a.points");
    du.within_1_sigma = r.Share(u, "within_1_sigma", "uncertainty_of_a.within_1_sigma");
    du.within_2_sigma = r.Share(u, "within_2_sigma", "uncertainty_of_a.within_2_sigma");
    du.within_3_sigma = r.Share(u, "within_3_sigma", "uncertainty_of_a.within_3_sigma");
    d.uncertainty_of_a = du;
  }
  return d;
}

ResolvedCalibration ReadResolved(const fs::path& json_path) {
  const Reader r(json_path);
  r.CheckFormat(kResolvedFormat);
  const Json& j = r.root();
  ResolvedCalibration c;
  c.lensmodel = r.String(j, "lensmodel", "lensmodel");
  c.intrinsics = r.Numbers(j, "intrinsics", "intrinsics");
  c.noise_stdev_px = r.Number(j, "noise_stdev_px", "noise_stdev_px");
  c.failed = r.Integer(j, "failed", "failed");
  for (const Json& failure : r.Array(j, "failures", "failures")) {
    if (!failure.is_string()) r.Fail("failures", "expected strings");
    c.failures.push_back(failure.get<std::string>());
  }
  const Json& samples = r.Array(j, "samples", "samples");
  for (size_t k = 0; k < samples.size(); ++k) {
    if (samples[k].is_null()) continue;  // a failed sample, counted in "failed"
    const std::string where = "samples[" + std::to_string(k) + "]";
    ResolvedIntrinsics solved;
    solved.intrinsics = r.Numbers(samples[k], "intrinsics", where + ".intrinsics");
    if (solved.intrinsics.size() != c.intrinsics.size()) r.Fail(where, "one value per intrinsic expected");
    solved.rotation_rad = r.Vector3(samples[k], "rotation_rad", where + ".rotation_rad");
    c.solved.push_back(std::move(solved));
  }
  return c;
}

IntrinsicsModes ReadModes(const fs::path& json_path) {
  const Reader r(json_path);
  r.CheckFormat(kModesFormat);
  const Json& j = r.root();
  IntrinsicsModes m;
  m.lensmodel = r.String(j, "lensmodel", "lensmodel");
  m.intrinsics = r.Numbers(j, "intrinsics", "intrinsics");
  m.noise_stdev_px = r.Number(j, "noise_stdev_px", "noise_stdev_px");
  m.imager_worst_stdev_median_px = r.Number(j, "imager_worst_stdev_median_px", "imager_worst_stdev_median_px");
  m.compensated_worst_stdev_median_px =
      r.Number(j, "compensated_worst_stdev_median_px", "compensated_worst_stdev_median_px");
  m.variance_kept = r.Share(j, "variance_kept", "variance_kept");
  const Json& modes = r.Array(j, "modes", "modes");
  for (size_t k = 0; k < modes.size(); ++k) {
    const std::string where = "modes[" + std::to_string(k) + "]";
    IntrinsicsMode mode;
    mode.intrinsics_delta = r.Numbers(modes[k], "intrinsics_delta", where + ".intrinsics_delta");
    if (mode.intrinsics_delta.size() != m.intrinsics.size()) r.Fail(where, "one change per intrinsic expected");
    mode.rotation_rad = r.Vector3(modes[k], "rotation_rad", where + ".rotation_rad");
    mode.projection_rms_px = r.Number(modes[k], "projection_rms_px", where + ".projection_rms_px");
    m.modes.push_back(std::move(mode));
  }
  return m;
}

}  // namespace

std::vector<std::string> HdaGeometry::Validate() const {
  std::vector<std::string> errors;
  RequireOption(range_m > 0, "range_m", range_m, "> 0 metres", &errors);
  RequireOption(baseline_m > 0, "baseline_m", baseline_m, "> 0 metres", &errors);
  RequireOption(site_m > 0, "site_m", site_m, "> 0 metres", &errors);
  RequireOption(band_x0 >= 0 && band_x0 < 1, "band_x0", band_x0, "a fraction in [0,1)", &errors);
  RequireOption(band_x1 > band_x0 && band_x1 <= 1, "band_x1", band_x1, "a fraction in (band_x0, 1]",
                &errors);
  RequireOption(band_y0 >= 0 && band_y0 < 1, "band_y0", band_y0, "a fraction in [0,1)", &errors);
  RequireOption(band_y1 > band_y0 && band_y1 <= 1, "band_y1", band_y1, "a fraction in (band_y0, 1]",
                &errors);
  return errors;
}

std::vector<std::string> AnalysisOptions::Validate() const {
  std::vector<std::string> errors = hda.Validate();
  if (python.empty())
    errors.push_back("python is empty: expected an interpreter such as /usr/bin/python3");
  RequireOption(timeout_s > 0, "timeout_s", timeout_s, "> 0 seconds", &errors);
  RequireOption(slope_samples >= 0, "slope_samples", slope_samples, ">= 0", &errors);
  return errors;
}

std::vector<std::string> DiffOptions::Validate() const {
  std::vector<std::string> errors;
  if (python.empty())
    errors.push_back("python is empty: expected an interpreter such as /usr/bin/python3");
  RequireOption(timeout_s > 0, "timeout_s", timeout_s, "> 0 seconds", &errors);
  RequireOption(gridn >= 2, "gridn", gridn, ">= 2 grid points across", &errors);
  return errors;
}

// The slope figure of each camera's Monte Carlo: the script leaves each
// re-solve's intrinsics and implied rotation ("solved"); the flight method's
// steps (options.hda_tilt_deg) fit the HDA site with each, and the section
// gets nominal_deg (the nominal model through the same steps: the
// machinery's floor) and rms, median, p90 and max over the re-solves, in
// place of the list.
void AddHdaSlopeErrors(const fs::path& json_path, const std::vector<std::string>& models,
                       const AnalysisOptions& options) {
  using OrderedJson = nlohmann::ordered_json;  // the script's key order kept
  bool ok = false;
  OrderedJson record = OrderedJson::parse(ReadText(json_path, &ok), nullptr, false);
  if (!ok || record.is_discarded() || !record.contains("cameras") || !record["cameras"].is_array()) return;  // ReadAnalysis names it
  for (size_t c = 0; c < record["cameras"].size() && c < models.size(); ++c) {
    OrderedJson& slope = record["cameras"][c]["slope_error"];
    if (!slope.is_object() || !slope.contains("solved")) continue;
    const OrderedJson solved = slope["solved"];
    slope.erase("solved");
    if (!options.hda_tilt_deg) {
      slope["error"] = "no slope figure: the flight method's steps were not given (calib::AnalysisOptions::hda_tilt_deg)";
      continue;
    }
    const CameraModel truth = CameraModel::Load(models[c]);
    std::vector<double> tilts;
    int failed = 0;
    for (const OrderedJson& sample : solved) {
      std::vector<double> intrinsics = sample.at("intrinsics").get<std::vector<double>>();
      const std::vector<double> r = sample.at("rotation_rad").get<std::vector<double>>();
      const CameraModel believed(truth.LensModelName(), std::move(intrinsics), truth.WidthPx(), truth.HeightPx(),
                                 truth.RtCamRef(), models[c]);
      const double tilt = options.hda_tilt_deg(truth, believed, Eigen::Vector3d(r.at(0), r.at(1), r.at(2)), options.hda);
      if (std::isfinite(tilt)) {
        tilts.push_back(tilt);
      } else {
        ++failed;
      }
    }
    if (failed > 0) {
      slope["ok"] = slope["ok"].get<int>() - failed;
      slope["failed"] = slope["failed"].get<int>() + failed;
      slope["failures"].push_back("the flight method's steps fitted no plane to the HDA site");
    }
    slope["nominal_deg"] = options.hda_tilt_deg(truth, truth, Eigen::Vector3d::Zero(), options.hda);
    slope["geometry"]["site_grid"] = {10, 10};
    if (tilts.empty()) continue;
    double sum2 = 0.0;
    for (double t : tilts) sum2 += t * t;
    std::sort(tilts.begin(), tilts.end());
    slope["rms_deg"] = std::sqrt(sum2 / static_cast<double>(tilts.size()));
    slope["median_deg"] = util::Quantile(tilts, 0.5);
    slope["p90_deg"] = util::Quantile(tilts, 0.9);
    slope["max_deg"] = tilts.back();
  }
  util::WriteFileAtomically(json_path, record.dump(2) + "\n");
}

CalibrationAnalysis AnalyseCalibration(const std::vector<std::string>& models,
                                       const std::string& out_dir, const AnalysisOptions& options) {
  const std::vector<std::string> errors = options.Validate();
  ThrowIfInvalid("calibration analysis options: ", errors);
  if (models.empty()) throw InputError("calibration analysis: no camera model given");
  if (out_dir.empty()) throw InputError("calibration analysis: the output folder is empty");
  for (const std::string& model : models) RequireModelFile(model);

  const fs::path dir(out_dir);
  const fs::path json = dir / "analysis.json";
  const fs::path figures = dir / "figures";
  const fs::path opencv = dir / "opencv";
  const fs::path logs = dir / "logs";
  const fs::path log = logs / "analysis.log";
  CreateFolder(dir, "calibration analysis output");
  CreateFolder(figures, "figures");
  CreateFolder(opencv, "OpenCV models");
  CreateFolder(logs, "logs");
  // An earlier record must not pass for this run's if this one fails.
  RemoveFile(json, "analysis record");

  // Option and value on one line each.
  // clang-format off
  std::vector<std::string> arguments = {
      "analyse",
      "--json", fs::absolute(json).string(),
      "--figures", fs::absolute(figures).string(),
      "--opencv-dir", fs::absolute(opencv).string(),
      "--band-x0", util::ShortestText(options.hda.band_x0),
      "--band-x1", util::ShortestText(options.hda.band_x1),
      "--band-y0", util::ShortestText(options.hda.band_y0),
      "--band-y1", util::ShortestText(options.hda.band_y1),
      "--range-m", util::ShortestText(options.hda.range_m),
      "--baseline-m", util::ShortestText(options.hda.baseline_m),
      "--site-m", util::ShortestText(options.hda.site_m),
      "--samples", std::to_string(options.slope_samples),
      "--seed", std::to_string(options.seed),
      "--"};
  // clang-format on
  arguments.insert(arguments.end(), models.begin(), models.end());
  util::ProcessResult result;
  try {
    result =
        RunScript(options.python, options.timeout_s, arguments, log, "the calibration analysis");
  } catch (...) {
    for (const fs::path& folder : {dir, figures, opencv}) RemoveScriptTemporaries(folder, true);
    throw;
  }

  try {
    AddHdaSlopeErrors(json, models, options);
  } catch (const nlohmann::json::exception& e) {
    throw ExternalError(json.string() + ": unusable calibration analysis output: the re-solves: " +
                        util::JsonErrorText(e.what()));
  }
  CalibrationAnalysis analysis = ReadAnalysis(json);
  if (analysis.cameras.size() != models.size()) {
    throw ExternalError(json.string() + ": unusable calibration analysis output: " +
                        std::to_string(analysis.cameras.size()) + " cameras for " +
                        std::to_string(models.size()) + " models");
  }
  analysis.json_path = json.string();
  analysis.log_path = log.string();
  analysis.wall_s = result.wall_s;
  return analysis;
}

ProjectionDiff DiffCalibrations(const std::string& a, const std::string& b,
                                const std::string& out_json, const std::string& heatmap_png,
                                const DiffOptions& options) {
  const std::vector<std::string> errors = options.Validate();
  ThrowIfInvalid("calibration diff options: ", errors);
  RequireModelFile(a);
  RequireModelFile(b);
  if (out_json.empty()) throw InputError("calibration diff: the JSON output path is empty");
  if (heatmap_png.empty()) throw InputError("calibration diff: the heat map path is empty");

  const fs::path json(out_json);
  const fs::path png(heatmap_png);
  fs::path log = json;
  log.replace_extension(".log");
  CreateFolder(json.has_parent_path() ? json.parent_path() : fs::path("."), "diff output");
  CreateFolder(png.has_parent_path() ? png.parent_path() : fs::path("."), "heat map");
  RemoveFile(json, "diff record");

  std::vector<std::string> arguments = {"diff", "--json", fs::absolute(json).string(), "--png",
                                        fs::absolute(png).string(), "--gridn",
                                        std::to_string(options.gridn)};
  if (options.with_uncertainty_of_a) arguments.push_back("--uncertainty-of-a");
  arguments.insert(arguments.end(), {"--", a, b});
  try {
    RunScript(options.python, options.timeout_s, arguments, log, "the calibration diff");
  } catch (...) {
    RemoveScriptTemporaries(json, false);
    RemoveScriptTemporaries(png, false);
    throw;
  }

  ProjectionDiff diff = ReadDiff(json, options.with_uncertainty_of_a);
  diff.json_path = json.string();
  diff.heatmap_png = png.string();
  diff.log_path = log.string();
  return diff;
}

std::vector<std::string> ModesOptions::Validate() const {
  std::vector<std::string> errors;
  if (python.empty())
    errors.push_back("python is empty: expected an interpreter such as /usr/bin/python3");
  RequireOption(timeout_s > 0, "timeout_s", timeout_s, "> 0 seconds", &errors);
  return errors;
}

bool ModelHasOptimizationInputs(const std::string& path) {
  bool ok = false;
  const std::string text = ReadText(path, &ok);
  return ok && (text.find("'optimization_inputs'") != std::string::npos ||
                text.find("\"optimization_inputs\"") != std::string::npos);
}

namespace {

// Runs the script's `command` on a calibration's model (one holding its
// optimization_inputs) in a temporary folder and reads the JSON it writes.
template <typename Record>
Record RunOnCalibration(const std::string& model, const ModesOptions& options, const std::string& command,
                        const std::vector<std::string>& extra, const std::string& what,
                        Record (*read)(const fs::path&)) {
  ThrowIfInvalid("calibration script options: ", options.Validate());
  RequireModelFile(model);
  if (!ModelHasOptimizationInputs(model)) {
    throw InputError(model + ": the model holds no optimization_inputs, so its calibration has no "
                     "uncertainty to propagate (mrcal-calibrate-cameras and hdabench calibrate write them; "
                     "re-saving a model elsewhere drops them)");
  }
  const util::TempFolder work("calibration-" + command);
  const fs::path json = work.path() / (command + ".json");
  std::vector<std::string> arguments = {command, "--json", json.string()};
  arguments.insert(arguments.end(), extra.begin(), extra.end());
  arguments.insert(arguments.end(), {"--", model});
  RunScript(options.python, options.timeout_s, arguments, work.path() / (command + ".log"), what);
  return read(json);
}

}  // namespace

IntrinsicsModes ComputeIntrinsicsModes(const std::string& model, const ModesOptions& options) {
  IntrinsicsModes modes = RunOnCalibration(model, options, "modes", {}, "the calibration's uncertainty modes",
                                           ReadModes);
  modes.model = model;
  return modes;
}

ResolvedCalibration ResolveCalibration(const std::string& model, int samples, std::uint64_t seed,
                                       const ModesOptions& options) {
  if (samples < 1) throw InputError("calibration re-solves: samples = " + std::to_string(samples) + ": expected >= 1");
  ResolvedCalibration resolved =
      RunOnCalibration(model, options, "resolve", {"--samples", std::to_string(samples), "--seed", std::to_string(seed)},
                       "the calibration's re-solves", ReadResolved);
  resolved.model = model;
  return resolved;
}

}  // namespace hdabench::calib
