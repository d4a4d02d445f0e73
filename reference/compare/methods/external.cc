// external: a team's own method, run as a program the user names
// (CompareOptions::external, docs/external-method.md). The bench writes the
// pair as the flight method sees it (images, camera model, navigation, the
// flight method's ROIs with their matches and points) into a folder, runs the
// program on it with a time limit, and reads back one plane (or a status) per
// ROI. The program's failure, timeout or unusable output fails this column
// only, with the reason; the other methods' results are kept.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "reference/compare/method.h"
#include "reference/compare/methods/method_support.h"
#include "tools/images/png.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/process.h"

namespace hdabench::reference {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

Json VectorJson(const Eigen::Vector3d& v) { return Json::array({v.x(), v.y(), v.z()}); }

// A pose as rows of its rotation matrix and its translation (b_from_a: a
// point x in a is R x + t in b).
Json PoseJson(const Rigid3d& b_from_a) {
  const Eigen::Matrix3d r = b_from_a.RotationMatrix();
  Json rows = Json::array();
  for (int i = 0; i < 3; ++i) rows.push_back(Json::array({r(i, 0), r(i, 1), r(i, 2)}));
  return Json{{"rotation", rows}, {"translation_m", VectorJson(b_from_a.translation)}};
}

Json BoxJson(const cv::Rect& box) {
  if (box.empty()) return Json(nullptr);
  return Json::array({box.x, box.y, box.width, box.height});
}

Json PixelsJson(const std::vector<cv::Point2d>& pixels) {
  Json out = Json::array();
  for (const cv::Point2d& p : pixels) out.push_back(Json::array({p.x, p.y}));
  return out;
}

Json PointsJson(const std::vector<Eigen::Vector3d>& points) {
  Json out = Json::array();
  for (const Eigen::Vector3d& p : points) out.push_back(VectorJson(p));
  return out;
}

// The program's input: input.json and the files it names, in `dir`.
void WriteInput(const PairContext& ctx, const fs::path& dir) {
  util::WriteFileAtomically(dir / "image1.png", images::EncodePng(ctx.input().image1));
  util::WriteFileAtomically(dir / "image2.png", images::EncodePng(ctx.input().image2));
  ctx.dataset().camera.Save((dir / "camera.cameramodel").string());
  const hda::HdaInput& in = ctx.input();
  Json j;
  j["format"] = "hdabench-external-input";
  j["format_version"] = 1;
  j["dataset"] = ctx.dataset().name;
  j["frames"] = Json::array({ctx.frame1(), ctx.frame2()});
  j["image1"] = "image1.png";
  j["image2"] = "image2.png";
  j["camera_model"] = "camera.cameramodel";
  j["local_from_cam1"] = PoseJson(ctx.local_from_cam1());
  j["local_from_cam2"] = PoseJson(ctx.local_from_cam2());
  j["cam2_from_cam1"] = PoseJson(in.cam2_from_cam1);
  j["gravity_in_local_mps2"] = VectorJson(in.gravity_in_local_mps2);
  j["lrf"] = Json{{"range_m", in.lrf_range_m},
                  {"origin_in_cam1_m", VectorJson(in.lrf_origin_in_cam1_m)},
                  {"beam_in_cam1", VectorJson(in.lrf_beam_in_cam1.normalized())}};
  j["min_points"] = ctx.options().min_points;
  Json rois = Json::array();
  for (const hda::RoiResult& r : ctx.flight().result.rois) {
    rois.push_back(Json{{"id", r.id},
                        {"box1_px", BoxJson(r.box1_px)},
                        {"box2_px", BoxJson(r.box2_px)},
                        {"flight_status", hda::ToString(r.status)},
                        {"flight_points1_px", PixelsJson(r.points1_px)},
                        {"flight_points2_px", PixelsJson(r.points2_px)},
                        {"flight_points_in_local_m", PointsJson(r.points_in_local_m)}});
  }
  j["rois"] = rois;
  util::WriteFileAtomically(dir / "input.json", j.dump(1) + "\n");
}

// The most points or ROI id a record may name.
constexpr double kMaxCount = 1e9;

// A status the program may give an ROI: every comparison status but the
// flight method's own.
bool ParseStatus(const std::string& name, MethodRoiStatus* status) {
  for (int s = 0; s < static_cast<int>(MethodRoiStatus::kFlight); ++s) {
    if (name == ToString(static_cast<MethodRoiStatus>(s))) {
      *status = static_cast<MethodRoiStatus>(s);
      return true;
    }
  }
  return false;
}

std::string StatusNames() {
  std::string names;
  for (int s = 0; s < static_cast<int>(MethodRoiStatus::kFlight); ++s) {
    names += (s == 0 ? "'" : ", '") + std::string(ToString(static_cast<MethodRoiStatus>(s))) + "'";
  }
  return names;
}

// A finite vector of 3 numbers, or throws naming `where`.
Eigen::Vector3d ReadVector(const Json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number()) {
    throw InputError(where + ": expected a list of 3 numbers");
  }
  const Eigen::Vector3d v(j[0].get<double>(), j[1].get<double>(), j[2].get<double>());
  if (!v.allFinite()) throw InputError(where + ": not finite");
  return v;
}

