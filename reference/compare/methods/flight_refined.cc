// flight-refined: the flight method's points and the nav relative pose
// refined together by a two-view bundle adjustment with the nav pose as a
// prior (Ceres, reference/ceres/ceres_refine.h).
#include "reference/compare/methods/method_support.h"
#include "reference/ceres/ceres_refine.h"

namespace hdabench::reference {

namespace {

using methods::Bearings;
using methods::SecondsSince;

// flight-refined: every flight point of every ROI with a fit and the nav pose
// refined together; the ROIs refitted with the refined points.
PairReconstruction FlightRefined(const FlightRun& flight, const CompareOptions& options,
                                 const PairContext& ctx, std::string* note) {
  const auto start = std::chrono::steady_clock::now();
  PairReconstruction recon;
  recon.method = kMethodFlightRefined;
  CeresRefineInput input;
  input.nav_cam2_from_cam1 = ctx.input().cam2_from_cam1;
  input.focal_px = ctx.focal_px();
  std::vector<Eigen::Vector2d> pixels1;
  const Rigid3d cam1_from_local = ctx.local_from_cam1().Inverse();
  for (const hda::RoiResult& r : flight.result.rois) {
    if (!r.has_fit) continue;
    std::vector<unsigned char> valid1, valid2;
    const std::vector<Eigen::Vector3d> b1 = Bearings(ctx.dataset().camera, r.points1_px, &valid1);
    const std::vector<Eigen::Vector3d> b2 = Bearings(ctx.dataset().camera, r.points2_px, &valid2);
    for (size_t k = 0; k < r.points1_px.size(); ++k) {
      if (valid1[k] == 0 || valid2[k] == 0) continue;
      input.bearings1_in_cam1.push_back(b1[k]);
      input.bearings2_in_cam2.push_back(b2[k]);
      input.points_in_cam1_m.push_back(cam1_from_local * r.points_in_local_m[k]);
      pixels1.emplace_back(r.points1_px[k].x, r.points1_px[k].y);
    }
  }
  // The prior's sigmas are the flight method's own, as resolved for this pair
  // (they follow the geometry, --params and --set).
  CeresRefineOptions refine = options.refine;
  refine.nav_position_sigma_m = flight.options.prediction.nav_position_sigma_m;
  refine.nav_attitude_sigma_deg = flight.options.prediction.nav_attitude_sigma_deg;
  refine.pixel_sigma_px = flight.options.match_error_px;
  // The range finder fixes the scale the images leave to the nav baseline:
  // its range, to level ground through the 20 flight points nearest its beam
  // within one, two or four sites of it, the smallest that holds three (the
  // ground the flight points sample around the spot; level, as the bench
  // takes the LRF's ground everywhere else).
  if (flight.range_source == RangeSource::kLrf) {
    CeresRefineInput::Lrf lrf;
    lrf.origin_in_cam1_m = ctx.input().lrf_origin_in_cam1_m;
    lrf.beam_in_cam1 = ctx.input().lrf_beam_in_cam1;
    lrf.range_m = ctx.input().lrf_range_m;
    lrf.range_sigma_m = options.lrf_range_sigma_m;
    lrf.support_radius_m = 4.0 * flight.options.quadtree.site_size_m;
    lrf.ground_normal_in_cam1 = methods::UpInCam1(ctx);
    input.lrf = lrf;
  }
  const CeresRefineResult refined = RefineTwoView(input, refine);
  recon.wall_s = SecondsSince(start);
  // Any status but invalid input or too few points leaves a usable state
  // (the initial one when Ceres made it worse or failed).
  if (refined.status == CeresRefineStatus::kInvalidInput) {
    recon.failure = "ceres refinement: " + refined.failure;
    return recon;
  }
  if (refined.status == CeresRefineStatus::kTooFewPoints) {
    // Nothing to refine is not a failure: every ROI gets too few points.
    recon.ok = true;
    *note = "nothing to refine: " + refined.failure;
    return recon;
  }
  recon.ok = true;
  *note = std::string("ceres: ") + ToString(refined.status) + ", " +
          (refined.lrf_note.empty() ? std::string() : refined.lrf_note + ", ") +
          std::to_string(refined.iterations) + " iterations, cost " +
          std::to_string(refined.initial_cost.total) + " -> " +
          std::to_string(refined.final_cost.total) +
          (refined.failure.empty() ? "" : " (" + refined.failure + ")");
  recon.has_pose = true;
  recon.cam2_from_cam1 = refined.cam2_from_cam1;
  for (size_t k = 0; k < refined.points_in_cam1_m.size(); ++k) {
    ReconstructedPoint p;
    p.point_in_local_m = ctx.local_from_cam1() * refined.points_in_cam1_m[k];
    p.pixel1 = pixels1[k];
    recon.points.push_back(p);
  }
  return recon;
}

// flight-refined refits the flight method's own points, so an ROI the flight
// method did not fit has none: its reason passes on the flight method's, and
// an ROI the flight method refused before matching because the nav pose
// leaves its depth unobservable is low parallax here too.
void PassOnFlightReasons(const hda::HdaResult& flight, std::vector<MethodRoi>* rois) {
  for (size_t i = 0; i < rois->size(); ++i) {
    const hda::RoiResult& r = flight.rois[i];
    MethodRoi& roi = (*rois)[i];
    if (r.has_fit || roi.num_points > 0) continue;
    if (r.depth_unobservable) roi.status = MethodRoiStatus::kLowParallax;
    roi.reason = "no points: the flight method fitted none here (" + std::string(hda::ToString(r.status)) +
                 (r.reason.empty() ? "" : ": " + r.reason) + ")";
  }
}

}  // namespace

MethodEntry FlightRefinedMethod() {
  MethodEntry m;
  m.name = kMethodFlightRefined;
  m.summary = "the flight points and the nav pose refined by a two-view bundle adjustment (Ceres)";
  m.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    ctx.Say("flight-refined: two-view bundle adjustment of the flight points");
    std::string note;
    const PairReconstruction recon = FlightRefined(ctx.flight(), ctx.options(), ctx, &note);
    methods::FillFromReconstruction(recon, ctx, rois, summary);
    summary->note = note;
    if (recon.ok) PassOnFlightReasons(ctx.flight().result, rois);
    methods::NoteLowParallax(*rois, "the flight method found their depth unobservable under the nav pose", summary);
    methods::PoseErrorAgainstTruth(recon, ctx, summary);
  };
  return m;
}

}  // namespace hdabench::reference
