#include "hda/pipeline.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <random>
#include <sstream>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "tools/util/error.h"
#include "tools/util/angles.h"
#include "tools/util/text.h"

namespace hdabench::hda {

namespace {

using util::kDegToRad;
using util::kInfinity;

// Step of the central differences of GroundMotionJacobian, pixels.
constexpr double kMotionStepPx = 4.0;

// Finite, with a rotation that can be normalized.
bool IsUsablePose(const Rigid3d& pose) { return pose.AllFinite() && pose.rotation.norm() > 0.0; }

Rigid3d Normalized(const Rigid3d& pose) {
  return Rigid3d(pose.rotation.normalized(), pose.translation);
}

// The ROI's centre pixel (continuous): the centre of its pixel block.
Eigen::Vector2d BoxCentre(const cv::Rect& box) {
  return Eigen::Vector2d(box.x + (box.width - 1) / 2.0, box.y + (box.height - 1) / 2.0);
}

// Level ground through the LRF spot, in cam1: up . p = up . spot.
struct LevelGround {
  Eigen::Vector3d up_in_cam1 = Eigen::Vector3d::Zero();
  double offset = 0.0;  // up . spot (negative: the ground is below the camera)
  // Distance along the unit bearing to the plane, or +infinity when the ray
  // does not reach it (parallel, or pointing away).
  double DepthAlong(const Eigen::Vector3d& bearing) const {
    const double denominator = up_in_cam1.dot(bearing);
    if (!(std::abs(denominator) > 1e-9)) return kInfinity;
    const double depth = offset / denominator;
    return depth > 0.0 ? depth : kInfinity;
  }
};

// Intersection of pixel-edge corner rays of box with the plane (normal n,
// point c), in cam1, and the area of the quadrilateral they span. 0 when a
// ray misses the plane.
double FootprintAreaM2(const calib::CameraModel& camera, const cv::Rect& box,
                       const Eigen::Vector3d& normal_in_cam1, const Eigen::Vector3d& point_in_cam1) {
  const std::vector<Eigen::Vector2d> outline = BoxOutlinePx(box);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  if (camera.Unproject({outline[1], outline[3], outline[5], outline[7]}, &bearings, &valid) != 4) return 0.0;
  Eigen::Vector3d corners[4];
  for (int i = 0; i < 4; ++i) {
    const double denominator = normal_in_cam1.dot(bearings[static_cast<size_t>(i)]);
    if (!(std::abs(denominator) > 1e-12)) return 0.0;
    const double depth = normal_in_cam1.dot(point_in_cam1) / denominator;
    if (!(depth > 0.0)) return 0.0;
    corners[i] = depth * bearings[static_cast<size_t>(i)];
  }
  return 0.5 * (corners[2] - corners[0]).cross(corners[3] - corners[1]).norm();
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(mid), values.end());
  double median = values[mid];
  if (values.size() % 2 == 0) {
    median = 0.5 * (median + *std::max_element(values.begin(),
                                               values.begin() + static_cast<std::ptrdiff_t>(mid)));
  }
  return median;
}

void CheckInput(const HdaInput& input, const calib::CameraModel& camera, const HdaOptions& options) {
  const std::vector<std::string> errors = options.Validate();
  if (!errors.empty()) {
    std::string message = "RunHda: invalid options:";
    for (const std::string& e : errors) message += "\n  " + e;
    throw InputError(message);
  }
  for (const auto& [image, name] : {std::pair<const cv::Mat*, const char*>{&input.image1, "image 1"},
                                    std::pair<const cv::Mat*, const char*>{&input.image2, "image 2"}}) {
    if (image->empty()) continue;  // no ROIs, said in the result's note
    if (image->type() != CV_8UC1 && image->type() != CV_16UC1) {
      throw InputError(std::string("RunHda: ") + name + " type " + cv::typeToString(image->type()) +
                       " is not supported: expected CV_8UC1 or CV_16UC1");
    }
    if (image->cols != camera.WidthPx() || image->rows != camera.HeightPx()) {
      throw InputError(std::string("RunHda: ") + name + " is " + std::to_string(image->cols) + "x" +
                       std::to_string(image->rows) + " pixels: expected the camera's " +
                       std::to_string(camera.WidthPx()) + "x" + std::to_string(camera.HeightPx()));
    }
  }
  if (!IsUsablePose(input.local_from_cam1)) {
    throw InputError("RunHda: local_from_cam1 is not finite (or has a zero quaternion)");
  }
  if (!IsUsablePose(input.cam2_from_cam1)) {
    throw InputError("RunHda: cam2_from_cam1 is not finite (or has a zero quaternion)");
  }
  if (!std::isfinite(input.lrf_range_m) || !(input.lrf_range_m > 0.0)) {
    throw InputError("RunHda: LRF range = " + util::FixedText(input.lrf_range_m, 3) + " m: expected finite and > 0");
  }
  if (!input.gravity_in_local_mps2.allFinite() || !(input.gravity_in_local_mps2.norm() > 0.0)) {
    throw InputError("RunHda: gravity is not finite and non-zero");
  }
  if (!input.ils_in_local_m.allFinite()) throw InputError("RunHda: ILS is not finite");
  if (!input.lrf_origin_in_cam1_m.allFinite() || !input.lrf_beam_in_cam1.allFinite() ||
      !(input.lrf_beam_in_cam1.norm() > 0.0)) {
    throw InputError("RunHda: LRF origin or beam is not finite and non-zero");
  }
  const Eigen::Vector3d spot =
      input.lrf_origin_in_cam1_m + input.lrf_range_m * input.lrf_beam_in_cam1.normalized();
  if (!(spot.z() > 0.0)) {
    throw InputError("RunHda: the LRF spot is not in front of camera 1 (z = " + util::FixedText(spot.z(), 3) +
                     " m)");
  }
}

// Everything the per-ROI steps share.
struct Context {
  const calib::CameraModel* camera = nullptr;
  const HdaOptions* options = nullptr;
  cv::Mat image1, image2;       // CV_8UC1
  Rigid3d cam2_from_cam1;       // nav, unit quaternion
  Rigid3d local_from_cam1;      // nav, unit quaternion
  Eigen::Vector3d gravity_in_local = Eigen::Vector3d::Zero();
  Eigen::Vector3d up_in_cam1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d c2_in_cam1 = Eigen::Vector3d::Zero();  // camera 2's centre
  LevelGround ground;
  double focal_px = 0.0;        // pixels per radian at the image centre
  // Side of the image-1 window a match's position comes from, pixels
  // (MatchWindowPx of the matcher); 0 for matches given by the caller, whose
  // errors are taken as independent.
  double match_window_px = 0.0;
};

// The image motion expected from navigation for points near pixel `centre`
// of image 1 on a surface whose depth along a unit bearing of camera 1 is
// depth_along(bearing): d(pixel in image 2) / d(pixel in image 1), by central
// differences over +-kMotionStepPx. Identity when one of the four pixels
// cannot be mapped (no unprojection, a ray that misses the surface, a point
// image 2 cannot see).
cv::Matx22d MotionJacobian(const Context& ctx, const Eigen::Vector2d& centre,
                           const std::function<double(const Eigen::Vector3d&)>& depth_along) {
  const std::vector<Eigen::Vector2d> pixels = {centre - Eigen::Vector2d(kMotionStepPx, 0),
                                               centre + Eigen::Vector2d(kMotionStepPx, 0),
                                               centre - Eigen::Vector2d(0, kMotionStepPx),
                                               centre + Eigen::Vector2d(0, kMotionStepPx)};
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  const int count = static_cast<int>(pixels.size());
  if (ctx.camera->Unproject(pixels, &bearings, &valid) != count) return cv::Matx22d::eye();
  std::vector<Eigen::Vector3d> points_in_cam2;
  for (const Eigen::Vector3d& bearing : bearings) {
    const double depth = depth_along(bearing);
    if (!std::isfinite(depth) || !(depth > 0.0)) return cv::Matx22d::eye();
    points_in_cam2.push_back(ctx.cam2_from_cam1 * (depth * bearing));
  }
  std::vector<Eigen::Vector2d> pixels2;
  if (ctx.camera->Project(points_in_cam2, &pixels2, &valid) != count) return cv::Matx22d::eye();
  const Eigen::Vector2d d_dx = (pixels2[1] - pixels2[0]) / (2.0 * kMotionStepPx);
  const Eigen::Vector2d d_dy = (pixels2[3] - pixels2[2]) / (2.0 * kMotionStepPx);
  const cv::Matx22d jacobian(d_dx.x(), d_dy.x(), d_dx.y(), d_dy.y());
  const double det = cv::determinant(jacobian);
  return std::isfinite(det) && det > 0.0 ? jacobian : cv::Matx22d::eye();
}

// The motion for points on the level ground through the LRF spot.
cv::Matx22d GroundMotionJacobian(const Context& ctx, const Eigen::Vector2d& centre) {
  return MotionJacobian(ctx, centre, [&ctx](const Eigen::Vector3d& b) { return ctx.ground.DepthAlong(b); });
}

// Where image-1 pixels fall in image 2 when they lie on the level ground
// through the LRF spot, moved with the nav relative pose (nav-guided matching).
void ExpectOnGround(const Context& ctx, const std::vector<cv::Point2d>& pixels1,
                    std::vector<cv::Point2d>* pixels2, std::vector<unsigned char>* valid) {
  std::vector<Eigen::Vector2d> pixels;
  for (const cv::Point2d& p : pixels1) pixels.emplace_back(p.x, p.y);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> unprojected;
  ctx.camera->Unproject(pixels, &bearings, &unprojected);
  std::vector<Eigen::Vector3d> points_in_cam2(pixels.size(), Eigen::Vector3d::Zero());
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double depth = unprojected[i] ? ctx.ground.DepthAlong(bearings[i]) : kInfinity;
    if (std::isfinite(depth)) points_in_cam2[i] = ctx.cam2_from_cam1 * (depth * bearings[i]);
  }
  std::vector<Eigen::Vector2d> projected;
  ctx.camera->Project(points_in_cam2, &projected, valid);  // the zero point (no depth) is invalid
  pixels2->resize(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) (*pixels2)[i] = cv::Point2d(projected[i].x(), projected[i].y());
}

