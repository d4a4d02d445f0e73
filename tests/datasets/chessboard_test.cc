// Tests of the synthetic chessboard views (datasets/synth/chessboard.h): the
// rendering is deterministic, shows the board where its pose puts it, and
// OpenCV's detector (the calibration command's detector for non-square boards)
// finds every corner where the truth says, in the truth's order; the poses
// spread over the imager as a calibration set needs; bad options are refused;
// the writer's files read back.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/camera_model.h"
#include "tools/images/codecs.h"
#include "tools/util/error.h"
#include "datasets/synth/chessboard.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets::synth {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::SplitCsv;
using testing_support::SplitLines;

// 640 x 480, f = 500 px, strong barrel distortion: the corners of the imager
// move by ~40 px, so a renderer that ignored the lens would be far off.
calib::CameraModel DistortedOpenCv8() {
  return calib::CameraModel("LENSMODEL_OPENCV8",
                            {500.0, 500.0, 319.5, 239.5, -0.3, 0.1, 0.001, -0.0015, 0.0, 0.0, 0.0, 0.0}, 640,
                            480);
}

// A splined stereographic lens with a smooth, non-zero correction on every
// knot (a few pixels), so the rendering goes through the spline surface.
calib::CameraModel SplinedStereographic() {
  const int nx = 16;
  const int ny = 12;
  std::vector<double> intrinsics = {420.0, 420.0, 322.0, 236.0};
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      intrinsics.push_back(0.01 * std::sin(0.5 * i + 0.3 * j));
      intrinsics.push_back(0.01 * std::cos(0.4 * i - 0.2 * j));
    }
  }
  return calib::CameraModel("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100", intrinsics,
                            640, 480);
}

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  return a.type() == b.type() && a.size() == b.size() && a.isContinuous() && b.isContinuous() &&
         std::memcmp(a.data, b.data, a.total() * a.elemSize()) == 0;
}

struct Detection {
  bool found = false;
  std::vector<Eigen::Vector2d> corners;
};

// OpenCV's detector with the calibration command's settings
// (calib/chessboard.cc): adaptive threshold and normalisation, then
// cornerSubPix with a half-window of a third of the smallest corner spacing
// (3..11 px), to 0.001 px or 40 iterations. The order is OpenCV's, untouched.
Detection DetectWithOpenCv(const cv::Mat& image, int corners_x, int corners_y) {
  Detection detection;
  std::vector<cv::Point2f> corners;
  detection.found = cv::findChessboardCorners(image, cv::Size(corners_x, corners_y), corners,
                                              cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  if (!detection.found || corners.size() != static_cast<size_t>(corners_x * corners_y)) {
    detection.found = false;
    return detection;
  }
  const auto at = [&](int i, int j) { return corners[static_cast<size_t>(j * corners_x + i)]; };
  double smallest = 1e30;
  for (int j = 0; j < corners_y; ++j) {
    for (int i = 0; i < corners_x; ++i) {
      if (i + 1 < corners_x) smallest = std::min(smallest, cv::norm(at(i + 1, j) - at(i, j)));
      if (j + 1 < corners_y) smallest = std::min(smallest, cv::norm(at(i, j + 1) - at(i, j)));
    }
  }
  const int half = std::clamp(static_cast<int>(std::lround(smallest / 3.0)), 3, 11);
  cv::cornerSubPix(image, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001));
  for (const cv::Point2f& p : corners) detection.corners.emplace_back(p.x, p.y);
  return detection;
}

// Detector error bounds. With 4 x 4 supersampling and noise sigma 2 (of a
// 190-level step), cornerSubPix on these pixel-integrated, unblurred edges
// scatters by ~0.05 px RMS: the same without noise (0.059 px measured) and
// barely less with 16 x 16 samples (0.050 px), so the floor is the
// detector's own locking to the pixel grid on sharp edges, not the
// rendering. Noise adds ~sigma / (contrast * sqrt(edge pixels in the window))
// ~ 2 / (190 * 4) ~ 0.003 px. A renderer off by a quarter pixel anywhere, or
// ignoring the lens, would be far above these bounds.
constexpr double kMaxRmsPx = 0.1;
constexpr double kMaxCornerErrorPx = 0.35;

