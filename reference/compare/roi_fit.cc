// Every method's ROI plane, fitted the same way (FitRoiPoints), its points'
// accuracy against the truth DEM, and a whole-pair reconstruction split by
// ROI (compare.h).
#include <algorithm>
#include <cmath>

#include "hda/geometry.h"
#include "reference/compare/compare.h"
#include "reference/compare/methods/method_support.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

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
    std::vector<Eigen::Vector2d> pixels1;
    for (const ReconstructedPoint& p : recon.points) {
      if (!methods::InBox(p.pixel1, flight.rois[i].box1_px)) continue;
      points.push_back(p.point_in_local_m);
      pixels1.push_back(p.pixel1);
    }
    methods::FillFromPoints(points, pixels1, centre1, centre2, dataset, min_points, &rois[i]);
  }
  return rois;
}

}  // namespace hdabench::reference