// The assumed matching noise as an angle, radians.
double AssumedSigmaAngle(const Context& ctx) { return ctx.options->assumed_pixel_sigma_px / ctx.focal_px; }

// The epipolar test's limit for an ROI whose centre's ground point is
// roi_range_m away: k sigmas of matching noise in both images, nav attitude
// and nav direction.
double EpipolarLimitRad(const Context& ctx, double roi_range_m) {
  const PredictionOptions& nav = ctx.options->prediction;
  const double sigma_angle = AssumedSigmaAngle(ctx);
  const double sigma_attitude = nav.nav_attitude_sigma_deg * kDegToRad;
  const double sigma_direction = nav.nav_position_sigma_m / roi_range_m;
  return nav.sigma_multiplier * std::sqrt(2.0 * sigma_angle * sigma_angle + sigma_attitude * sigma_attitude +
                                          sigma_direction * sigma_direction);
}

// The depth test's half-width around the level ground for a point `depth`
// along `bearing` (unit, cam1): the relief allowed, and k sigmas of range
// and of the point's own depth under the assumed matching noise (infinite
// without a baseline across the ray).
double DepthWindowM(const Context& ctx, const Eigen::Vector3d& bearing, double depth) {
  const HdaOptions& options = *ctx.options;
  const double baseline_perp = ctx.c2_in_cam1.cross(bearing).norm();
  const double depth_sigma =
      baseline_perp > 0.0 ? depth * depth * AssumedSigmaAngle(ctx) / baseline_perp : kInfinity;
  const double incidence = std::abs(ctx.up_in_cam1.dot(bearing));
  return options.max_relief_m / incidence +
         options.prediction.sigma_multiplier * (options.prediction.range_sigma_m + depth_sigma);
}

// Nav-based rejection and triangulation of one ROI's matches. Fills counts,
// points, the pixel lists of the survivors, their bearings and parallaxes.
void RejectAndTriangulate(const Context& ctx, const RoiMatches& matches, double roi_range_m,
                          RoiResult* roi, std::vector<Eigen::Vector3d>* bearings1,
                          std::vector<Eigen::Vector3d>* bearings2,
                          std::vector<Eigen::Vector3d>* points_in_cam1,
                          std::vector<double>* parallaxes_deg) {
  const HdaOptions& options = *ctx.options;
  const size_t n = matches.points1_px.size();
  // The bearings matching computed for RANSAC, where it gave them; a side
  // whose points were moved since (or given without) is unprojected here.
  const auto bearings_of = [&](const std::vector<cv::Point2d>& points, const std::vector<Eigen::Vector3d>& given,
                               std::vector<Eigen::Vector3d>* bearings, std::vector<unsigned char>* valid) {
    if (given.size() == n) {
      *bearings = given;
      valid->assign(n, 1);
      return;
    }
    std::vector<Eigen::Vector2d> pixels(n);
    for (size_t i = 0; i < n; ++i) pixels[i] = Eigen::Vector2d(points[i].x, points[i].y);
    ctx.camera->Unproject(pixels, bearings, valid);
  };
  std::vector<Eigen::Vector3d> b1, b2;
  std::vector<unsigned char> valid1, valid2;
  bearings_of(matches.points1_px, matches.bearings1, &b1, &valid1);
  bearings_of(matches.points2_px, matches.bearings2, &b2, &valid2);

  const double epipolar_limit_rad = EpipolarLimitRad(ctx, roi_range_m);
  for (size_t i = 0; i < n; ++i) {
    if (!valid1[i] || !valid2[i]) continue;
    if (!(EpipolarAngleRad(b1[i], b2[i], ctx.cam2_from_cam1) <= epipolar_limit_rad)) continue;
    ++roi->counts.epipolar_inliers;
    Eigen::Vector3d point;
    double parallax_deg = 0.0;
    if (TriangulateMidpoint(b1[i], b2[i], ctx.cam2_from_cam1, options.triangulation, &point,
                            &parallax_deg) != TriangulationStatus::kOk) {
      continue;
    }
    ++roi->counts.triangulated;
    // Depth along ray 1 against the level ground through the LRF spot.
    const double depth = point.dot(b1[i]);
    const double ground_depth = ctx.ground.DepthAlong(b1[i]);
    if (std::isfinite(ground_depth) &&
        !(std::abs(depth - ground_depth) <= DepthWindowM(ctx, b1[i], depth))) {
      continue;
    }
    ++roi->counts.depth_inliers;
    roi->points1_px.push_back(matches.points1_px[i]);
    roi->points2_px.push_back(matches.points2_px[i]);
    bearings1->push_back(b1[i]);
    bearings2->push_back(b2[i]);
    points_in_cam1->push_back(point);
    parallaxes_deg->push_back(parallax_deg);
  }
}