struct Agreement {
  int views_found = 0;
  int views_same_order = 0;
  int views_reversed = 0;
  double rms_px = 0.0;
  double max_px = 0.0;
};

// Detects every view and compares with its truth in the truth's order.
Agreement CompareWithOpenCv(const std::vector<ChessboardView>& views, const ChessboardBoard& board) {
  Agreement agreement;
  double sum_squared = 0.0;
  size_t count = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    const Detection detection = DetectWithOpenCv(views[v].image, board.corners_x, board.corners_y);
    EXPECT_TRUE(detection.found);
    if (!detection.found) continue;
    ++agreement.views_found;
    const std::vector<Eigen::Vector2d>& truth = views[v].true_corners_px;
    EXPECT_EQ(detection.corners.size(), truth.size());
    if (detection.corners.size() != truth.size()) continue;
    const size_t n = truth.size();
    const Eigen::Vector2d& first = detection.corners.front();
    const bool same = (first - truth.front()).norm() < (first - truth.back()).norm();
    (same ? agreement.views_same_order : agreement.views_reversed) += 1;
    for (size_t k = 0; k < n; ++k) {
      const double error = (detection.corners[k] - truth[same ? k : n - 1 - k]).norm();
      sum_squared += error * error;
      agreement.max_px = std::max(agreement.max_px, error);
      ++count;
    }
  }
  agreement.rms_px = count > 0 ? std::sqrt(sum_squared / static_cast<double>(count)) : 0.0;
  return agreement;
}

// The rule the generator promises: each corner at least `squares` times its
// largest distance to a neighbouring corner from the imager's edge.
double WorstBorderRatio(const ChessboardView& view, const ChessboardBoard& board, int width, int height) {
  double worst = 1e30;
  const auto& c = view.true_corners_px;
  for (int j = 0; j < board.corners_y; ++j) {
    for (int i = 0; i < board.corners_x; ++i) {
      const Eigen::Vector2d& p = c[static_cast<size_t>(j * board.corners_x + i)];
      double square = 0.0;
      for (const auto& [di, dj] : {std::pair{-1, 0}, std::pair{1, 0}, std::pair{0, -1}, std::pair{0, 1}}) {
        const int ni = i + di;
        const int nj = j + dj;
        if (ni < 0 || nj < 0 || ni >= board.corners_x || nj >= board.corners_y) continue;
        square = std::max(square, (c[static_cast<size_t>(nj * board.corners_x + ni)] - p).norm());
      }
      const double to_edge = std::min({p.x() + 0.5, width - 0.5 - p.x(), p.y() + 0.5, height - 0.5 - p.y()});
      worst = std::min(worst, to_edge / square);
    }
  }
  return worst;
}

TEST(ChessboardViews, SameBytesTwiceAndForAnyThreadCount) {
  const calib::CameraModel camera = DistortedOpenCv8();
  ChessboardViewsOptions options;
  options.views = 4;
  options.supersampling = 2;
  options.seed = 7;
  options.threads = 1;
  const std::vector<ChessboardView> first = RenderChessboardViews(camera, ChessboardBoard(), options);
  options.threads = 3;
  const std::vector<ChessboardView> second = RenderChessboardViews(camera, ChessboardBoard(), options);
  ASSERT_EQ(first.size(), 4u);
  ASSERT_EQ(second.size(), 4u);
  for (size_t v = 0; v < first.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    EXPECT_EQ(first[v].image.type(), CV_8UC1);
    EXPECT_EQ(first[v].image.cols, 640);
    EXPECT_EQ(first[v].image.rows, 480);
    EXPECT_TRUE(SameBytes(first[v].image, second[v].image));
    EXPECT_EQ(first[v].true_corners_px, second[v].true_corners_px);
    EXPECT_EQ(first[v].cam_from_board.rotation.coeffs(), second[v].cam_from_board.rotation.coeffs());
    EXPECT_EQ(first[v].cam_from_board.translation, second[v].cam_from_board.translation);
  }
  // Another seed, other views.
  options.seed = 8;
  const std::vector<ChessboardView> other = RenderChessboardViews(camera, ChessboardBoard(), options);
  EXPECT_FALSE(SameBytes(first[0].image, other[0].image));
  EXPECT_NE(first[0].true_corners_px, other[0].true_corners_px);
}

