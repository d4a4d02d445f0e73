#include "reference/flight/calibration_check.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include "calib/calibration_analysis.h"
#include "hda/calibration_sigma.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/options_check.h"
#include "tools/util/statistics.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using Json = nlohmann::ordered_json;

Json CheckNumber(double value) { return std::isfinite(value) ? Json(value) : Json(nullptr); }

RatioStats Ratios(const std::vector<CalibrationCheckRoi>& rois, double CalibrationCheckRoi::*empirical,
                  double CalibrationCheckRoi::*predicted, int CalibrationCheckRoi::*samples) {
  std::vector<double> ratios;
  for (const CalibrationCheckRoi& roi : rois) {
    if (roi.*samples >= 2 && roi.*predicted > 0.0) ratios.push_back(roi.*empirical / roi.*predicted);
  }
  RatioStats stats;
  stats.rois = static_cast<int>(ratios.size());
  if (ratios.empty()) return stats;
  std::sort(ratios.begin(), ratios.end());
  stats.median = util::Quantile(ratios, 0.5);
  stats.p10 = util::Quantile(ratios, 0.1);
  stats.p90 = util::Quantile(ratios, 0.9);
  return stats;
}

Json RatioJson(const RatioStats& r) {
  return {{"rois", r.rois}, {"median", CheckNumber(r.median)}, {"p10", CheckNumber(r.p10)}, {"p90", CheckNumber(r.p90)}};
}

}  // namespace

CalibrationCheck CheckCalibrationTerm(const datasets::Dataset& dataset, const FlightRun& run, int samples,
                                      std::uint64_t seed, const std::function<void(int, int)>& progress) {
  const CalibrationTerm& term = run.calibration;
  if (!term.available) throw InputError("no calibration term to check: " + term.why);
  CalibrationCheck check;
  check.model = term.model_file;
  check.samples = samples;
  check.seed = seed;
  const calib::ResolvedCalibration resolved = calib::ResolveCalibration(term.model_file, samples, seed);
  if (resolved.lensmodel != dataset.camera.LensModelName() || resolved.intrinsics != dataset.camera.Intrinsics()) {
    throw InputError(term.model_file + ": the re-solved calibration is not about the dataset's camera");
  }
  check.solved = static_cast<int>(resolved.solved.size());
  check.noise_stdev_px = resolved.noise_stdev_px;
  check.failures = resolved.failures;

  const hda::HdaInput input = MakeHdaInput(dataset, run.frame1, run.frame2);
  const double window_px = hda::MatchWindowPx(run.options.matching);
  const std::vector<hda::RoiResult>& rois = run.result.rois;
  // The ROIs with a prediction, and the reference of each column: the
  // nominal model on the fixed matches, and a run on the same ROIs.
  std::vector<size_t> checked;
  std::vector<hda::RoiResult> fixed_nominal;
  hda::HdaInput given = input;
  for (size_t i = 0; i < rois.size(); ++i) {
    if (!(term.SlopeSigmaDeg(i) > 0.0)) continue;
    checked.push_back(i);
    fixed_nominal.push_back(hda::EvaluateMatchedSite(input, dataset.camera, run.options, rois[i].box1_px,
                                                     rois[i].points1_px, rois[i].points2_px, window_px));
    given.given_rois_px.push_back(rois[i].box1_px);
  }
  const auto by_box = [](const hda::HdaResult& result, const cv::Rect& box) -> const hda::RoiResult* {
    for (const hda::RoiResult& roi : result.rois) {
      if (roi.box1_px == box) return &roi;
    }
    return nullptr;
  };
  const hda::HdaResult rerun_nominal = hda::RunHda(given, dataset.camera, run.options);

  std::vector<double> fixed_slope2(checked.size(), 0.0), fixed_tilt2(checked.size(), 0.0),
      rerun_slope2(checked.size(), 0.0);
  check.rois.resize(checked.size());
  for (size_t s = 0; s < resolved.solved.size(); ++s) {
    const calib::ResolvedIntrinsics& sample = resolved.solved[s];
    const calib::CameraModel camera(dataset.camera.LensModelName(), sample.intrinsics, dataset.camera.WidthPx(),
                                    dataset.camera.HeightPx(), dataset.camera.RtCamRef(), term.model_file);
    const Eigen::Vector3d& rotation = sample.rotation_rad;
    const hda::HdaInput turned = hda::InputInTurnedFrame(input, rotation);
    hda::HdaInput turned_given = hda::InputInTurnedFrame(given, rotation);
    const hda::HdaResult rerun = hda::RunHda(turned_given, camera, run.options);
    for (size_t c = 0; c < checked.size(); ++c) {
      const hda::RoiResult& roi = rois[checked[c]];
      const hda::RoiResult& nominal = fixed_nominal[c];
      const hda::RoiResult moved = hda::EvaluateMatchedSite(turned, camera, run.options, roi.box1_px, roi.points1_px,
                                                            roi.points2_px, window_px);
      CalibrationCheckRoi& row = check.rois[c];
      if (nominal.has_fit && moved.has_fit && moved.counts.depth_inliers == nominal.counts.depth_inliers) {
        fixed_slope2[c] += std::pow(moved.slope_deg - nominal.slope_deg, 2);
        fixed_tilt2[c] += std::pow(TiltErrorDeg(moved.normal_in_local, nominal.normal_in_local), 2);
        ++row.fixed_samples;
      }
      const hda::RoiResult* again = by_box(rerun, roi.box1_px);
      const hda::RoiResult* reference = by_box(rerun_nominal, roi.box1_px);
      if (again != nullptr && reference != nullptr && again->has_fit && reference->has_fit &&
          hda::HasSlope(again->status) && hda::HasSlope(reference->status)) {
        rerun_slope2[c] += std::pow(again->slope_deg - reference->slope_deg, 2);
        ++row.rerun_samples;
      }
    }
    if (progress) progress(static_cast<int>(s) + 1, static_cast<int>(resolved.solved.size()));
  }
  for (size_t c = 0; c < checked.size(); ++c) {
    CalibrationCheckRoi& row = check.rois[c];
    row.id = rois[checked[c]].id;
    row.predicted_slope_deg = term.SlopeSigmaDeg(checked[c]);
    row.predicted_tilt_deg = term.TiltSigmaDeg(checked[c]);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    row.fixed_slope_rms_deg = row.fixed_samples > 0 ? std::sqrt(fixed_slope2[c] / row.fixed_samples) : nan;
    row.fixed_tilt_rms_deg = row.fixed_samples > 0 ? std::sqrt(fixed_tilt2[c] / row.fixed_samples) : nan;
    row.rerun_slope_rms_deg = row.rerun_samples > 0 ? std::sqrt(rerun_slope2[c] / row.rerun_samples) : nan;
  }
  check.fixed_slope = Ratios(check.rois, &CalibrationCheckRoi::fixed_slope_rms_deg,
                             &CalibrationCheckRoi::predicted_slope_deg, &CalibrationCheckRoi::fixed_samples);
  check.fixed_tilt = Ratios(check.rois, &CalibrationCheckRoi::fixed_tilt_rms_deg,
                            &CalibrationCheckRoi::predicted_tilt_deg, &CalibrationCheckRoi::fixed_samples);
  check.rerun_slope = Ratios(check.rois, &CalibrationCheckRoi::rerun_slope_rms_deg,
                             &CalibrationCheckRoi::predicted_slope_deg, &CalibrationCheckRoi::rerun_samples);
  return check;
}