// Whether the nav pose leaves the ROI's depth unobservable: no match of it
// can pass both the triangulation's parallax test and the depth test. Two
// rays, from camera 1 along unit bearing b and from camera 2's centre c2,
// that meet at an angle of at least min_parallax_deg meet at most
//   t_max = c2 . b + |c2 x b| / tan(min_parallax_deg)
// along b (at most 0: not in front of camera 1); the depth test admits no
// point nearer than the level ground's depth g less its window at t_max
// (DepthWindowM, which grows with depth). Unobservable at b when
// t_max < g - window(t_max) (exact for midpoint triangulation, skew rays and
// any nav rotation: the midpoint's depth along b is the closest point's),
// judged at the box's centre, corners and edge middles; false (not judged)
// where a ray misses the ground or cannot be unprojected. Between those nine
// bearings a sliver can remain where a match of exactly the minimum parallax
// would pass (t_max peaks 90 deg - min_parallax_deg from c2, and the window
// is infinite at the epipole), only near the critical baseline: measured with
// a pinhole f = 1000 px at 200 m, a band 7 cm deep along one pixel of a
// 256 px ROI, or a disc of about 0.13 px around an epipole inside the box;
// too few matches for a fit. `figures` gets t_max,
// g - window and g at the centre.
struct DepthReach {
  double farthest_m = 0.0;  // t_max
  double nearest_m = 0.0;   // g - window(t_max)
  double ground_m = 0.0;    // g
};
bool DepthUnobservable(const Context& ctx, const cv::Rect& box, DepthReach* figures) {
  const std::vector<Eigen::Vector2d> samples = BoxOutlinePx(box);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  if (ctx.camera->Unproject(samples, &bearings, &valid) != static_cast<int>(samples.size())) return false;
  const double tan_min = std::tan(ctx.options->triangulation.min_parallax_deg * kDegToRad);
  for (size_t i = 0; i < bearings.size(); ++i) {
    const Eigen::Vector3d& b = bearings[i];
    const double ground = ctx.ground.DepthAlong(b);
    if (!std::isfinite(ground)) return false;
    const double farthest = ctx.c2_in_cam1.dot(b) + ctx.c2_in_cam1.cross(b).norm() / tan_min;
    const double nearest = farthest > 0.0 ? ground - DepthWindowM(ctx, b, farthest) : ground;
    if (i == 0) *figures = {std::max(0.0, farthest), nearest, ground};
    if (!(farthest <= 0.0 || farthest < nearest)) return false;
  }
  return true;
}

// Depth not observable on this ROI (DepthUnobservable: a zero or short
// baseline across the line of sight, or motion along it): marks the ROI
// degenerate, with the figures at its centre, and returns true; its matching
// is not run.
bool MarkUnobservableDepth(const Context& ctx, RoiResult* roi) {
  DepthReach reach;
  if (!DepthUnobservable(ctx, roi->box1_px, &reach)) return false;
  roi->status = RoiStatus::kDegenerate;
  roi->depth_unobservable = true;
  roi->reason = "depth not observable: under the nav pose (baseline " +
                util::FixedText(ctx.c2_in_cam1.norm(), 3) + " m) a point with the " +
                util::FixedText(ctx.options->triangulation.min_parallax_deg, 3) +
                " deg of parallax triangulation needs lies within " + util::FixedText(reach.farthest_m, 3) +
                " m along this ROI's centre ray, short of the " + util::FixedText(reach.nearest_m, 3) +
                " m the depth test admits (level ground at " + util::FixedText(reach.ground_m, 3) + " m)";
  return true;
}

// Fewer points than a plane fit needs: says where the matches were lost.
void MarkTooFewPoints(size_t n, const HdaOptions& options, RoiResult* roi) {
  roi->status = RoiStatus::kTooFewPoints;
  roi->reason = std::to_string(n) + " points survived (" + std::to_string(roi->counts.matches) +
                " matches, " + std::to_string(roi->counts.ransac_inliers) + " RANSAC inliers, " +
                std::to_string(roi->counts.epipolar_inliers) + " nav epipolar inliers): fewer than " +
                std::to_string(options.min_points);
}

// Matching noise: the spread of the signed Sampson distances under the nav
// pose (for equal noise in both images it equals the per-image noise). Their
// mean is left out: a nav attitude error shifts every match of the ROI alike,
// which moves the site as a whole but not its points against each other.
// Matches whose windows overlap share noise, which their mean takes along, so
// the spread is divided by what correlated residuals leave of it
// (SpreadOfCorrelatedResidualsPx). 0 with fewer than two finite distances.
double SignedSampsonSpreadPx(const Context& ctx, const std::vector<Eigen::Vector3d>& bearings1,
                             const std::vector<Eigen::Vector3d>& bearings2,
                             const std::vector<cv::Point2d>& points1_px) {
  const size_t n = bearings1.size();
  const Eigen::Matrix3d rotation = ctx.cam2_from_cam1.rotation.toRotationMatrix();
  std::vector<double> signed_residuals;
  std::vector<Eigen::Vector2d> pixels;
  signed_residuals.reserve(n);
  pixels.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    const double d = SampsonErrorPx(bearings1[i], bearings2[i], ctx.cam2_from_cam1, ctx.focal_px);
    if (!std::isfinite(d)) continue;
    const double side =
        bearings2[i].dot(ctx.cam2_from_cam1.translation.cross(rotation * bearings1[i]));
    signed_residuals.push_back(side < 0.0 ? -d : d);
    pixels.emplace_back(points1_px[i].x, points1_px[i].y);
  }
  if (signed_residuals.size() < 2) return 0.0;
  const double mean = std::accumulate(signed_residuals.begin(), signed_residuals.end(), 0.0) /
                      static_cast<double>(signed_residuals.size());
  double sum_squares = 0.0;
  for (const double r : signed_residuals) sum_squares += (r - mean) * (r - mean);
  return SpreadOfCorrelatedResidualsPx(sum_squares, pixels, ctx.match_window_px);
}

// Each point's triangulation covariance, rotated into the local frame for the
// plane fit. False, with the ROI marked degenerate, when one cannot be
// propagated.
bool LocalCovariances(const Context& ctx, const std::vector<Eigen::Vector3d>& bearings1,
                      const std::vector<Eigen::Vector3d>& bearings2, double sigma_angle,
                      const Eigen::Matrix3d& local_r_cam1,
                      std::vector<Eigen::Matrix3d>* covariances_in_local, RoiResult* roi) {
  const size_t n = bearings1.size();
  covariances_in_local->reserve(n);
  for (size_t i = 0; i < n; ++i) {
    Eigen::Matrix3d covariance;
    if (!TriangulationCovariance(bearings1[i], bearings2[i], ctx.cam2_from_cam1, sigma_angle,
                                 &covariance)) {
      roi->status = RoiStatus::kDegenerate;
      roi->reason = "the uncertainty of point " + std::to_string(i + 1) +
                    " cannot be propagated (rays nearly parallel)";
      return false;
    }
    covariances_in_local->push_back(local_r_cam1 * covariance * local_r_cam1.transpose());
  }
  return true;
}

// The fitted plane's figures into the ROI, with the noise the covariances put
// along its normal and the relief left once that noise is taken out.
void RecordPlane(const PlaneFitResult& plane,
                 const std::vector<Eigen::Matrix3d>& covariances_in_local, size_t n,
                 RoiResult* roi) {
  roi->has_fit = true;
  roi->slope_deg = plane.slope_deg;
  roi->normal_in_local = plane.normal_in_local;
  roi->centroid_in_local_m = plane.centroid_in_local_m;
  roi->roughness_rms_m = plane.roughness_rms_m;
  roi->roughness_max_m = plane.roughness_max_m;
  double noise_squares = 0.0;
  for (const Eigen::Matrix3d& c : covariances_in_local) {
    noise_squares += plane.normal_in_local.dot(c * plane.normal_in_local);
  }
  roi->noise_rms_m = std::sqrt(noise_squares / static_cast<double>(n));
  roi->roughness_excess_m = std::sqrt(
      std::max(0.0, roi->roughness_rms_m * roi->roughness_rms_m - roi->noise_rms_m * roi->noise_rms_m));
}