// The true corners are the model's projection of the board corners at the
// view's pose, and the pose keeps the board in front of the camera.
void ExpectTruthIsProjection(const calib::CameraModel& camera, const std::vector<ChessboardView>& views,
                             const ChessboardBoard& board) {
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    std::vector<Eigen::Vector3d> points;
    for (int j = 0; j < board.corners_y; ++j) {
      for (int i = 0; i < board.corners_x; ++i) {
        points.push_back(views[v].cam_from_board * Eigen::Vector3d(i * board.spacing_m, j * board.spacing_m, 0.0));
        EXPECT_GT(points.back().z(), 0.0);
      }
    }
    std::vector<Eigen::Vector2d> pixels;
    std::vector<unsigned char> valid;
    ASSERT_EQ(camera.Project(points, &pixels, &valid), static_cast<int>(points.size()));
    ASSERT_EQ(pixels.size(), views[v].true_corners_px.size());
    for (size_t k = 0; k < pixels.size(); ++k) EXPECT_LT((pixels[k] - views[v].true_corners_px[k]).norm(), 1e-9);
    EXPECT_TRUE(views[v].all_corners_visible);
  }
}

TEST(ChessboardViews, OpenCvFindsTheTrueCornersThroughOpenCv8) {
  const calib::CameraModel camera = DistortedOpenCv8();
  const ChessboardBoard board;
  ChessboardViewsOptions options;  // 20 views, 4 x 4 samples, noise 2
  const auto start = std::chrono::steady_clock::now();
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  RecordProperty("render_s", std::to_string(seconds));
  std::printf("20 views 640x480, 4x4 samples: %.2f s\n", seconds);
  ASSERT_EQ(views.size(), 20u);
  ExpectTruthIsProjection(camera, views, board);

  const Agreement agreement = CompareWithOpenCv(views, board);
  std::printf("OPENCV8: %d/20 found, %d in the truth's order, %d reversed; RMS %.4f px, max %.4f px\n",
              agreement.views_found, agreement.views_same_order, agreement.views_reversed, agreement.rms_px,
              agreement.max_px);
  EXPECT_EQ(agreement.views_found, 20);
  // With the board rolled by at most 20 degrees, OpenCV reports a 9 x 6
  // board in the truth's order: corner (0, 0) first, corners_x per row.
  EXPECT_EQ(agreement.views_same_order, 20);
  EXPECT_EQ(agreement.views_reversed, 0);
  EXPECT_LT(agreement.rms_px, kMaxRmsPx);
  EXPECT_LT(agreement.max_px, kMaxCornerErrorPx);
  // And the calibration command's own normalisation (first corner nearer the
  // image's top-left, calib/chessboard.h) keeps that order.
  for (const ChessboardView& view : views) {
    EXPECT_LT(view.true_corners_px.front().sum(), view.true_corners_px.back().sum());
  }
}

TEST(ChessboardViews, OpenCvFindsTheTrueCornersThroughASplinedStereographicLens) {
  const calib::CameraModel camera = SplinedStereographic();
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.views = 9;  // one round of anchors: corners, edges, centre
  options.seed = 3;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  ASSERT_EQ(views.size(), 9u);
  ExpectTruthIsProjection(camera, views, board);
  const Agreement agreement = CompareWithOpenCv(views, board);
  std::printf("splined stereographic: %d/9 found, %d in order, %d reversed; RMS %.4f px, max %.4f px\n",
              agreement.views_found, agreement.views_same_order, agreement.views_reversed, agreement.rms_px,
              agreement.max_px);
  EXPECT_EQ(agreement.views_found, 9);
  EXPECT_EQ(agreement.views_same_order, 9);
  EXPECT_LT(agreement.rms_px, kMaxRmsPx);
  EXPECT_LT(agreement.max_px, kMaxCornerErrorPx);
}