HdaGeometrySite MakeHdaGeometrySite(const calib::CameraModel& truth, const calib::HdaGeometry& geometry) {
  ThrowIfInvalid("the HDA geometry: ", geometry.Validate());
  const double w = truth.WidthPx();
  const double h = truth.HeightPx();
  // The band's centre in mrcal's pixels (the imager spans -0.5 .. W - 0.5).
  const Eigen::Vector2d centre((geometry.band_x0 + geometry.band_x1) / 2.0 * w - 0.5,
                               (geometry.band_y0 + geometry.band_y1) / 2.0 * h - 0.5);
  std::vector<Eigen::Vector3d> sight_of;
  std::vector<unsigned char> valid;
  if (truth.Unproject({centre}, &sight_of, &valid) != 1) {
    throw InputError("the HDA geometry: the camera cannot unproject the band's centre");
  }
  const Eigen::Vector3d sight = sight_of.front().normalized();
  const Eigen::Vector3d along_x = (Eigen::Vector3d::UnitX() - sight.x() * sight).normalized();
  const Eigen::Vector3d along_y = sight.cross(along_x);
  const Eigen::Vector3d baseline = geometry.baseline_m * along_x;
  HdaGeometrySite site;
  // The local frame is camera 1's; the ground is level, so up is -sight.
  site.input.local_from_cam1 = Rigid3d();
  site.input.cam2_from_cam1 = Rigid3d(Eigen::Quaterniond::Identity(), -baseline);
  site.input.gravity_in_local_mps2 = 1.62 * sight;
  site.input.lrf_range_m = geometry.range_m;
  site.input.lrf_beam_in_cam1 = sight;
  site.input.ils_in_local_m = geometry.range_m * sight;
  site.true_normal_in_local = -sight;
  constexpr int kGrid = 10;
  std::vector<Eigen::Vector3d> in_cam1, in_cam2;
  for (int j = 0; j < kGrid; ++j) {
    for (int i = 0; i < kGrid; ++i) {
      const double u = geometry.site_m * ((i + 0.5) / kGrid - 0.5);
      const double v = geometry.site_m * ((j + 0.5) / kGrid - 0.5);
      in_cam1.push_back(geometry.range_m * sight + u * along_x + v * along_y);
      in_cam2.push_back(in_cam1.back() - baseline);
    }
  }
  std::vector<Eigen::Vector2d> q1, q2;
  if (truth.Project(in_cam1, &q1, &valid) != kGrid * kGrid || truth.Project(in_cam2, &q2, &valid) != kGrid * kGrid) {
    throw InputError("the HDA geometry: the site does not project into both camera positions");
  }
  double x0 = q1.front().x(), x1 = x0, y0 = q1.front().y(), y1 = y0;
  for (size_t k = 0; k < q1.size(); ++k) {
    site.points1_px.emplace_back(q1[k].x(), q1[k].y());
    site.points2_px.emplace_back(q2[k].x(), q2[k].y());
    x0 = std::min(x0, q1[k].x());
    x1 = std::max(x1, q1[k].x());
    y0 = std::min(y0, q1[k].y());
    y1 = std::max(y1, q1[k].y());
  }
  site.box1_px = cv::Rect(cv::Point(static_cast<int>(std::floor(x0)), static_cast<int>(std::floor(y0))),
                          cv::Point(static_cast<int>(std::ceil(x1)) + 1, static_cast<int>(std::ceil(y1)) + 1));
  return site;
}

