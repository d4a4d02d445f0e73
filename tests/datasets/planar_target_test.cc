// A real planar target as a dataset (datasets/planar_target.h): the board's
// box, PnP through an mrcal model, the resampling of image 2 into camera 1's
// model, the truth plane, and the errors, on the OpenCV stereo sample images
// with the bench's own calibration of them
// (tests/data/opencv-stereo-chessboard/mrcal).
#include "datasets/planar_target.h"

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/test_support.h"
#include "tools/images/codecs.h"
#include "tools/util/angles.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::InputErrorOf;

const fs::path kData = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard";

calib::CameraModel Model(int camera) {
  return calib::CameraModel::Load((kData / "mrcal" / ("camera-" + std::to_string(camera) + ".cameramodel")).string());
}

calib::ChessboardSpec Board() { return {9, 6, 1.0}; }

std::string Image(const std::string& side, const std::string& number) {
  return (kData / (side + number + ".jpg")).string();
}

TEST(PlanarTarget, LargestBoxInHullOfADiamondAndOfARectangle) {
  // |x - 50| + |y - 50| <= 20: the largest box is |dx|, |dy| <= 10.
  const std::vector<Eigen::Vector2d> diamond = {{30, 50}, {50, 30}, {70, 50}, {50, 70}, {50, 50}};
  EXPECT_EQ(LargestBoxInHull(diamond), cv::Rect(40, 40, 21, 21));
  // An axis-aligned rectangle with corners on pixel centres is its own box.
  const std::vector<Eigen::Vector2d> rectangle = {{10, 20}, {109, 20}, {109, 59}, {10, 59}};
  EXPECT_EQ(LargestBoxInHull(rectangle), cv::Rect(10, 20, 100, 40));
  // Fewer than three points, or a hull between pixel centres: no box.
  EXPECT_TRUE(LargestBoxInHull({{1, 1}, {5, 5}}).empty());
  EXPECT_TRUE(LargestBoxInHull({{1.2, 1.2}, {1.8, 1.2}, {1.5, 1.8}}).empty());
}

// PnP through a lens with distortion recovers an exactly projected board.
TEST(PlanarTarget, PnpThroughTheModelRecoversAProjectedBoard) {
  const calib::CameraModel camera = Model(0);
  const Rigid3d truth(Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(0.3, -1.0, 0.2).normalized())),
                      Eigen::Vector3d(-3.0, -2.0, 13.0));
  std::vector<Eigen::Vector3d> in_cam;
  for (int i = 0; i < 54; ++i) in_cam.push_back(truth * Eigen::Vector3d(i % 9, i / 9, 0.0));
  std::vector<Eigen::Vector2d> corners;
  std::vector<unsigned char> valid;
  ASSERT_EQ(camera.Project(in_cam, &corners, &valid), 54);
  double rms = -1.0, worst = -1.0;
  const Rigid3d pose = BoardPoseByPnp(camera, corners, Board(), "synthetic", &rms, &worst);
  EXPECT_LT((pose.translation - truth.translation).norm(), 1e-6);
  EXPECT_LT(pose.rotation.angularDistance(truth.rotation), 1e-8);
  EXPECT_LT(rms, 1e-6);
  EXPECT_LT(worst, 1e-6);
  // A wrong number of corners is refused.
  corners.pop_back();
  EXPECT_NE(InputErrorOf([&] { BoardPoseByPnp(camera, corners, Board(), "short", &rms, &worst); })
                .find("short: 53 corners for a 9x6 board"),
            std::string::npos);
}