// The slope's predicted sigma and the site's footprint area, both worked out
// in camera 1's frame from the fitted plane.
void PredictSlopeSigmaAndArea(const Context& ctx,
                              const std::vector<Eigen::Vector3d>& points_in_cam1,
                              const PlaneFitResult& plane, const Eigen::Matrix3d& local_r_cam1,
                              RoiResult* roi) {
  const HdaOptions& options = *ctx.options;
  const Eigen::Vector3d normal_in_cam1 = local_r_cam1.transpose() * plane.normal_in_local;
  SlopeSigmaOptions sigma_options;
  sigma_options.pixel_sigma_px = roi->pixel_sigma_px;
  sigma_options.focal_px = ctx.focal_px;
  sigma_options.baseline_sigma_m = options.prediction.nav_position_sigma_m;
  sigma_options.attitude_sigma_deg = options.prediction.nav_attitude_sigma_deg;
  sigma_options.match_window_px = ctx.match_window_px;
  std::vector<Eigen::Vector2d> pixels1_px;
  pixels1_px.reserve(roi->points1_px.size());
  for (const cv::Point2d& p : roi->points1_px) pixels1_px.emplace_back(p.x, p.y);
  roi->slope_sigma_deg = PredictSlopeSigmaDeg(sigma_options, points_in_cam1, ctx.cam2_from_cam1,
                                              ctx.up_in_cam1, &roi->slope_sigma_terms, &normal_in_cam1,
                                              &pixels1_px);
  const Eigen::Vector3d centroid_in_cam1 =
      ctx.local_from_cam1.Inverse() * plane.centroid_in_local_m;
  roi->area_m2 = FootprintAreaM2(*ctx.camera, roi->box1_px, normal_in_cam1, centroid_in_cam1);
}

// The verdict on a fitted ROI of n points, checked in order: slope not
// observable, then the paper's rule (too steep, too rough, else safe) or the
// probability rule (HdaOptions::decide_on_probability).
void Classify(const HdaOptions& options, size_t n, RoiResult* roi) {
  // Observability: the sigma of the noise and the nav, without the windows'
  // lean, which is a known error of the refinement, not a want of parallax.
  const double lean = roi->slope_sigma_terms.lean_deg;
  const double observability_sigma =
      std::sqrt(std::max(0.0, roi->slope_sigma_deg * roi->slope_sigma_deg - lean * lean));
  if (!std::isfinite(observability_sigma) || observability_sigma > options.max_slope_sigma_deg) {
    roi->status = RoiStatus::kDegenerate;
    roi->reason = "predicted slope sigma " +
                  (std::isfinite(observability_sigma) ? util::FixedText(observability_sigma, 2) + " deg"
                                                      : std::string("unbounded")) +
                  " over " + util::FixedText(options.max_slope_sigma_deg, 2) + " deg (median parallax " +
                  util::FixedText(roi->median_parallax_deg, 3) + " deg): slope not observable";
    return;
  }
  const int num_points = static_cast<int>(n);
  roi->probability_safe = ProbabilitySafe(roi->slope_deg, roi->slope_sigma_deg, options.max_slope_deg,
                                          roi->roughness_rms_m, roi->noise_rms_m, num_points,
                                          options.max_roughness_rms_m);
  if (options.decide_on_probability) {
    const double slope_part = ProbabilitySafe(roi->slope_deg, roi->slope_sigma_deg, options.max_slope_deg, 0.0,
                                              roi->noise_rms_m, num_points, options.max_roughness_rms_m);
    if (!(roi->probability_safe >= options.min_probability_safe)) {
      const bool by_slope = !(slope_part >= options.min_probability_safe);
      roi->status = by_slope ? RoiStatus::kUnsafeSlope : RoiStatus::kUnsafeRoughness;
      roi->reason = "probability of safety " + util::FixedText(roi->probability_safe, 3) + " under " +
                    util::FixedText(options.min_probability_safe, 3) + " (slope " +
                    util::FixedText(roi->slope_deg, 2) + " +- " + util::FixedText(roi->slope_sigma_deg, 2) +
                    " deg, relief " + util::FixedText(roi->roughness_excess_m, 3) + " m RMS)";
      return;
    }
    roi->status = RoiStatus::kEvaluated;
    roi->reason = "safe with probability " + util::FixedText(roi->probability_safe, 3) + ": slope " +
                  util::FixedText(roi->slope_deg, 2) + " +- " + util::FixedText(roi->slope_sigma_deg, 2) +
                  " deg, relief " + util::FixedText(roi->roughness_excess_m, 3) + " m RMS";
    return;
  }
  if (roi->slope_deg > options.max_slope_deg) {
    roi->status = RoiStatus::kUnsafeSlope;
    roi->reason = "slope " + util::FixedText(roi->slope_deg, 2) + " deg over " +
                  util::FixedText(options.max_slope_deg, 2) + " deg";
    return;
  }
  // Relief: only what stands out of the noise with confidence. With N points
  // and known noise, N rms^2 / noise^2 is chi-square with N - 3 degrees of
  // freedom; its one-sided 97.7 % bound is about 1 + 2 sqrt(2 / (N - 3)).
  const double chi_bound = 1.0 + 2.0 * std::sqrt(2.0 / std::max(1.0, static_cast<double>(n) - 3.0));
  const double relief_lower_bound_squared = roi->roughness_rms_m * roi->roughness_rms_m -
                                            chi_bound * roi->noise_rms_m * roi->noise_rms_m;
  if (relief_lower_bound_squared > options.max_roughness_rms_m * options.max_roughness_rms_m) {
    roi->status = RoiStatus::kUnsafeRoughness;
    roi->reason = "relief " + util::FixedText(roi->roughness_excess_m, 3) + " m RMS beyond noise (at least " +
                  util::FixedText(std::sqrt(relief_lower_bound_squared), 3) + " m with 97.7 % confidence) over " +
                  util::FixedText(options.max_roughness_rms_m, 3) + " m";
    return;
  }
  roi->status = RoiStatus::kEvaluated;
  roi->reason = "safe: slope " + util::FixedText(roi->slope_deg, 2) + " +- " + util::FixedText(roi->slope_sigma_deg, 2) +
                " deg, relief " + util::FixedText(roi->roughness_excess_m, 3) + " m RMS";
}

// The lean of one match (docs/flight-method.md, step 6). The nav-aided
// refinement maps its window with the motion `used` (the level ground's);
// where the surface moves with used + change, it settles off the truth by,
// to first order,
//   (delta, o) = (sum_k a_k a_k^T)^-1 sum_k a_k (j_k . change u_k),
// a_k = (j_k, -1), j_k the image-1 gradient at window pixel k through
// used^-T, u_k the pixel's offset in the window: the refinement's own normal
// matrix, with the texture's pull as the right-hand side. Both sums run over
// every second row and column of the window (a quarter of the work; both
// scale alike). False where the window leaves image 1 or has no texture.
bool WindowLeanPx(const cv::Mat& image1, const cv::Matx22d& used, const cv::Matx22d& change, int window_px,
                  const cv::Point& p1, cv::Vec2d* lean) {
  const int half = window_px / 2;
  if (p1.x - half < 1 || p1.y - half < 1 || p1.x + half + 1 >= image1.cols || p1.y + half + 1 >= image1.rows) {
    return false;
  }
  const cv::Matx22d to_image2 = used.inv().t();
  cv::Matx33d normal = cv::Matx33d::zeros();
  cv::Vec3d rhs(0.0, 0.0, 0.0);
  constexpr int kStride = 2;
  for (int v = -half; v <= half; v += kStride) {
    const std::uint8_t* above = image1.ptr<std::uint8_t>(p1.y + v - 1);
    const std::uint8_t* row = image1.ptr<std::uint8_t>(p1.y + v);
    const std::uint8_t* below = image1.ptr<std::uint8_t>(p1.y + v + 1);
    for (int u = -half; u <= half; u += kStride) {
      const int x = p1.x + u;
      const double gx = 0.5 * (row[x + 1] - row[x - 1]), gy = 0.5 * (below[x] - above[x]);
      const double jx = to_image2(0, 0) * gx + to_image2(0, 1) * gy;
      const double jy = to_image2(1, 0) * gx + to_image2(1, 1) * gy;
      const double pull = jx * (change(0, 0) * u + change(0, 1) * v) + jy * (change(1, 0) * u + change(1, 1) * v);
      normal(0, 0) += jx * jx;
      normal(0, 1) += jx * jy;
      normal(1, 1) += jy * jy;
      normal(0, 2) -= jx;
      normal(1, 2) -= jy;
      normal(2, 2) += 1.0;
      rhs[0] += jx * pull;
      rhs[1] += jy * pull;
      rhs[2] -= pull;
    }
  }
  normal(1, 0) = normal(0, 1);
  normal(2, 0) = normal(0, 2);
  normal(2, 1) = normal(1, 2);
  cv::Matx33d inverse;
  if (cv::invert(normal, inverse, cv::DECOMP_CHOLESKY) == 0.0) return false;
  const cv::Vec3d solution = inverse * rhs;
  *lean = cv::Vec2d(solution[0], solution[1]);
  return std::isfinite(solution[0]) && std::isfinite(solution[1]);
}

