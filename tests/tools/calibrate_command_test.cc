// `hdabench calibrate` and `hdabench calib-diff` end to end: the real images of
// tests/data/opencv-stereo-chessboard through the real mrcal-calibrate-cameras,
// bad inputs, and the calibrated model used by the rest of the bench.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calib/camera_model.h"
#include "datasets/synth/chessboard.h"
#include "tests/support/test_support.h"
#include "tools/images/codecs.h"

namespace {

namespace fs = std::filesystem;
using hdabench::testing_support::CommandResult;
using hdabench::testing_support::FreshTestDir;
using hdabench::testing_support::ReadText;
using hdabench::testing_support::RunHdabench;
using hdabench::testing_support::WriteText;
using Json = nlohmann::json;

const fs::path kBoardData = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard";

std::vector<std::string> BoardImages(const std::string& side) {
  std::vector<std::string> paths;
  for (const auto& item : fs::directory_iterator(kBoardData)) {
    const std::string name = item.path().filename().string();
    if (name.rfind(side, 0) == 0 && item.path().extension() == ".jpg") {
      paths.push_back(item.path().string());
    }
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

// Every .cameramodel under `dir`, at any depth.
std::vector<std::string> ModelsUnder(const fs::path& dir) {
  std::vector<std::string> models;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return models;
  for (const auto& item : fs::recursive_directory_iterator(dir)) {
    if (item.path().extension() == ".cameramodel") models.push_back(item.path().string());
  }
  return models;
}

// The upstream calibration's camera matrix M1 (left) or M2 (right).
cv::Mat UpstreamMatrix(const std::string& key) {
  cv::FileStorage file((kBoardData / "upstream_results/intrinsic.yml").string(),
                       cv::FileStorage::READ);
  cv::Mat m;
  file[key] >> m;
  return m;
}

std::vector<std::string> CalibrateArgs(const std::vector<std::string>& images, const fs::path& out) {
  std::vector<std::string> args = {"calibrate"};
  args.insert(args.end(), images.begin(), images.end());
  for (const char* a :
       {"--board", "9x6", "--spacing", "1", "--slope-samples", "8", "--quiet", "--out"}) {
    args.push_back(a);
  }
  args.push_back(out.string());
  return args;
}

// Must show: the 13 left images all used, RMS under 0.5 px, focal lengths
// within 2 % of the third party's calibration; the model then drives a
// synthetic dataset that `hdabench dataset check` accepts.
TEST(Calibrate, RealLeftImagesAllUsedFocalMatchesUpstreamAndTheModelLoadsInTheBench) {
  const fs::path dir = FreshTestDir();
  const std::vector<std::string> images = BoardImages("left");
  ASSERT_EQ(images.size(), 13u);
  const CommandResult run = RunHdabench(CalibrateArgs(images, dir / "cal"), dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  std::printf("%s\n", run.out.c_str());
  EXPECT_NE(run.out.find("| images used / given | 13 / 13 |"), std::string::npos) << run.out;

  const Json summary = Json::parse(ReadText(dir / "cal/calibration.json"));
  EXPECT_EQ(summary["schema"], "hdabench-calibration");
  int used = 0;
  for (const Json& image : summary["images"]) used += image["used"].get<bool>() ? 1 : 0;
  EXPECT_EQ(used, 13);
  const Json analysis = Json::parse(ReadText(dir / "cal/analysis.json"));
  const double rms = analysis["cameras"][0]["residuals"]["rms_px"].get<double>();
  EXPECT_LT(rms, 0.5);
  EXPECT_GT(rms, 0.0);
  // How good the calibration must be: the band's uncertainty scaled by a
  // tenth of the method's sigma over the calibration's slope RMS, per degree
  // of that sigma (none given here).
  const Json& requirement = summary["requirements"][0];
  const double band = analysis["cameras"][0]["uncertainty"]["band_median_px"].get<double>();
  const double slope = analysis["cameras"][0]["slope_error"]["rms_deg"].get<double>();
  EXPECT_DOUBLE_EQ(requirement["allowed_band_median_px_per_method_sigma_deg"].get<double>(), band * 0.1 / slope);
  EXPECT_TRUE(requirement["allowed_band_median_px"].is_null());
  EXPECT_NE(run.out.find("px per degree of S (median; it is"), std::string::npos) << run.out;

  const hdabench::calib::CameraModel model =
      hdabench::calib::CameraModel::Load((dir / "cal/camera-0.cameramodel").string());
  EXPECT_EQ(model.LensModelName(), "LENSMODEL_OPENCV8");
  EXPECT_EQ(model.WidthPx(), 640);
  EXPECT_EQ(model.HeightPx(), 480);
  const cv::Mat m1 = UpstreamMatrix("M1");
  ASSERT_EQ(m1.rows, 3);
  const double fx = model.Intrinsics()[0], fy = model.Intrinsics()[1];
  std::printf("[ calib    ] fx %.3f (upstream %.3f, %+.2f %%), fy %.3f (upstream %.3f, %+.2f %%)\n",
              fx, m1.at<double>(0, 0), 100 * (fx / m1.at<double>(0, 0) - 1), fy,
              m1.at<double>(1, 1), 100 * (fy / m1.at<double>(1, 1) - 1));
  EXPECT_NEAR(fx, m1.at<double>(0, 0), 0.02 * m1.at<double>(0, 0));
  EXPECT_NEAR(fy, m1.at<double>(1, 1), 0.02 * m1.at<double>(1, 1));

  // Files a person or another tool opens.
  for (const char* file : {"summary.md", "detections.csv", "corners.vnl", "opencv/camera-0.cameramodel",
                           "logs/mrcal-calibrate-cameras.log", "figures/coverage-camera-0.png",
                           "figures/uncertainty-camera-0.png", "figures/opencv-diff-camera-0.png"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / "cal" / file)) << file;
  }
  EXPECT_EQ(ModelsUnder(dir / "cal").size(), 2u);  // mrcal's, and OpenCV's cross-check

  // The rest of the bench uses the model: a synthetic dataset through it, of
  // the 7 frames that hold the pair `run` takes (0 and 6).
  const CommandResult synth =
      RunHdabench({"synth", "--out", (dir / "ds").string(), "--camera-model",
                   (dir / "cal/camera-0.cameramodel").string(), "--set", "collection_s=2.4", "--quiet"},
                  dir);
  ASSERT_EQ(synth.exit_code, 0) << synth.err;
  const CommandResult check = RunHdabench({"dataset", "check", (dir / "ds").string()}, dir);
  EXPECT_EQ(check.exit_code, 0) << check.out << check.err;
  EXPECT_NE(check.out.find("LENSMODEL_OPENCV8, 640 x 480 px"), std::string::npos) << check.out;

  // calib-diff of the calibration against OpenCV's cross-check model: the
  // same figures the summary gave for it, and the heat map.
  const CommandResult diff =
      RunHdabench({"calib-diff", (dir / "cal/camera-0.cameramodel").string(),
                   (dir / "cal/opencv/camera-0.cameramodel").string(), "--out", (dir / "diff").string()},
                  dir);
  ASSERT_EQ(diff.exit_code, 0) << diff.err;
  EXPECT_NE(diff.out.find("median"), std::string::npos);
  EXPECT_TRUE(fs::is_regular_file(dir / "diff/calib-diff.png"));
  const Json diff_json = Json::parse(ReadText(dir / "diff/calib-diff.json"));
  const Json& opencv_diff = analysis["cameras"][0]["opencv"]["diff"];
  for (const char* key : {"median_px", "p90_px", "max_px"}) {
    EXPECT_NEAR(diff_json[key].get<double>(), opencv_diff[key].get<double>(),
                1e-6 * (1.0 + opencv_diff[key].get<double>()))
        << key;
  }
  // The slope terms: a finite tilt at the HDA geometry, with the bench
  // calibration's sigma there (it holds its optimization_inputs).
  EXPECT_GE(diff_json["hda_slope"]["tilt_deg"].get<double>(), 0.0);
  EXPECT_GT(diff_json["hda_slope"]["a_calibration_tilt_sigma_deg"].get<double>(), 0.0);
  // A model without its calibration has no sigma to compare with, and says so.
  const CommandResult reverse =
      RunHdabench({"calib-diff", (dir / "cal/opencv/camera-0.cameramodel").string(),
                   (dir / "cal/camera-0.cameramodel").string(), "--out", (dir / "reverse").string()},
                  dir);
  ASSERT_EQ(reverse.exit_code, 0) << reverse.err;
  EXPECT_NE(reverse.out.find("A holds no optimization_inputs"), std::string::npos) << reverse.out;
  EXPECT_TRUE(Json::parse(ReadText(dir / "reverse/calib-diff.json"))["hda_slope"]["a_calibration_tilt_sigma_deg"]
                  .is_null());
}

// A seed in, the same bytes out: two calibrations of the same images into the
// same folder give the same model (but for the time mrcal writes in its first
// line) and the same analysis.json. mrcal-calibrate-cameras draws part of its
// starting point from numpy's generator, which the bench seeds.
TEST(Calibrate, TheSameImagesGiveTheSameModelAndAnalysisTwice) {
  const fs::path dir = FreshTestDir();
  const std::vector<std::string> images = BoardImages("left");
  std::string models[2], analyses[2];
  for (int k = 0; k < 2; ++k) {
    fs::remove_all(dir / "cal");
    const CommandResult run = RunHdabench(CalibrateArgs(images, dir / "cal"), dir);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const std::string model = ReadText(dir / "cal/camera-0.cameramodel");
    ASSERT_EQ(model.rfind("# generated on ", 0), 0u) << model.substr(0, 80);
    models[k] = model.substr(model.find('\n') + 1);
    analyses[k] = ReadText(dir / "cal/analysis.json");
  }
  EXPECT_FALSE(models[0].empty());
  EXPECT_TRUE(models[0] == models[1]) << "the two models differ";
  EXPECT_TRUE(analyses[0] == analyses[1]) << "the two analysis.json differ";
}

// An output folder given relative to the working folder: mrcal runs in a
// scratch folder of its own, so the paths it is given must not be relative.
// With the method's sigma given, the requirement is a figure, met or not.
TEST(Calibrate, ARelativeOutputFolderWorks) {
  const fs::path dir = FreshTestDir();
  const fs::path previous = fs::current_path();
  fs::current_path(dir);
  std::vector<std::string> args = CalibrateArgs(BoardImages("left"), "cal");
  args.insert(args.end(), {"--method-sigma-deg", "0.94"});
  const CommandResult run = RunHdabench(args, dir);
  fs::current_path(previous);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Json requirement = Json::parse(ReadText(dir / "cal/calibration.json"))["requirements"][0];
  EXPECT_DOUBLE_EQ(requirement["allowed_band_median_px"].get<double>(),
                   requirement["allowed_band_median_px_per_method_sigma_deg"].get<double>() * 0.94);
  EXPECT_NE(run.out.find("with S = 0.94 deg, at most "), std::string::npos) << run.out;
  EXPECT_NO_THROW(hdabench::calib::CameraModel::Load((dir / "cal/camera-0.cameramodel").string()));
  EXPECT_TRUE(fs::is_regular_file(dir / "cal/analysis.json"));
}

// Two cameras calibrated together: both models, and their relative pose
// close to the third party's (T about 3.34 squares).
TEST(Calibrate, APairOfCamerasGivesBothModelsAndTheirBaseline) {
  const fs::path dir = FreshTestDir();
  std::vector<std::string> args = CalibrateArgs(BoardImages("left"), dir / "cal");
  args.push_back("--pair");
  for (const std::string& right : BoardImages("right")) args.push_back(right);
  const CommandResult run = RunHdabench(args, dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_TRUE(fs::is_regular_file(dir / "cal/camera-0.cameramodel"));
  EXPECT_TRUE(fs::is_regular_file(dir / "cal/camera-1.cameramodel"));
  const Json analysis = Json::parse(ReadText(dir / "cal/analysis.json"));
  ASSERT_EQ(analysis["cameras"].size(), 2u);
  for (const Json& cam : analysis["cameras"]) {
    EXPECT_LT(cam["residuals"]["rms_px"].get<double>(), 0.5);
  }
  const hdabench::calib::CameraModel right =
      hdabench::calib::CameraModel::Load((dir / "cal/camera-1.cameramodel").string());
  const Eigen::Vector3d t = right.CamFromRef().translation;
  // Upstream T = (-3.3426, 0.0467, 0.0022) squares. Two independent solves of
  // 13 views agree on a baseline to about 1 % (the board's own flatness and
  // the focal lengths, which differ by 1 % between the two, scale it).
  std::printf("[ calib    ] camera 1 from camera 0: t = (%.4f, %.4f, %.4f) squares\n", t.x(), t.y(),
              t.z());
  EXPECT_NEAR(t.norm(), 3.3429, 0.02 * 3.3429);
  EXPECT_NEAR(t.x(), -3.3426, 0.07);
  EXPECT_NEAR(t.y(), 0.0467, 0.07);
}

// Bad input: a clear message, a non-zero exit, and never a model.
TEST(Calibrate, ASpacingOfZeroOrABadBoardIsAUsageErrorAndCreatesNothing) {
  const fs::path dir = FreshTestDir();
  std::vector<std::string> args = CalibrateArgs(BoardImages("left"), dir / "cal");
  auto with = [&](const std::string& flag, const std::string& value) {
    std::vector<std::string> changed = args;
    const auto at = std::find(changed.begin(), changed.end(), flag);
    *(at + 1) = value;
    return changed;
  };
  CommandResult run = RunHdabench(with("--spacing", "0"), dir);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("spacing = 0"), std::string::npos) << run.err;
  run = RunHdabench(with("--board", "9by6"), dir);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--board '9by6'"), std::string::npos) << run.err;
  run = RunHdabench(with("--board", "1x6"), dir);
  EXPECT_EQ(run.exit_code, 2);
  run = RunHdabench(with("--board", "4294967305x6"), dir);  // had wrapped to 9 x 6
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--board '4294967305x6'"), std::string::npos) << run.err;
  std::vector<std::string> lens = args;
  lens.push_back("--lensmodel");
  lens.push_back("LENSMODEL_NONSENSE");
  run = RunHdabench(lens, dir);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("LENSMODEL_NONSENSE"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir / "cal"));
}

TEST(Calibrate, AWrongBoardSizeFindsNoViewAndWritesNoModel) {
  const fs::path dir = FreshTestDir();
  std::vector<std::string> args = CalibrateArgs(BoardImages("left"), dir / "cal");
  *(std::find(args.begin(), args.end(), "--board") + 1) = "8x5";
  const CommandResult run = RunHdabench(args, dir);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("only 0 of 13 images show the whole 8x5 board"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("left14.jpg: no 8x5 chessboard found"), std::string::npos) << run.err;
  EXPECT_TRUE(ModelsUnder(dir / "cal").empty());
  // What was found is kept for the user to look at.
  EXPECT_TRUE(fs::is_regular_file(dir / "cal/detections.csv"));
}

TEST(Calibrate, ImagesWithoutABoardUnreadableOrMissingAreNamedWithTheirReason) {
  const fs::path dir = FreshTestDir();
  // A smooth gradient: an image, but no board in it.
  cv::Mat plain(480, 640, CV_8UC1);
  for (int r = 0; r < plain.rows; ++r) {
    for (int c = 0; c < plain.cols; ++c) plain.at<unsigned char>(r, c) = static_cast<unsigned char>((r + c) / 5);
  }
  ASSERT_TRUE(hdabench::images::Write((dir / "plain.png").string(), plain));
  WriteText(dir / "text.png", "this is not an image\n");
  std::vector<std::string> images = BoardImages("left");
  images.resize(4);
  images.push_back((dir / "plain.png").string());
  images.push_back((dir / "text.png").string());
  images.push_back((dir / "missing.png").string());
  // A board image cut short: OpenCV would decode its top half.
  const std::string jpeg = ReadText(BoardImages("left")[4]);
  WriteText(dir / "cut.jpg", jpeg.substr(0, jpeg.size() * 3 / 4));
  images.push_back((dir / "cut.jpg").string());
  const CommandResult run = RunHdabench(CalibrateArgs(images, dir / "cal"), dir);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("only 4 of 8 images"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("plain.png: no 9x6 chessboard found"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("text.png: is not an image OpenCV can read"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("missing.png: file not found"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("cut.jpg: is truncated: "), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find("Premature end of JPEG file"), std::string::npos) << run.err;
  EXPECT_TRUE(ModelsUnder(dir / "cal").empty());

  // The same set with --min-views 4 calibrates from the four good views and
  // lists the three others as not used, with why.
  std::vector<std::string> args = CalibrateArgs(images, dir / "cal4");
  args.push_back("--min-views");
  args.push_back("4");
  const CommandResult four = RunHdabench(args, dir);
  ASSERT_EQ(four.exit_code, 0) << four.err;
  EXPECT_NE(four.out.find("## Images not used"), std::string::npos) << four.out;
  EXPECT_NE(four.out.find("text.png | is not an image OpenCV can read"), std::string::npos) << four.out;
  EXPECT_TRUE(fs::is_regular_file(dir / "cal4/camera-0.cameramodel"));
}

TEST(Calibrate, TooFewViewsStopBeforeMrcalRuns) {
  const fs::path dir = FreshTestDir();
  std::vector<std::string> images = BoardImages("left");
  images.resize(3);
  const CommandResult run = RunHdabench(CalibrateArgs(images, dir / "cal"), dir);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("only 3 of 3 images show the whole 9x6 board; a calibration needs at least 5"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(fs::exists(dir / "cal/logs/mrcal-calibrate-cameras.log"));
  EXPECT_TRUE(ModelsUnder(dir / "cal").empty());
}

TEST(Calibrate, AnOutputFolderInUseIsRefused) {
  const fs::path dir = FreshTestDir();
  fs::create_directories(dir / "cal");
  WriteText(dir / "cal/keep.txt", "mine\n");
  const CommandResult run = RunHdabench(CalibrateArgs(BoardImages("left"), dir / "cal"), dir);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(ReadText(dir / "cal/keep.txt"), "mine\n");
}

// Must show: views rendered through a known lens (with noise), calibrated
// back. The recovered projection is compared with the truth's over the whole
// imager with calib-diff, and against the uncertainty the calibration reports.
//
// The bound: OpenCV's corners on these renders are off by 0.065 px RMS (the
// renderer's test measures it: pixel-grid snapping on sharp edges, the 2-grey-
// level noise adds 0.003 px). A least-squares fit of 12 intrinsics to ~1000
// such corners places the projection where the corners were seen to a small
// fraction of one corner's error; the fit cannot be worse there than a single
// corner. The views cover the whole imager, border cells included (the
// renderer's test checks it), so the median over the imager must stay under
// 0.065 px, after the implied rotation between the two camera frames is taken
// out (a calibration fixes its frame only through the board poses). mrcal's 1-sigma
// projection uncertainty must cover the actual difference at 3 sigma over at
// least 90 % of the imager (a 2-D Gaussian error is within 3 sigma of its
// worst direction 99 % of the time; 90 % leaves room for the detector's bias,
// which is not noise).
TEST(Calibrate, SyntheticViewsThroughAKnownLensComeBackWithinTheirUncertainty) {
  const fs::path dir = FreshTestDir();
  namespace synth = hdabench::datasets::synth;
  const hdabench::calib::CameraModel truth(
      "LENSMODEL_OPENCV8", {500.0, 502.0, 322.0, 236.0, -0.30, 0.10, 0.0005, -0.0003, -0.015, 0.0, 0.0, 0.0},
      640, 480);
  truth.Save((dir / "truth.cameramodel").string());
  synth::ChessboardBoard board;  // 9 x 6, 0.03 m
  synth::ChessboardViewsOptions views;
  views.views = 20;
  views.seed = 7;
  views.threads = 1;
  synth::WriteChessboardViews(synth::RenderChessboardViews(truth, board, views),
                              (dir / "views").string(), "view");
  std::vector<std::string> images;
  for (int i = 1; i <= views.views; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "view%02d.png", i);
    images.push_back((dir / "views" / name).string());
  }
  const CommandResult run = RunHdabench(
      {"calibrate", "--board", "9x6", "--spacing", "0.03", "--slope-samples", "0", "--quiet", "--out",
       (dir / "cal").string(), images[0], images[1], images[2], images[3], images[4], images[5], images[6],
       images[7], images[8], images[9], images[10], images[11], images[12], images[13], images[14],
       images[15], images[16], images[17], images[18], images[19]},
      dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("| images used / given | 20 / 20 |"), std::string::npos) << run.out;

  const CommandResult diff =
      RunHdabench({"calib-diff", (dir / "cal/camera-0.cameramodel").string(),
                   (dir / "truth.cameramodel").string(), "--out", (dir / "diff").string(),
                   "--with-uncertainty"},
                  dir);
  ASSERT_EQ(diff.exit_code, 0) << diff.err;
  std::printf("%s", diff.out.c_str());
  const Json d = Json::parse(ReadText(dir / "diff/calib-diff.json"));
  const Json analysis = Json::parse(ReadText(dir / "cal/analysis.json"));
  const Json& cam = analysis["cameras"][0];
  std::printf("[ calib    ] residual RMS %.3f px; imager median difference %.4f px; uncertainty "
              "median %.4f px; within 1/2/3 sigma %.2f / %.2f / %.2f\n",
              cam["residuals"]["rms_px"].get<double>(), d["median_px"].get<double>(),
              d["uncertainty_of_a"]["median_px"].get<double>(),
              d["uncertainty_of_a"]["within_1_sigma"].get<double>(),
              d["uncertainty_of_a"]["within_2_sigma"].get<double>(),
              d["uncertainty_of_a"]["within_3_sigma"].get<double>());
  EXPECT_LT(d["median_px"].get<double>(), 0.065);
  EXPECT_GE(d["uncertainty_of_a"]["within_3_sigma"].get<double>(), 0.9);
  // In slope terms: the calibration against the true lens at the HDA
  // geometry, in units of the calibration's own sigma there: a draw of the
  // calibration's uncertainty, so of the order of one sigma.
  const Json& slope = d["hda_slope"];
  std::printf("[ calib    ] HDA geometry: tilt %.4f deg, calibration sigma %.4f deg, %.2f sigma\n",
              slope["tilt_deg"].get<double>(), slope["a_calibration_tilt_sigma_deg"].get<double>(),
              slope["sigmas"].get<double>());
  EXPECT_GT(slope["a_calibration_tilt_sigma_deg"].get<double>(), 0.0);
  EXPECT_LT(slope["sigmas"].get<double>(), 4.0);
  EXPECT_NE(diff.out.find("B tilts the flight method's plane by"), std::string::npos) << diff.out;

}

// A square board goes to mrgingham (the finder mrcal's tools use). On these
// sharp renders its corners are coarser than OpenCV's sub-pixel ones (0.25 px
// RMS residual against 0.06 px, measured) and it misses the most tilted views,
// but the calibration stays within the bench's residual limit (0.5 px) and
// the focal length within 1 %.
TEST(Calibrate, ASquareBoardIsFoundByMrgingham) {
  const fs::path dir = FreshTestDir();
  namespace synth = hdabench::datasets::synth;
  const hdabench::calib::CameraModel truth(
      "LENSMODEL_OPENCV8", {500.0, 500.0, 319.5, 239.5, -0.2, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}, 640,
      480);
  synth::ChessboardBoard board;
  board.corners_x = 10;
  board.corners_y = 10;
  synth::ChessboardViewsOptions views;
  views.views = 12;
  views.seed = 3;
  views.threads = 1;
  synth::WriteChessboardViews(synth::RenderChessboardViews(truth, board, views),
                              (dir / "views").string(), "view");
  std::vector<std::string> args = {"calibrate", "--board", "10x10", "--spacing", "0.03",
                                   "--slope-samples", "0", "--quiet", "--out", (dir / "cal").string()};
  for (int i = 1; i <= views.views; ++i) {
    char name[32];
    std::snprintf(name, sizeof(name), "view%02d.png", i);
    args.push_back((dir / "views" / name).string());
  }
  const CommandResult run = RunHdabench(args, dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const std::string detections = ReadText(dir / "cal/detections.csv");
  EXPECT_EQ(detections.find(",opencv,"), std::string::npos) << detections;
  EXPECT_NE(detections.find(",mrgingham,"), std::string::npos) << detections;
  const Json analysis = Json::parse(ReadText(dir / "cal/analysis.json"));
  const double rms = analysis["cameras"][0]["residuals"]["rms_px"].get<double>();
  std::printf("[ calib    ] mrgingham corners: residual RMS %.3f px\n", rms);
  EXPECT_LT(rms, 0.5);
  const hdabench::calib::CameraModel recovered =
      hdabench::calib::CameraModel::Load((dir / "cal/camera-0.cameramodel").string());
  EXPECT_NEAR(recovered.Intrinsics()[0], 500.0, 5.0);
}

TEST(CalibDiff, MissingOrMismatchedModelsAreInputErrors) {
  const fs::path dir = FreshTestDir();
  const hdabench::calib::CameraModel a("LENSMODEL_PINHOLE", {500, 500, 319.5, 239.5}, 640, 480);
  const hdabench::calib::CameraModel b("LENSMODEL_PINHOLE", {500, 500, 399.5, 299.5}, 800, 600);
  a.Save((dir / "a.cameramodel").string());
  b.Save((dir / "b.cameramodel").string());
  CommandResult run = RunHdabench({"calib-diff", (dir / "a.cameramodel").string(),
                                   (dir / "nowhere.cameramodel").string(), "--out", (dir / "d").string()},
                                  dir);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("nowhere.cameramodel"), std::string::npos) << run.err;
  run = RunHdabench({"calib-diff", (dir / "a.cameramodel").string(), (dir / "b.cameramodel").string(),
                     "--out", (dir / "d").string()},
                    dir);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_NE(run.err.find("imager"), std::string::npos) << run.err;
  // Neither refusal leaves the output folder behind.
  EXPECT_FALSE(fs::exists(dir / "d"));
  // A grid finer than A's 640 pixels is a bad flag value; an --out that is a
  // file is named with the reason.
  run = RunHdabench({"calib-diff", (dir / "a.cameramodel").string(), (dir / "a.cameramodel").string(),
                     "--out", (dir / "d").string(), "--gridn", "641"},
                    dir);
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("--gridn 641: more grid points across than the 640 pixels"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir / "d"));
  run = RunHdabench({"calib-diff", (dir / "a.cameramodel").string(), (dir / "a.cameramodel").string(),
                     "--out", (dir / "a.cameramodel").string()},
                    dir);
  EXPECT_EQ(run.exit_code, 3) << run.err;
  EXPECT_NE(run.err.find("a.cameramodel: cannot create the output folder: it exists and is not a folder"),
            std::string::npos)
      << run.err;
  // A model against itself: no difference.
  run = RunHdabench({"calib-diff", (dir / "a.cameramodel").string(), (dir / "a.cameramodel").string(),
                     "--out", (dir / "same").string()},
                    dir);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  // mrcal fits the implied rotation iteratively: identity to about 1e-6 rad,
  // 0.001 px at 500 px focal length.
  const Json same = Json::parse(ReadText(dir / "same/calib-diff.json"));
  EXPECT_LT(same["max_px"].get<double>(), 0.01) << run.out;
}

}  // namespace
