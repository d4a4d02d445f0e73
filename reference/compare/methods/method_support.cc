#include "reference/compare/methods/method_support.h"

#include <algorithm>
#include <cmath>

#include "tools/util/angles.h"

namespace hdabench::reference::methods {

namespace {

using util::kRadToDeg;

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

}  // namespace

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

bool InBox(const Eigen::Vector2d& pixel, const cv::Rect& box) {
  // A pixel belongs to the box when its nearest pixel centre does.
  return pixel.x() >= box.x - 0.5 && pixel.x() < box.x + box.width - 0.5 &&
         pixel.y() >= box.y - 0.5 && pixel.y() < box.y + box.height - 0.5;
}

// Fills a method's ROI from its points in the ROI.
void FillFromPoints(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector2d>& pixels1,
                    const Eigen::Vector3d& centre1,
                    const Eigen::Vector3d& centre2, const datasets::Dataset& dataset,
                    int min_points, MethodRoi* roi) {
  roi->num_points = static_cast<int>(points.size());
  roi->points_in_local_m = points;
  roi->support_px = pixels1;
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

// Every match of the pair, ROIs first (in ROI order), then the tiles';
// *first, when given, gets ROI i's range [first[i], first[i + 1]).
void PoolPairMatches(const PairMatches& matches, std::vector<Eigen::Vector3d>* b1,
                     std::vector<Eigen::Vector3d>* b2, std::vector<size_t>* first) {
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

// The unit vector against gravity, in camera 1 (navigation).
Eigen::Vector3d UpInCam1(const PairContext& ctx) {
  return (ctx.local_from_cam1().Inverse().rotation * (-ctx.dataset().gravity_in_local_mps2)).normalized();
}

// Level ground through the laser range finder's point: p . X = 1 in camera 1.
Eigen::Vector3d LevelGroundInCam1(const PairContext& ctx) {
  const Eigen::Vector3d up_in_cam1 = UpInCam1(ctx);
  const Eigen::Vector3d lrf_point =
      ctx.input().lrf_origin_in_cam1_m + ctx.input().lrf_range_m * ctx.input().lrf_beam_in_cam1.normalized();
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

void FillFromReconstruction(const PairReconstruction& recon, const PairContext& ctx,
                            std::vector<MethodRoi>* rois, MethodSummary* summary) {
  *rois = RoisOfReconstruction(recon, ctx.flight().result, ctx.dataset(), ctx.local_from_cam1(),
                               ctx.local_from_cam2(), ctx.options().min_points);
  summary->ok = recon.ok;
  summary->failure = recon.failure;
  summary->wall_s = recon.wall_s;
}

void PoseErrorAgainstTruth(const PairReconstruction& recon, const PairContext& ctx,
                           MethodSummary* summary) {
  if (!recon.ok || !recon.has_pose || !ctx.has_true_pose()) return;
  summary->has_pose_error = true;
  summary->rotation_error_deg =
      RotationAngleDeg(recon.cam2_from_cam1.rotation * ctx.true_cam2_from_cam1().rotation.inverse());
  // Camera 2's centre in camera 1: the direction of the baseline.
  const Eigen::Vector3d estimated = recon.cam2_from_cam1.Inverse().translation;
  const Eigen::Vector3d truth = ctx.true_cam2_from_cam1().Inverse().translation;
  summary->translation_direction_error_deg = DirectionAngleDeg(estimated, truth);
}

}  // namespace hdabench::reference::methods