// The points with each match moved back by its lean under the fitted plane's
// motion (points2 - lean, triangulated again with the nav pose; a point whose
// lean cannot be worked out, or whose moved rays do not triangulate, keeps
// its place). False, nothing written, where the refinement did not map its
// windows (no image, no nav-aided refinement) or the lean is under the noise
// (below).
bool PointsWithoutLeans(const Context& ctx, const RoiResult& roi, const std::vector<Eigen::Vector3d>& bearings1,
                        const std::vector<Eigen::Vector3d>& points_in_cam1,
                        std::vector<Eigen::Vector3d>* moved_in_cam1, std::vector<cv::Point2d>* moved2_px) {
  const MatchingOptions& matching = ctx.options->matching;
  if (ctx.image1.empty() || !matching.subpixel_refine || !matching.warp_refine) return false;
  const Eigen::Vector2d centre = BoxCentre(roi.box1_px);
  const Rigid3d cam1_from_local = ctx.local_from_cam1.Inverse();
  const Eigen::Vector3d normal = cam1_from_local.rotation * roi.normal_in_local;
  const double offset = normal.dot(cam1_from_local * roi.centroid_in_local_m);
  const cv::Matx22d used = GroundMotionJacobian(ctx, centre);
  const cv::Matx22d plane_motion = MotionJacobian(ctx, centre, [&](const Eigen::Vector3d& b) {
    const double along = normal.dot(b);
    return along != 0.0 ? offset / along : kInfinity;
  });
  // Where the plane's motion moves no corner of a window by more than the
  // ROI's measured matching noise from where the level ground's put it, the
  // lean is under the noise: nothing to move.
  const cv::Matx22d change = plane_motion - used;
  const double half = matching.warp_refine_window_px / 2;
  double largest_move_px = 0.0;
  for (const double u : {-half, half}) {
    for (const double v : {-half, half}) {
      const cv::Vec2d move = change * cv::Vec2d(u, v);
      largest_move_px = std::max(largest_move_px, std::hypot(move[0], move[1]));
    }
  }
  if (!(largest_move_px > roi.pixel_sigma_px)) return false;
  const size_t n = points_in_cam1.size();
  std::vector<Eigen::Vector2d> pixels2(n);
  std::vector<unsigned char> has_lean(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const cv::Point whole(cvRound(roi.points1_px[i].x), cvRound(roi.points1_px[i].y));
    cv::Vec2d lean;
    has_lean[i] = WindowLeanPx(ctx.image1, used, change, matching.warp_refine_window_px, whole, &lean);
    if (!has_lean[i]) lean = cv::Vec2d(0.0, 0.0);
    pixels2[i] = Eigen::Vector2d(roi.points2_px[i].x - lean[0], roi.points2_px[i].y - lean[1]);
  }
  std::vector<Eigen::Vector3d> bearings2;
  std::vector<unsigned char> valid;
  ctx.camera->Unproject(pixels2, &bearings2, &valid);
  *moved_in_cam1 = points_in_cam1;
  *moved2_px = roi.points2_px;
  for (size_t i = 0; i < n; ++i) {
    if (!has_lean[i] || !valid[i]) continue;
    Eigen::Vector3d point;
    if (TriangulateMidpoint(bearings1[i], bearings2[i], ctx.cam2_from_cam1, ctx.options->triangulation, &point,
                            nullptr) != TriangulationStatus::kOk) {
      continue;
    }
    (*moved_in_cam1)[i] = point;
    (*moved2_px)[i] = cv::Point2d(pixels2[i].x(), pixels2[i].y());
  }
  return true;
}

// Plane fit, uncertainty and status of one ROI from its triangulated points
// (one bearing pair and parallax per point).
void FitAndClassify(const Context& ctx, const std::vector<Eigen::Vector3d>& bearings1,
                    const std::vector<Eigen::Vector3d>& bearings2,
                    const std::vector<Eigen::Vector3d>& points_in_cam1,
                    const std::vector<double>& parallaxes_deg, RoiResult* roi) {
  const HdaOptions& options = *ctx.options;
  const size_t n = points_in_cam1.size();
  const Eigen::Matrix3d local_r_cam1 = ctx.local_from_cam1.rotation.toRotationMatrix();
  roi->points_in_local_m.reserve(n);
  for (const Eigen::Vector3d& p : points_in_cam1) roi->points_in_local_m.push_back(ctx.local_from_cam1 * p);
  roi->median_parallax_deg = Median(parallaxes_deg);
  if (static_cast<int>(n) < options.min_points) {
    MarkTooFewPoints(n, options, roi);
    return;
  }

  roi->pixel_sigma_px =
      std::max(options.pixel_sigma_floor_px, SignedSampsonSpreadPx(ctx, bearings1, bearings2, roi->points1_px));
  const double sigma_angle = roi->pixel_sigma_px / ctx.focal_px;

  std::vector<Eigen::Matrix3d> covariances_in_local;
  if (!LocalCovariances(ctx, bearings1, bearings2, sigma_angle, local_r_cam1, &covariances_in_local,
                        roi)) {
    return;
  }
  const PlaneFitResult plane = FitPlaneWithCovariance(roi->points_in_local_m, covariances_in_local,
                                                      ctx.gravity_in_local, options.min_points);
  if (plane.status != PlaneFitStatus::kOk) {
    roi->status = RoiStatus::kDegenerate;
    roi->reason = std::string("plane fit: ") + ToString(plane.status);
    return;
  }
  RecordPlane(plane, covariances_in_local, n, roi);
  // The windows' lean under the fitted plane's motion: corrected, or carried
  // in the sigma as a term of its own. The sigma and the area are predicted
  // once, for the plane the ROI keeps.
  bool predicted = false;
  std::vector<Eigen::Vector3d> moved_in_cam1;
  std::vector<cv::Point2d> moved2_px;
  if (PointsWithoutLeans(ctx, *roi, bearings1, points_in_cam1, &moved_in_cam1, &moved2_px)) {
    std::vector<Eigen::Vector3d> moved_in_local;
    moved_in_local.reserve(n);
    for (const Eigen::Vector3d& p : moved_in_cam1) moved_in_local.push_back(ctx.local_from_cam1 * p);
    const PlaneFitResult moved = FitPlaneWithCovariance(moved_in_local, covariances_in_local, ctx.gravity_in_local,
                                                        options.min_points);
    if (moved.status == PlaneFitStatus::kOk) {
      if (options.correct_window_lean) {
        roi->points_in_local_m = moved_in_local;
        roi->points2_px = moved2_px;
        RecordPlane(moved, covariances_in_local, n, roi);
        PredictSlopeSigmaAndArea(ctx, moved_in_cam1, moved, local_r_cam1, roi);
      } else {
        PredictSlopeSigmaAndArea(ctx, points_in_cam1, plane, local_r_cam1, roi);
        const double lean_deg = std::abs(moved.slope_deg - plane.slope_deg);
        roi->slope_sigma_terms.lean_deg = lean_deg;
        roi->slope_sigma_deg = std::sqrt(roi->slope_sigma_deg * roi->slope_sigma_deg + lean_deg * lean_deg);
      }
      predicted = true;
    }
  }
  if (!predicted) PredictSlopeSigmaAndArea(ctx, points_in_cam1, plane, local_r_cam1, roi);
  Classify(options, n, roi);
}

}  // namespace

