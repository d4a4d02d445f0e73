#include "reference/flight/flight_run.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "calib/calibration_analysis.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/text.h"
#include "datasets/synth/truth.h"

namespace hdabench::reference {

namespace {

// The slant range at a frame and where it came from. The LRF's, when it has a
// sample there. Otherwise the navigation's: along camera 1's optical axis
// from its centre to the level ground through the ILS (the mission map's
// height of the landing site), which needs the axis at least
// kMinAxisDepressionDeg below the horizon. InputError when neither exists.
constexpr double kMinAxisDepressionDeg = 10.0;

struct SlantRange {
  double range_m = 0.0;
  RangeSource source = RangeSource::kLrf;
};

SlantRange RangeAtFrame(const datasets::Dataset& dataset, int frame) {
  const double time_s = dataset.frames[static_cast<size_t>(frame)].time_s;
  std::string lrf_problem;
  try {
    return {dataset.LrfRangeAt(time_s), RangeSource::kLrf};
  } catch (const std::out_of_range& e) {
    lrf_problem = e.what();
  }
  const std::string no_lrf = "no LRF range at frame " + std::to_string(frame) + " (" + lrf_problem + ")";
  Rigid3d local_from_cam;
  try {
    local_from_cam = dataset.CamFromLocal(frame).Inverse();
  } catch (const std::out_of_range& e) {
    throw InputError(no_lrf + ", and no navigation there either (" + e.what() + ")");
  }
  const double g = dataset.gravity_in_local_mps2.norm();
  const Eigen::Vector3d up = -dataset.gravity_in_local_mps2 / g;
  const Eigen::Vector3d axis = local_from_cam.rotation * Eigen::Vector3d::UnitZ();
  const double height_m = up.dot(local_from_cam.translation - dataset.ils_in_local_m);
  const double descent = -up.dot(axis);  // sine of the axis' depression below the horizon
  if (!(g > 0.0) || !(descent > std::sin(kMinAxisDepressionDeg * util::kDegToRad)) || !(height_m > 0.0)) {
    throw InputError(no_lrf + ", and camera " + std::to_string(frame) +
                     "'s optical axis does not meet the level ground through the ILS from above (axis " +
                     util::FixedText(std::asin(std::clamp(descent, -1.0, 1.0)) * util::kRadToDeg, 1) +
                     " deg below the horizon, camera " + util::FixedText(height_m, 1) +
                     " m above the ILS): the flight method needs a range to place the level ground and "
                     "size the sites");
  }
  return {height_m / descent, RangeSource::kNavigation};
}

// Runs `pose` (a pose query of the dataset), turning a time outside the
// navigation into an InputError naming the frames.
template <typename Query>
auto PoseOfFrames(int frame1, int frame2, Query query) {
  try {
    return query();
  } catch (const std::out_of_range& e) {
    throw InputError("no navigation for frames " + std::to_string(frame1) + "," + std::to_string(frame2) +
                     " (" + e.what() + ")");
  }
}

}  // namespace

const char* ToString(RangeSource source) { return source == RangeSource::kLrf ? "lrf" : "navigation"; }

std::pair<int, int> DefaultFramePair(const datasets::Dataset& dataset) {
  const std::vector<int> imaged = datasets::FramesWithImages(dataset.frames);
  if (imaged.size() < 2) {
    throw InputError("dataset " + dataset.name + " has " + std::to_string(imaged.size()) +
                     " frame(s) with an image: the flight method needs 2");
  }
  const int first = imaged.front();
  const double range = RangeAtFrame(dataset, first).range_m;
  int best = imaged[1];
  double best_error = std::numeric_limits<double>::infinity();
  for (size_t k = 1; k < imaged.size(); ++k) {
    const int j = imaged[k];
    const double error = std::abs(PoseOfFrames(first, j, [&] { return dataset.BaselineM(first, j); }) / range -
                                  kPaperBaselineToRange);
    if (error < best_error) {
      best_error = error;
      best = j;
    }
  }
  return {first, best};
}

std::vector<int> PairFramesToRender(const datasets::Dataset& dataset, bool with_next) {
  const std::pair<int, int> pair = DefaultFramePair(dataset);
  std::vector<int> frames = {pair.first, pair.second};
  if (with_next && pair.second + 1 < static_cast<int>(dataset.frames.size())) frames.push_back(pair.second + 1);
  return frames;
}

hda::HdaInput MakeHdaInput(const datasets::Dataset& dataset, int frame1, int frame2, RangeSource* range_source) {
  const int n = static_cast<int>(dataset.frames.size());
  for (const int frame : {frame1, frame2}) {
    if (frame < 0 || frame >= n) {
      throw InputError("frame " + std::to_string(frame) + " is not in the dataset (frames 0.." +
                       std::to_string(n - 1) + ")");
    }
  }
  if (frame1 == frame2) {
    throw InputError("frames " + std::to_string(frame1) + "," + std::to_string(frame2) +
                     ": the flight method needs two different frames");
  }
  const datasets::FrameRecord& record1 = dataset.frames[static_cast<size_t>(frame1)];
  const datasets::FrameRecord& record2 = dataset.frames[static_cast<size_t>(frame2)];
  for (const datasets::FrameRecord* record : {&record1, &record2}) {
    if (!record->HasImage()) {
      throw InputError("frame " + std::to_string(record->index) +
                       " has no image in the dataset (frames with images: " +
                       util::JoinInts(datasets::FramesWithImages(dataset.frames)) + ")");
    }
  }
  if (record1.image.empty() || record2.image.empty()) {
    throw InputError("the images of frames " + std::to_string(frame1) + " and " +
                     std::to_string(frame2) + " are not loaded");
  }
  hda::HdaInput input;
  input.image1 = record1.image;
  input.image2 = record2.image;
  input.local_from_cam1 = PoseOfFrames(frame1, frame2, [&] { return dataset.CamFromLocal(frame1).Inverse(); });
  input.cam2_from_cam1 = PoseOfFrames(frame1, frame2, [&] { return dataset.Cam2FromCam1(frame1, frame2); });
  input.gravity_in_local_mps2 = dataset.gravity_in_local_mps2;
  input.ils_in_local_m = dataset.ils_in_local_m;
  const SlantRange range = RangeAtFrame(dataset, frame1);
  input.lrf_range_m = range.range_m;
  if (range_source != nullptr) *range_source = range.source;
  if (range.source == RangeSource::kNavigation) {
    // The range along camera 1's optical axis from its centre.
    input.lrf_origin_in_cam1_m = Eigen::Vector3d::Zero();
    input.lrf_beam_in_cam1 = Eigen::Vector3d::UnitZ();
    return input;
  }
  // The beam of the last sample at or before frame 1 (the first one if none).
  auto after = std::upper_bound(
      dataset.lrf.begin(), dataset.lrf.end(), record1.time_s,
      [](double t, const datasets::LrfSample& sample) { return t < sample.time_s; });
  const datasets::LrfSample& sample = after == dataset.lrf.begin() ? dataset.lrf.front() : *(after - 1);
  input.lrf_origin_in_cam1_m = dataset.cam_from_body * dataset.lrf_origin_in_body_m;
  input.lrf_beam_in_cam1 = dataset.cam_from_body.rotation * sample.boresight_in_body;
  return input;
}

std::vector<RoiTruthValue> TruthOfRois(const datasets::Dataset& dataset, int frame1,
                                       const hda::HdaResult& result,
                                       const datasets::synth::LanderGeometry& lander) {
  std::vector<RoiTruthValue> truths(result.rois.size());
  const bool has_points =
      std::any_of(dataset.truth.points.begin(), dataset.truth.points.end(),
                  [&](const datasets::TruthPoints& p) { return p.frame == frame1; });
  const bool has_dem = dataset.truth.dem.has_value() && !dataset.truth.dem->height_in_local_m.empty();
  std::optional<datasets::synth::LanderOnSurface> on_surface;
  if (has_points && has_dem && !result.rois.empty()) {
    on_surface.emplace(datasets::synth::SurfaceOfTruth(dataset.truth), lander);
  }
  for (size_t i = 0; i < result.rois.size(); ++i) {
    RoiTruthValue& truth = truths[i];
    if (!has_points) {
      truth.why = "the dataset has no truth points for frame " + std::to_string(frame1);
      continue;
    }
    const cv::Rect& box = result.rois[i].box1_px;
    try {
      const datasets::synth::RoiTruth roi_truth = datasets::synth::ComputeRoiTruth(
          dataset, frame1, datasets::synth::PixelRoi{box.x, box.y, box.width, box.height});
      truth.available = true;
      truth.num_points = roi_truth.num_points;
      truth.slope_deg = roi_truth.slope_deg;
      truth.roughness_rms_m = roi_truth.roughness_rms_m;
      truth.roughness_max_m = roi_truth.roughness_max_m;
      truth.hazard_height_m = roi_truth.hazard_height_m;
      truth.max_rock_height_m = roi_truth.max_rock_height_m;
      truth.normal_in_local = roi_truth.normal_in_local;
      if (on_surface.has_value()) {
        truth.landing = on_surface->Evaluate(roi_truth.centroid_in_local_m.head<2>());
      } else {
        truth.landing.why = "the dataset has no truth DEM";
      }
    } catch (const InputError& e) {
      truth.why = e.what();
    }
  }
  return truths;
}

FlightRun RunFlight(const datasets::Dataset& dataset, int frame1, int frame2,
                    const hda::HdaOptions& options, const std::vector<cv::Rect>& given_rois_px,
                    const hda::RoiProgress& progress, const datasets::synth::LanderGeometry& lander) {
  ThrowIfInvalid("the lander: ", lander.Validate());
  FlightRun run;
  hda::HdaInput input = MakeHdaInput(dataset, frame1, frame2, &run.range_source);
  input.given_rois_px = given_rois_px;
  run.dataset_name = dataset.name;
  run.frame1 = frame1;
  run.frame2 = frame2;
  run.lens_model = dataset.camera.LensModelName();
  run.image_width_px = dataset.camera.WidthPx();
  run.image_height_px = dataset.camera.HeightPx();
  run.baseline_m = PoseOfFrames(frame1, frame2, [&] { return dataset.BaselineM(frame1, frame2); });
  run.lrf_range_m = input.lrf_range_m;
  run.options = options;
  run.given_rois = !given_rois_px.empty();
  run.result = hda::RunHda(input, dataset.camera, options, hda::SteadySeconds, progress);
  run.lander = lander;
  run.truths = TruthOfRois(dataset, frame1, run.result, lander);
  run.calibration = ComputeCalibrationTerm(dataset, input, options, run.result);
  return run;
}

FlightRun RunFlight(const datasets::Dataset& dataset, int frame1, int frame2,
                    const HdaSettings& settings, const std::vector<cv::Rect>& given_rois_px,
                    const hda::RoiProgress& progress) {
  const int n = static_cast<int>(dataset.frames.size());
  if (frame1 < 0 || frame1 >= n || frame2 < 0 || frame2 >= n) {
    return RunFlight(dataset, frame1, frame2, settings.options, given_rois_px, progress,
                     settings.lander);  // MakeHdaInput names the frame
  }
  PairGeometry geometry;
  geometry.lrf_range_m = RangeAtFrame(dataset, frame1).range_m;
  geometry.baseline_m = PoseOfFrames(frame1, frame2, [&] { return dataset.BaselineM(frame1, frame2); });
  const cv::Mat& image1 = dataset.frames[static_cast<size_t>(frame1)].image;
  // The texture only sets the site size: not counted when the site is given.
  if (!image1.empty() && settings.given.count("quadtree.site_size_m") == 0) {
    geometry.keypoints_per_px = OrbKeypointDensity(image1, settings.options.matching,
                                                   settings.options.quadtree.min_block_mean);
  }
  std::vector<DerivedParam> derived;
  const hda::HdaOptions options = ResolveHdaOptions(settings, dataset.camera, geometry, &derived);
  ThrowIfInvalid("flight-method parameters for frames " + std::to_string(frame1) + "," +
                     std::to_string(frame2) + ": ",
                 options.Validate());
  FlightRun run = RunFlight(dataset, frame1, frame2, options, given_rois_px, progress, settings.lander);
  run.derived_options = std::move(derived);
  return run;
}

double TiltErrorDeg(const Eigen::Vector3d& normal, const Eigen::Vector3d& true_normal) {
  if (!normal.allFinite() || !true_normal.allFinite() || normal.norm() == 0.0 || true_normal.norm() == 0.0) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  return std::atan2(normal.cross(true_normal).norm(), std::abs(normal.dot(true_normal))) * util::kRadToDeg;
}

double CalibrationTerm::SlopeSigmaDeg(size_t i) const {
  return available && i < rois.size() && rois[i].available ? rois[i].slope_deg
                                                            : std::numeric_limits<double>::quiet_NaN();
}

double CalibrationTerm::TiltSigmaDeg(size_t i) const {
  return available && i < rois.size() && rois[i].available ? rois[i].tilt_deg
                                                            : std::numeric_limits<double>::quiet_NaN();
}

CalibrationTerm ComputeCalibrationTerm(const datasets::Dataset& dataset, const hda::HdaInput& input,
                                       const hda::HdaOptions& options, const hda::HdaResult& result) {
  CalibrationTerm term;
  if (dataset.dir.empty()) {
    term.why = "the dataset was built in memory: no camera model file to take a calibration from";
    return term;
  }
  term.model_file = (std::filesystem::path(dataset.dir) / dataset.camera_model_file).string();
  if (!calib::ModelHasOptimizationInputs(term.model_file)) {
    term.why = term.model_file +
               " holds no optimization_inputs (a model that is not a calibration's output, such as a "
               "synthetic scene's true camera): no calibration term";
    return term;
  }
  try {
    term.modes = calib::ComputeIntrinsicsModes(term.model_file);
    const double window_px = hda::MatchWindowPx(options.matching);
    for (const hda::RoiResult& roi : result.rois) {
      hda::CalibrationSigma sigma;
      if (!roi.has_fit) {
        sigma.why = "no fit";
      } else {
        sigma = hda::SiteCalibrationSigma(input, dataset.camera, options, term.modes, roi.box1_px, roi.points1_px,
                                          roi.points2_px, window_px);
      }
      term.rois.push_back(std::move(sigma));
    }
  } catch (const InputError& e) {
    term.rois.clear();
    term.why = e.what();
    return term;
  } catch (const ExternalError& e) {
    term.rois.clear();
    term.why = e.what();
    return term;
  }
  term.available = true;
  return term;
}

double FlightRun::CombinedSlopeSigmaDeg(size_t i) const {
  const double method = i < result.rois.size() ? result.rois[i].slope_sigma_deg : std::numeric_limits<double>::quiet_NaN();
  return hda::CombinedSlopeSigmaDeg(method, calibration.SlopeSigmaDeg(i));
}

bool FlightRun::AnyTruth() const {
  return std::any_of(truths.begin(), truths.end(), [](const RoiTruthValue& t) { return t.available; });
}

}  // namespace hdabench::reference