double ReadNonNegative(const Json& r, const char* key, const std::string& where) {
  if (!r.contains(key)) return 0.0;
  if (!r[key].is_number() || !std::isfinite(r[key].get<double>()) || r[key].get<double>() < 0.0) {
    throw InputError(where + ": '" + key + "' must be a finite number >= 0");
  }
  return r[key].get<double>();
}

// One ROI of the output into `roi`; `up` is the local frame's up (-gravity).
void ReadRoi(const Json& r, const std::string& where, const Eigen::Vector3d& up, const datasets::TruthDem* dem,
             MethodRoi* roi) {
  if (!r.contains("status") || !r["status"].is_string()) {
    throw InputError(where + ": 'status' must be one of " + StatusNames());
  }
  MethodRoiStatus status;
  if (!ParseStatus(r["status"].get<std::string>(), &status)) {
    throw InputError(where + ": unknown status '" + r["status"].get<std::string>() + "' (one of " + StatusNames() +
                     ")");
  }
  roi->status = status;
  roi->reason = r.contains("reason") && r["reason"].is_string() ? r["reason"].get<std::string>() : "";
  if (r.contains("points_in_local_m")) {
    const Json& points = r["points_in_local_m"];
    if (!points.is_array()) throw InputError(where + ": 'points_in_local_m' must be a list of [x, y, z]");
    for (size_t i = 0; i < points.size(); ++i) {
      roi->points_in_local_m.push_back(ReadVector(points[i], where + ": points_in_local_m[" + std::to_string(i) + "]"));
    }
    if (dem != nullptr && !roi->points_in_local_m.empty()) {
      roi->accuracy = ComputePointAccuracy(roi->points_in_local_m, *dem);
    }
  }
  roi->num_points = static_cast<int>(roi->points_in_local_m.size());
  if (r.contains("num_points")) {
    if (!r["num_points"].is_number_integer() || r["num_points"].get<double>() < 0.0 ||
        r["num_points"].get<double>() > kMaxCount) {
      throw InputError(where + ": 'num_points' must be a whole number in [0, 1000000000]");
    }
    roi->num_points = static_cast<int>(r["num_points"].get<long long>());
  }
  if (status != MethodRoiStatus::kOk) return;
  if (!r.contains("normal_in_local")) throw InputError(where + ": status 'ok' needs 'normal_in_local'");
  Eigen::Vector3d normal = ReadVector(r["normal_in_local"], where + ": normal_in_local");
  const double largest = normal.cwiseAbs().maxCoeff();
  if (!(largest > 0.0)) throw InputError(where + ": normal_in_local is the zero vector");
  normal = (normal / largest).normalized();  // scaled first: any finite vector has a direction
  if (normal.dot(up) < 0.0) normal = -normal;  // the plane's normal, up
  roi->has_fit = true;
  roi->normal_in_local = normal;
  roi->slope_deg = std::atan2(normal.cross(up).norm(), normal.dot(up)) * util::kRadToDeg;  // exact near 0
  roi->roughness_rms_m = ReadNonNegative(r, "roughness_rms_m", where);
  roi->roughness_max_m = ReadNonNegative(r, "roughness_max_m", where);
}

}  // namespace

