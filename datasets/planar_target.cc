#include "datasets/planar_target.h"

#include <cmath>
#include <filesystem>
#include <limits>
#include <vector>

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "datasets/internal/pair_frames.h"
#include "tools/images/codecs.h"
#include "tools/util/files.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;

using util::kRadToDeg;

// The board's corner i in its own frame (row-major, board.width per row).
Eigen::Vector3d BoardCorner(const calib::ChessboardSpec& board, int i) {
  return Eigen::Vector3d((i % board.width) * board.spacing, (i / board.width) * board.spacing, 0.0);
}

// 8-bit grey image of `path`, checked against the model's imager size.
cv::Mat ReadGrey(const std::string& path, const calib::CameraModel& camera) {
  std::string error;
  const cv::Mat image = images::ReadWholeImage(path, cv::IMREAD_GRAYSCALE, &error);
  if (image.empty()) throw InputError(path + ": " + error);
  if (image.cols != camera.WidthPx() || image.rows != camera.HeightPx()) {
    throw InputError(path + ": " + std::to_string(image.cols) + " x " + std::to_string(image.rows) +
                     " px, but its camera model is " + std::to_string(camera.WidthPx()) + " x " +
                     std::to_string(camera.HeightPx()) + " px");
  }
  return image;
}

// One image: the board found, its pose, and the figures of the fit.
PlanarTargetView MeasureView(const std::string& path, const cv::Mat& image,
                             const calib::CameraModel& camera, const calib::ChessboardSpec& board,
                             calib::CornerDetector detector) {
  const calib::CornerDetection detection = calib::DetectChessboard(image, board, detector);
  if (!detection.found) throw InputError(path + ": " + detection.reason);
  PlanarTargetView view;
  view.image_path = path;
  view.corners_px = detection.corners;
  view.cam_from_board = BoardPoseByPnp(camera, detection.corners, board, path,
                                       &view.reprojection_rms_px, &view.reprojection_max_px);
  // The optical axis (camera z) against the board's plane z = 0.
  const Rigid3d board_from_cam = view.cam_from_board.Inverse();
  const Eigen::Vector3d centre = board_from_cam.translation;
  const Eigen::Vector3d axis = board_from_cam.rotation * Eigen::Vector3d::UnitZ();
  const double range = -centre.z() / axis.z();
  if (!(range > 0.0) || !std::isfinite(range)) {
    throw InputError(path + ": the camera's optical axis does not meet the board's plane");
  }
  view.range_m = range;
  view.tilt_deg = std::acos(std::min(1.0, std::abs(axis.z()))) * kRadToDeg;
  return view;
}

// Every pixel's bearing through `camera` (row-major); valid[i] = 0 where the
// model cannot unproject.
void PixelBearings(const calib::CameraModel& camera, std::vector<Eigen::Vector3d>* bearings,
                   std::vector<unsigned char>* valid) {
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(static_cast<size_t>(camera.WidthPx()) * camera.HeightPx());
  for (int row = 0; row < camera.HeightPx(); ++row) {
    for (int col = 0; col < camera.WidthPx(); ++col) pixels.emplace_back(col, row);
  }
  camera.Unproject(pixels, bearings, valid);
}

// Image 2 seen through camera 1's model from camera 2's pose: each pixel's
// camera-1 bearing, taken in camera 2's frame, projected with camera 2's model.
cv::Mat ResampleIntoModel(const cv::Mat& image2, const calib::CameraModel& camera2,
                          const std::vector<Eigen::Vector3d>& bearings1,
                          const std::vector<unsigned char>& valid1, int width, int height) {
  std::vector<Eigen::Vector2d> pixels2;
  std::vector<unsigned char> valid2;
  camera2.Project(bearings1, &pixels2, &valid2);
  cv::Mat map_x(height, width, CV_32FC1), map_y(height, width, CV_32FC1);
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const size_t i = static_cast<size_t>(row) * width + col;
      const bool ok = valid1[i] && valid2[i];
      map_x.at<float>(row, col) = ok ? static_cast<float>(pixels2[i].x()) : -1.0f;
      map_y.at<float>(row, col) = ok ? static_cast<float>(pixels2[i].y()) : -1.0f;
    }
  }
  cv::Mat resampled;
  cv::remap(image2, resampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  return resampled;
}

