#include "calib/calibrate.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>
#include <system_error>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "tools/util/files.h"
#include "calib/camera_model.h"
#include "tools/images/codecs.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/process.h"
#include "tools/util/text.h"

namespace hdabench::calib {

namespace {

namespace fs = std::filesystem;
using OrderedJson = nlohmann::ordered_json;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

void Progress(const CalibrateOptions& options, const std::string& line) {
  if (options.progress) options.progress(line);
}

// "cam0-007.jpg": the camera, the image's position in its list (from 1), and
// the original extension when it is a plain one.
std::string MrcalImageName(int camera, size_t index, const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  const bool plain = extension.size() >= 2 && extension.size() <= 6 &&
                     std::all_of(extension.begin() + 1, extension.end(),
                                 [](char c) { return std::isalnum(static_cast<unsigned char>(c)); });
  if (!plain) extension = ".img";
  char name[64];
  std::snprintf(name, sizeof(name), "cam%d-%03zu", camera, index + 1);
  return name + extension;
}

// The output folder must not exist, or be empty; it is created.
void PrepareOutputFolder(const std::string& out_dir) {
  std::error_code ec;
  if (fs::exists(out_dir, ec)) {
    if (!fs::is_directory(out_dir, ec)) {
      throw InputError(out_dir + ": the output folder is a file");
    }
    if (!fs::is_empty(out_dir, ec)) {
      throw InputError(out_dir + ": the output folder is not empty (choose a new one)");
    }
  }
  fs::create_directories(out_dir, ec);
  if (ec) throw InputError(out_dir + ": cannot create the output folder (" + ec.message() + ")");
}

struct CameraImages {
  std::vector<size_t> rows;  // indices into the result's images (this camera's, in order)
  std::vector<CornerDetection> detections;  // one per row
  int width_px = 0;
  int height_px = 0;
  int used = 0;
};

// Reads and searches one camera's images; fills result->images.
CameraImages DetectCamera(const CalibrateOptions& options, int camera,
                          const std::vector<std::string>& paths, CalibrateResult* result) {
  CameraImages cam;
  for (size_t i = 0; i < paths.size(); ++i) {
    ImageUse use;
    use.path = paths[i];
    use.camera = camera;
    use.name = MrcalImageName(camera, i, paths[i]);
    CornerDetection detection;
    const cv::Mat gray = images::ReadWholeImage(paths[i], cv::IMREAD_GRAYSCALE, &use.reason);
    if (!gray.empty()) {
      use.width_px = gray.cols;
      use.height_px = gray.rows;
      if (cam.width_px == 0) {
        cam.width_px = gray.cols;
        cam.height_px = gray.rows;
      }
      if (gray.cols != cam.width_px || gray.rows != cam.height_px) {
        use.reason = "image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                     " differs from camera " + std::to_string(camera) + "'s first image (" +
                     std::to_string(cam.width_px) + "x" + std::to_string(cam.height_px) + ")";
      } else {
        detection = DetectChessboard(gray, options.board, options.detector);
        if (detection.found) {
          use.used = true;
          use.detector = detection.detector;
          ++cam.used;
        } else {
          use.reason = detection.reason;
        }
      }
    }
    Progress(options, "camera " + std::to_string(camera) + " image " + std::to_string(i + 1) + "/" +
                          std::to_string(paths.size()) + " " + paths[i] + ": " +
                          (use.used ? std::to_string(detection.corners.size()) + " corners (" +
                                          detection.detector + ")"
                                    : "rejected: " + use.reason));
    if (!use.used) detection = CornerDetection();
    cam.rows.push_back(result->images.size());
    cam.detections.push_back(std::move(detection));
    result->images.push_back(std::move(use));
  }
  return cam;
}

std::string RejectionList(const CalibrateResult& result, int camera) {
  std::ostringstream out;
  for (const ImageUse& use : result.images) {
    if (use.camera != camera) continue;
    out << "\n  " << use.path << ": " << (use.used ? "board found" : use.reason);
  }
  return out.str();
}

// A focal-length seed for mrcal from the detected corners: OpenCV's closed-form
// estimate from the boards' homographies (cv::initCameraMatrix2D), the mean of
// fx and fy. Good to tens of percent, which is all mrcal's seeding needs.
double EstimateFocal(const CalibrateOptions& options, const CameraImages& cam) {
  std::vector<cv::Point3f> board;
  for (int r = 0; r < options.board.height; ++r) {
    for (int c = 0; c < options.board.width; ++c) {
      board.emplace_back(static_cast<float>(c * options.board.spacing),
                         static_cast<float>(r * options.board.spacing), 0.0f);
    }
  }
  std::vector<std::vector<cv::Point3f>> object_points;
  std::vector<std::vector<cv::Point2f>> image_points;
  for (const CornerDetection& d : cam.detections) {
    if (!d.found) continue;
    object_points.push_back(board);
    std::vector<cv::Point2f> points;
    for (const Eigen::Vector2d& q : d.corners) points.emplace_back(q.x(), q.y());
    image_points.push_back(std::move(points));
  }
  const cv::Mat k = cv::initCameraMatrix2D(object_points, image_points,
                                           cv::Size(cam.width_px, cam.height_px), 0.0);
  const double focal = 0.5 * (k.at<double>(0, 0) + k.at<double>(1, 1));
  if (!std::isfinite(focal) || focal <= 0.0) {
    throw InputError("the board views give no usable focal-length estimate (degenerate views?); "
                     "give one with --focal-px");
  }
  return focal;
}

// The last line of a log holding `key`, and the number after it; NaN if none.
double NumberAfter(const std::string& text, const std::string& key) {
  const size_t at = text.rfind(key);
  if (at == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
  try {
    return std::stod(text.substr(at + key.size()));
  } catch (const std::exception&) {
    return std::numeric_limits<double>::quiet_NaN();
  }
}

OrderedJson NumberOrNull(double value) { return std::isfinite(value) ? OrderedJson(value) : OrderedJson(nullptr); }

std::string DetectionsCsv(const CalibrateResult& result) {
  std::ostringstream out;
  out << "camera,name,path,used,detector,width_px,height_px,reason\n";
  for (const ImageUse& use : result.images) {
    std::string path = use.path, reason = use.reason;
    for (std::string* field : {&path, &reason}) {
      if (field->find_first_of(",\"\n") != std::string::npos) {
        std::string quoted = "\"";
        for (char c : *field) quoted += (c == '"') ? std::string("\"\"") : std::string(1, c);
        *field = quoted + "\"";
      }
    }
    out << use.camera << ',' << use.name << ',' << path << ',' << (use.used ? 1 : 0) << ','
        << use.detector << ',' << use.width_px << ',' << use.height_px << ',' << reason << '\n';
  }
  return out.str();
}

OrderedJson SummaryJson(const CalibrateOptions& options, const CalibrateResult& result) {
  OrderedJson j;
  j["schema"] = "hdabench-calibration";
  j["version"] = 1;
  j["board"] = {{"width", options.board.width},
                {"height", options.board.height},
                {"spacing", options.board.spacing}};
  j["lensmodel"] = options.lensmodel;
  j["detector"] = CornerDetectorName(options.detector);
  j["imager_px"] = {result.imager_width_px, result.imager_height_px};
  j["focal_seed_px"] = result.focal_seed_px;
  j["mrcal_rms_per_coordinate_px"] = NumberOrNull(result.mrcal_rms_px);
  OrderedJson models = OrderedJson::array();
  for (const std::string& m : result.model_paths) models.push_back(fs::path(m).filename().string());
  j["models"] = models;
  j["analysis"] = fs::path(result.analysis.json_path).filename().string();
  OrderedJson images = OrderedJson::array();
  for (const ImageUse& use : result.images) {
    OrderedJson row = {{"camera", use.camera}, {"path", use.path}, {"name", use.name}, {"used", use.used}};
    if (use.used) row["detector"] = use.detector;
    if (!use.used) row["reason"] = use.reason;
    images.push_back(row);
  }
  j["images"] = images;
  OrderedJson requirements = OrderedJson::array();
  for (const CalibrationRequirement& r : result.requirements) {
    if (!r.available) {
      requirements.push_back(nullptr);
      continue;
    }
    requirements.push_back({{"share", r.share},
                            {"band_median_px", r.band_median_px},
                            {"slope_rms_deg", r.slope_rms_deg},
                            {"allowed_band_median_px_per_method_sigma_deg", r.allowed_px_per_deg},
                            {"method_sigma_deg", r.method_sigma_deg > 0.0 ? OrderedJson(r.method_sigma_deg)
                                                                            : OrderedJson(nullptr)},
                            {"allowed_band_median_px",
                             r.method_sigma_deg > 0.0 ? OrderedJson(r.allowed_px) : OrderedJson(nullptr)}});
  }
  j["requirements"] = requirements;
  j["seconds"] = {{"detection", result.detection_s},
                  {"mrcal", result.mrcal_s},
                  {"analysis", result.analysis_s}};
  return j;
}

// Throws one InputError listing every invalid option, before anything is written.
void ThrowIfOptionsInvalid(const CalibrateOptions& options) {
  hdabench::ThrowIfInvalid("calibration options:\n  ", options.Validate(), "\n  ");
}

// Step 1: the corners of every camera's images, camera 0 first; the time is
// the result's detection_s.
std::vector<CameraImages> DetectAllCameras(const CalibrateOptions& options,
                                           CalibrateResult* result) {
  const auto start = Clock::now();
  std::vector<CameraImages> cameras;
  cameras.push_back(DetectCamera(options, 0, options.images, result));
  if (!options.pair_images.empty()) {
    cameras.push_back(DetectCamera(options, 1, options.pair_images, result));
  }
  result->detection_s = SecondsSince(start);
  return cameras;
}

// corners.vnl (mrcal's input) and detections.csv, written before the checks
// so that a rejected calibration still shows what was found.
void WriteDetections(const fs::path& out, const std::vector<CameraImages>& cameras,
                     const CalibrateResult& result) {
  std::vector<CornersVnlEntry> entries;
  for (const CameraImages& cam : cameras) {
    for (size_t i = 0; i < cam.rows.size(); ++i) {
      entries.push_back({result.images[cam.rows[i]].name, &cam.detections[i]});
    }
  }
  util::WriteFileAtomically(out / "corners.vnl", CornersVnlText(entries));
  util::WriteFileAtomically(out / "detections.csv", DetectionsCsv(result));
}

// Step 2: enough views per camera, and one imager size for a pair; throws
// InputError otherwise.
void CheckViews(const CalibrateOptions& options, const std::vector<CameraImages>& cameras,
                const CalibrateResult& result) {
  for (size_t c = 0; c < cameras.size(); ++c) {
    if (cameras[c].used < options.min_views) {
      throw InputError("camera " + std::to_string(c) + ": only " + std::to_string(cameras[c].used) +
                       " of " + std::to_string(cameras[c].rows.size()) + " images show the whole " +
                       options.board.SizeText() + " board; a calibration needs at least " +
                       std::to_string(options.min_views) + " (--min-views). Images:" +
                       RejectionList(result, static_cast<int>(c)));
    }
  }
  if (cameras.size() == 2 && (cameras[0].width_px != cameras[1].width_px ||
                              cameras[0].height_px != cameras[1].height_px)) {
    throw InputError("the two cameras' images differ in size (" + std::to_string(cameras[0].width_px) +
                     "x" + std::to_string(cameras[0].height_px) + " and " +
                     std::to_string(cameras[1].width_px) + "x" +
                     std::to_string(cameras[1].height_px) +
                     "); a pair is calibrated with one imager size");
  }
}

// mrcal's --focal list, one seed per camera (given, or estimated from the
// views); camera 0's seed is the result's focal_seed_px.
std::string FocalSeedList(const CalibrateOptions& options,
                          const std::vector<CameraImages>& cameras, CalibrateResult* result) {
  std::string focal_list;
  for (const CameraImages& cam : cameras) {
    const double focal = options.focal_px > 0.0 ? options.focal_px : EstimateFocal(options, cam);
    if (focal_list.empty()) result->focal_seed_px = focal;
    focal_list += (focal_list.empty() ? "" : ",") + util::FixedCell(focal, 3);
  }
  return focal_list;
}

// The interpreter and mrcal's tool, both resolved before anything runs; throws
// ExternalError naming the missing one.
void FindMrcalTools(const CalibrateOptions& options, std::string* python, std::string* tool) {
  *python = util::FindExecutable(options.python);
  if (python->empty()) {
    throw ExternalError("the Python interpreter '" + options.python +
                        "' was not found; mrcal's tools need Debian's python3 with python3-mrcal");
  }
  *tool = util::FindExecutable(options.mrcal_calibrate);
  if (tool->empty()) {
    throw ExternalError("'" + options.mrcal_calibrate +
                        "' was not found (Debian package: mrcal)");
  }
}

// mrcal-calibrate-cameras starts the distortion coefficients it does not seed
// from small values drawn with numpy's global generator, unseeded: its model
// then differs from run to run in the last bits. This runs the tool (argv[2],
// its arguments after it, as if started directly) with that generator seeded
// from argv[1], so the same inputs give the same model.
constexpr char kSeededMrcalRun[] =
    "import runpy, sys\n"
    "import numpy\n"
    "numpy.random.seed(int(sys.argv[1]) % 2**32)\n"
    "sys.argv = sys.argv[2:]\n"
    "runpy.run_path(sys.argv[0], run_name='__main__')\n";

// The command line of mrcal-calibrate-cameras: the corners cache, the board,
// the seeds, and one image glob per camera; run through kSeededMrcalRun with
// the calibration's seed. It runs in `work`, so its paths are absolute.
std::vector<std::string> MrcalArguments(const CalibrateOptions& options, const std::string& python,
                                        const std::string& tool, const fs::path& out,
                                        const fs::path& work, const std::string& focal_list,
                                        size_t num_cameras, const CalibrateResult& result) {
  std::vector<std::string> argv = {python,
                                   "-c",
                                   kSeededMrcalRun,
                                   std::to_string(options.analysis.seed),
                                   tool,
                                   "--corners-cache",
                                   fs::absolute(out / "corners.vnl").string(),
                                   "--lensmodel",
                                   options.lensmodel,
                                   "--focal",
                                   focal_list,
                                   "--imagersize",
                                   std::to_string(result.imager_width_px),
                                   std::to_string(result.imager_height_px),
                                   "--object-spacing",
                                   util::FixedCell(options.board.spacing, 12),
                                   "--object-width-n",
                                   std::to_string(options.board.width),
                                   "--object-height-n",
                                   std::to_string(options.board.height),
                                   "--outdir",
                                   fs::absolute(work).string()};
  for (size_t c = 0; c < num_cameras; ++c) argv.push_back("cam" + std::to_string(c) + "-*");
  return argv;
}

// A failed mrcal run: its scratch folder goes, and the error names the log and
// what the log said last.
[[noreturn]] void FailMrcal(const fs::path& work, const fs::path& log, const std::string& what) {
  std::error_code ec;
  fs::remove_all(work, ec);
  const std::string last = util::LastLineOfLog(log.string());
  throw ExternalError("mrcal-calibrate-cameras " + what + " (log: " + log.string() + ")" +
                      (last.empty() ? "" : ": " + last));
}

// The models mrcal wrote in `work`, one per camera, each checked to load.
std::vector<std::string> CheckedMrcalModels(const fs::path& work, const fs::path& log,
                                            size_t num_cameras) {
  std::error_code ec;
  std::vector<std::string> work_models;
  for (size_t c = 0; c < num_cameras; ++c) {
    const fs::path model = work / ("camera-" + std::to_string(c) + ".cameramodel");
    if (!fs::is_regular_file(model, ec)) {
      FailMrcal(work, log, "wrote no " + model.filename().string());
    }
    try {
      const CameraModel loaded = CameraModel::Load(model.string());
      (void)loaded;
    } catch (const InputError& e) {
      FailMrcal(work, log, std::string("wrote a model the bench cannot read: ") + e.what());
    }
    work_models.push_back(model.string());
  }
  return work_models;
}

// Steps 3-4: mrcal-calibrate-cameras in the scratch folder `work`, logged
// under logs/; its time is the result's mrcal_s, its RMS the result's
// mrcal_rms_px. Returns the models it wrote (still in `work`).
std::vector<std::string> RunMrcal(const CalibrateOptions& options, const fs::path& out,
                                  const fs::path& work, size_t num_cameras,
                                  const std::string& focal_list, CalibrateResult* result) {
  std::string python, tool;
  FindMrcalTools(options, &python, &tool);
  const fs::path logs = out / "logs";
  std::error_code ec;
  fs::remove_all(work, ec);
  fs::create_directories(work, ec);
  fs::create_directories(logs, ec);
  const fs::path log = logs / "mrcal-calibrate-cameras.log";
  const std::vector<std::string> argv =
      MrcalArguments(options, python, tool, out, work, focal_list, num_cameras, *result);
  Progress(options, "running mrcal-calibrate-cameras (" + options.lensmodel + ", focal seed " +
                        focal_list + " px; log " + log.string() + ")");
  util::ProcessOptions process;
  process.working_dir = work.string();
  process.log_file = log.string();
  process.timeout_s = options.mrcal_timeout_s;
  process.environment = {{"PYTHONDONTWRITEBYTECODE", "1"}, {"MPLBACKEND", "Agg"}};
  const auto start = Clock::now();
  const util::ProcessResult run = util::RunProcess(argv, process);
  result->mrcal_s = SecondsSince(start);
  if (!run.Ok()) FailMrcal(work, log, "failed: " + run.error);
  std::ifstream log_in(log, std::ios::binary);
  const std::string log_text((std::istreambuf_iterator<char>(log_in)), std::istreambuf_iterator<char>());
  result->mrcal_rms_px = NumberAfter(log_text, "## RMS error:");
  return CheckedMrcalModels(work, log, num_cameras);
}

// Moves mrcal's models to the output folder, where the analysis records their
// paths, then removes the scratch folder.
void MoveModelsIntoPlace(const fs::path& out, const fs::path& work,
                         const std::vector<std::string>& work_models, CalibrateResult* result) {
  std::error_code ec;
  for (size_t c = 0; c < work_models.size(); ++c) {
    const fs::path target = out / ("camera-" + std::to_string(c) + ".cameramodel");
    fs::rename(work_models[c], target, ec);
    if (ec) {
      throw InputError(target.string() + ": cannot move the calibrated model into place (" +
                       ec.message() + ")");
    }
    result->model_paths.push_back(target.string());
  }
  fs::remove_all(work, ec);
}

// The bench's analysis of the models (timed: analysis_s). If it fails, the
// models move to unanalysed/: nothing computed is lost, and no model sits
// where a judged one would. The error keeps its kind.
void AnalyseModels(const CalibrateOptions& options, const fs::path& out, CalibrateResult* result) {
  Progress(options, "analysing the calibration (residuals, coverage, uncertainty, HDA slope, "
                    "OpenCV cross-check)");
  const auto start = Clock::now();
  try {
    result->analysis = AnalyseCalibration(result->model_paths, options.out_dir, options.analysis);
    for (const CameraAnalysis& camera : result->analysis.cameras) {
      result->requirements.push_back(RequirementOf(camera, options.slope_share, options.method_slope_sigma_deg));
    }
  } catch (const std::exception& e) {
    std::error_code ec;
    const fs::path aside = out / "unanalysed";
    fs::create_directories(aside, ec);
    for (const std::string& model : result->model_paths) {
      fs::rename(model, aside / fs::path(model).filename(), ec);
    }
    const std::string note = " (mrcal's model(s) kept in " + aside.string() + ")";
    if (dynamic_cast<const InputError*>(&e) != nullptr) throw InputError(e.what() + note);
    throw ExternalError(e.what() + note);
  }
  result->analysis_s = SecondsSince(start);
}

// Step 6: calibration.json and summary.md, their paths in the result first so
// that the JSON names them.
void WriteSummaries(const CalibrateOptions& options, const fs::path& out, CalibrateResult* result) {
  result->summary_json = (out / "calibration.json").string();
  result->summary_markdown = (out / "summary.md").string();
  util::WriteFileAtomically(result->summary_json, SummaryJson(options, *result).dump(2) + "\n");
  util::WriteFileAtomically(result->summary_markdown, CalibrationSummaryMarkdown(options, *result));
}

}  // namespace

std::vector<std::string> CalibrateOptions::Validate() const {
  std::vector<std::string> errors = board.Validate();
  if (images.empty()) errors.push_back("images: none given: expected at least one image");
  if (!pair_images.empty() && pair_images.size() != images.size()) {
    errors.push_back("pair images: " + std::to_string(pair_images.size()) +
                     " given for " + std::to_string(images.size()) +
                     " images of camera 0: expected one per image, in the same order");
  }
  RequireOption(focal_px >= 0.0, "focal_px", focal_px, "0 (estimate) or a positive focal length",
                &errors);
  RequireOption(min_views >= 1, "min_views", min_views, "at least 1", &errors);
  RequireOption(mrcal_timeout_s > 0.0, "mrcal_timeout_s", mrcal_timeout_s, "a positive time limit",
                &errors);
  if (out_dir.empty()) errors.push_back("out_dir: empty: expected an output folder");
  RequireOption(slope_share > 0.0 && slope_share <= 1.0, "slope_share", slope_share, "in (0, 1]", &errors);
  RequireOption(method_slope_sigma_deg >= 0.0 && std::isfinite(method_slope_sigma_deg), "method_slope_sigma_deg",
                method_slope_sigma_deg, "0 (not given) or a positive slope sigma in degrees", &errors);
  try {
    LensModelParameterCount(lensmodel, "lens model");
  } catch (const InputError& e) {
    errors.push_back(e.what());
  }
  return errors;
}

CalibrateResult Calibrate(const CalibrateOptions& options) {
  ThrowIfOptionsInvalid(options);
  PrepareOutputFolder(options.out_dir);
  const fs::path out(options.out_dir);
  CalibrateResult result;

  // 1-2. Corners, and enough views.
  const std::vector<CameraImages> cameras = DetectAllCameras(options, &result);
  WriteDetections(out, cameras, result);
  CheckViews(options, cameras, result);
  result.imager_width_px = cameras[0].width_px;
  result.imager_height_px = cameras[0].height_px;

  // 3-4. mrcal.
  const std::string focal_list = FocalSeedList(options, cameras, &result);
  const fs::path work = out / ".mrcal";
  const std::vector<std::string> work_models =
      RunMrcal(options, out, work, cameras.size(), focal_list, &result);

  // 5. The models into place (the analysis records their paths), then the
  // bench's analysis.
  MoveModelsIntoPlace(out, work, work_models, &result);
  AnalyseModels(options, out, &result);

  // 6. The summaries.
  WriteSummaries(options, out, &result);
  return result;
}

}  // namespace hdabench::calib

namespace hdabench::calib {

namespace {

std::string OptionalNumber(const std::optional<double>& value, int decimals) {
  return value ? util::FixedCell(*value, decimals) : "-";
}

// A row of the summary table: a label and one cell per camera.
void Row(std::ostringstream& out, const std::string& label, const std::vector<std::string>& cells) {
  out << "| " << label;
  for (const std::string& cell : cells) out << " | " << cell;
  out << " |\n";
}

// One cell per camera, in the order of the analysis: fn(camera) each.
template <typename Fn>
std::vector<std::string> Cells(const std::vector<CameraAnalysis>& cams, Fn fn) {
  std::vector<std::string> v;
  for (const CameraAnalysis& cam : cams) v.push_back(fn(cam));
  return v;
}

// The title, the inputs, the models and the verdict: what a reader needs first.
void WriteSummaryHead(std::ostringstream& out, const CalibrateOptions& options,
                      const CalibrateResult& result) {
  out << "# Calibration\n\n";
  out << "- lens model: " << options.lensmodel << "\n";
  out << "- imager: " << result.imager_width_px << " x " << result.imager_height_px << " px\n";
  out << "- board: " << options.board.SizeText() << " inner corners, spacing "
      << util::FixedCell(options.board.spacing, 6) << "\n";
  out << "- focal-length seed: " << util::FixedCell(result.focal_seed_px, 1) << " px\n";
  for (size_t c = 0; c < result.model_paths.size(); ++c) {
    out << "- camera " << c << ": " << fs::path(result.model_paths[c]).filename().string() << "\n";
  }
  out << "\n## Verdict\n\n";
  for (const std::string& line : CalibrationVerdict(result)) out << "- " << line << "\n";
}

// The figures table's heading and the rows of the fit itself: views,
// intrinsics, residuals and coverage.
void WriteFitRows(std::ostringstream& out, const CalibrateResult& result) {
  const std::vector<CameraAnalysis>& cams = result.analysis.cameras;
  out << "\n## Figures\n\n| figure |";
  for (const CameraAnalysis& cam : cams) out << " camera " << cam.index << " |";
  out << "\n|---|";
  for (size_t i = 0; i < cams.size(); ++i) out << "---|";
  out << "\n";
  Row(out, "images used / given", Cells(cams, [&](const CameraAnalysis& cam) {
        int used = 0, given = 0;
        for (const ImageUse& use : result.images) {
          if (use.camera != cam.index) continue;
          ++given;
          used += use.used ? 1 : 0;
        }
        return std::to_string(used) + " / " + std::to_string(given);
      }));
  Row(out, "fx, fy, cx, cy (px)", Cells(cams, [&](const CameraAnalysis& cam) {
        try {
          const CameraModel model = CameraModel::Load(result.model_paths.at(cam.index));
          if (!model.HasCore()) return std::string("(no core)");
          const std::vector<double>& k = model.Intrinsics();
          return util::FixedCell(k[0], 2) + ", " + util::FixedCell(k[1], 2) + ", " + util::FixedCell(k[2], 2) +
                 ", " + util::FixedCell(k[3], 2);
        } catch (const std::exception&) {
          return std::string("-");
        }
      }));
  Row(out, "corners used (inliers) / outliers", Cells(cams, [](const CameraAnalysis& cam) {
        return std::to_string(cam.residuals.inliers) + " / " + std::to_string(cam.residuals.outliers);
      }));
  Row(out, "RMS reprojection error per corner (px)",
      Cells(cams, [](const CameraAnalysis& cam) { return util::FixedCell(cam.residuals.rms_px, 3); }));
  Row(out, "worst inlier residual (px)", Cells(cams, [](const CameraAnalysis& cam) {
        return util::FixedCell(cam.residuals.worst_px, 3);
      }));
  Row(out, "mrcal's RMS per coordinate (px)", Cells(cams, [](const CameraAnalysis& cam) {
        return util::FixedCell(cam.residuals.mrcal_rms_px, 3);
      }));
  Row(out, "imager cells with corners (10 x 10)", Cells(cams, [](const CameraAnalysis& cam) {
        return util::FixedCell(100.0 * cam.coverage.share, 0) + " %";
      }));
  Row(out, "HDA band cells with corners", Cells(cams, [](const CameraAnalysis& cam) {
        return util::FixedCell(100.0 * cam.coverage.band_share, 0) + " %";
      }));
}

// The table's rows of what the fit is worth: uncertainty, the HDA slope error
// and the OpenCV cross-check.
void WriteCheckRows(std::ostringstream& out, const CalibrateResult& result) {
  const std::vector<CameraAnalysis>& cams = result.analysis.cameras;
  Row(out, "projection uncertainty, HDA band median / max (px, 1 sigma)",
      Cells(cams, [](const CameraAnalysis& cam) {
        return cam.uncertainty ? util::FixedCell(cam.uncertainty->band_median_px, 3) + " / " +
                                     util::FixedCell(cam.uncertainty->band_max_px, 3)
                               : "- (" + cam.uncertainty_error + ")";
      }));
  Row(out, "projection uncertainty, imager centre / median (px)",
      Cells(cams, [](const CameraAnalysis& cam) {
        return cam.uncertainty ? util::FixedCell(cam.uncertainty->imager_centre_px, 3) + " / " +
                                     util::FixedCell(cam.uncertainty->imager_median_px, 3)
                               : "-";
      }));
  Row(out, "HDA slope error from the calibration alone, RMS / p90 (deg)",
      Cells(cams, [](const CameraAnalysis& cam) {
        return OptionalNumber(cam.slope.rms_deg, 4) + " / " + OptionalNumber(cam.slope.p90_deg, 4) +
               " (" + std::to_string(cam.slope.ok) + " of " + std::to_string(cam.slope.samples) +
               " re-solves)";
      }));
  Row(out, "OpenCV cross-check: RMS (px)", Cells(cams, [](const CameraAnalysis& cam) {
        return cam.opencv ? util::FixedCell(cam.opencv->rms_px, 3) : "- (" + cam.opencv_error + ")";
      }));
  Row(out, "mrcal vs OpenCV projection, median / p90 / max over the imager (px)",
      Cells(cams, [](const CameraAnalysis& cam) {
        return cam.opencv ? util::FixedCell(cam.opencv->diff.median_px, 3) + " / " +
                                util::FixedCell(cam.opencv->diff.p90_px, 3) + " / " +
                                util::FixedCell(cam.opencv->diff.max_px, 3)
                          : "-";
      }));
  Row(out, "mrcal vs OpenCV projection, HDA band median (px)",
      Cells(cams, [](const CameraAnalysis& cam) {
        return cam.opencv ? OptionalNumber(cam.opencv->diff.band_median_px, 3) : "-";
      }));
}

// The HDA geometry the figures assume, and the pair's relative poses.
void WriteGeometry(std::ostringstream& out, const CalibrateOptions& options,
                   const CalibrateResult& result) {
  out << "\nThe HDA geometry: range " << util::FixedCell(options.analysis.hda.range_m, 0)
      << " m, baseline " << util::FixedCell(options.analysis.hda.baseline_m, 1) << " m, site "
      << util::FixedCell(options.analysis.hda.site_m, 1) << " m; the HDA band is x "
      << util::FixedCell(100 * options.analysis.hda.band_x0, 0) << "-"
      << util::FixedCell(100 * options.analysis.hda.band_x1, 0) << " % of the width, y "
      << util::FixedCell(100 * options.analysis.hda.band_y0, 0) << "-"
      << util::FixedCell(100 * options.analysis.hda.band_y1, 0) << " % of the height.\n";

  for (const RelativePose& pose : result.analysis.relative_poses) {
    out << "\nCamera " << pose.camera << " relative to camera " << pose.relative_to << ": baseline "
        << OptionalNumber(pose.baseline, 4) << " (board units), rotation "
        << OptionalNumber(pose.rotation_deg, 3) << " deg\n";
  }
}

// The images left out and why (only when there are any), then every used
// image's residuals under its given path, and the list of files.
void WriteImageTables(std::ostringstream& out, const CalibrateResult& result) {
  bool any_rejected = false;
  for (const ImageUse& use : result.images) any_rejected = any_rejected || !use.used;
  if (any_rejected) {
    out << "\n## Images not used\n\n| camera | image | why |\n|---|---|---|\n";
    for (const ImageUse& use : result.images) {
      if (!use.used) out << "| " << use.camera << " | " << use.path << " | " << use.reason << " |\n";
    }
  }
  out << "\n## Per image\n\n| camera | image | corners | outliers | RMS (px) | worst (px) |\n"
      << "|---|---|---|---|---|---|\n";
  for (const CameraAnalysis& cam : result.analysis.cameras) {
    for (const ImageResiduals& image : cam.residuals.images) {
      std::string path = image.image;
      for (const ImageUse& use : result.images) {
        // mrcal records the names of corners.vnl, possibly with a folder.
        if (use.camera == cam.index && use.name == fs::path(image.image).filename().string()) {
          path = use.path;
        }
      }
      out << "| " << cam.index << " | " << path << " | " << image.corners << " | " << image.outliers
          << " | " << OptionalNumber(image.rms_px, 3) << " | " << OptionalNumber(image.worst_px, 3)
          << " |\n";
    }
  }
  out << "\nFiles: calibration.json (this summary as data), analysis.json (every figure), "
         "detections.csv, corners.vnl, figures/, opencv/, logs/.\n";
}

}  // namespace

constexpr double kVerdictResidualRmsPx = 0.5;
constexpr double kVerdictSlopeNotLimitDeg = 0.1;
constexpr double kVerdictSlopeLimitDeg = 0.5;

CalibrationRequirement RequirementOf(const CameraAnalysis& camera, double share, double method_sigma_deg) {
  CalibrationRequirement r;
  r.share = share;
  r.method_sigma_deg = method_sigma_deg;
  if (!camera.uncertainty || !camera.slope.rms_deg || !(*camera.slope.rms_deg > 0.0)) return r;
  r.available = true;
  r.band_median_px = camera.uncertainty->band_median_px;
  r.slope_rms_deg = *camera.slope.rms_deg;
  r.allowed_px_per_deg = r.band_median_px * share / r.slope_rms_deg;
  r.allowed_px = r.allowed_px_per_deg * method_sigma_deg;
  return r;
}

// The requirement in words: what the band's projection uncertainty may be.
std::string RequirementLine(const CalibrationRequirement& r) {
  const std::string share = util::FixedCell(100.0 * r.share, 0) + " %";
  std::string line = "for its slope term to stay under " + share + " of the flight method's own slope sigma S, the " +
                     "HDA band's projection uncertainty may be at most " + util::FixedCell(r.allowed_px_per_deg, 3) +
                     " px per degree of S (median; it is " + util::FixedCell(r.band_median_px, 3) + " px, " +
                     util::FixedCell(r.slope_rms_deg, 3) + " deg RMS of slope)";
  if (r.method_sigma_deg > 0.0) {
    line += ": with S = " + util::ShortestText(r.method_sigma_deg) + " deg, at most " +
            util::FixedCell(r.allowed_px, 3) + " px, " +
            (r.band_median_px <= r.allowed_px ? "met" : "NOT MET: add views over the band, or a sharper board");
  } else {
    line += "; give --method-sigma-deg S (the median slope_sigma_deg of a run) for the figure";
  }
  return line;
}

std::vector<std::string> CalibrationVerdict(const CalibrateResult& result) {
  std::vector<std::string> lines;
  for (size_t c = 0; c < result.analysis.cameras.size(); ++c) {
    const CameraAnalysis& cam = result.analysis.cameras[c];
    const std::string who = "camera " + std::to_string(cam.index) + ": ";
    if (cam.residuals.rms_px <= kVerdictResidualRmsPx) {
      lines.push_back(who + "residuals fine (RMS " + util::FixedCell(cam.residuals.rms_px, 3) +
                      " px per corner, limit " + util::FixedCell(kVerdictResidualRmsPx, 1) + " px)");
    } else {
      lines.push_back(who + "RESIDUALS HIGH (RMS " + util::FixedCell(cam.residuals.rms_px, 3) +
                      " px per corner, limit " + util::FixedCell(kVerdictResidualRmsPx, 1) +
                      " px): check focus, the board's flatness, the detections, or try a richer "
                      "lens model");
    }
    if (cam.coverage.band_share < 1.0) {
      lines.push_back(who + "the boards left " +
                      util::FixedCell(100.0 * (1.0 - cam.coverage.band_share), 0) +
                      " % of the HDA band's cells without a corner: add views there");
    }
    if (!cam.slope.rms_deg) {
      lines.push_back(who + "no HDA slope-error figure (" +
                      (cam.slope.error.empty() ? "every re-solve failed" : cam.slope.error) + ")");
    } else if (*cam.slope.p90_deg <= kVerdictSlopeNotLimitDeg) {
      lines.push_back(who + "at the HDA geometry the calibration alone gives " +
                      util::FixedCell(*cam.slope.p90_deg, 3) +
                      " deg of slope error (p90): not the limit; the navigation and matching are");
    } else if (*cam.slope.p90_deg <= kVerdictSlopeLimitDeg) {
      lines.push_back(who + "at the HDA geometry the calibration alone gives " +
                      util::FixedCell(*cam.slope.p90_deg, 3) +
                      " deg of slope error (p90): noticeable against the 1 deg slope bar");
    } else {
      lines.push_back(who + "CALIBRATION LIMITS THE HDA SLOPE: " +
                      util::FixedCell(*cam.slope.p90_deg, 3) +
                      " deg of slope error (p90) at the HDA geometry from the calibration alone");
    }
    if (c < result.requirements.size() && result.requirements[c].available) {
      lines.push_back(who + RequirementLine(result.requirements[c]));
    }
  }
  return lines;
}

std::string CalibrationSummaryMarkdown(const CalibrateOptions& options, const CalibrateResult& result) {
  std::ostringstream out;
  WriteSummaryHead(out, options, result);
  WriteFitRows(out, result);
  WriteCheckRows(out, result);
  WriteGeometry(out, options, result);
  WriteImageTables(out, result);
  return out.str();
}

}  // namespace hdabench::calib