TEST(ChessboardViews, OpticalBlurKeepsTheCornersInPlace) {
  // A point-spread function smooths the edges symmetrically about each
  // corner, so the detector still finds the truth (and locks less to the
  // pixel grid).
  const calib::CameraModel camera = DistortedOpenCv8();
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.views = 6;
  options.blur_sigma_px = 0.8;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  const Agreement agreement = CompareWithOpenCv(views, board);
  std::printf("blur 0.8 px: %d/6 found; RMS %.4f px, max %.4f px\n", agreement.views_found, agreement.rms_px,
              agreement.max_px);
  EXPECT_EQ(agreement.views_found, 6);
  EXPECT_EQ(agreement.views_same_order, 6);
  EXPECT_LT(agreement.rms_px, kMaxRmsPx);
  EXPECT_LT(agreement.max_px, kMaxCornerErrorPx);
}

// Square boards look the same turned by 90 degrees, so OpenCV may start from
// any corner: each detected corner is matched to its nearest true corner.
TEST(ChessboardViews, SquareBoardRendersAndIsFound) {
  const calib::CameraModel camera = DistortedOpenCv8();
  ChessboardBoard board;
  board.corners_x = 10;
  board.corners_y = 10;
  board.spacing_m = 0.02;
  ChessboardViewsOptions options;
  options.views = 5;
  options.seed = 11;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  ASSERT_EQ(views.size(), 5u);
  ExpectTruthIsProjection(camera, views, board);
  double sum_squared = 0.0;
  size_t count = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    ASSERT_EQ(views[v].true_corners_px.size(), 100u);
    const Detection detection = DetectWithOpenCv(views[v].image, 10, 10);
    ASSERT_TRUE(detection.found);
    std::vector<int> matched(100, 0);
    for (const Eigen::Vector2d& corner : detection.corners) {
      size_t nearest = 0;
      for (size_t k = 1; k < 100; ++k) {
        if ((views[v].true_corners_px[k] - corner).norm() < (views[v].true_corners_px[nearest] - corner).norm()) {
          nearest = k;
        }
      }
      ++matched[nearest];
      const double error = (views[v].true_corners_px[nearest] - corner).norm();
      EXPECT_LT(error, kMaxCornerErrorPx);
      sum_squared += error * error;
      ++count;
    }
    EXPECT_EQ(std::count(matched.begin(), matched.end(), 1), 100);  // one detection per true corner
  }
  const double rms = std::sqrt(sum_squared / static_cast<double>(std::max<size_t>(1, count)));
  std::printf("10x10 board: RMS %.4f px\n", rms);
  EXPECT_LT(rms, kMaxRmsPx);
}