double PixelsPerRadian(const calib::CameraModel& camera, const Eigen::Vector2d& pixel) {
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  if (camera.Unproject({pixel}, &bearings, &valid) != 1) return 0.0;
  const Eigen::Vector3d b = bearings[0];
  Eigen::Index axis = 0;
  b.cwiseAbs().minCoeff(&axis);
  const Eigen::Vector3d e1 = b.cross(Eigen::Vector3d::Unit(axis)).normalized();
  const Eigen::Vector3d e2 = b.cross(e1);
  constexpr double kStepRad = 1e-4;
  std::vector<Eigen::Vector2d> pixels;
  if (camera.Project({b + kStepRad * e1, b - kStepRad * e1, b + kStepRad * e2, b - kStepRad * e2},
                     &pixels, &valid) != 4) {
    return 0.0;
  }
  return std::max((pixels[0] - pixels[1]).norm(), (pixels[2] - pixels[3]).norm()) / (2.0 * kStepRad);
}

bool HasSlope(RoiStatus status) {
  return status == RoiStatus::kEvaluated || status == RoiStatus::kUnsafeSlope ||
         status == RoiStatus::kUnsafeRoughness;
}

const char* ToString(RoiStatus status) {
  switch (status) {
    case RoiStatus::kEvaluated:
      return "evaluated";
    case RoiStatus::kUnsafeSlope:
      return "unsafe slope";
    case RoiStatus::kUnsafeRoughness:
      return "unsafe roughness";
    case RoiStatus::kDegenerate:
      return "degenerate";
    case RoiStatus::kTooFewPoints:
      return "too few points";
    case RoiStatus::kNotInImage2:
      return "not in image 2";
    case RoiStatus::kNotEvaluated:
      return "not evaluated";
  }
  return "unknown";
}

std::string HdaResult::Summary() const {
  constexpr int kNumStatuses = static_cast<int>(RoiStatus::kNotEvaluated) + 1;
  int counts[kNumStatuses] = {};
  for (const RoiResult& roi : rois) ++counts[static_cast<int>(roi.status)];
  std::ostringstream s;
  s << "hda: " << rois.size() << " ROIs";
  for (int i = 0; i < kNumStatuses; ++i) s << ", " << counts[i] << " " << ToString(static_cast<RoiStatus>(i));
  s << "; flight computer " << util::FixedText(FlightSeconds(), 2) << " s of a " << util::FixedText(budget_s, 2)
    << " s budget" << (budget_exhausted ? " (exhausted)" : "");
  if (!note.empty()) s << "; " << note;
  return s.str();
}

double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

double RankingScore(double area_m2, double slope_deg, double roughness_excess_m,
                    const HdaOptions& options) {
  const double site_area = options.quadtree.site_size_m * options.quadtree.site_size_m;
  const double area_term = std::clamp(area_m2 / site_area, 0.0, 4.0) / 4.0;
  const double slope_term = std::clamp(1.0 - slope_deg / options.max_slope_deg, 0.0, 1.0);
  const double roughness_term =
      std::clamp(1.0 - roughness_excess_m / options.max_hazard_height_m, 0.0, 1.0);
  return (area_term + slope_term + roughness_term) / 3.0;
}

double MatchWindowPx(const MatchingOptions& matching) {
  if (!matching.subpixel_refine) return 0.0;
  return matching.warp_refine ? matching.warp_refine_window_px : matching.refine_window_px;
}

double ProbabilitySafe(double slope_deg, double slope_sigma_deg, double max_slope_deg, double roughness_rms_m,
                       double noise_rms_m, int num_points, double max_roughness_rms_m) {
  if (!std::isfinite(slope_deg) || !std::isfinite(slope_sigma_deg) || !(slope_sigma_deg > 0.0) ||
      !std::isfinite(max_slope_deg) || !std::isfinite(roughness_rms_m) || !std::isfinite(noise_rms_m) ||
      !std::isfinite(max_roughness_rms_m) || num_points < 4) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const auto normal_cdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  const double slope_part = normal_cdf((max_slope_deg - slope_deg) / slope_sigma_deg);
  const double relief_squared = roughness_rms_m * roughness_rms_m - noise_rms_m * noise_rms_m;
  const double spread = noise_rms_m * noise_rms_m * std::sqrt(2.0 / static_cast<double>(num_points - 3));
  const double margin = max_roughness_rms_m * max_roughness_rms_m - relief_squared;
  double relief_part = margin >= 0.0 ? 1.0 : 0.0;  // no noise: the relief is known exactly
  if (spread > 0.0) relief_part = normal_cdf(margin / spread);
  return slope_part * relief_part;
}

cv::Mat ToEightBit(const cv::Mat& image, const char* what) {
  if (image.type() == CV_8UC1) return image;
  if (image.type() == CV_16UC1) {
    cv::Mat out;
    image.convertTo(out, CV_8U, 1.0 / 257.0);
    return out;
  }
  throw InputError(std::string(what) + " type " + cv::typeToString(image.type()) +
                   " is not supported: expected CV_8UC1 or CV_16UC1");
}

namespace {

// Charges the clock time since the last mark to a stage, so that the stages
// add up to the run's time; every lap reads the clock once, as before.
class StageTimer {
 public:
  StageTimer(const Clock& clock, double mark) : clock_(clock), mark_(mark) {}
  void Lap(double* stage) {
    const double now = clock_();
    *stage += now - mark_;
    mark_ = now;
  }
  // A new mark without a reading: the time before it is charged to no stage.
  void Restart(double mark) { mark_ = mark; }

