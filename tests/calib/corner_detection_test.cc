// Chessboard detection, the corner order, corners.vnl, and the calibration's
// failure paths that the command-line tests cannot reach.
#include "calib/chessboard.h"

#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/calibrate.h"
#include "tools/images/codecs.h"
#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::calib {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::SplitLines;

const fs::path kBoardData = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard";

cv::Mat Left(int index) {
  char name[32];
  std::snprintf(name, sizeof(name), "left%02d.jpg", index);
  return hdabench::images::Read((kBoardData / name).string(), cv::IMREAD_GRAYSCALE);
}

TEST(Chessboard, FindsAll54CornersRowMajorWithTheDarkEndFirst) {
  const cv::Mat image = Left(1);
  ASSERT_FALSE(image.empty());
  const ChessboardSpec board{9, 6, 1.0};
  const CornerDetection d = DetectChessboard(image, board, CornerDetector::kAuto);
  ASSERT_TRUE(d.found) << d.reason;
  EXPECT_EQ(d.detector, "opencv");
  ASSERT_EQ(d.corners.size(), 54u);
  ASSERT_EQ(d.levels.size(), 54u);
  // Row-major: neighbours along a row are one square apart, and the first
  // row's direction differs from the column direction.
  const Eigen::Vector2d along = d.corners[1] - d.corners[0];
  const Eigen::Vector2d down = d.corners[9] - d.corners[0];
  EXPECT_GT(along.norm(), 10.0);
  EXPECT_GT(down.norm(), 10.0);
  EXPECT_LT(std::abs(along.normalized().dot(down.normalized())), 0.5);
  // The image turned by a half turn shows the same board: the bench reports
  // the same physical corner first (the dark end), so corner i lands where
  // the turned image puts it.
  cv::Mat turned;
  cv::rotate(image, turned, cv::ROTATE_180);
  const CornerDetection t = DetectChessboard(turned, board, CornerDetector::kOpenCv);
  ASSERT_TRUE(t.found) << t.reason;
  double worst = 0.0;
  for (size_t i = 0; i < d.corners.size(); ++i) {
    const Eigen::Vector2d expected(image.cols - 1 - d.corners[i].x(), image.rows - 1 - d.corners[i].y());
    worst = std::max(worst, (t.corners[i] - expected).norm());
  }
  EXPECT_LT(worst, 0.3) << "the half-turned image numbers the board differently";
}

TEST(Chessboard, AnImageWithoutTheBoardGivesAReasonNotAnError) {
  const cv::Mat blank(480, 640, CV_8UC1, cv::Scalar(90));
  const CornerDetection d = DetectChessboard(blank, ChessboardSpec{9, 6, 1.0}, CornerDetector::kAuto);
  EXPECT_FALSE(d.found);
  EXPECT_EQ(d.reason, "no 9x6 chessboard found (OpenCV's detector)");
  EXPECT_TRUE(d.corners.empty());
  const CornerDetection m = DetectChessboard(blank, ChessboardSpec{10, 10, 1.0}, CornerDetector::kAuto);
  EXPECT_FALSE(m.found);
  EXPECT_EQ(m.detector, "mrgingham");
}

TEST(Chessboard, BadRequestsThrow) {
  const cv::Mat image = Left(2);
  EXPECT_THROW(DetectChessboard(image, ChessboardSpec{9, 6, 1.0}, CornerDetector::kMrgingham), InputError);
  EXPECT_THROW(DetectChessboard(image, ChessboardSpec{9, 6, 0.0}, CornerDetector::kAuto), InputError);
  EXPECT_THROW(DetectChessboard(image, ChessboardSpec{1, 6, 1.0}, CornerDetector::kAuto), InputError);
  EXPECT_THROW(DetectChessboard(cv::Mat(), ChessboardSpec{9, 6, 1.0}, CornerDetector::kAuto), InputError);
  cv::Mat colour;
  cv::cvtColor(image, colour, cv::COLOR_GRAY2BGR);
  EXPECT_THROW(DetectChessboard(colour, ChessboardSpec{9, 6, 1.0}, CornerDetector::kAuto), InputError);
  EXPECT_THROW(ParseCornerDetector("sift"), InputError);
  EXPECT_EQ(ParseCornerDetector("mrgingham"), CornerDetector::kMrgingham);
  const std::vector<std::string> errors = ChessboardSpec{0, 1, -1.0}.Validate();
  EXPECT_EQ(errors.size(), 3u);
}

TEST(CornersVnl, RowsPerCornerAndOneRowForAMissingBoard) {
  CornerDetection found;
  found.found = true;
  found.corners = {{1.25, 2.5}, {3.0, 4.0}};
  found.levels = {0, 1};
  CornerDetection missing;
  const std::string text = CornersVnlText({{"cam0-001.png", &found}, {"cam0-002.png", &missing}});
  const std::vector<std::string> lines = SplitLines(text);
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0], "# filename x y level");
  EXPECT_EQ(lines[1], "cam0-001.png 1.25 2.5 0");
  EXPECT_EQ(lines[2], "cam0-001.png 3 4 1");
  EXPECT_EQ(lines[3], "cam0-002.png - - -");
  EXPECT_THROW(CornersVnlText({{"with space.png", &found}}), InputError);
}

// mrcal's tool failing (here: a program that exits 1) is an ExternalError
// naming the log, and no model appears.
TEST(Calibrate, AFailingMrcalToolIsAnExternalErrorAndLeavesNoModel) {
  const fs::path dir = FreshTestDir();
  CalibrateOptions options;
  for (const char* name : {"left01.jpg", "left02.jpg", "left03.jpg", "left04.jpg", "left05.jpg"}) {
    options.images.push_back((kBoardData / name).string());
  }
  options.board = {9, 6, 1.0};
  options.out_dir = (dir / "cal").string();
  options.mrcal_calibrate = "/bin/false";
  try {
    Calibrate(options);
    FAIL() << "expected ExternalError";
  } catch (const ExternalError& e) {
    EXPECT_NE(std::string(e.what()).find("mrcal-calibrate-cameras.log"), std::string::npos) << e.what();
  }
  for (const auto& item : fs::recursive_directory_iterator(dir / "cal")) {
    EXPECT_NE(item.path().extension(), ".cameramodel") << item.path();
  }
  EXPECT_TRUE(fs::is_regular_file(dir / "cal/corners.vnl"));

  options.out_dir = (dir / "cal2").string();
  options.mrcal_calibrate = "no-such-mrcal-tool";
  EXPECT_THROW(Calibrate(options), ExternalError);
  options.out_dir = (dir / "cal3").string();
  options.mrcal_calibrate = "mrcal-calibrate-cameras";
  options.python = "/nonexistent/python3";
  EXPECT_THROW(Calibrate(options), ExternalError);
}

TEST(Calibrate, OptionsAreCheckedBeforeAnythingIsWritten) {
  const fs::path dir = FreshTestDir();
  CalibrateOptions options;
  options.board = {9, 6, 0.0};
  options.out_dir = (dir / "cal").string();
  options.lensmodel = "LENSMODEL_OPENCV9";
  options.pair_images = {"x.png"};
  options.min_views = 0;
  const std::vector<std::string> errors = options.Validate();
  EXPECT_EQ(errors.size(), 5u);  // spacing, no images, pair count, min views, lens model
  EXPECT_THROW(Calibrate(options), InputError);
  EXPECT_FALSE(fs::exists(dir / "cal"));
}

}  // namespace
}  // namespace hdabench::calib
