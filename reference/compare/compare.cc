#include "reference/compare/compare.h"

#include <algorithm>
#include <chrono>
#include <future>
#include <limits>
#include <cmath>
#include <set>
#include <utility>

#include "tools/util/error.h"
#include "hda/geometry.h"
#include "hda/matching.h"
#include "tools/util/text.h"
#include "tools/util/angles.h"
#include "tools/util/options_check.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

namespace {

using util::kRadToDeg;
constexpr int kDenseOrbFeaturesPerRoi = 2000;
constexpr int kDenseOrbFastThreshold = 5;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool IsOpenGvMethod(const std::string& method) {
  return method.rfind(kOpenGvMethodPrefix, 0) == 0;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

// Angle of a rotation, degrees in [0, 180].
double RotationAngleDeg(const Eigen::Quaterniond& q) {
  const Eigen::Quaterniond n = q.normalized();
  return 2.0 * std::atan2(n.vec().norm(), std::abs(n.w())) * kRadToDeg;
}

// Angle between two directions, degrees; 0 when either is zero.
double DirectionAngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  if (a.norm() == 0.0 || b.norm() == 0.0) return 0.0;
  return std::atan2(a.cross(b).norm(), a.dot(b)) * kRadToDeg;
}

// Everything the methods share for the run.
struct Context {
  const datasets::Dataset* dataset = nullptr;
  hda::HdaInput input;             // navigation inputs of the pair (and the images)
  Rigid3d local_from_cam1;         // navigation
  Rigid3d local_from_cam2;         // navigation
  bool has_true_pose = false;
  Rigid3d true_cam2_from_cam1;
  double focal_px = 0.0;           // pixels per radian at the image centre
};

bool InBox(const Eigen::Vector2d& pixel, const cv::Rect& box) {
  // A pixel belongs to the box when its nearest pixel centre does.
  return pixel.x() >= box.x - 0.5 && pixel.x() < box.x + box.width - 0.5 &&
         pixel.y() >= box.y - 0.5 && pixel.y() < box.y + box.height - 0.5;
}

// Fills a method's ROI from its points in the ROI.
void FillFromPoints(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& centre1,
                    const Eigen::Vector3d& centre2, const datasets::Dataset& dataset,
                    int min_points, MethodRoi* roi) {
  roi->num_points = static_cast<int>(points.size());
  roi->points_in_local_m = points;
  const RoiFit fit = FitRoiPoints(points, centre1, centre2, dataset.gravity_in_local_mps2, min_points);
  roi->status = fit.status;
  if (fit.status == MethodRoiStatus::kOk) {
    roi->has_fit = true;
    roi->slope_deg = fit.slope_deg;
    roi->normal_in_local = fit.normal_in_local;
    roi->roughness_rms_m = fit.roughness_rms_m;
    roi->roughness_max_m = fit.roughness_max_m;
    roi->reason = std::to_string(points.size()) + " points";
  } else if (fit.status == MethodRoiStatus::kTooFewPoints) {
    roi->reason = std::to_string(points.size()) + " points, fewer than " + std::to_string(min_points);
  } else {
    roi->reason = std::to_string(points.size()) + " points, collinear";
  }
  if (dataset.truth.dem.has_value()) roi->accuracy = ComputePointAccuracy(points, *dataset.truth.dem);
}

// ---------------------------------------------------------------------------
// The methods

std::vector<MethodRoi> FlightRois(const FlightRun& flight, const Context& ctx) {
  std::vector<MethodRoi> rois(flight.result.rois.size());
  for (size_t i = 0; i < rois.size(); ++i) {
    const hda::RoiResult& r = flight.result.rois[i];
    MethodRoi& roi = rois[i];
    roi.status = MethodRoiStatus::kFlight;
    roi.flight_status = r.status;
    roi.reason = r.reason;
    roi.num_points = static_cast<int>(r.points_in_local_m.size());
    roi.points_in_local_m = r.points_in_local_m;
    roi.has_fit = r.has_fit;
    roi.slope_deg = r.slope_deg;
    roi.normal_in_local = r.normal_in_local;
    roi.roughness_rms_m = r.roughness_rms_m;
    roi.roughness_max_m = r.roughness_max_m;
    roi.has_sigma = r.has_fit && std::isfinite(r.slope_sigma_deg);
    roi.slope_sigma_deg = r.slope_sigma_deg;
    roi.wall_s = r.wall_s;
    if (ctx.dataset->truth.dem.has_value() && !r.points_in_local_m.empty()) {
      roi.accuracy = ComputePointAccuracy(r.points_in_local_m, *ctx.dataset->truth.dem);
    }
  }
  return rois;
}

// Bearings of pixels through the camera model; valid[i] == 0 where not.
std::vector<Eigen::Vector3d> Bearings(const calib::CameraModel& camera,
                                      const std::vector<cv::Point2d>& pixels,
                                      std::vector<unsigned char>* valid) {
  std::vector<Eigen::Vector2d> q;
  q.reserve(pixels.size());
  for (const cv::Point2d& p : pixels) q.emplace_back(p.x, p.y);
  std::vector<Eigen::Vector3d> bearings;
  camera.Unproject(q, &bearings, valid);
  return bearings;
}

// flight-refined: every flight point of every ROI with a fit and the nav pose
// refined together; the ROIs refitted with the refined points.
PairReconstruction FlightRefined(const FlightRun& flight, const CompareOptions& options,
                                 const Context& ctx, std::string* note) {
  const auto start = std::chrono::steady_clock::now();
  PairReconstruction recon;
  recon.method = kMethodFlightRefined;
  CeresRefineInput input;
  input.nav_cam2_from_cam1 = ctx.input.cam2_from_cam1;
  input.focal_px = ctx.focal_px;
  std::vector<Eigen::Vector2d> pixels1;
  const Rigid3d cam1_from_local = ctx.local_from_cam1.Inverse();
  for (const hda::RoiResult& r : flight.result.rois) {
    if (!r.has_fit) continue;
    std::vector<unsigned char> valid1, valid2;
    const std::vector<Eigen::Vector3d> b1 = Bearings(ctx.dataset->camera, r.points1_px, &valid1);
    const std::vector<Eigen::Vector3d> b2 = Bearings(ctx.dataset->camera, r.points2_px, &valid2);
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
  refine.pixel_sigma_px = flight.options.pixel_sigma_floor_px;
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
          std::to_string(refined.iterations) + " iterations, cost " +
          std::to_string(refined.initial_cost.total) + " -> " +
          std::to_string(refined.final_cost.total) +
          (refined.failure.empty() ? "" : " (" + refined.failure + ")");
  recon.has_pose = true;
  recon.cam2_from_cam1 = refined.cam2_from_cam1;
  for (size_t k = 0; k < refined.points_in_cam1_m.size(); ++k) {
    ReconstructedPoint p;
    p.point_in_local_m = ctx.local_from_cam1 * refined.points_in_cam1_m[k];
    p.pixel1 = pixels1[k];
    recon.points.push_back(p);
  }
  return recon;
}

// The ROI's matches before any use of navigation: the flight matcher on the
// flight's boxes (RANSAC inliers).
struct RoiBearings {
  bool has_box = false;
  std::vector<cv::Point2d> pixels1;
  std::vector<Eigen::Vector3d> bearings1;
  std::vector<Eigen::Vector3d> bearings2;
};

// Each box pair's matches (image-1 box, image-2 search box; a pair without a
// search box gets none): the flight matcher, RANSAC inliers, without the
// nav-aided refinement, which maps each window through the motion the nav
// pose predicts, so that the relative-pose solvers see matches that owe
// nothing to navigation beyond the search boxes (Lucas-Kanade only).
std::vector<RoiBearings> MatchBoxes(const std::vector<std::pair<cv::Rect, cv::Rect>>& boxes,
                                    const CompareOptions& options, const Context& ctx) {
  std::vector<RoiBearings> all(boxes.size());
  hda::MatchingOptions matching = options.hda.options.matching;
  matching.warp_refine = false;
  if (options.opengv_dense_features) {
    matching.orb_features_per_roi = kDenseOrbFeaturesPerRoi;
    matching.orb_fast_threshold = kDenseOrbFastThreshold;
  }
  // 16-bit images are converted once, not once per box.
  const cv::Mat image1 = hda::ToEightBit(ctx.input.image1, "image 1");
  const cv::Mat image2 = hda::ToEightBit(ctx.input.image2, "image 2");
  for (size_t i = 0; i < all.size(); ++i) {
    const auto& [box1, box2] = boxes[i];
    if (box2.area() <= 0) continue;
    all[i].has_box = true;
    const hda::RoiMatches matches =
        hda::MatchRoiPair(image1, image2, box1, box2, ctx.dataset->camera, matching);
    std::vector<unsigned char> valid1, valid2;
    const std::vector<Eigen::Vector3d> b1 = Bearings(ctx.dataset->camera, matches.points1_px, &valid1);
    const std::vector<Eigen::Vector3d> b2 = Bearings(ctx.dataset->camera, matches.points2_px, &valid2);
    for (size_t k = 0; k < b1.size(); ++k) {
      if (valid1[k] == 0 || valid2[k] == 0) continue;
      all[i].pixels1.push_back(matches.points1_px[k]);
      all[i].bearings1.push_back(b1[k]);
      all[i].bearings2.push_back(b2[k]);
    }
  }
  return all;
}

// The ROIs' matches on the flight's boxes.
std::vector<RoiBearings> MatchAllRois(const FlightRun& flight, const CompareOptions& options,
                                      const Context& ctx) {
  std::vector<std::pair<cv::Rect, cv::Rect>> boxes;
  for (const hda::RoiResult& r : flight.result.rois) boxes.emplace_back(r.box1_px, r.box2_px);
  return MatchBoxes(boxes, options, ctx);
}

// The matches of the tiles over the rest of the overlap (OverlapTiles), each
// tile's search box in image 2 predicted as the flight method predicts an
// ROI's (hda::PredictSearchBoxes, its options as resolved for the pair).
// *num_tiles: the tiles laid.
std::vector<RoiBearings> MatchOverlapTiles(const FlightRun& flight, const CompareOptions& options,
                                           const Context& ctx, int* num_tiles) {
  std::vector<cv::Rect> roi_boxes;
  for (const hda::RoiResult& r : flight.result.rois) roi_boxes.push_back(r.box1_px);
  const std::vector<cv::Rect> tiles =
      OverlapTiles(ctx.input.image1.cols, ctx.input.image1.rows, roi_boxes, options.opengv_overlap_tiles);
  *num_tiles = static_cast<int>(tiles.size());
  if (tiles.empty()) return {};
  const std::vector<cv::Rect> boxes2 =
      hda::PredictSearchBoxes(ctx.input, ctx.dataset->camera, flight.options, tiles);
  std::vector<std::pair<cv::Rect, cv::Rect>> boxes;
  for (size_t i = 0; i < tiles.size(); ++i) boxes.emplace_back(tiles[i], boxes2[i]);
  return MatchBoxes(boxes, options, ctx);
}

// The matches of the pair: the ROIs' (parallel to the flight's ROIs) and the
// overlap tiles'.
struct PairMatches {
  std::vector<RoiBearings> rois;
  std::vector<RoiBearings> overlap;
  int overlap_tiles = 0;  // tiles laid (some may have no search box or no match)
  bool empty() const { return rois.empty(); }
};

// Every match of the pair, ROIs first (in ROI order), then the tiles';
// *first, when given, gets ROI i's range [first[i], first[i + 1]).
void PoolPairMatches(const PairMatches& matches, std::vector<Eigen::Vector3d>* b1,
                     std::vector<Eigen::Vector3d>* b2, std::vector<size_t>* first = nullptr) {
  if (first != nullptr) first->assign(matches.rois.size() + 1, 0);
  for (size_t i = 0; i < matches.rois.size(); ++i) {
    b1->insert(b1->end(), matches.rois[i].bearings1.begin(), matches.rois[i].bearings1.end());
    b2->insert(b2->end(), matches.rois[i].bearings2.begin(), matches.rois[i].bearings2.end());
    if (first != nullptr) (*first)[i + 1] = b1->size();
  }
  for (const RoiBearings& tile : matches.overlap) {
    b1->insert(b1->end(), tile.bearings1.begin(), tile.bearings1.end());
    b2->insert(b2->end(), tile.bearings2.begin(), tile.bearings2.end());
  }
}

// Whether a solver's pose can be trusted in a configuration. The free solvers
// (rotation and translation from the matches) need relief a plane-induced
// homography does not explain; the 2-point solver holds the nav rotation, and
// a plane is no degeneracy for its translation: only low parallax and too few
// matches are.
bool SolverTrustsConfiguration(OpenGvSolver solver, ConfigurationType type) {
  if (type == ConfigurationType::kWellConditioned) return true;
  return solver == OpenGvSolver::kTwoPointKnownRotation && type == ConfigurationType::kPlanar;
}

// OpenGV on the whole pair: one relative pose from every ROI's matches and
// the overlap tiles' pooled, its configuration judged for the pair; each ROI
// is then triangulated with that pose (scaled to the nav baseline) from its
// own matches among the pose's inliers.
std::vector<MethodRoi> OpenGvRois(OpenGvSolver solver, const PairMatches& pair_matches,
                                  const CompareOptions& options, const Context& ctx,
                                  MethodSummary* summary) {
  const std::vector<RoiBearings>& matches = pair_matches.rois;
  std::vector<MethodRoi> rois(matches.size());
  const Rigid3d* truth = ctx.has_true_pose ? &ctx.true_cam2_from_cam1 : nullptr;
  std::vector<Eigen::Vector3d> b1, b2;
  std::vector<size_t> first;  // ROI i's matches: [first[i], first[i + 1]); the tiles' after
  PoolPairMatches(pair_matches, &b1, &b2, &first);
  const RelativePoseResult pair =
      SolveRelativePose(b1, b2, solver, ctx.input.cam2_from_cam1, ctx.focal_px, options.opengv, truth);
  summary->wall_s += pair.wall_s;
  if (pair.ok && pair.has_truth_errors) {
    summary->has_pose_error = true;
    summary->rotation_error_deg = pair.rotation_error_deg;
    summary->translation_direction_error_deg = pair.translation_direction_error_deg;
  }
  const ConfigurationReport& configuration = pair.configuration;
  const bool trusted = SolverTrustsConfiguration(solver, configuration.type);
  summary->note = std::string("pair: ") + ToString(configuration.type) + " (" + configuration.reason + ")" +
                  "; matches: " + std::to_string(first.back()) + " from the ROIs, " +
                  std::to_string(b1.size() - first.back()) + " from " +
                  std::to_string(pair_matches.overlap_tiles) + " overlap tiles" +
                  (pair.ok ? "; " + std::to_string(pair.num_inliers) + " of " + std::to_string(b1.size()) +
                                 " inliers"
                           : "; " + pair.message);
  // The pair's triangulated inliers, by ROI.
  std::vector<std::vector<Eigen::Vector3d>> points(matches.size());
  if (trusted && pair.ok) {
    for (const TriangulatedMatch& m : pair.points) {
      const size_t index = static_cast<size_t>(m.match_index);
      if (index >= first.back()) continue;  // an overlap tile's: the pose only
      const size_t roi = static_cast<size_t>(std::upper_bound(first.begin(), first.end(), index) - first.begin()) - 1;
      points[roi].push_back(ctx.local_from_cam1 * m.point_in_cam1_m);
    }
  }
  const Eigen::Vector3d centre1 = ctx.local_from_cam1.translation;
  const Eigen::Vector3d centre2 =
      pair.ok ? (ctx.local_from_cam1 * pair.cam2_from_cam1.Inverse()).translation : Eigen::Vector3d::Zero();
  for (size_t i = 0; i < matches.size(); ++i) {
    MethodRoi& roi = rois[i];
    roi.configuration = ToString(configuration.type);
    if (!matches[i].has_box) {
      roi.status = MethodRoiStatus::kNoSearchBox;
      roi.reason = "the ROI was not predicted in image 2";
      continue;
    }
    if (!trusted) {
      // No confident slope from a pose the pair's configuration cannot give.
      roi.status = StatusOfConfiguration(configuration.type);
      roi.reason = "pair " + std::string(ToString(configuration.type)) + ": " + configuration.reason;
      roi.num_points = static_cast<int>(matches[i].bearings1.size());
      continue;
    }
    if (!pair.ok) {
      roi.status = MethodRoiStatus::kPoseFailed;
      roi.reason = pair.message;
      continue;
    }
    FillFromPoints(points[i], centre1, centre2, *ctx.dataset, options.min_points, &roi);
    roi.reason += " (of " + std::to_string(matches[i].bearings1.size()) + " matches; the pair's pose)";
  }
  return rois;
}

// The unit vector against gravity, in camera 1 (navigation).
Eigen::Vector3d UpInCam1(const Context& ctx) {
  return (ctx.local_from_cam1.Inverse().rotation * (-ctx.dataset->gravity_in_local_mps2)).normalized();
}

// Level ground through the laser range finder's point: p . X = 1 in camera 1.
Eigen::Vector3d LevelGroundInCam1(const Context& ctx) {
  const Eigen::Vector3d up_in_cam1 = UpInCam1(ctx);
  const Eigen::Vector3d lrf_point =
      ctx.input.lrf_origin_in_cam1_m + ctx.input.lrf_range_m * ctx.input.lrf_beam_in_cam1.normalized();
  return up_in_cam1 / up_in_cam1.dot(lrf_point);
}

// Appends to a method's note how many ROIs it left unfitted for low
// parallax, and why (nothing when none).
void NoteLowParallax(const std::vector<MethodRoi>& rois, const std::string& why, MethodSummary* summary) {
  const auto low_parallax = std::count_if(rois.begin(), rois.end(), [](const MethodRoi& roi) {
    return roi.status == MethodRoiStatus::kLowParallax;
  });
  if (low_parallax > 0) {
    summary->note += "; " + std::to_string(low_parallax) + " ROIs not fitted: low parallax (" + why + ")";
  }
}

// dense-nav: the pair rectified with the nav pose and matched by SGBM
// (reference/direct/dense_stereo.h); each ROI's plane fitted to the points
// its image-1 box sees, as every point-based method's. An ROI without enough
// points is "outside overlap" when under half of its pixels can be matched
// at all (outside the rectified field or image 2), "no texture" otherwise;
// one with enough points is "low parallax" when the matcher's disparity step
// leaves its slope more uncertain than max_slope_sigma_deg.
std::vector<MethodRoi> DenseNavRois(const FlightRun& flight, const CompareOptions& options, const Context& ctx,
                                    MethodSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  const DenseStereoResult dense = RunDenseStereo(ctx.input.image1, ctx.input.image2, ctx.dataset->camera,
                                                 ctx.input.cam2_from_cam1, LevelGroundInCam1(ctx),
                                                 options.dense_stereo);
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
    recon.points[k].point_in_local_m = ctx.local_from_cam1 * dense.points_in_cam1[k];
    recon.points[k].pixel1 = dense.pixels1[k];
  }
  rois = RoisOfReconstruction(recon, flight.result, *ctx.dataset, ctx.local_from_cam1, ctx.local_from_cam2,
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
    if (roi.status == MethodRoiStatus::kOk && share < options.dense_stereo.min_roi_share) {
      roi.status = MethodRoiStatus::kTooFewPoints;
      roi.has_fit = false;
    }
    // Too little parallax for the matcher's step to give a slope: no plane
    // stood by, however many points (on a pair that did not move but whose
    // nav pose did, they are noise triangulated with the nav baseline).
    if (roi.status == MethodRoiStatus::kOk) {
      const double sigma_deg = DenseSlopeSigmaDeg(dense, ctx.dataset->camera, box, roi.num_points, in_cam1);
      if (!(sigma_deg <= options.dense_stereo.max_slope_sigma_deg)) {
        roi.status = MethodRoiStatus::kLowParallax;
        roi.has_fit = false;
        roi.reason = std::to_string(roi.num_points) + " points, but the matcher's 1/" +
                     util::FixedText(kDisparityStepsPerPx, 0) + " px disparity step alone " +
                     "leaves their slope uncertain by " +
                     (std::isfinite(sigma_deg) ? util::FixedText(sigma_deg, 1) + " deg" : "any angle") +
                     " under the nav pose (at most " +
                     util::FixedText(options.dense_stereo.max_slope_sigma_deg, 1) + " deg)";
      }
    }
    if (roi.status != MethodRoiStatus::kTooFewPoints) continue;
    roi.reason = std::to_string(pixels.size()) + " of the ROI's " + std::to_string(box.area()) +
                 " pixels have a point (" +
                 std::to_string(static_cast<int>(std::lround(100.0 * options.dense_stereo.min_roi_share))) +
                 " % needed)";
    const double seen = DenseOverlapFraction(dense, ctx.dataset->camera, ctx.input.cam2_from_cam1, box,
                                             options.dense_stereo.block_size_px);
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
                            util::FixedText(options.dense_stereo.max_slope_sigma_deg, 1) + " deg",
                  summary);
  summary->wall_s = SecondsSince(start);
  return rois;
}

// plane-nav: each ROI's plane by the direct photometric fit under the nav
// pose (reference/direct/plane_direct.h), started from level ground at the
// LRF's point (never from the flight method's fit, so that the reference owes
// nothing to it), over the ROI's box grown by half the flight method's
// warp-refinement window.
std::vector<MethodRoi> PlaneNavRois(const FlightRun& flight, const CompareOptions& options, const Context& ctx,
                                    MethodSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  std::vector<MethodRoi> rois(flight.result.rois.size());
  const DirectPlaneImages images = PrepareDirectPlaneImages(ctx.input.image1, ctx.input.image2);
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
                           cv::Rect(0, 0, ctx.dataset->camera.WidthPx(), ctx.dataset->camera.HeightPx());
    const DirectPlaneResult fit = FitPlaneDirect(images, ctx.dataset->camera, grown, ctx.input.cam2_from_cam1,
                                                 level, up_in_cam1,
                                                 options.direct_plane);
    roi.reason = fit.reason;
    roi.num_points = fit.pixels;
    switch (fit.status) {
      case DirectPlaneStatus::kOk: {
        roi.status = MethodRoiStatus::kOk;
        roi.has_fit = true;
        roi.slope_deg = fit.slope_deg;
        roi.normal_in_local = ctx.local_from_cam1.rotation * fit.up_normal_in_cam1;
        roi.has_sigma = true;
        roi.slope_sigma_deg = fit.slope_sigma_deg;
        // A plane has no roughness of its own.
        roi.roughness_rms_m = std::numeric_limits<double>::quiet_NaN();
        roi.roughness_max_m = std::numeric_limits<double>::quiet_NaN();
        for (const Eigen::Vector3d& p : fit.points_in_cam1) roi.points_in_local_m.push_back(ctx.local_from_cam1 * p);
        if (ctx.dataset->truth.dem.has_value()) {
          roi.accuracy = ComputePointAccuracy(roi.points_in_local_m, *ctx.dataset->truth.dem);
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
                  std::to_string(options.direct_plane.max_iterations) + " iterations";
  NoteLowParallax(rois, "the nav pose's parallax leaves their plane unobservable", summary);
  return rois;
}

// A method that cannot read the pair as it needs (an InputError of its own):
// it fails, with every ROI saying why, and the other methods still run.
std::vector<MethodRoi> FailMethod(const std::string& failure, size_t num_rois, MethodSummary* summary) {
  summary->ok = false;
  summary->failure = failure;
  std::vector<MethodRoi> rois(num_rois);
  for (MethodRoi& roi : rois) roi.reason = failure;
  return rois;
}

// A free reconstruction's ROIs when the pair's configuration cannot give a
// confident relative pose: the configuration as status, no slope.
void WithholdIllConditioned(const ConfigurationReport& configuration, std::vector<MethodRoi>* rois) {
  for (MethodRoi& roi : *rois) {
    roi.configuration = ToString(configuration.type);
    if (configuration.type == ConfigurationType::kWellConditioned || roi.status == MethodRoiStatus::kFailed) {
      continue;
    }
    if (roi.has_fit) {
      roi.reason = "pair " + std::string(ToString(configuration.type)) + "; the fit would give " +
                   std::to_string(roi.slope_deg) + " deg from " + std::to_string(roi.num_points) +
                   " points";
    }
    roi.status = StatusOfConfiguration(configuration.type);
    roi.has_fit = false;
  }
}

void PoseErrorAgainstTruth(const PairReconstruction& recon, const Context& ctx,
                           MethodSummary* summary) {
  if (!recon.ok || !recon.has_pose || !ctx.has_true_pose) return;
  summary->has_pose_error = true;
  summary->rotation_error_deg =
      RotationAngleDeg(recon.cam2_from_cam1.rotation * ctx.true_cam2_from_cam1.rotation.inverse());
  // Camera 2's centre in camera 1: the direction of the baseline.
  const Eigen::Vector3d estimated = recon.cam2_from_cam1.Inverse().translation;
  const Eigen::Vector3d truth = ctx.true_cam2_from_cam1.Inverse().translation;
  summary->translation_direction_error_deg = DirectionAngleDeg(estimated, truth);
}

// ---------------------------------------------------------------------------
// Summaries

void Summarise(const CompareRun& run, size_t m, size_t colmap_nav_index, double flight_seconds,
               MethodSummary* s) {
  const std::vector<MethodRoi>& rois = run.rois[m];
  std::vector<double> vs_truth, tilt_vs_truth, rough_vs_truth, vs_colmap;
  double signed_sum = 0.0;
  PointAccuracy accuracy;
  int accuracy_points = 0;
  double median_sum = 0.0, within01 = 0.0, within03 = 0.0, within1 = 0.0;
  for (size_t i = 0; i < rois.size(); ++i) {
    const MethodRoi& roi = rois[i];
    if (roi.HasSlope()) ++s->rois_with_fit;
    if (roi.accuracy.available) {
      // Point-weighted means of the per-ROI shares; the median is the
      // point-weighted mean of the ROI medians (documented as such).
      const double n = roi.accuracy.num_points;
      accuracy_points += roi.accuracy.num_points;
      median_sum += n * roi.accuracy.median_m;
      within01 += n * roi.accuracy.within_0_1_m;
      within03 += n * roi.accuracy.within_0_3_m;
      within1 += n * roi.accuracy.within_1_m;
    }
    if (!roi.HasSlope() || roi.num_points < kMinPointsForSlopeStats) continue;
    const RoiTruthValue* truth =
        i < run.flight.truths.size() && run.flight.truths[i].available ? &run.flight.truths[i] : nullptr;
    if (truth != nullptr) {
      vs_truth.push_back(std::abs(roi.slope_deg - truth->slope_deg));
      tilt_vs_truth.push_back(TiltErrorDeg(roi.normal_in_local, truth->normal_in_local));
      signed_sum += roi.slope_deg - truth->slope_deg;
      if (std::isfinite(roi.roughness_rms_m)) {
        rough_vs_truth.push_back(std::abs(roi.roughness_rms_m - truth->roughness_rms_m));
      }
    }
    if (colmap_nav_index < run.rois.size() && colmap_nav_index != m) {
      const MethodRoi& ref = run.rois[colmap_nav_index][i];
      if (ref.HasSlope() && ref.num_points >= kMinPointsForSlopeStats) {
        vs_colmap.push_back(std::abs(roi.slope_deg - ref.slope_deg));
      }
    }
  }
  if (accuracy_points > 0) {
    accuracy.available = true;
    accuracy.num_points = accuracy_points;
    accuracy.median_m = median_sum / accuracy_points;
    accuracy.within_0_1_m = within01 / accuracy_points;
    accuracy.within_0_3_m = within03 / accuracy_points;
    accuracy.within_1_m = within1 / accuracy_points;
  }
  s->accuracy = accuracy;
  s->slope_vs_truth_deg = ComputeErrorStats(vs_truth);
  s->tilt_vs_truth_deg = ComputeErrorStats(tilt_vs_truth);
  s->slope_bias_deg = vs_truth.empty() ? 0.0 : signed_sum / static_cast<double>(vs_truth.size());
  s->roughness_vs_truth_m = ComputeErrorStats(rough_vs_truth);
  s->slope_vs_colmap_nav_deg = ComputeErrorStats(vs_colmap);
  s->time_ratio_to_flight = flight_seconds > 0.0 ? s->wall_s / flight_seconds : 0.0;
}

}  // namespace

// ---------------------------------------------------------------------------

bool MethodRoi::HasSlope() const {
  return has_fit && (status != MethodRoiStatus::kFlight || hda::HasSlope(flight_status));
}

std::vector<std::string> AllMethodNames() {
  std::vector<std::string> names = {kMethodFlight, kMethodFlightRefined, kMethodColmapNav,
                                    kMethodColmapFree};
  for (const OpenGvSolver solver : AllOpenGvSolvers()) {
    names.push_back(std::string(kOpenGvMethodPrefix) + ToString(solver));
  }
  names.push_back(kMethodDenseNav);
  names.push_back(kMethodPlaneNav);
  return names;
}

std::vector<std::string> ParseMethodList(const std::string& comma_separated) {
  const std::vector<std::string> all = AllMethodNames();
  if (comma_separated == "all") return all;
  std::vector<std::string> methods;
  std::set<std::string> seen;
  size_t start = 0;
  while (start <= comma_separated.size()) {
    const size_t end = std::min(comma_separated.find(',', start), comma_separated.size());
    const std::string name = comma_separated.substr(start, end - start);
    if (std::find(all.begin(), all.end(), name) == all.end()) {
      throw InputError("unknown method '" + name + "'; the methods are: " + JoinNames(all) +
                       " (or all)");
    }
    if (!seen.insert(name).second) throw InputError("method '" + name + "' is listed twice");
    methods.push_back(name);
    start = end + 1;
  }
  if (seen.count(kMethodFlight) == 0) methods.insert(methods.begin(), kMethodFlight);
  // Table order: as AllMethodNames.
  std::vector<std::string> ordered;
  for (const std::string& name : all) {
    if (std::find(methods.begin(), methods.end(), name) != methods.end()) ordered.push_back(name);
  }
  return ordered;
}

std::vector<cv::Rect> OverlapTiles(int image_width_px, int image_height_px,
                                   const std::vector<cv::Rect>& roi_boxes_px, int max_tiles) {
  int side = 0;
  for (const cv::Rect& box : roi_boxes_px) side = std::max({side, box.width, box.height});
  if (max_tiles <= 0 || side <= 0 || image_width_px < side || image_height_px < side) return {};
  const int columns = image_width_px / side;
  const int rows = image_height_px / side;
  // Every k-th tile of the grid in each direction: ceil(columns / k) x ceil(rows / k) of them.
  int k = 1;
  while (static_cast<long long>((columns + k - 1) / k) * ((rows + k - 1) / k) > max_tiles) ++k;
  std::vector<cv::Rect> tiles;
  for (int r = 0; r < rows; r += k) {
    for (int c = 0; c < columns; c += k) {
      const cv::Rect tile(c * side, r * side, side, side);
      const bool meets_roi = std::any_of(roi_boxes_px.begin(), roi_boxes_px.end(),
                                         [&](const cv::Rect& box) { return (tile & box).area() > 0; });
      if (!meets_roi) tiles.push_back(tile);
    }
  }
  return tiles;
}

CeresRefineOptions DefaultRefineOptions() {
  const hda::HdaOptions flight;
  CeresRefineOptions refine;
  refine.nav_position_sigma_m = flight.prediction.nav_position_sigma_m;
  refine.nav_attitude_sigma_deg = flight.prediction.nav_attitude_sigma_deg;
  refine.pixel_sigma_px = flight.pixel_sigma_floor_px;
  return refine;
}

std::vector<std::string> CompareOptions::Validate() const {
  std::vector<std::string> errors;
  const std::vector<std::string> all = AllMethodNames();
  for (const std::string& m : methods) {
    if (std::find(all.begin(), all.end(), m) == all.end()) {
      errors.push_back("methods: unknown method '" + m + "'");
    }
  }
  if (methods.empty() || methods.front() != kMethodFlight) {
    errors.push_back("methods: must start with flight (it finds the ROIs)");
  }
  for (const std::string& e : hda.options.Validate()) errors.push_back("hda." + e);
  for (const std::string& e : colmap.Validate()) errors.push_back("colmap." + e);
  for (const std::string& e : opengv.Validate()) errors.push_back("opengv." + e);
  for (const std::string& e : direct_plane.Validate()) errors.push_back("direct_plane." + e);
  for (const std::string& e : dense_stereo.Validate()) errors.push_back("dense_stereo." + e);
  for (const std::string& e : refine.Validate()) errors.push_back("refine." + e);
  if (!(fit_pixel_sigma_px > 0.0 && std::isfinite(fit_pixel_sigma_px))) {
    errors.push_back("fit_pixel_sigma_px = " + std::to_string(fit_pixel_sigma_px) +
                     ": expected > 0");
  }
  if (min_points < 3) {
    errors.push_back("min_points = " + std::to_string(min_points) + ": expected >= 3");
  }
  if (opengv_overlap_tiles < 0) {
    errors.push_back("opengv_overlap_tiles = " + std::to_string(opengv_overlap_tiles) + ": expected >= 0");
  }
  return errors;
}

const char* ToString(MethodRoiStatus status) {
  switch (status) {
    case MethodRoiStatus::kOk: return "ok";
    case MethodRoiStatus::kTooFewPoints: return "too few points";
    case MethodRoiStatus::kDegenerate: return "degenerate";
    case MethodRoiStatus::kFailed: return "failed";
    case MethodRoiStatus::kNoSearchBox: return "no search box";
    case MethodRoiStatus::kPlanar: return "planar";
    case MethodRoiStatus::kLowParallax: return "low parallax";
    case MethodRoiStatus::kPoseFailed: return "pose failed";
    case MethodRoiStatus::kOutsideOverlap: return "outside overlap";
    case MethodRoiStatus::kNoTexture: return "no texture";
    case MethodRoiStatus::kDiverged: return "diverged";
    case MethodRoiStatus::kNotRectifiable: return "not rectifiable";
    case MethodRoiStatus::kFlight: return "flight";
  }
  return "unknown";
}

MethodRoiStatus StatusOfConfiguration(ConfigurationType type) {
  switch (type) {
    case ConfigurationType::kWellConditioned: return MethodRoiStatus::kOk;
    case ConfigurationType::kPlanar: return MethodRoiStatus::kPlanar;
    case ConfigurationType::kLowParallax: return MethodRoiStatus::kLowParallax;
    case ConfigurationType::kTooFewPoints: return MethodRoiStatus::kTooFewPoints;
  }
  return MethodRoiStatus::kTooFewPoints;
}

std::string MethodRoi::StatusName() const {
  return status == MethodRoiStatus::kFlight ? hda::ToString(flight_status) : ToString(status);
}

RoiFit FitRoiPoints(const std::vector<Eigen::Vector3d>& points_in_local,
                    const Eigen::Vector3d& camera1_centre_in_local,
                    const Eigen::Vector3d& camera2_centre_in_local,
                    const Eigen::Vector3d& gravity_in_local, int min_points) {
  RoiFit fit;
  fit.num_points = static_cast<int>(points_in_local.size());
  // Each point's covariance from its two rays, in a frame aligned with the
  // local frame at camera 1 (only the shapes of the covariances matter).
  const Rigid3d cam2_from_cam1(Eigen::Quaterniond::Identity(),
                               -(camera2_centre_in_local - camera1_centre_in_local));
  constexpr double kSigmaRad = 1e-3;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Matrix3d> covariances;
  for (const Eigen::Vector3d& p : points_in_local) {
    Eigen::Matrix3d covariance;
    const Eigen::Vector3d b1 = p - camera1_centre_in_local;
    const Eigen::Vector3d b2 = p - camera2_centre_in_local;
    if (!hda::TriangulationCovariance(b1, b2, cam2_from_cam1, kSigmaRad, &covariance)) continue;
    points.push_back(p);
    covariances.push_back(covariance);
  }
  const hda::PlaneFitResult plane =
      points.size() == points_in_local.size()
          ? hda::FitPlaneWithCovariance(points, covariances, gravity_in_local, min_points)
          : hda::FitPlane(points_in_local, gravity_in_local, min_points);
  switch (plane.status) {
    case hda::PlaneFitStatus::kOk:
      fit.status = MethodRoiStatus::kOk;
      fit.slope_deg = plane.slope_deg;
      fit.normal_in_local = plane.normal_in_local;
      fit.roughness_rms_m = plane.roughness_rms_m;
      fit.roughness_max_m = plane.roughness_max_m;
      break;
    case hda::PlaneFitStatus::kTooFewPoints:
      fit.status = MethodRoiStatus::kTooFewPoints;
      break;
    default:
      fit.status = MethodRoiStatus::kDegenerate;
      break;
  }
  return fit;
}

PointAccuracy ComputePointAccuracy(const std::vector<Eigen::Vector3d>& points_in_local,
                                   const datasets::TruthDem& dem) {
  PointAccuracy accuracy;
  const cv::Mat& h = dem.height_in_local_m;
  if (h.empty() || h.type() != CV_32FC1 || !(dem.spacing_m > 0.0)) return accuracy;
  std::vector<double> distances;
  for (const Eigen::Vector3d& p : points_in_local) {
    if (!p.allFinite()) continue;
    // Continuous cell coordinates: x along columns, rows southward.
    const double c = (p.x() - dem.origin_in_local_m.x()) / dem.spacing_m;
    const double r = (dem.origin_in_local_m.y() - p.y()) / dem.spacing_m;
    const int c0 = static_cast<int>(std::floor(c));
    const int r0 = static_cast<int>(std::floor(r));
    if (c0 < 0 || r0 < 0 || c0 + 1 >= h.cols || r0 + 1 >= h.rows) continue;
    const double fc = c - c0, fr = r - r0;
    const double h00 = h.at<float>(r0, c0), h01 = h.at<float>(r0, c0 + 1);
    const double h10 = h.at<float>(r0 + 1, c0), h11 = h.at<float>(r0 + 1, c0 + 1);
    const double height = (1 - fr) * ((1 - fc) * h00 + fc * h01) + fr * ((1 - fc) * h10 + fc * h11);
    // Gradient of the bilinear patch (dh/dx, dh/dy; y grows northward = -rows).
    const double dhdx = ((1 - fr) * (h01 - h00) + fr * (h11 - h10)) / dem.spacing_m;
    const double dhdy = -((1 - fc) * (h10 - h00) + fc * (h11 - h01)) / dem.spacing_m;
    distances.push_back(std::abs(p.z() - height) / std::sqrt(1.0 + dhdx * dhdx + dhdy * dhdy));
  }
  if (distances.empty()) return accuracy;
  accuracy.available = true;
  accuracy.num_points = static_cast<int>(distances.size());
  const auto share = [&](double limit) {
    return static_cast<double>(std::count_if(distances.begin(), distances.end(),
                                             [&](double d) { return d <= limit; })) /
           static_cast<double>(distances.size());
  };
  accuracy.within_0_1_m = share(0.1);
  accuracy.within_0_3_m = share(0.3);
  accuracy.within_1_m = share(1.0);
  std::sort(distances.begin(), distances.end());
  accuracy.median_m = util::Quantile(distances, 0.5);
  return accuracy;
}

ErrorStats ComputeErrorStats(std::vector<double> values) {
  ErrorStats stats;
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
               values.end());
  if (values.empty()) return stats;
  std::sort(values.begin(), values.end());
  stats.count = static_cast<int>(values.size());
  stats.median = util::Quantile(values, 0.5);
  stats.p90 = util::Quantile(values, 0.9);
  stats.max = values.back();
  return stats;
}

std::vector<MethodRoi> RoisOfReconstruction(const PairReconstruction& recon,
                                            const hda::HdaResult& flight,
                                            const datasets::Dataset& dataset,
                                            const Rigid3d& local_from_cam1,
                                            const Rigid3d& nav_local_from_cam2, int min_points) {
  std::vector<MethodRoi> rois(flight.rois.size());
  if (!recon.ok) {
    for (MethodRoi& roi : rois) {
      roi.status = MethodRoiStatus::kFailed;
      roi.reason = recon.failure;
    }
    return rois;
  }
  const Eigen::Vector3d centre1 = local_from_cam1.translation;
  const Eigen::Vector3d centre2 =
      recon.has_pose ? (local_from_cam1 * recon.cam2_from_cam1.Inverse()).translation
                     : nav_local_from_cam2.translation;
  for (size_t i = 0; i < flight.rois.size(); ++i) {
    std::vector<Eigen::Vector3d> points;
    for (const ReconstructedPoint& p : recon.points) {
      if (InBox(p.pixel1, flight.rois[i].box1_px)) points.push_back(p.point_in_local_m);
    }
    FillFromPoints(points, centre1, centre2, dataset, min_points, &rois[i]);
  }
  return rois;
}

namespace {

// The geometry every method shares: the flight inputs, the nav poses, the
// true relative pose where there is truth, the focal length in pixels.
Context MakeContext(const datasets::Dataset& dataset, int frame1, int frame2) {
  Context ctx;
  ctx.dataset = &dataset;
  ctx.input = MakeHdaInput(dataset, frame1, frame2);
  ctx.local_from_cam1 = ctx.input.local_from_cam1;
  ctx.local_from_cam2 = ctx.local_from_cam1 * ctx.input.cam2_from_cam1.Inverse();
  try {
    ctx.true_cam2_from_cam1 = dataset.TrueCam2FromCam1(frame1, frame2);
    ctx.has_true_pose = !dataset.truth.navigation.empty();
  } catch (const std::exception&) {
    ctx.has_true_pose = false;
  }
  ctx.focal_px = hda::PixelsPerRadian(
      dataset.camera,
      Eigen::Vector2d(0.5 * (dataset.camera.WidthPx() - 1), 0.5 * (dataset.camera.HeightPx() - 1)));
  if (!(ctx.focal_px > 0.0)) throw InputError("the camera cannot project around its image centre");
  return ctx;
}

// The smallest side of the flight method's ROI boxes in image 1, pixels; 0
// without ROIs.
double SmallestRoiSidePx(const FlightRun& flight) {
  int side = 0;
  for (const auto& roi : flight.result.rois) {
    const int s = std::min(roi.box1_px.width, roi.box1_px.height);
    if (s > 0 && (side == 0 || s < side)) side = s;
  }
  return side;
}

// colmap-nav and colmap-free (whichever are wanted) in one COLMAP run: the
// pair first, then, with use_all_frames, every other frame of the window.
ColmapResults RunColmapMethods(const datasets::Dataset& dataset, int frame1, int frame2,
                               const CompareOptions& options, bool nav, bool free,
                               double smallest_roi_px, const std::string& workspace) {
  if (dataset.dir.empty()) {
    throw InputError("colmap needs the dataset's image files: the dataset has no folder");
  }
  std::vector<int> frames = {frame1, frame2};
  if (options.colmap.use_all_frames) {
    for (int f = 0; f < static_cast<int>(dataset.frames.size()); ++f) {
      if (f != frame1 && f != frame2) frames.push_back(f);
    }
  }
  ColmapInput input;
  for (const int f : frames) {
    input.image_paths.push_back(dataset.dir + "/" + dataset.frames[static_cast<size_t>(f)].image_path);
    input.local_from_cam.push_back(dataset.CamFromLocal(f).Inverse());
  }
  input.camera = dataset.camera;
  input.workspace = workspace;
  input.smallest_roi_px = smallest_roi_px;
  ColmapOptions colmap = options.colmap;
  colmap.run_nav = nav;
  colmap.run_free = free;
  return RunColmap(input, colmap);
}

// The configuration of the whole pair, from all its matches: a free
// reconstruction of a near-planar pair (colmap-free) has an ill-conditioned
// relative pose, and its ROIs say so instead of giving a confident slope.
ConfigurationReport PairConfiguration(const PairMatches& pair_matches, const Context& ctx,
                                      const CompareOptions& options) {
  if (pair_matches.empty()) return ConfigurationReport();
  std::vector<Eigen::Vector3d> b1, b2;
  PoolPairMatches(pair_matches, &b1, &b2);
  return ClassifyConfiguration(b1, b2, ctx.input.cam2_from_cam1, ctx.focal_px, options.opengv);
}

// The methods that reconstruct the whole pair at once (flight-refined,
// colmap-nav, colmap-free), each with its name.
struct WholePairMethods {
  std::vector<std::pair<std::string, PairReconstruction>> reconstructions;
  std::string refine_note;  // flight-refined's solver note
  std::string colmap_note;  // COLMAP's extraction (ColmapResults::extraction_note)
};

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

// A whole-pair method's ROIs and summary from its reconstruction.
void FillWholePairMethod(const std::string& method, const PairReconstruction& recon,
                         const WholePairMethods& whole, const CompareRun& run,
                         const PairMatches& pair_matches,
                         const ConfigurationReport& pair_configuration,
                         const CompareOptions& options, const Context& ctx,
                         std::vector<MethodRoi>* rois, MethodSummary* summary) {
  *rois = RoisOfReconstruction(recon, run.flight.result, *ctx.dataset, ctx.local_from_cam1,
                               ctx.local_from_cam2, options.min_points);
  summary->ok = recon.ok;
  summary->failure = recon.failure;
  summary->wall_s = recon.wall_s;
  if (method == kMethodFlightRefined) {
    summary->note = whole.refine_note;
    if (recon.ok) PassOnFlightReasons(run.flight.result, rois);
    NoteLowParallax(*rois, "the flight method found their depth unobservable under the nav pose", summary);
  }
  if (!recon.log_dir.empty()) summary->note = "logs: " + recon.log_dir;
  if ((method == kMethodColmapNav || method == kMethodColmapFree) && !whole.colmap_note.empty()) {
    summary->note += std::string(summary->note.empty() ? "" : "; ") + whole.colmap_note;
  }
  if (method == kMethodColmapFree && !pair_matches.empty()) {
    summary->note += std::string(summary->note.empty() ? "" : "; ") + "pair configuration: " +
                     pair_configuration.reason;
    // With every frame of the window the views are no longer two:
    // a plane's two-fold ambiguity is resolved, and the ROIs keep their fits.
    if (!options.colmap.use_all_frames) WithholdIllConditioned(pair_configuration, rois);
  }
  PoseErrorAgainstTruth(recon, ctx, summary);
}

// A per-ROI method one of `methods` computes in this process (flight,
// plane-nav, dense-nav, OpenGV); nothing for the whole-pair methods, filled
// from their reconstructions. A method that cannot run on this dataset (a
// bad input, a lens model it cannot unproject) fails its column only.
void ComputeMethodHere(const std::string& method, const FlightRun& flight,
                       const PairMatches& pair_matches, const CompareOptions& options,
                       const Context& ctx, const std::function<void(const std::string&)>& say,
                       std::vector<MethodRoi>* rois, MethodSummary* summary) {
  const auto guarded = [&](const std::function<std::vector<MethodRoi>()>& compute) {
    try {
      *rois = compute();
    } catch (const InputError& e) {
      *rois = FailMethod(e.what(), flight.result.rois.size(), summary);
    } catch (const UnsupportedError& e) {  // a lens model the method cannot unproject
      *rois = FailMethod(e.what(), flight.result.rois.size(), summary);
    }
  };
  if (method == kMethodFlight) {
    *rois = FlightRois(flight, ctx);
    summary->wall_s = flight.result.times.total_s;
  } else if (method == kMethodPlaneNav) {
    say("plane-nav: the direct plane of every ROI");
    guarded([&] { return PlaneNavRois(flight, options, ctx, summary); });
  } else if (method == kMethodDenseNav) {
    say("dense-nav: the rectified pair's semi-global matching");
    guarded([&] { return DenseNavRois(flight, options, ctx, summary); });
  } else if (IsOpenGvMethod(method)) {
    say(method);
    const OpenGvSolver solver = ParseOpenGvSolver(method.substr(std::string(kOpenGvMethodPrefix).size()));
    *rois = OpenGvRois(solver, pair_matches, options, ctx, summary);
  }
}

}  // namespace

CompareRun RunCompare(const datasets::Dataset& dataset, int frame1, int frame2,
                      const CompareOptions& options, const std::string& colmap_workspace,
                      const CompareProgress& progress) {
  ThrowIfInvalid("invalid comparison options: ", options.Validate());
  const auto say = [&](const std::string& message) {
    if (progress) progress(message);
  };
  CompareRun run;
  run.methods = options.methods;
  const Context ctx = MakeContext(dataset, frame1, frame2);

  say("flight method on frames " + std::to_string(frame1) + "," + std::to_string(frame2));
  run.flight = RunFlight(dataset, frame1, frame2, options.hda);
  run.any_truth = run.flight.AnyTruth();
  const double flight_seconds = run.flight.result.times.total_s;

  const auto wants = [&](const std::string& m) {
    return std::find(run.methods.begin(), run.methods.end(), m) != run.methods.end();
  };
  WholePairMethods whole;
  if (wants(kMethodFlightRefined)) {
    say("flight-refined: two-view bundle adjustment of the flight points");
    whole.reconstructions.emplace_back(kMethodFlightRefined,
                                       FlightRefined(run.flight, options, ctx, &whole.refine_note));
  }
  // COLMAP (an external program, one thread, and the exact matcher) runs
  // alongside the methods computed here; its results are taken when those
  // are done. Nothing is shared but read-only inputs, so no result depends on
  // it; the in-process methods' times are measured under its load.
  const bool any_colmap = wants(kMethodColmapNav) || wants(kMethodColmapFree);
  std::future<ColmapResults> colmap_results;
  if (any_colmap) {
    say("colmap: SIFT, matching, reconstruction in " + colmap_workspace + " (alongside the other methods)");
    colmap_results = std::async(std::launch::async, [&] {
      return RunColmapMethods(dataset, frame1, frame2, options, wants(kMethodColmapNav), wants(kMethodColmapFree),
                              SmallestRoiSidePx(run.flight), colmap_workspace);
    });
    run.colmap_workspace = colmap_workspace;
  }
  PairMatches pair_matches;
  const bool any_opengv = std::any_of(run.methods.begin(), run.methods.end(), IsOpenGvMethod);
  if (any_opengv || wants(kMethodColmapFree)) {
    say("matching the ROIs and the overlap without navigation (OpenGV, the pair's configuration)");
    pair_matches.rois = MatchAllRois(run.flight, options, ctx);
    pair_matches.overlap = MatchOverlapTiles(run.flight, options, ctx, &pair_matches.overlap_tiles);
  }
  const ConfigurationReport pair_configuration = PairConfiguration(pair_matches, ctx, options);

  run.rois.resize(run.methods.size());
  run.summaries.resize(run.methods.size());
  for (size_t m = 0; m < run.methods.size(); ++m) {
    run.summaries[m].method = run.methods[m];
    ComputeMethodHere(run.methods[m], run.flight, pair_matches, options, ctx, say, &run.rois[m],
                      &run.summaries[m]);
  }
  // The whole-pair methods, COLMAP's once it is done (a future of std::async
  // waits for its task when destroyed, so an exception above never leaves
  // COLMAP running on freed inputs).
  if (any_colmap) {
    say("colmap: waiting for it to finish");
    ColmapResults results = colmap_results.get();
    whole.colmap_note = results.extraction_note;
    if (wants(kMethodColmapNav)) whole.reconstructions.emplace_back(kMethodColmapNav, std::move(results.nav));
    if (wants(kMethodColmapFree)) whole.reconstructions.emplace_back(kMethodColmapFree, std::move(results.free));
  }
  for (const auto& [method, recon] : whole.reconstructions) {
    const size_t m = static_cast<size_t>(std::find(run.methods.begin(), run.methods.end(), method) -
                                         run.methods.begin());
    FillWholePairMethod(method, recon, whole, run, pair_matches, pair_configuration, options, ctx, &run.rois[m],
                        &run.summaries[m]);
  }
  const auto colmap_nav = std::find(run.methods.begin(), run.methods.end(), kMethodColmapNav);
  const size_t colmap_nav_index = static_cast<size_t>(colmap_nav - run.methods.begin());
  for (size_t m = 0; m < run.methods.size(); ++m) {
    Summarise(run, m, colmap_nav_index, flight_seconds, &run.summaries[m]);
  }
  return run;
}

}  // namespace hdabench::reference