// Without noise, a pixel well inside a square, the margin or the background
// has exactly that region's grey level (the background a plane in x, y).
TEST(ChessboardViews, NoiseFreePixelsShowWhatTheirRayHits) {
  const calib::CameraModel camera = DistortedOpenCv8();
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.views = 3;
  options.noise_sigma = 0.0;
  options.supersampling = 2;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    const Rigid3d board_from_cam = views[v].cam_from_board.Inverse();
    std::vector<Eigen::Vector2d> pixels;
    for (int row = 2; row < 480; row += 7) {
      for (int col = 2; col < 640; col += 7) pixels.emplace_back(col, row);
    }
    std::vector<Eigen::Vector3d> bearings;
    std::vector<unsigned char> valid;
    ASSERT_EQ(camera.Unproject(pixels, &bearings, &valid), static_cast<int>(pixels.size()));
    int squares = 0;
    int margin = 0;
    std::vector<Eigen::Vector3d> background;  // x, y, value
    for (size_t k = 0; k < pixels.size(); ++k) {
      // Ray from the camera centre to the board plane, in board coordinates
      // (squares).
      const Eigen::Vector3d origin = board_from_cam.translation;
      const Eigen::Vector3d direction = board_from_cam.rotation * bearings[k];
      ASSERT_GT(direction.z(), 0.0);
      const Eigen::Vector3d hit = origin - origin.z() / direction.z() * direction;
      const double u = hit.x() / board.spacing_m;
      const double w = hit.y() / board.spacing_m;
      // Keep away from every boundary by 0.2 squares (>= 2 px here).
      const auto clear = [](double a) { return std::abs(a - std::round(a)) > 0.2; };
      const int value =
          views[v].image.at<unsigned char>(static_cast<int>(pixels[k].y()), static_cast<int>(pixels[k].x()));
      const double outer = 1.0 + board.margin_squares;
      if (u > -1 && w > -1 && u < board.corners_x && w < board.corners_y) {
        if (!clear(u) || !clear(w)) continue;
        const bool black = ((static_cast<int>(std::floor(u)) + static_cast<int>(std::floor(w))) & 1) == 0;
        EXPECT_EQ(value, black ? 30 : 220) << "square at u " << u << ", v " << w;
        ++squares;
      } else if (u > -outer && w > -outer && u < board.corners_x - 1 + outer && w < board.corners_y - 1 + outer) {
        const double to_outside =
            std::min({u + outer, w + outer, board.corners_x - 1 + outer - u, board.corners_y - 1 + outer - w});
        if (to_outside < 0.2 ||
            std::max({-1.0 - u, -1.0 - w, u - board.corners_x, w - board.corners_y}) < 0.2) {
          continue;
        }
        EXPECT_EQ(value, 220) << "margin at u " << u << ", v " << w;
        ++margin;
      } else if (std::max({-outer - u, -outer - w, u - (board.corners_x - 1 + outer),
                           w - (board.corners_y - 1 + outer)}) > 0.2) {
        background.emplace_back(pixels[k].x(), pixels[k].y(), value);
      }
    }
    EXPECT_GT(squares, 50);
    EXPECT_GT(margin, 5);
    ASSERT_GT(background.size(), 100u);
    // The background: a plane in (x, y) to within the rounding, and not flat.
    Eigen::MatrixXd a(background.size(), 3);
    Eigen::VectorXd b(background.size());
    for (size_t k = 0; k < background.size(); ++k) {
      a.row(static_cast<Eigen::Index>(k)) << 1.0, background[k].x(), background[k].y();
      b(static_cast<Eigen::Index>(k)) = background[k].z();
    }
    const Eigen::Vector3d plane = a.colPivHouseholderQr().solve(b);
    EXPECT_LT((a * plane - b).cwiseAbs().maxCoeff(), 0.51);
    EXPECT_NEAR(plane(0) + plane(1) * 319.5 + plane(2) * 239.5, options.background, 0.5);
    // It changes by background_gradient from one side of the imager to the other.
    EXPECT_NEAR(std::hypot(plane(1) * 639.0, plane(2) * 479.0), options.background_gradient, 0.5);
  }
}