// Frame 0's truth: each pixel's ray met with the board's plane, inside the
// checkered area; NaN elsewhere.
cv::Mat BoardTruthPoints(const std::vector<Eigen::Vector3d>& bearings1,
                         const std::vector<unsigned char>& valid1, const Rigid3d& board_from_cam1,
                         const Rigid3d& local_from_board, const calib::ChessboardSpec& board,
                         int width, int height) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  cv::Mat points(height, width, CV_32FC3, cv::Scalar(nan, nan, nan));
  const Eigen::Vector3d centre = board_from_cam1.translation;
  const double s = board.spacing;
  for (int row = 0; row < height; ++row) {
    for (int col = 0; col < width; ++col) {
      const size_t i = static_cast<size_t>(row) * width + col;
      if (!valid1[i]) continue;
      const Eigen::Vector3d ray = board_from_cam1.rotation * bearings1[i];
      const double t = -centre.z() / ray.z();
      if (!(t > 0.0) || !std::isfinite(t)) continue;
      const Eigen::Vector3d p = centre + t * ray;
      if (p.x() < -s || p.x() > board.width * s || p.y() < -s || p.y() > board.height * s) continue;
      const Eigen::Vector3d q = local_from_board * Eigen::Vector3d(p.x(), p.y(), 0.0);
      points.at<cv::Vec3f>(row, col) =
          cv::Vec3f(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
    }
  }
  return points;
}

double RotationAngleDeg(const Eigen::Quaterniond& q) {
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w())) * kRadToDeg;
}

bool HasExtrinsics(const calib::CameraModel& camera) {
  for (double v : camera.RtCamRef()) {
    if (v != 0.0) return true;
  }
  return false;
}

std::string DefaultName(const std::string& image1_path, const std::string& image2_path) {
  return "planar-target-" + fs::path(image1_path).stem().string() + "-" +
         fs::path(image2_path).stem().string();
}


}  // namespace

cv::Rect LargestBoxInHull(const std::vector<Eigen::Vector2d>& points_px) {
  if (points_px.size() < 3) return {};
  // OpenCV's hull takes float points: it picks the vertices, their double
  // coordinates are kept.
  std::vector<cv::Point2f> points;
  for (const Eigen::Vector2d& p : points_px) points.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
  std::vector<int> indices;
  cv::convexHull(points, indices);
  std::vector<cv::Point2d> hull;
  for (int i : indices) hull.emplace_back(points_px[static_cast<size_t>(i)].x(), points_px[static_cast<size_t>(i)].y());
  if (hull.size() < 3) return {};
  double top = hull[0].y, bottom = hull[0].y;
  for (const cv::Point2d& p : hull) {
    top = std::min(top, p.y);
    bottom = std::max(bottom, p.y);
  }
  const int row0 = static_cast<int>(std::ceil(top));
  const int row1 = static_cast<int>(std::floor(bottom));
  if (row1 < row0) return {};
  // Each row's span [left, right] inside the hull.
  const int rows = row1 - row0 + 1;
  std::vector<double> left(rows, std::numeric_limits<double>::infinity());
  std::vector<double> right(rows, -std::numeric_limits<double>::infinity());
  for (int r = 0; r < rows; ++r) {
    const double y = row0 + r;
    for (size_t i = 0; i < hull.size(); ++i) {
      const cv::Point2d& a = hull[i];
      const cv::Point2d& b = hull[(i + 1) % hull.size()];
      if ((y < std::min(a.y, b.y)) || (y > std::max(a.y, b.y))) continue;
      const double x = a.y == b.y ? std::min(a.x, b.x) : a.x + (y - a.y) * (b.x - a.x) / (b.y - a.y);
      const double x_far = a.y == b.y ? std::max(a.x, b.x) : x;
      left[r] = std::min(left[r], x);
      right[r] = std::max(right[r], x_far);
    }
  }
  cv::Rect best;
  for (int r0 = 0; r0 < rows; ++r0) {
    for (int r1 = r0; r1 < rows; ++r1) {
      const int x0 = static_cast<int>(std::ceil(std::max(left[r0], left[r1])));
      const int x1 = static_cast<int>(std::floor(std::min(right[r0], right[r1])));
      if (x1 < x0) continue;
      const cv::Rect box(x0, row0 + r0, x1 - x0 + 1, r1 - r0 + 1);
      if (box.area() > best.area()) best = box;
    }
  }
  return best;
}

