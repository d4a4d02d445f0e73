// plane-nav: per ROI, the direct photometric plane under the nav pose
// (reference/direct/plane_direct.h, where its statuses are decided).
#include <limits>

#include "reference/compare/methods/method_support.h"
#include "reference/direct/plane_direct.h"

namespace hdabench::reference {

namespace {

using methods::LevelGroundInCam1;
using methods::NoteLowParallax;
using methods::SecondsSince;
using methods::UpInCam1;

// plane-nav: each ROI's plane by the direct photometric fit under the nav
// pose (reference/direct/plane_direct.h), started from level ground at the
// LRF's point (never from the flight method's fit, so that the reference owes
// nothing to it), over the ROI's box grown by half the flight method's
// warp-refinement window.
std::vector<MethodRoi> PlaneNavRois(const FlightRun& flight, const CompareOptions& options, const PairContext& ctx,
                                    MethodSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  // The bound on a slope's sigma is the flight method's, as resolved for the
  // pair (--set hda.max_slope_sigma_deg moves every method's).
  DirectPlaneOptions plane_options = options.direct_plane;
  plane_options.max_slope_sigma_deg = flight.options.max_slope_sigma_deg;
  std::vector<MethodRoi> rois(flight.result.rois.size());
  const DirectPlaneImages images = PrepareDirectPlaneImages(ctx.input().image1, ctx.input().image2);
  const Eigen::Vector3d up_in_cam1 = UpInCam1(ctx);
  const Eigen::Vector3d level = LevelGroundInCam1(ctx);
  // The pixels the flight method's matches of the ROI see: the box grown by
  // half its warp-refinement window (a match at the box's edge reads that far
  // out), so that the two methods judge the same ground with the same support.
  const int margin = options.hda.options.matching.warp_refine_window_px / 2;
  int converged = 0, fitted = 0;
  for (size_t i = 0; i < rois.size(); ++i) {
    const auto roi_start = std::chrono::steady_clock::now();
    MethodRoi& roi = rois[i];
    const cv::Rect grown = (flight.result.rois[i].box1_px + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) &
                           cv::Rect(0, 0, ctx.dataset().camera.WidthPx(), ctx.dataset().camera.HeightPx());
    const DirectPlaneResult fit = FitPlaneDirect(images, ctx.dataset().camera, grown, ctx.input().cam2_from_cam1,
                                                 level, up_in_cam1,
                                                 plane_options);
    roi.reason = fit.reason;
    roi.num_points = fit.pixels;
    switch (fit.status) {
      case DirectPlaneStatus::kOk: {
        roi.status = MethodRoiStatus::kOk;
        roi.has_fit = true;
        roi.slope_deg = fit.slope_deg;
        roi.normal_in_local = ctx.local_from_cam1().rotation * fit.up_normal_in_cam1;
        roi.has_sigma = true;
        roi.slope_sigma_deg = fit.slope_sigma_deg;
        // A plane has no roughness of its own.
        roi.roughness_rms_m = std::numeric_limits<double>::quiet_NaN();
        roi.roughness_max_m = std::numeric_limits<double>::quiet_NaN();
        for (const Eigen::Vector3d& p : fit.points_in_cam1) roi.points_in_local_m.push_back(ctx.local_from_cam1() * p);
        roi.support_px = fit.support_px;
        roi.support_weights = fit.support_weights;
        if (ctx.dataset().truth.dem.has_value()) {
          roi.accuracy = ComputePointAccuracy(roi.points_in_local_m, *ctx.dataset().truth.dem);
        }
        ++fitted;
        if (fit.converged) ++converged;
        break;
      }
      case DirectPlaneStatus::kOutsideOverlap:
        roi.status = MethodRoiStatus::kOutsideOverlap;
        break;
      case DirectPlaneStatus::kNoTexture:
        roi.status = MethodRoiStatus::kNoTexture;
        break;
      case DirectPlaneStatus::kDiverged:
        roi.status = MethodRoiStatus::kDiverged;
        break;
      case DirectPlaneStatus::kLowParallax:
        roi.status = MethodRoiStatus::kLowParallax;
        break;
    }
    roi.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - roi_start).count();
  }
  summary->wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  summary->note = std::to_string(fitted) + " planes, " + std::to_string(converged) + " converged within " +
                  std::to_string(plane_options.max_iterations) + " iterations";
  NoteLowParallax(rois, "the nav pose's parallax leaves their plane unobservable", summary);
  return rois;
}

}  // namespace

MethodEntry PlaneNavMethod() {
  MethodEntry m;
  m.name = kMethodPlaneNav;
  m.summary = "per ROI, the direct photometric plane under the nav pose";
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    ctx.Say("plane-nav: the direct plane of every ROI");
    *rois = PlaneNavRois(ctx.flight(), ctx.options(), ctx, summary);
  };
  return m;
}

}  // namespace hdabench::reference