// A check of the rendering at the sub-pixel level that does not go through a
// corner detector. Through a pinhole lens every square is a quadrilateral
// with straight sides, so the area and centroid of the black squares follow
// exactly from the projected square corners (shoelace formula). The image
// gives the same from each pixel's blackness (white - value) / (white -
// black), summed inside the margin: the margin is white, so it adds nothing.
// Measured: areas within 3e-4, centroids within 0.02 px; the differences
// come from the 4 x 4 samples at the edges and the rounding to 8 bits. A
// renderer shifted by a fraction of a pixel (e.g. a pixel-centre convention
// off by 0.5) would miss by that fraction.
TEST(ChessboardViews, BlackAreaAndCentroidMatchTheProjectedSquares) {
  const calib::CameraModel camera("LENSMODEL_PINHOLE", {500.0, 500.0, 319.5, 239.5}, 640, 480);
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.views = 4;
  options.noise_sigma = 0.0;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    const ChessboardView& view = views[v];
    const auto project = [&](double u, double w) {
      std::vector<Eigen::Vector2d> pixels;
      std::vector<unsigned char> valid;
      const Eigen::Vector3d point = Eigen::Vector3d(u * board.spacing_m, w * board.spacing_m, 0.0);
      camera.Project({view.cam_from_board * point}, &pixels, &valid);
      return pixels[0];
    };
    double area = 0.0;
    Eigen::Vector2d moment = Eigen::Vector2d::Zero();
    for (int iw = -1; iw < board.corners_y; ++iw) {
      for (int iu = -1; iu < board.corners_x; ++iu) {
        if (((iu + iw) & 1) != 0) continue;  // white
        const Eigen::Vector2d quad[4] = {project(iu, iw), project(iu + 1, iw), project(iu + 1, iw + 1),
                                         project(iu, iw + 1)};
        double twice_area = 0.0;
        Eigen::Vector2d sum = Eigen::Vector2d::Zero();
        for (int k = 0; k < 4; ++k) {
          const Eigen::Vector2d& a = quad[k];
          const Eigen::Vector2d& b = quad[(k + 1) % 4];
          const double cross = a.x() * b.y() - b.x() * a.y();
          twice_area += cross;
          sum += (a + b) * cross;
        }
        const Eigen::Vector2d centroid = sum / (3.0 * twice_area);
        area += std::abs(twice_area) / 2.0;
        moment += std::abs(twice_area) / 2.0 * centroid;
      }
    }
    // Half-way through the margin: inside it every pixel is square or margin.
    const double half = board.margin_squares / 2.0;
    std::vector<cv::Point2f> outline;
    for (const auto& [u, w] : {std::pair{-1.0 - half, -1.0 - half}, std::pair{board.corners_x + half, -1.0 - half},
                               std::pair{board.corners_x + half, board.corners_y + half},
                               std::pair{-1.0 - half, board.corners_y + half}}) {
      const Eigen::Vector2d q = project(u, w);
      outline.emplace_back(static_cast<float>(q.x()), static_cast<float>(q.y()));
    }
    double image_area = 0.0;
    Eigen::Vector2d image_moment = Eigen::Vector2d::Zero();
    for (int row = 0; row < 480; ++row) {
      for (int col = 0; col < 640; ++col) {
        const cv::Point2f centre(static_cast<float>(col), static_cast<float>(row));
        if (cv::pointPolygonTest(outline, centre, false) < 0) continue;
        const double blackness =
            (options.white - view.image.at<unsigned char>(row, col)) / (options.white - options.black);
        image_area += blackness;
        image_moment += blackness * Eigen::Vector2d(col, row);
      }
    }
    EXPECT_NEAR(image_area / area, 1.0, 1e-3);
    EXPECT_LT((image_moment / image_area - moment / area).norm(), 0.05)
        << "image " << (image_moment / image_area).transpose() << ", squares " << (moment / area).transpose();
  }
}