Rigid3d BoardPoseByPnp(const calib::CameraModel& camera, const std::vector<Eigen::Vector2d>& corners_px,
                       const calib::ChessboardSpec& board, const std::string& where, double* rms_px,
                       double* max_px) {
  const size_t n = corners_px.size();
  if (n != static_cast<size_t>(board.width) * board.height || n < 4) {
    throw InputError(where + ": " + std::to_string(n) + " corners for a " + board.SizeText() + " board");
  }
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  camera.Unproject(corners_px, &bearings, &valid);
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> normalized;
  for (size_t i = 0; i < n; ++i) {
    if (!valid[i] || !(bearings[i].z() > 0.0)) {
      throw InputError(where + ": corner " + std::to_string(i) + " at (" + util::FixedText(corners_px[i].x(), 2) +
                       ", " + util::FixedText(corners_px[i].y(), 2) +
                       ") px cannot be unprojected in front of the camera by its model");
    }
    const Eigen::Vector3d p = BoardCorner(board, static_cast<int>(i));
    object.emplace_back(p.x(), p.y(), p.z());
    normalized.emplace_back(bearings[i].x() / bearings[i].z(), bearings[i].y() / bearings[i].z());
  }
  const cv::Mat identity = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat rvec, tvec;
  bool ok = false;
  try {
    ok = cv::solvePnP(object, normalized, identity, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE);
    if (ok) cv::solvePnPRefineLM(object, normalized, identity, cv::noArray(), rvec, tvec);
  } catch (const cv::Exception& e) {
    throw InputError(where + ": PnP on the board failed: " + e.what());
  }
  if (!ok) throw InputError(where + ": PnP on the board found no pose");
  cv::Mat rotation_cv;
  cv::Rodrigues(rvec, rotation_cv);
  Eigen::Matrix3d rotation;
  cv::cv2eigen(rotation_cv, rotation);
  const Rigid3d cam_from_board(Eigen::Quaterniond(rotation).normalized(),
                               Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2)));
  if (!cam_from_board.translation.allFinite() || !(cam_from_board.translation.z() > 0.0)) {
    throw InputError(where + ": PnP put the board behind the camera");
  }
  std::vector<Eigen::Vector3d> in_cam(n);
  for (size_t i = 0; i < n; ++i) in_cam[i] = cam_from_board * BoardCorner(board, static_cast<int>(i));
  std::vector<Eigen::Vector2d> projected;
  camera.Project(in_cam, &projected, &valid);
  double sum2 = 0.0, worst = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const double e = valid[i] ? (projected[i] - corners_px[i]).norm() : std::numeric_limits<double>::infinity();
    sum2 += e * e;
    worst = std::max(worst, e);
  }
  *rms_px = std::sqrt(sum2 / static_cast<double>(n));
  *max_px = worst;
  return cam_from_board;
}