 private:
  const Clock& clock_;
  double mark_;
};

// Fills the context's navigation geometry (poses, up, camera 2's centre, the
// focal length, the level ground through the LRF spot); returns that spot in
// cam1. Throws when the camera model cannot give a focal length.
Eigen::Vector3d SetUpGeometry(const HdaInput& input, Context* ctx) {
  const calib::CameraModel& camera = *ctx->camera;
  ctx->cam2_from_cam1 = Normalized(input.cam2_from_cam1);
  ctx->local_from_cam1 = Normalized(input.local_from_cam1);
  ctx->gravity_in_local = input.gravity_in_local_mps2;
  ctx->up_in_cam1 =
      ctx->local_from_cam1.rotation.inverse() * (-input.gravity_in_local_mps2.normalized());
  ctx->c2_in_cam1 = ctx->cam2_from_cam1.Inverse().translation;
  const Eigen::Vector2d centre((camera.WidthPx() - 1) / 2.0, (camera.HeightPx() - 1) / 2.0);
  ctx->focal_px = PixelsPerRadian(camera, centre);
  if (!(ctx->focal_px > 0.0)) {
    throw InputError("RunHda: the camera model cannot unproject and project around the image centre");
  }
  const Eigen::Vector3d spot_in_cam1 =
      input.lrf_origin_in_cam1_m + input.lrf_range_m * input.lrf_beam_in_cam1.normalized();
  ctx->ground.up_in_cam1 = ctx->up_in_cam1;
  ctx->ground.offset = ctx->up_in_cam1.dot(spot_in_cam1);
  return spot_in_cam1;
}

// Per ROI: the range of its centre's ground point (for the nav thresholds)
// and its depth along the optical axis (the prediction's ground plane); the
// LRF spot's where the centre's ray misses the level ground. Also the centre
// pixels and the order of evaluation.
struct RoiPlacement {
  std::vector<double> range_m;
  std::vector<double> axis_depth_m;
  std::vector<Eigen::Vector2d> centres;
  std::vector<size_t> order;  // ROI indices, nearest to the ILS first
};

// Creates the ROI results (id, box, ILS distance) and places each ROI on the
// level ground. Order: nearest to the ILS first (horizontal distance of the
// ROI centre's ground point), ties and ROIs whose ray misses the ground by id.
RoiPlacement PlaceRois(const Context& ctx, const Eigen::Vector3d& ils_in_local_m,
                       const Eigen::Vector3d& spot_in_cam1, HdaResult* result) {
  const Eigen::Vector3d ils_in_cam1 = ctx.local_from_cam1.Inverse() * ils_in_local_m;
  const size_t num_rois = result->quadtree.rois.size();
  result->rois.resize(num_rois);
  RoiPlacement placement;
  placement.range_m.assign(num_rois, spot_in_cam1.norm());
  placement.axis_depth_m.assign(num_rois, spot_in_cam1.z());
  placement.centres.resize(num_rois);
  for (size_t i = 0; i < num_rois; ++i) {
    placement.centres[i] = BoxCentre(result->quadtree.rois[i].box_px);
  }
  std::vector<Eigen::Vector3d> centre_bearings;
  std::vector<unsigned char> valid;
  ctx.camera->Unproject(placement.centres, &centre_bearings, &valid);
  for (size_t i = 0; i < num_rois; ++i) {
    RoiResult& roi = result->rois[i];
    roi.id = result->quadtree.rois[i].id;
    roi.box1_px = result->quadtree.rois[i].box_px;
    roi.ils_distance_m = kInfinity;
    if (!valid[i]) continue;
    const double depth = ctx.ground.DepthAlong(centre_bearings[i]);
    if (!std::isfinite(depth)) continue;
    const Eigen::Vector3d ground = depth * centre_bearings[i];
    const Eigen::Vector3d offset = ground - ils_in_cam1;
    roi.ils_distance_m = (offset - ctx.up_in_cam1 * ctx.up_in_cam1.dot(offset)).norm();
    placement.range_m[i] = depth;
    if (ground.z() > 0.0) placement.axis_depth_m[i] = ground.z();
  }
  placement.order.resize(num_rois);
  std::iota(placement.order.begin(), placement.order.end(), size_t{0});
  std::stable_sort(placement.order.begin(), placement.order.end(), [&](size_t a, size_t b) {
    return result->rois[a].ils_distance_m < result->rois[b].ils_distance_m;
  });
  return placement;
}

// ROI i's search box in image 2: its outline on the plane perpendicular to
// camera 1's axis at the depth its placement gives it.
PredictedRoi PredictPlacedRoi(const Context& ctx, const RoiPlacement& placement, const HdaResult& result,
                              size_t i) {
  return PredictRoi(result.quadtree.rois[i], *ctx.camera, ctx.cam2_from_cam1, placement.axis_depth_m[i],
                    ctx.options->prediction);
}

// Fault injection (HdaOptions::fault_match_noise_px): Gaussian noise on
// every image-2 match position, seeded by the ROI id.
void AddFaultMatchNoise(const HdaOptions& options, int roi_id, RoiMatches* matches) {
  if (!(options.fault_match_noise_px > 0.0)) return;
  std::mt19937_64 rng(static_cast<std::uint64_t>(roi_id));
  std::normal_distribution<double> noise(0.0, options.fault_match_noise_px);
  for (cv::Point2d& p : matches->points2_px) {
    p.x += noise(rng);
    p.y += noise(rng);
  }
  matches->bearings2.clear();  // the moved points' are unprojected anew
}

// Matches the ROI pair. The expected motion serves the nav-aided refinement
// and the pre-warp; the fault injection's noise on image 2's points is seeded
// by the ROI id so that a run repeats.
RoiMatches MatchRoi(const Context& ctx, const RoiResult& roi, const Eigen::Vector2d& centre) {
  const HdaOptions& options = *ctx.options;
  const bool uses_motion = (options.matching.subpixel_refine && options.matching.warp_refine) ||
                           options.matching.prewarp_min_stretch > 0.0;
  RoiMatches matches =
      MatchRoiPair(ctx.image1, ctx.image2, roi.box1_px, roi.box2_px, *ctx.camera, options.matching,
                   uses_motion ? GroundMotionJacobian(ctx, centre) : cv::Matx22d::eye(),
                   [&ctx](const std::vector<cv::Point2d>& pixels1, std::vector<cv::Point2d>* pixels2,
                          std::vector<unsigned char>* valid) { ExpectOnGround(ctx, pixels1, pixels2, valid); });
  AddFaultMatchNoise(options, roi.id, &matches);
  return matches;
}


// One ROI through prediction, matching, rejection and the plane fit, each
// stage's time charged to its timing.
void EvaluateRoi(const Context& ctx, const RoiPlacement& placement, size_t i, StageTimer* timer,
                 HdaResult* result) {
  RoiResult& roi = result->rois[i];
  const PredictedRoi predicted = PredictPlacedRoi(ctx, placement, *result, i);
  timer->Lap(&result->times.prediction_s);
  roi.work[WorkUnit::kPredictedRois] = 1;
  if (UnprojectsIteratively(ctx.camera->LensModelName())) roi.work[WorkUnit::kIteratedPredictions] = 1;
  roi.prediction_margin_px = predicted.margin_px;
  if (predicted.status != PredictionStatus::kOk) {
    roi.status = RoiStatus::kNotInImage2;
    roi.reason = std::string("prediction: ") + PredictionStatusName(predicted.status);
    return;
  }
  roi.box2_px = predicted.box_px;
  if (MarkUnobservableDepth(ctx, &roi)) {
    timer->Lap(&result->times.rejection_s);
    return;
  }
  const RoiMatches matches = MatchRoi(ctx, roi, placement.centres[i]);
  timer->Lap(&result->times.matching_s);
  roi.matched = true;
  roi.matching_status = matches.status;
  roi.prewarped = matches.prewarped;
  roi.counts.keypoints1 = matches.keypoints1;
  roi.counts.keypoints2 = matches.keypoints2;
  roi.counts.matches = matches.matches;
  roi.counts.refine_rejected = matches.refine_rejected;
  roi.counts.ransac_inliers = matches.ransac_inliers;
  roi.work += matches.work;
  std::vector<Eigen::Vector3d> bearings1, bearings2, points_in_cam1;
  std::vector<double> parallaxes_deg;
  RejectAndTriangulate(ctx, matches, placement.range_m[i], &roi, &bearings1, &bearings2,
                       &points_in_cam1, &parallaxes_deg);
  timer->Lap(&result->times.rejection_s);
  roi.work[WorkUnit::kRejectionPoints] = matches.ransac_inliers;
  FitAndClassify(ctx, bearings1, bearings2, points_in_cam1, parallaxes_deg, &roi);
  timer->Lap(&result->times.plane_s);
  roi.work[WorkUnit::kPlanePoints] = static_cast<std::int64_t>(points_in_cam1.size());
}

// Evaluates the ROIs in placement order until the budget runs out. Kick-out:
// stop when the next ROI, at the mean cost so far, would not fit in what is
// left of the budget; the rest are marked not evaluated. Costs are the
// flight computer's seconds predicted from the counted work, never a clock's.
void EvaluateRois(const Context& ctx, const RoiPlacement& placement, const Clock& clock,
                  const RoiProgress& progress, StageTimer* timer, HdaResult* result) {
  double roi_seconds_total = 0.0;
  int rois_done = 0;
  for (size_t rank = 0; rank < placement.order.size(); ++rank) {
    const size_t i = placement.order[rank];
    RoiResult& roi = result->rois[i];
    roi.order = static_cast<int>(rank) + 1;
    const double mean_cost = rois_done > 0 ? roi_seconds_total / rois_done : 0.0;
    if (result->budget_exhausted || result->FlightSeconds() + mean_cost > result->budget_s) {
      result->budget_exhausted = true;
      roi.status = RoiStatus::kNotEvaluated;
      roi.reason = "time budget of " + util::FixedText(result->budget_s, 3) +
                   " s of the flight computer used up before this ROI";
      continue;
    }
    const double roi_start = clock();
    timer->Restart(roi_start);
    EvaluateRoi(ctx, placement, i, timer, result);
    roi.wall_s = clock() - roi_start;
    result->work += roi.work;
    roi_seconds_total += result->FlightSeconds(roi.work);
    ++rois_done;
    if (progress) progress(rois_done, static_cast<int>(placement.order.size()));
  }
}

// Scores the safe sites and ranks them, best first: by score, or by the
// probability of safety and then the score under the probability rule (ties
// by id).
void RankSafeSites(const HdaOptions& options, HdaResult* result) {
  std::vector<size_t> safe;
  for (size_t i = 0; i < result->rois.size(); ++i) {
    RoiResult& roi = result->rois[i];
    if (roi.status != RoiStatus::kEvaluated) continue;
    roi.score = RankingScore(roi.area_m2, roi.slope_deg, roi.roughness_excess_m, options);
    safe.push_back(i);
  }
  std::stable_sort(safe.begin(), safe.end(), [&](size_t a, size_t b) {
    const RoiResult& ra = result->rois[a];
    const RoiResult& rb = result->rois[b];
    if (options.decide_on_probability && ra.probability_safe != rb.probability_safe) {
      return ra.probability_safe > rb.probability_safe;
    }
    return ra.score > rb.score;
  });
  for (size_t r = 0; r < safe.size(); ++r) {
    result->rois[safe[r]].rank = static_cast<int>(r) + 1;
    result->ranking.push_back(result->rois[safe[r]].id);
  }
}

}  // namespace