// Pair 01 through both models: PnP fits the corners, its relative pose agrees
// with the calibrated extrinsics, the truth lies on the board, and image 2,
// resampled into camera 1's model, shows the board where camera 1's model puts
// it from camera 2's pose.
TEST(PlanarTarget, StereoPairBecomesADatasetWhoseImagesAndTruthAgreeWithPnp) {
  const calib::CameraModel camera1 = Model(0), camera2 = Model(1);
  const PlanarTargetPair pair =
      MakePlanarTargetPair(Image("left", "01"), camera1, Image("right", "01"), camera2, Board());
  for (const PlanarTargetView& view : pair.view) {
    EXPECT_LT(view.reprojection_rms_px, 0.3) << view.image_path;  // the calibration's 0.19 px
    EXPECT_GT(view.range_m, 11.0);
    EXPECT_LT(view.range_m, 17.0);
  }
  ASSERT_TRUE(pair.has_calibrated_extrinsics);
  EXPECT_LT(pair.extrinsics_rotation_diff_deg, 0.5);
  EXPECT_LT(pair.extrinsics_translation_diff, 0.1);  // squares, of a 3.3-square baseline
  const Dataset& dataset = pair.dataset;
  ASSERT_EQ(dataset.frames.size(), 2u);
  EXPECT_NEAR(dataset.BaselineM(0, 1), 3.3, 0.1);

  // The board's box is inside the board and covers a good part of its hull.
  const cv::Rect box = pair.board_box_px;
  EXPECT_GT(box.area(), 20000);
  const cv::Mat& truth = dataset.truth.points.at(0).points_in_local_m;
  for (const cv::Point& corner : {box.tl(), box.br() - cv::Point(1, 1)}) {
    const cv::Vec3f p = truth.at<cv::Vec3f>(corner);
    ASSERT_TRUE(std::isfinite(p[0])) << corner;
    EXPECT_NEAR(p[2], 0.0, 1e-4);  // on the board's plane (local z = 0)
  }
  EXPECT_FALSE(std::isfinite(truth.at<cv::Vec3f>(0, 0)[0]));  // the room, not the board

  // Up (local z) points from the board toward both cameras.
  EXPECT_GT(dataset.CameraCenterInLocal(0).z(), 0.0);
  EXPECT_GT(dataset.CameraCenterInLocal(1).z(), 0.0);

  // The board in the resampled image 2 against camera 1's model at camera 2's pose.
  const calib::CornerDetection found =
      calib::DetectChessboard(dataset.frames[1].image, Board(), calib::CornerDetector::kOpenCv);
  ASSERT_TRUE(found.found) << found.reason;
  const Rigid3d cam_from_local = dataset.CamFromLocal(1);
  const Rigid3d local_from_board = dataset.nav[0].local_from_body * pair.view[0].cam_from_board;
  std::vector<Eigen::Vector3d> in_cam;
  for (int i = 0; i < 54; ++i) in_cam.push_back(cam_from_local * (local_from_board * Eigen::Vector3d(i % 9, i / 9, 0)));
  std::vector<Eigen::Vector2d> expected;
  std::vector<unsigned char> valid;
  ASSERT_EQ(camera1.Project(in_cam, &expected, &valid), 54);
  double sum2 = 0.0;
  for (int i = 0; i < 54; ++i) sum2 += (expected[static_cast<size_t>(i)] - found.corners[static_cast<size_t>(i)]).squaredNorm();
  EXPECT_LT(std::sqrt(sum2 / 54.0), 0.4);  // PnP's 0.19 px plus the bilinear resampling

  // Written and read back whole.
  const fs::path dir = FreshTestDir() / "target";
  WriteDataset(dataset, dir.string());
  const DatasetLoadResult loaded = LoadDataset(dir.string());
  EXPECT_TRUE(loaded.Ok()) << (loaded.problems.empty() ? "" : loaded.problems.front().ToString());
}

TEST(PlanarTarget, OneCameraForBothImagesIsNotResampled) {
  const calib::CameraModel camera = Model(0);
  const PlanarTargetPair pair =
      MakePlanarTargetPair(Image("left", "02"), camera, Image("left", "03"), camera, Board());
  const cv::Mat original = hdabench::images::Read(Image("left", "03"), cv::IMREAD_GRAYSCALE);
  EXPECT_EQ(cv::norm(pair.dataset.frames[1].image, original, cv::NORM_INF), 0.0);
  EXPECT_FALSE(pair.has_calibrated_extrinsics);
}

TEST(PlanarTarget, UnusableInputsAreNamed) {
  const calib::CameraModel camera = Model(0);
  const fs::path dir = FreshTestDir();
  EXPECT_NE(InputErrorOf([&] {
              MakePlanarTargetPair((dir / "none.jpg").string(), camera, Image("right", "01"), camera, Board());
            }).find("none.jpg: file not found"),
            std::string::npos);
  // A folder is named as one.
  EXPECT_NE(InputErrorOf([&] {
              MakePlanarTargetPair(dir.string(), camera, Image("right", "01"), camera, Board());
            }).find(dir.string() + ": is a directory; expected a file"),
            std::string::npos);
  // An image without the board.
  const fs::path blank = dir / "blank.png";
  hdabench::images::Write(blank.string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  EXPECT_NE(InputErrorOf([&] {
              MakePlanarTargetPair(Image("left", "01"), camera, blank.string(), camera, Board());
            }).find("blank.png: no 9x6 chessboard found"),
            std::string::npos);
  // An image of another size than its model.
  const fs::path small = dir / "small.png";
  hdabench::images::Write(small.string(), cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)));
  EXPECT_NE(InputErrorOf([&] {
              MakePlanarTargetPair(small.string(), camera, Image("right", "01"), camera, Board());
            }).find("small.png: 320 x 240 px, but its camera model is 640 x 480 px"),
            std::string::npos);
  // A board spec that cannot be.
  EXPECT_NE(InputErrorOf([&] {
              MakePlanarTargetPair(Image("left", "01"), camera, Image("right", "01"), camera, {9, 6, -1.0});
            }).find("planar target board:"),
            std::string::npos);
}

}  // namespace
}  // namespace hdabench::datasets