PlanarTargetPair MakePlanarTargetPair(const std::string& image1_path, const calib::CameraModel& camera1,
                                      const std::string& image2_path, const calib::CameraModel& camera2,
                                      const calib::ChessboardSpec& board, calib::CornerDetector detector,
                                      const std::string& name) {
  const std::vector<std::string> errors = board.Validate();
  if (!errors.empty()) throw InputError("planar target board: " + errors.front());
  if (camera1.WidthPx() != camera2.WidthPx() || camera1.HeightPx() != camera2.HeightPx()) {
    throw InputError(image2_path + ": its camera model's imager (" + std::to_string(camera2.WidthPx()) + " x " +
                     std::to_string(camera2.HeightPx()) + " px) differs from camera 1's (" +
                     std::to_string(camera1.WidthPx()) + " x " + std::to_string(camera1.HeightPx()) +
                     " px): one dataset holds one imager size");
  }
  const int width = camera1.WidthPx();
  const int height = camera1.HeightPx();
  const cv::Mat image1 = ReadGrey(image1_path, camera1);
  const cv::Mat image2 = ReadGrey(image2_path, camera2);

  PlanarTargetPair pair{Dataset(camera1), {}, cv::Rect(), false, 0.0, 0.0};
  pair.view[0] = MeasureView(image1_path, image1, camera1, board, detector);
  pair.view[1] = MeasureView(image2_path, image2, camera2, board, detector);
  const Rigid3d board_from_cam1 = pair.view[0].cam_from_board.Inverse();
  const Rigid3d board_from_cam2 = pair.view[1].cam_from_board.Inverse();
  if ((board_from_cam1.translation.z() > 0.0) != (board_from_cam2.translation.z() > 0.0)) {
    throw InputError(image2_path + ": PnP puts this camera on the other side of the board than " +
                     image1_path + "'s: the two images number the corners differently");
  }
  // Local: z toward the cameras.
  const Rigid3d local_from_board =
      board_from_cam1.translation.z() < 0.0
          ? Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(util::kPi, Eigen::Vector3d::UnitX())), Eigen::Vector3d::Zero())
          : Rigid3d();

  if (HasExtrinsics(camera1) || HasExtrinsics(camera2)) {
    const Rigid3d calibrated = camera2.CamFromRef() * camera1.CamFromRef().Inverse();
    const Rigid3d pnp = pair.view[1].cam_from_board * board_from_cam1;
    pair.has_calibrated_extrinsics = true;
    pair.extrinsics_rotation_diff_deg = RotationAngleDeg(pnp.rotation * calibrated.rotation.conjugate());
    pair.extrinsics_translation_diff = (pnp.translation - calibrated.translation).norm();
  }

  pair.board_box_px = LargestBoxInHull(pair.view[0].corners_px);
  std::vector<Eigen::Vector3d> bearings1;
  std::vector<unsigned char> valid1;
  PixelBearings(camera1, &bearings1, &valid1);
  const cv::Mat frame2 =
      &camera1 == &camera2 || camera1.ToText() == camera2.ToText()
          ? image2
          : ResampleIntoModel(image2, camera2, bearings1, valid1, width, height);

  Dataset& dataset = pair.dataset;
  dataset.name = name.empty() ? DefaultName(image1_path, image2_path) : name;
  dataset.description =
      "Planar target (" + board.SizeText() + " chessboard, spacing " + util::ShortestText(board.spacing) +
      "): frame 0 = " + fs::path(image1_path).filename().string() + ", frame 1 = " +
      fs::path(image2_path).filename().string() +
      (frame2.data == image2.data ? "" : " resampled into frame 0's camera model") +
      ", times 0 s and 1 s by convention. Navigation: each image's pose by PnP on the board; local "
      "frame: the board's, z toward the cameras; gravity along -z, so a slope is the angle to the "
      "board's normal. Truth: the board's plane over its squares. The board as one ROI: hdabench run "
      "--roi " + std::to_string(pair.board_box_px.x) + "," + std::to_string(pair.board_box_px.y) + "," +
      std::to_string(pair.board_box_px.width) + "," + std::to_string(pair.board_box_px.height) +
      " (docs/planar-target.md).";
  dataset.cam_from_body = Rigid3d();
  dataset.gravity_in_local_mps2 = Eigen::Vector3d(0.0, 0.0, -kStandardGravityMps2);
  dataset.ils_in_local_m =
      local_from_board * Eigen::Vector3d((board.width - 1) * board.spacing / 2.0,
                                         (board.height - 1) * board.spacing / 2.0, 0.0);
  dataset.lrf_origin_in_body_m = Eigen::Vector3d::Zero();
  internal::AddPairFrame(0, image1, local_from_board * board_from_cam1, pair.view[0].range_m,
                         Eigen::Vector3d::UnitZ(), &dataset);
  internal::AddPairFrame(1, frame2, local_from_board * board_from_cam2, pair.view[1].range_m,
                         Eigen::Vector3d::UnitZ(), &dataset);

  TruthPoints truth;
  truth.frame = 0;
  truth.file = "truth/points_000000.npy";
  truth.points_in_local_m =
      BoardTruthPoints(bearings1, valid1, board_from_cam1, local_from_board, board, width, height);
  dataset.truth.points.push_back(truth);
  return pair;
}

}  // namespace hdabench::datasets