void ParseExternalOutput(const std::string& text, const std::string& where_file, const std::vector<int>& roi_ids,
                         const Eigen::Vector3d& gravity_in_local, const datasets::TruthDem* dem,
                         std::vector<MethodRoi>* rois, std::string* note) {
  const std::string& path = where_file;
  Json j;
  try {
    j = Json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // a syntax error, or a number past a double's range
    throw InputError(path + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object() || !j.contains("format") || j["format"] != "hdabench-external-output") {
    throw InputError(path + ": expected an object with \"format\": \"hdabench-external-output\"");
  }
  if (!j.contains("format_version") || j["format_version"] != 1) {
    throw InputError(path + ": format_version must be 1");
  }
  if (!j.contains("rois") || !j["rois"].is_array()) throw InputError(path + ": 'rois' must be a list");
  std::map<int, size_t> index_of_id;
  for (size_t i = 0; i < roi_ids.size(); ++i) index_of_id[roi_ids[i]] = i;
  rois->assign(roi_ids.size(), MethodRoi());
  std::vector<bool> given(roi_ids.size(), false);
  if (!(gravity_in_local.norm() > 0.0) || !gravity_in_local.allFinite()) {
    throw InputError(path + ": no gravity to take the slopes against");
  }
  const Eigen::Vector3d up = (-gravity_in_local).normalized();
  for (size_t k = 0; k < j["rois"].size(); ++k) {
    const Json& r = j["rois"][k];
    const std::string where = path + ": rois[" + std::to_string(k) + "]";
    if (!r.is_object() || !r.contains("id") || !r["id"].is_number_integer() ||
        std::abs(r["id"].get<double>()) > kMaxCount) {
      throw InputError(where + ": expected an object with a whole-number 'id' (an ROI of the input)");
    }
    const auto found = index_of_id.find(static_cast<int>(r["id"].get<long long>()));
    if (found == index_of_id.end()) {
      throw InputError(where + ": id " + r["id"].dump() + " is not an ROI of the input");
    }
    if (given[found->second]) throw InputError(where + ": ROI " + r["id"].dump() + " is given twice");
    given[found->second] = true;
    ReadRoi(r, where, up, dem, &(*rois)[found->second]);
  }
  int missing = 0;
  for (size_t i = 0; i < roi_ids.size(); ++i) {
    if (given[i]) continue;
    ++missing;
    (*rois)[i].status = MethodRoiStatus::kFailed;
    (*rois)[i].reason = "the program gave no result for ROI " + std::to_string(roi_ids[i]);
  }
  note->clear();
  if (j.contains("note") && j["note"].is_string()) *note = j["note"].get<std::string>();
  if (missing > 0) {
    *note += std::string(note->empty() ? "" : "; ") + std::to_string(missing) +
             " ROI(s) without a result from the program";
  }
}

MethodEntry ExternalMethod() {
  MethodEntry m;
  m.name = kMethodExternal;
  m.summary = "a program you name (--external-program; docs/external-method.md), given the pair, the nav "
              "and the ROIs, returning a plane per ROI";
  m.in_all = false;
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    const ExternalMethodOptions& o = ctx.options().external;
    if (o.program.empty()) {
      throw InputError("no program given: the external method runs the program of --external-program "
                       "(a gate suite's \"external\": {\"program\": ...})");
    }
    // Without a folder of its own (a run that keeps no outputs), a temporary one.
    std::unique_ptr<util::TempFolder> temporary;
    if (o.work_dir.empty()) temporary = std::make_unique<util::TempFolder>("external");
    // Absolute: the program runs in it and gets its files' paths.
    const fs::path dir = fs::absolute(temporary ? temporary->path() : fs::path(o.work_dir));
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw InputError(dir.string() + ": cannot create the external method's folder: " + ec.message());
    fs::remove(dir / "output.json", ec);
    ctx.Say("external: writing the input to " + dir.string());
    WriteInput(ctx, dir);
    std::vector<std::string> argv = {o.program};
    argv.insert(argv.end(), o.args.begin(), o.args.end());
    argv.push_back((dir / "input.json").string());
    argv.push_back((dir / "output.json").string());
    util::ProcessOptions process;
    process.working_dir = dir.string();
    process.log_file = (dir / "program.log").string();
    process.timeout_s = o.timeout_s;
    ctx.Say("external: running " + o.program);
    const util::ProcessResult result = util::RunProcess(argv, process);
    summary->wall_s = result.wall_s;
    if (!result.Ok()) {
      // RunProcess's error names the program and says how it ended.
      std::string why = result.error.empty() ? o.program + ": failed" : result.error;
      const std::string last = util::LastLineOfLog(process.log_file);
      if (!last.empty()) why += "; its last line: " + last;
      // The folder's name, not its path: the gate moves an entry's folder into place after its run.
      if (!temporary) why += " (its output: external/program.log)";
      throw InputError(why);
    }
    const fs::path output = dir / "output.json";
    std::string text;
    std::string error;
    if (!fs::exists(output)) throw InputError("the program exited 0 but wrote no " + output.string());
    if (!util::ReadFileBytes(output, &text, &error)) throw InputError(output.string() + ": " + error);
    std::vector<int> ids;
    for (const hda::RoiResult& r : ctx.flight().result.rois) ids.push_back(r.id);
    const datasets::TruthDem* dem = ctx.dataset().truth.dem.has_value() ? &*ctx.dataset().truth.dem : nullptr;
    ParseExternalOutput(text, output.string(), ids, ctx.input().gravity_in_local_mps2, dem, rois, &summary->note);
  };
  return m;
}

}  // namespace hdabench::reference
