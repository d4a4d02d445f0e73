// flight: the flight method as it would fly (RunHda), its ROIs as the
// comparison reads them. RunCompare runs it first: it finds the ROIs.
#include <cmath>

#include "reference/compare/method.h"

namespace hdabench::reference {

namespace {

std::vector<MethodRoi> FlightRois(const FlightRun& flight, const PairContext& ctx) {
  std::vector<MethodRoi> rois(flight.result.rois.size());
  for (size_t i = 0; i < rois.size(); ++i) {
    const hda::RoiResult& r = flight.result.rois[i];
    MethodRoi& roi = rois[i];
    roi.status = MethodRoiStatus::kFlight;
    roi.flight_status = r.status;
    roi.reason = r.reason;
    roi.num_points = static_cast<int>(r.points_in_local_m.size());
    roi.points_in_local_m = r.points_in_local_m;
    for (const cv::Point2d& pixel : r.points1_px) roi.support_px.emplace_back(pixel.x, pixel.y);
    roi.has_fit = r.has_fit;
    roi.slope_deg = r.slope_deg;
    roi.normal_in_local = r.normal_in_local;
    roi.roughness_rms_m = r.roughness_rms_m;
    roi.roughness_max_m = r.roughness_max_m;
    roi.has_sigma = r.has_fit && std::isfinite(r.slope_sigma_deg);
    roi.slope_sigma_deg = r.slope_sigma_deg;
    roi.slope_sigma_calibration_deg = flight.calibration.SlopeSigmaDeg(i);
    roi.wall_s = r.wall_s;
    if (ctx.dataset().truth.dem.has_value() && !r.points_in_local_m.empty()) {
      roi.accuracy = ComputePointAccuracy(r.points_in_local_m, *ctx.dataset().truth.dem);
    }
  }
  return rois;
}

}  // namespace

MethodEntry FlightMethod() {
  MethodEntry m;
  m.name = kMethodFlight;
  m.summary = "the flight method as it would fly (hda/, RunHda); it finds the ROIs and always runs";
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    *rois = FlightRois(ctx.flight(), ctx);
    summary->wall_s = ctx.flight().result.times.total_s;
  };
  return m;
}

}  // namespace hdabench::reference