// Poses like a good calibration set: corners reach every part of the imager,
// distances and tilts spread over their ranges, and every corner keeps the
// promised distance from the border.
TEST(ChessboardViews, PosesSpreadOverTheImagerAndTheRanges) {
  const calib::CameraModel camera = DistortedOpenCv8();
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.supersampling = 1;  // the poses do not depend on it
  options.noise_sigma = 0.0;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, board, options);
  ASSERT_EQ(views.size(), 20u);
  // Coverage on an 8 x 6 grid of 80 px cells.
  std::vector<int> cells(48, 0);
  std::vector<int> quadrants(4, 0);
  double near_corner[4] = {1e30, 1e30, 1e30, 1e30};
  const Eigen::Vector2d imager_corners[4] = {{-0.5, -0.5}, {639.5, -0.5}, {639.5, 479.5}, {-0.5, 479.5}};
  double shortest = 1e30;
  double longest = 0.0;
  int tilt_axis_quadrants[4] = {0, 0, 0, 0};
  for (size_t v = 0; v < views.size(); ++v) {
    SCOPED_TRACE("view " + std::to_string(v + 1));
    const ChessboardView& view = views[v];
    EXPECT_GE(WorstBorderRatio(view, board, 640, 480), options.min_border_squares - 1e-9);
    for (const Eigen::Vector2d& p : view.true_corners_px) {
      ++cells[static_cast<size_t>(std::clamp(static_cast<int>((p.y() + 0.5) / 80), 0, 5) * 8 +
                                  std::clamp(static_cast<int>((p.x() + 0.5) / 80), 0, 7))];
      ++quadrants[static_cast<size_t>((p.x() > 319.5 ? 1 : 0) + (p.y() > 239.5 ? 2 : 0))];
      for (int c = 0; c < 4; ++c) near_corner[c] = std::min(near_corner[c], (p - imager_corners[c]).norm());
    }
    EXPECT_GE(view.tilt_deg, options.min_tilt_deg - 1e-6);
    EXPECT_LE(view.tilt_deg, options.max_tilt_deg + 1e-6);
    shortest = std::min(shortest, view.distance_m);
    longest = std::max(longest, view.distance_m);
    // Which way the board leans: its normal's direction across the line of sight.
    const Eigen::Vector3d centre =
        view.cam_from_board * Eigen::Vector3d(4 * board.spacing_m, 2.5 * board.spacing_m, 0);
    const Eigen::Vector3d normal = view.cam_from_board.rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d lean = normal - normal.dot(centre.normalized()) * centre.normalized();
    ++tilt_axis_quadrants[(lean.x() > 0 ? 1 : 0) + (lean.y() > 0 ? 2 : 0)];
  }
  for (int q = 0; q < 4; ++q) EXPECT_GT(quadrants[static_cast<size_t>(q)], 100) << "quadrant " << q;
  for (int q = 0; q < 4; ++q) EXPECT_GE(tilt_axis_quadrants[q], 1) << "lean quadrant " << q;
  for (int row = 0; row < 6; ++row) {
    for (int col = 0; col < 8; ++col) {
      if (row == 0 || row == 5 || col == 0 || col == 7) {
        EXPECT_GT(cells[static_cast<size_t>(row * 8 + col)], 0) << "border cell row " << row << " col " << col;
      }
    }
  }
  // The border cells include the imager's corner cells: some corner lies
  // within 80 px of each imager corner along both axes. The border rule keeps
  // it at least 1.5 squares (20-50 px here) from both edges.
  EXPECT_GT(longest / shortest, 1.8);
  std::printf("distances %.3f - %.3f m; nearest corner to each imager corner %.0f %.0f %.0f %.0f px\n", shortest,
              longest, near_corner[0], near_corner[1], near_corner[2], near_corner[3]);

  // A poorer set when asked: coverage 0.3 keeps the corners off the edges.
  options.coverage = 0.3;
  options.views = 9;
  double closest_to_edge = 1e30;
  for (const ChessboardView& view : RenderChessboardViews(camera, board, options)) {
    for (const Eigen::Vector2d& p : view.true_corners_px) {
      closest_to_edge = std::min({closest_to_edge, p.x(), p.y(), 639.0 - p.x(), 479.0 - p.y()});
    }
  }
  EXPECT_GT(closest_to_edge, 40.0);
}

TEST(ChessboardViews, ExplicitDistancesAreUsed) {
  const calib::CameraModel camera = DistortedOpenCv8();
  ChessboardViewsOptions options;
  options.views = 6;
  options.supersampling = 1;
  options.min_distance_m = 0.5;
  options.max_distance_m = 0.7;
  const std::vector<ChessboardView> views = RenderChessboardViews(camera, ChessboardBoard(), options);
  for (const ChessboardView& view : views) {
    EXPECT_GE(view.distance_m, 0.5 - 1e-9);
    EXPECT_LE(view.distance_m, 0.7 + 1e-9);
  }
}

TEST(ChessboardViews, BadOptionsListEveryProblem) {
  const calib::CameraModel camera = DistortedOpenCv8();
  ChessboardBoard board;
  board.corners_x = 1;
  board.spacing_m = -0.03;
  ChessboardViewsOptions options;
  options.views = 0;
  options.supersampling = 0;
  options.noise_sigma = -1.0;
  options.white = 10.0;  // below black
  options.max_tilt_deg = std::nan("");
  options.min_distance_m = 0.5;  // max_distance_m left 0
  try {
    RenderChessboardViews(camera, board, options);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    const std::string message = error.what();
    for (const char* field : {"corners_x = 1", "spacing_m = -0.03", "views = 0", "supersampling = 0",
                              "noise_sigma = -1", "white = 10", "max_tilt_deg = nan", "max_distance_m = 0"}) {
      EXPECT_NE(message.find(field), std::string::npos) << field << " missing from: " << message;
    }
    EXPECT_EQ(message.find("corners_y"), std::string::npos) << message;
  }
  EXPECT_TRUE(ChessboardBoard().Validate().empty());
  EXPECT_TRUE(ChessboardViewsOptions().Validate().empty());
}