RoiResult EvaluateMatchedSite(const HdaInput& input, const calib::CameraModel& camera,
                              const HdaOptions& options, const cv::Rect& box1_px,
                              const std::vector<cv::Point2d>& points1_px,
                              const std::vector<cv::Point2d>& points2_px,
                              double match_window_px) {
  CheckInput(input, camera, options);
  if (points1_px.size() != points2_px.size()) {
    throw InputError("EvaluateMatchedSite: " + std::to_string(points1_px.size()) + " image-1 points but " +
                     std::to_string(points2_px.size()) + " image-2 points");
  }
  if (!(match_window_px >= 0.0)) {
    throw InputError("EvaluateMatchedSite: match_window_px = " + util::FixedText(match_window_px, 3) +
                     ": expected >= 0");
  }
  Context ctx;
  ctx.camera = &camera;
  ctx.options = &options;
  ctx.match_window_px = match_window_px;
  const Eigen::Vector3d spot_in_cam1 = SetUpGeometry(input, &ctx);
  HdaResult placed;
  placed.quadtree.rois.push_back({1, box1_px, 0.0, 0.0});
  const RoiPlacement placement = PlaceRois(ctx, input.ils_in_local_m, spot_in_cam1, &placed);
  RoiResult roi = placed.rois.front();
  roi.order = 1;
  RoiMatches matches;
  matches.status = MatchingStatus::kOk;
  matches.points1_px = points1_px;
  matches.points2_px = points2_px;
  roi.matched = true;
  roi.matching_status = MatchingStatus::kOk;
  roi.counts.matches = static_cast<int>(points1_px.size());
  roi.counts.ransac_inliers = roi.counts.matches;
  if (MarkUnobservableDepth(ctx, &roi)) return roi;
  std::vector<Eigen::Vector3d> bearings1, bearings2, points_in_cam1;
  std::vector<double> parallaxes_deg;
  RejectAndTriangulate(ctx, matches, placement.range_m.front(), &roi, &bearings1, &bearings2, &points_in_cam1,
                       &parallaxes_deg);
  FitAndClassify(ctx, bearings1, bearings2, points_in_cam1, parallaxes_deg, &roi);
  return roi;
}

std::vector<cv::Rect> PredictSearchBoxes(const HdaInput& input, const calib::CameraModel& camera,
                                         const HdaOptions& options, const std::vector<cv::Rect>& boxes1_px) {
  CheckInput(input, camera, options);
  Context ctx;
  ctx.camera = &camera;
  ctx.options = &options;
  const Eigen::Vector3d spot_in_cam1 = SetUpGeometry(input, &ctx);
  HdaResult placed;
  for (size_t i = 0; i < boxes1_px.size(); ++i) {
    placed.quadtree.rois.push_back({static_cast<int>(i) + 1, boxes1_px[i], 0.0, 0.0});
  }
  const RoiPlacement placement = PlaceRois(ctx, input.ils_in_local_m, spot_in_cam1, &placed);
  std::vector<cv::Rect> boxes2_px(boxes1_px.size());
  for (size_t i = 0; i < boxes1_px.size(); ++i) {
    const PredictedRoi predicted = PredictPlacedRoi(ctx, placement, placed, i);
    if (predicted.status == PredictionStatus::kOk) boxes2_px[i] = predicted.box_px;
  }
  return boxes2_px;
}

HdaResult RunHda(const HdaInput& input, const calib::CameraModel& camera, const HdaOptions& options,
                 const Clock& clock, const RoiProgress& progress) {
  const double start = clock();
  StageTimer timer(clock, start);
  CheckInput(input, camera, options);
  HdaResult result;
  result.budget_s = options.compute_budget_s;
  result.flight_instructions_per_s = options.flight_instructions_per_s;
  if (input.image1.empty() || input.image2.empty()) {
    result.note = std::string(input.image1.empty() ? "image 1" : "image 2") +
                  " is empty: no ROI can be found or matched";
    result.times.total_s = clock() - start;
    return result;
  }

  Context ctx;
  ctx.camera = &camera;
  ctx.options = &options;
  ctx.image1 = ToEightBit(input.image1, "RunHda: image 1");
  ctx.image2 = ToEightBit(input.image2, "RunHda: image 2");
  for (const cv::Mat* image : {&input.image1, &input.image2}) {
    if (image->type() != CV_8UC1) result.work[WorkUnit::kConvertedPixels] += static_cast<std::int64_t>(image->total());
  }
  ctx.match_window_px = MatchWindowPx(options.matching);
  timer.Lap(&result.times.convert_s);
  const Eigen::Vector3d spot_in_cam1 = SetUpGeometry(input, &ctx);

  // Quadtree on image 1, unless the ROIs are given.
  if (input.given_rois_px.empty()) {
    const int min_block_px = MinimumBlockSizePx(camera, spot_in_cam1.norm(), options.quadtree);
    result.quadtree = RunQuadtree(ctx.image1, min_block_px, options.quadtree);
  } else {
    result.quadtree = GivenRois(ctx.image1, input.given_rois_px);
  }
  timer.Lap(&result.times.quadtree_s);
  // The quadtree's statistics read every pixel of image 1 (given ROIs: only theirs).
  std::int64_t quadtree_pixels = static_cast<std::int64_t>(ctx.image1.total());
  if (!input.given_rois_px.empty()) {
    quadtree_pixels = 0;
    for (const Roi& roi : result.quadtree.rois) quadtree_pixels += roi.box_px.area();
  }
  result.work[WorkUnit::kQuadtreePixels] = quadtree_pixels;
  result.work[WorkUnit::kQuadtreeBlocks] = result.quadtree.blocks_visited;
  if (result.quadtree.rois.empty()) {
    result.note = "the quadtree kept no block: " + result.quadtree.Summary();
  }

  const RoiPlacement placement = PlaceRois(ctx, input.ils_in_local_m, spot_in_cam1, &result);
  EvaluateRois(ctx, placement, clock, progress, &timer, &result);
  RankSafeSites(options, &result);
  timer.Lap(&result.times.ranking_s);
  result.times.total_s = clock() - start;
  return result;
}

}  // namespace hdabench::hda