double HdaGeometryTiltDeg(const HdaGeometrySite& site, const calib::CameraModel& believed,
                          const Eigen::Vector3d& rotation_rad) {
  const hda::RoiResult fit =
      hda::EvaluateMatchedSite(hda::InputInTurnedFrame(site.input, rotation_rad), believed, hda::HdaOptions(),
                               site.box1_px, site.points1_px, site.points2_px, 0.0);
  if (!fit.has_fit) return std::numeric_limits<double>::quiet_NaN();
  return TiltErrorDeg(fit.normal_in_local, site.true_normal_in_local);
}

std::string CalibrationCheckJson(const CalibrationCheck& check) {
  Json rows = Json::array();
  for (const CalibrationCheckRoi& r : check.rois) {
    rows.push_back({{"id", r.id},
                    {"predicted_slope_deg", CheckNumber(r.predicted_slope_deg)},
                    {"predicted_tilt_deg", CheckNumber(r.predicted_tilt_deg)},
                    {"fixed_slope_rms_deg", CheckNumber(r.fixed_slope_rms_deg)},
                    {"fixed_tilt_rms_deg", CheckNumber(r.fixed_tilt_rms_deg)},
                    {"fixed_samples", r.fixed_samples},
                    {"rerun_slope_rms_deg", CheckNumber(r.rerun_slope_rms_deg)},
                    {"rerun_samples", r.rerun_samples}});
  }
  Json j;
  j["format"] = "hdabench-calibration-check";
  j["format_version"] = 1;
  j["model"] = check.model;
  j["samples"] = check.samples;
  j["solved"] = check.solved;
  j["seed"] = check.seed;
  j["noise_stdev_px"] = CheckNumber(check.noise_stdev_px);
  j["failures"] = check.failures;
  j["ratios"] = {{"what", "empirical RMS over the re-solves / predicted sigma, over the ROIs"},
                 {"fixed_slope", RatioJson(check.fixed_slope)},
                 {"fixed_tilt", RatioJson(check.fixed_tilt)},
                 {"rerun_slope", RatioJson(check.rerun_slope)}};
  j["rois"] = rows;
  return j.dump(2) + "\n";
}

std::string CalibrationCheckLine(const CalibrationCheck& check) {
  std::ostringstream line;
  const auto ratio = [&](const char* what, const RatioStats& r) {
    line << "; " << what << " median " << util::FixedCell(r.median, 2) << ", p10-p90 " << util::FixedCell(r.p10, 2)
         << "-" << util::FixedCell(r.p90, 2) << " (" << r.rois << " ROIs)";
  };
  line << "calibration check, " << check.solved << " of " << check.samples
       << " re-solves: empirical / predicted calibration sigma";
  ratio("slope, matches fixed", check.fixed_slope);
  ratio("tilt, matches fixed", check.fixed_tilt);
  ratio("slope, method re-run", check.rerun_slope);
  return line.str();
}

}  // namespace hdabench::reference
