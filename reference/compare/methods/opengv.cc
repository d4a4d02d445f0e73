// opengv-<solver>: every ROI's ORB matches and those of tiles over the rest
// of the overlap pooled (the flight matcher's RANSAC inliers, before any use
// of navigation), one relative pose for the pair by OpenGV with that solver,
// scaled by the nav baseline, each ROI triangulated with it from its own
// matches among the pose's inliers (reference/opengv/opengv_solvers.h).
#include <algorithm>

#include "reference/compare/methods/method_support.h"

namespace hdabench::reference {

namespace {

using methods::FillFromPoints;
using methods::PoolPairMatches;

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
                                  const CompareOptions& options, const PairContext& ctx,
                                  MethodSummary* summary) {
  const std::vector<RoiBearings>& matches = pair_matches.rois;
  std::vector<MethodRoi> rois(matches.size());
  const Rigid3d* truth = ctx.has_true_pose() ? &ctx.true_cam2_from_cam1() : nullptr;
  std::vector<Eigen::Vector3d> b1, b2;
  std::vector<size_t> first;  // ROI i's matches: [first[i], first[i + 1]); the tiles' after
  PoolPairMatches(pair_matches, &b1, &b2, &first);
  const RelativePoseResult pair =
      SolveRelativePose(b1, b2, solver, ctx.input().cam2_from_cam1, ctx.focal_px(), options.opengv, truth);
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
  std::vector<std::vector<Eigen::Vector2d>> pixels(matches.size());
  if (trusted && pair.ok) {
    for (const TriangulatedMatch& m : pair.points) {
      const size_t index = static_cast<size_t>(m.match_index);
      if (index >= first.back()) continue;  // an overlap tile's: the pose only
      const size_t roi = static_cast<size_t>(std::upper_bound(first.begin(), first.end(), index) - first.begin()) - 1;
      points[roi].push_back(ctx.local_from_cam1() * m.point_in_cam1_m);
      const cv::Point2d& pixel1 = matches[roi].pixels1[index - first[roi]];
      pixels[roi].emplace_back(pixel1.x, pixel1.y);
    }
  }
  const Eigen::Vector3d centre1 = ctx.local_from_cam1().translation;
  const Eigen::Vector3d centre2 =
      pair.ok ? (ctx.local_from_cam1() * pair.cam2_from_cam1.Inverse()).translation : Eigen::Vector3d::Zero();
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
    FillFromPoints(points[i], pixels[i], centre1, centre2, ctx.dataset(), options.min_points, &roi);
    roi.reason += " (of " + std::to_string(matches[i].bearings1.size()) + " matches; the pair's pose)";
  }
  return rois;
}

}  // namespace

MethodEntry OpenGvMethod(OpenGvSolver solver) {
  MethodEntry m;
  m.name = std::string(kOpenGvMethodPrefix) + ToString(solver);
  m.summary = std::string("OpenGV's ") + ToString(solver) + " solver: one relative pose from the pair's ORB " +
              (solver == OpenGvSolver::kTwoPointKnownRotation ? "matches with the nav rotation held"
                                                              : "matches") +
              ", scaled by the nav baseline";
  m.needs.pair_matches = true;
  m.run = [solver](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    ctx.Say(std::string(kOpenGvMethodPrefix) + ToString(solver));
    *rois = OpenGvRois(solver, ctx.Matches(), ctx.options(), ctx, summary);
  };
  return m;
}

}  // namespace hdabench::reference
