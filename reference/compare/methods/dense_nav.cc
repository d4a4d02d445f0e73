// dense-nav: the pair rectified with the nav pose, semi-global matching,
// every matched pixel triangulated (reference/direct/dense_stereo.h, where
// its statuses are decided).
#include <cmath>
#include <set>

#include "reference/compare/methods/method_support.h"
#include "reference/direct/dense_stereo.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace {

using methods::InBox;
using methods::LevelGroundInCam1;
using methods::NoteLowParallax;
using methods::SecondsSince;

// dense-nav: the pair rectified with the nav pose and matched by SGBM
// (reference/direct/dense_stereo.h); each ROI's plane fitted to the points
// its image-1 box sees, as every point-based method's. An ROI without enough
// points is "outside overlap" when under half of its pixels can be matched
// at all (outside the rectified field or image 2), "no texture" otherwise;
// one with enough points is "low parallax" when the matcher's disparity step
// leaves its slope more uncertain than max_slope_sigma_deg.
std::vector<MethodRoi> DenseNavRois(const FlightRun& flight, const CompareOptions& options, const PairContext& ctx,
                                    MethodSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  // The bound on a slope's sigma is the flight method's, as resolved for the
  // pair (--set hda.max_slope_sigma_deg moves every method's).
  DenseStereoOptions dense_options = options.dense_stereo;
  dense_options.max_slope_sigma_deg = flight.options.max_slope_sigma_deg;
  const DenseStereoResult dense = RunDenseStereo(ctx.input().image1, ctx.input().image2, ctx.dataset().camera,
                                                 ctx.input().cam2_from_cam1, LevelGroundInCam1(ctx),
                                                 dense_options);
  std::vector<MethodRoi> rois(flight.result.rois.size());
  if (dense.status != DenseStereoStatus::kOk) {
    for (MethodRoi& roi : rois) {
      roi.status = MethodRoiStatus::kNotRectifiable;
      roi.reason = dense.reason;
    }
    summary->note = dense.reason;
    summary->wall_s = SecondsSince(start);
    return rois;
  }
  PairReconstruction recon;
  recon.method = kMethodDenseNav;
  recon.ok = true;
  recon.points.resize(dense.points_in_cam1.size());
  for (size_t k = 0; k < dense.points_in_cam1.size(); ++k) {
    recon.points[k].point_in_local_m = ctx.local_from_cam1() * dense.points_in_cam1[k];
    recon.points[k].pixel1 = dense.pixels1[k];
  }
  rois = RoisOfReconstruction(recon, flight.result, ctx.dataset(), ctx.local_from_cam1(), ctx.local_from_cam2(),
                              options.min_points);
  for (size_t i = 0; i < rois.size(); ++i) {
    MethodRoi& roi = rois[i];
    const cv::Rect& box = flight.result.rois[i].box1_px;
    // A dense method that matched only a corner of the ROI (at the overlap's
    // edge, or a shadow's) does not stand by a plane for all of it. The
    // share counts image-1 pixels (an oblique rectification can sample a
    // pixel twice).
    std::set<std::pair<long, long>> pixels;
    std::vector<Eigen::Vector3d> in_cam1;
    for (size_t k = 0; k < recon.points.size(); ++k) {
      const Eigen::Vector2d& pixel1 = recon.points[k].pixel1;
      if (!InBox(pixel1, box)) continue;
      pixels.emplace(std::lround(pixel1.x()), std::lround(pixel1.y()));
      in_cam1.push_back(dense.points_in_cam1[k]);
    }
    const double share = static_cast<double>(pixels.size()) / std::max(1, box.area());
    if (roi.status == MethodRoiStatus::kOk && share < dense_options.min_roi_share) {
      roi.status = MethodRoiStatus::kTooFewPoints;
      roi.has_fit = false;
    }
    // Too little parallax for the matcher's step to give a slope: no plane
    // stood by, however many points (on a pair that did not move but whose
    // nav pose did, they are noise triangulated with the nav baseline).
    if (roi.status == MethodRoiStatus::kOk) {
      const double sigma_deg = DenseSlopeSigmaDeg(dense, ctx.dataset().camera, box, roi.num_points, in_cam1);
      if (!(sigma_deg <= dense_options.max_slope_sigma_deg)) {
        roi.status = MethodRoiStatus::kLowParallax;
        roi.has_fit = false;
        roi.reason = std::to_string(roi.num_points) + " points, but the matcher's 1/" +
                     util::FixedText(kDisparityStepsPerPx, 0) + " px disparity step alone " +
                     "leaves their slope uncertain by " +
                     (std::isfinite(sigma_deg) ? util::FixedText(sigma_deg, 1) + " deg" : "any angle") +
                     " under the nav pose (at most " +
                     util::FixedText(dense_options.max_slope_sigma_deg, 1) + " deg)";
      }
    }
    if (roi.status != MethodRoiStatus::kTooFewPoints) continue;
    roi.reason = std::to_string(pixels.size()) + " of the ROI's " + std::to_string(box.area()) +
                 " pixels have a point (" +
                 std::to_string(static_cast<int>(std::lround(100.0 * dense_options.min_roi_share))) +
                 " % needed)";
    const double seen = DenseOverlapFraction(dense, ctx.dataset().camera, ctx.input().cam2_from_cam1, box,
                                             dense_options.block_size_px);
    const int percent = static_cast<int>(std::lround(100.0 * seen));
    if (seen < 0.5) {
      roi.status = MethodRoiStatus::kOutsideOverlap;
      roi.reason += "; " + std::to_string(percent) + " % of them are in the rectified field and image 2";
    } else {
      roi.status = MethodRoiStatus::kNoTexture;
      roi.reason += "; " + std::to_string(percent) + " % of them are in the rectified field and image 2, "
                    "the rest found no match";
    }
  }
  summary->note = dense.reason;
  NoteLowParallax(rois, "the disparity step leaves their slope uncertain by more than " +
                            util::FixedText(dense_options.max_slope_sigma_deg, 1) + " deg",
                  summary);
  summary->wall_s = SecondsSince(start);
  return rois;
}

}  // namespace

MethodEntry DenseNavMethod() {
  MethodEntry m;
  m.name = kMethodDenseNav;
  m.summary = "the pair rectified with the nav pose, semi-global matching, every matched pixel triangulated";
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    ctx.Say("dense-nav: the rectified pair's semi-global matching");
    *rois = DenseNavRois(ctx.flight(), ctx.options(), ctx, summary);
  };
  return m;
}

}  // namespace hdabench::reference