TEST(ChessboardViews, BoardThatCannotFitThrows) {
  // A 2 m board at 0.3 m cannot keep its corners inside a 640 x 480 imager.
  ChessboardBoard board;
  board.spacing_m = 0.25;
  ChessboardViewsOptions options;
  options.views = 1;
  options.min_distance_m = 0.3;
  options.max_distance_m = 0.3;
  options.max_attempts = 50;
  try {
    RenderChessboardViews(DistortedOpenCv8(), board, options);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find("no pose out of 50"), std::string::npos) << error.what();
  }
}

TEST(WriteChessboardViews, WritesImagesTruthAndPoses) {
  const fs::path dir = FreshTestDir() / "views";
  const ChessboardBoard board;
  ChessboardViewsOptions options;
  options.views = 3;
  options.supersampling = 1;
  const std::vector<ChessboardView> views = RenderChessboardViews(DistortedOpenCv8(), board, options);
  WriteChessboardViews(views, dir.string(), "cam0-");
  std::vector<std::string> names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names,
            (std::vector<std::string>{"cam0-01.png", "cam0-02.png", "cam0-03.png", "poses.csv", "truth.csv"}));
  for (size_t v = 0; v < views.size(); ++v) {
    const cv::Mat image = hdabench::images::Read((dir / names[v]).string(), cv::IMREAD_UNCHANGED);
    EXPECT_TRUE(SameBytes(image, views[v].image)) << names[v];
  }
  const std::vector<std::string> truth = SplitLines(ReadText(dir / "truth.csv"));
  ASSERT_EQ(truth.size(), 1 + 3 * 54u);
  EXPECT_EQ(truth[0], "view,corner,x_px,y_px");
  // Every value reads back bit-identical.
  for (size_t line = 1; line < truth.size(); ++line) {
    const std::vector<std::string> fields = SplitCsv(truth[line]);
    ASSERT_EQ(fields.size(), 4u);
    const size_t v = std::stoul(fields[0]) - 1;
    const size_t k = std::stoul(fields[1]);
    ASSERT_LT(v, 3u);
    ASSERT_LT(k, 54u);
    EXPECT_EQ(std::stod(fields[2]), views[v].true_corners_px[k].x());
    EXPECT_EQ(std::stod(fields[3]), views[v].true_corners_px[k].y());
  }
  const std::vector<std::string> poses = SplitLines(ReadText(dir / "poses.csv"));
  ASSERT_EQ(poses.size(), 4u);
  EXPECT_EQ(poses[0], "view,image,qw,qx,qy,qz,tx_m,ty_m,tz_m,distance_m,tilt_deg");
  for (size_t v = 0; v < 3; ++v) {
    const std::vector<std::string> fields = SplitCsv(poses[v + 1]);
    ASSERT_EQ(fields.size(), 11u);
    EXPECT_EQ(fields[1], names[v]);
    const Rigid3d& pose = views[v].cam_from_board;
    EXPECT_EQ(std::stod(fields[2]), pose.rotation.w());
    EXPECT_EQ(std::stod(fields[5]), pose.rotation.z());
    EXPECT_EQ(std::stod(fields[8]), pose.translation.z());
  }
  // No temporary file left behind.
  for (const std::string& name : names) EXPECT_EQ(name.find(".tmp"), std::string::npos);
}

TEST(WriteChessboardViews, UnwritableFolderThrowsNamingIt) {
  const fs::path dir = FreshTestDir();
  testing_support::WriteText(dir / "a-file", "not a folder");
  ChessboardViewsOptions options;
  options.views = 1;
  options.supersampling = 1;
  const std::vector<ChessboardView> views = RenderChessboardViews(DistortedOpenCv8(), ChessboardBoard(), options);
  const std::string target = (dir / "a-file" / "views").string();
  try {
    WriteChessboardViews(views, target, "view");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(target), std::string::npos) << error.what();
  }
  EXPECT_THROW(WriteChessboardViews(views, (dir / "ok").string(), "sub/view"), InputError);
  EXPECT_THROW(WriteChessboardViews({}, (dir / "ok").string(), "view"), InputError);
}

}  // namespace
}  // namespace hdabench::datasets::synth
