// calib::AnalyseCalibration and calib::DiffCalibrations on real calibrations:
// the OpenCV stereo sample images (tests/data/opencv-stereo-chessboard), their
// corners found with OpenCV and calibrated by mrcal-calibrate-cameras inside
// the test. The calibrations are made once per build and shared by the test
// processes (CachedDataset).
#include "calib/calibration_analysis.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "reference/flight/calibration_check.h"
#include "tools/images/codecs.h"
#include "tools/util/error.h"
#include "tools/util/process.h"
#include "tests/support/test_support.h"

namespace hdabench::calib {
namespace {

namespace fs = std::filesystem;
using testing_support::CachedDataset;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::WriteText;

// Analysis options whose slope figure comes from the flight method's steps,
// as hdabench calibrate gives them.
AnalysisOptions WithFlightSlope() {
  AnalysisOptions options;
  options.hda_tilt_deg = [](const CameraModel& truth, const CameraModel& believed, const Eigen::Vector3d& rotation_rad,
                            const HdaGeometry& geometry) {
    return reference::HdaGeometryTiltDeg(reference::MakeHdaGeometrySite(truth, geometry), believed, rotation_rad);
  };
  return options;
}

const fs::path kImages =
    fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "opencv-stereo-chessboard";
constexpr int kBoardWidth = 9;  // inner corners
constexpr int kBoardHeight = 6;
// Fewer Monte Carlo re-solves than the default 30 keep the tests quick; 8
// are enough for finite, repeatable statistics.
constexpr int kTestSamples = 8;

std::vector<std::string> ImageNames(const std::string& side) {
  std::vector<std::string> names;
  for (const int i : {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 12, 13, 14}) {
    char name[32];
    std::snprintf(name, sizeof(name), "%s%02d.jpg", side.c_str(), i);
    names.push_back(name);
  }
  return names;
}

// corners.vnl as mrcal-calibrate-cameras reads it: OpenCV's chessboard corners
// refined to subpixel, level 0 (weight 1). Throws when an image fails, so that
// no half-made calibration is ever cached.
void WriteCorners(const std::vector<std::string>& names, const fs::path& vnl) {
  std::string text = "# filename x y level\n";
  for (const std::string& name : names) {
    const cv::Mat image = hdabench::images::Read((kImages / name).string(), cv::IMREAD_GRAYSCALE);
    if (image.empty())
      throw std::runtime_error((kImages / name).string() + ": cannot read the image");
    std::vector<cv::Point2f> corners;
    if (!cv::findChessboardCorners(image, {kBoardWidth, kBoardHeight}, corners,
                                   cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE)) {
      throw std::runtime_error(name + ": OpenCV finds no 9 x 6 chessboard");
    }
    cv::cornerSubPix(
        image, corners, {11, 11}, {-1, -1},
        cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::MAX_ITER, 30, 0.01));
    for (const cv::Point2f& c : corners) {
      char line[96];
      std::snprintf(line, sizeof(line), "%s %.4f %.4f 0\n", name.c_str(), static_cast<double>(c.x),
                    static_cast<double>(c.y));
      text += line;
    }
  }
  WriteText(vnl, text);
}

// A mrcal-calibrate-cameras run over the given sides ("left", "right"), made
// once per build: camera-N.cameramodel and mrcal.log (its output) in the folder.
fs::path Calibration(const std::vector<std::string>& sides) {
  std::string name = "calibration";
  for (const std::string& side : sides) name += "-" + side;
  return CachedDataset(
      fs::path(HDABENCH_TEST_TMP) / "calibration-cache", name, [&sides](const fs::path& staging) {
        fs::create_directories(staging);
        std::vector<std::string> names;
        for (const std::string& side : sides) {
          for (const std::string& n : ImageNames(side)) names.push_back(n);
        }
        WriteCorners(names, staging / "corners.vnl");
        // clang-format off
        std::vector<std::string> argv = {
            "mrcal-calibrate-cameras", "--corners-cache", "corners.vnl",
            "--lensmodel", "LENSMODEL_OPENCV8", "--focal", "530", "--imagersize", "640", "480",
            "--object-spacing", "1", "--object-width-n", std::to_string(kBoardWidth),
            "--object-height-n", std::to_string(kBoardHeight), "--outdir", "."};
        // clang-format on
        for (const std::string& side : sides) argv.push_back(side + "*.jpg");
        util::ProcessOptions process;
        process.working_dir = staging.string();
        process.log_file = (staging / "mrcal.log").string();
        process.timeout_s = 120;
        const util::ProcessResult result = util::RunProcess(argv, process);
        if (!result.Ok()) {
          throw std::runtime_error("mrcal-calibrate-cameras failed: " + result.error + "\n" +
                                   ReadText(staging / "mrcal.log"));
        }
        WriteText(staging / "manifest.json", "{\"made_by\": \"calibration_analysis_test\"}\n");
      });
}

// mrcal-calibrate-cameras' own "## RMS error: x" (the final solve's).
double MrcalPrintedRms(const fs::path& calibration) {
  const std::string log = ReadText(calibration / "mrcal.log");
  const std::string key = "## RMS error: ";
  const size_t at = log.rfind(key);
  if (at == std::string::npos) return NAN;
  return std::stod(log.substr(at + key.size()));
}

bool IsPng(const std::string& path) {
  const std::string bytes = ReadText(path);
  return bytes.size() > 8 && bytes.compare(0, 8, "\x89PNG\r\n\x1a\n", 8) == 0;
}

std::string Model(const fs::path& calibration, int camera) {
  return (calibration / ("camera-" + std::to_string(camera) + ".cameramodel")).string();
}

TEST(CalibrationAnalysis, LeftImagesGiveTheExpectedFigures) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.slope_samples = kTestSamples;
  const CalibrationAnalysis analysis =
      AnalyseCalibration({Model(calibration, 0)}, (dir / "out").string(), options);
  ASSERT_EQ(analysis.cameras.size(), 1u);
  EXPECT_TRUE(analysis.relative_poses.empty());
  EXPECT_TRUE(fs::is_regular_file(analysis.json_path));
  EXPECT_TRUE(fs::is_regular_file(analysis.log_path));
  const CameraAnalysis& c = analysis.cameras[0];
  EXPECT_EQ(c.lensmodel, "LENSMODEL_OPENCV8");
  EXPECT_EQ(c.width_px, 640);
  EXPECT_EQ(c.height_px, 480);

  // Residuals: below half a pixel per corner, and mrcal's own printed figure
  // (per coordinate, over the joint solve's measurement vector) is what the
  // record says it is, about rms / sqrt(2).
  const ResidualSummary& r = c.residuals;
  EXPECT_GT(r.rms_px, 0.0);
  EXPECT_LT(r.rms_px, 0.5);
  const double printed = MrcalPrintedRms(calibration);
  ASSERT_TRUE(std::isfinite(printed)) << ReadText(calibration / "mrcal.log");
  EXPECT_NEAR(r.mrcal_rms_px, printed, 1e-6 * printed);
  EXPECT_NEAR(r.rms_px / std::sqrt(2.0), printed, 0.1 * printed);
  EXPECT_GE(r.worst_px, r.rms_px);
  EXPECT_LT(r.worst_px, 2.0);
  EXPECT_EQ(r.detected, 13 * 54);  // OpenCV finds every corner of these images
  EXPECT_EQ(r.board_points, 13 * 54);
  EXPECT_EQ(r.inliers + r.outliers, r.detected);
  EXPECT_GT(r.outliers, 0);  // mrcal rejects a few (18 at the time of writing)
  EXPECT_LT(r.outliers, r.detected / 10);
  ASSERT_EQ(r.images.size(), 13u);
  EXPECT_EQ(r.images.front().image, "left01.jpg");
  int inliers = 0;
  for (const ImageResiduals& image : r.images) {
    EXPECT_EQ(image.corners, 54) << image.image;
    EXPECT_EQ(image.inliers + image.outliers, image.corners) << image.image;
    ASSERT_TRUE(image.rms_px && image.worst_px) << image.image;
    EXPECT_LE(*image.rms_px, *image.worst_px) << image.image;
    EXPECT_LE(*image.worst_px, r.worst_px) << image.image;
    inliers += image.inliers;
  }
  EXPECT_EQ(inliers, r.inliers);

  // Coverage: the corner counts add up and the shares are shares. The boards
  // fill the middle of the imager, not its corners.
  const CoverageSummary& cov = c.coverage;
  EXPECT_EQ(cov.cells_x, 10);
  EXPECT_EQ(cov.band_cells, 24);  // 6 x 4 cells overlap the default band
  EXPECT_GT(cov.share, 0.3);
  EXPECT_LT(cov.share, 1.0);
  EXPECT_GE(cov.band_share, 0.0);
  EXPECT_LE(cov.band_share, 1.0);
  int counted = 0;
  for (const auto& row : cov.counts) {
    for (const int n : row) counted += n;
  }
  EXPECT_EQ(counted, r.inliers);
  EXPECT_EQ(cov.counts[0][0], 0);  // no board reached the top-left corner
  EXPECT_TRUE(IsPng(cov.figure)) << cov.figure;

  // Uncertainty: positive, finite, smallest where the boards were.
  ASSERT_TRUE(c.uncertainty) << c.uncertainty_error;
  const UncertaintySummary& u = *c.uncertainty;
  EXPECT_GT(u.band_median_px, 0.0);
  EXPECT_LE(u.band_median_px, u.band_max_px);
  EXPECT_LT(u.band_max_px, 1.0);
  EXPECT_GT(u.imager_centre_px, 0.0);
  EXPECT_LT(u.imager_centre_px, 0.5);
  EXPECT_GT(u.imager_max_px, u.band_max_px);
  EXPECT_TRUE(IsPng(u.figure)) << u.figure;

  // Slope error: every sample solved; finite, well above the machinery's own
  // floor (the nominal model through the same steps) and below what would
  // matter for a 10-15 degree slope limit.
  const SlopeErrorSummary& s = c.slope;
  EXPECT_TRUE(s.error.empty()) << s.error;
  EXPECT_EQ(s.samples, kTestSamples);
  EXPECT_EQ(s.ok, kTestSamples);
  EXPECT_EQ(s.failed, 0);
  ASSERT_TRUE(s.rms_deg && s.median_deg && s.p90_deg && s.max_deg && s.nominal_deg);
  EXPECT_GT(*s.rms_deg, 0.0);
  EXPECT_LT(*s.rms_deg, 2.0);
  EXPECT_LE(*s.median_deg, *s.p90_deg);
  EXPECT_LE(*s.p90_deg, *s.max_deg);
  EXPECT_LT(*s.nominal_deg, 1e-3);
  EXPECT_LT(*s.nominal_deg, 0.01 * *s.rms_deg);
  ASSERT_TRUE(s.convergence_deg);
  EXPECT_NEAR(*s.convergence_deg, std::atan2(30.0, 570.0) * 180.0 / std::acos(-1.0), 1e-6);
  // The Monte Carlo's projection spread, tied to the boards as mrcal ties it,
  // agrees with mrcal's analytic stdev (factor 2: 8 samples); the fitted
  // rotation takes out more, so its spread is smaller.
  ASSERT_TRUE(s.board_rotation_spread.worst_direction_stdev_px && s.mrcal_band_centre_stdev_px &&
              s.fitted_rotation_spread.worst_direction_stdev_px);
  EXPECT_NEAR(*s.mrcal_band_centre_stdev_px, u.band_centre_px, 1e-9);
  EXPECT_GT(*s.board_rotation_spread.worst_direction_stdev_px, 0.5 * *s.mrcal_band_centre_stdev_px);
  EXPECT_LT(*s.board_rotation_spread.worst_direction_stdev_px, 2.0 * *s.mrcal_band_centre_stdev_px);
  EXPECT_LT(*s.fitted_rotation_spread.worst_direction_stdev_px,
            *s.board_rotation_spread.worst_direction_stdev_px);

  // OpenCV: a LENSMODEL_OPENCV8 model of this imager, close to mrcal's in the
  // band. Measured at the time of writing: band median 0.53 px, max 1.38 px
  // with every corner; OpenCV has no outlier rejection and the 18 corners
  // mrcal threw out pull it (on mrcal's inliers alone: 0.13 / 0.28 px, the
  // rest being mrcal's board warp, which OpenCV does not model). The bounds
  // leave room for that and still catch a broken convention (pixel origin,
  // corner order, units), which costs pixels to tens of pixels.
  ASSERT_TRUE(c.opencv) << c.opencv_error;
  const OpenCvCrossCheck& o = *c.opencv;
  EXPECT_EQ(o.images, 13);
  EXPECT_EQ(o.corners, r.detected);
  EXPECT_GT(o.rms_px, r.rms_px);  // the outliers are in OpenCV's figure
  EXPECT_LT(o.rms_px, 0.6);       // about 0.40 px; the data's README: about 0.41 px
  const CameraModel opencv_model = CameraModel::Load(o.model);
  EXPECT_EQ(opencv_model.LensModelName(), "LENSMODEL_OPENCV8");
  EXPECT_EQ(opencv_model.WidthPx(), 640);
  ASSERT_TRUE(o.diff.band_median_px && o.diff.band_max_px);
  EXPECT_LT(*o.diff.band_median_px, 1.0);
  EXPECT_LT(*o.diff.band_max_px, 2.0);
  EXPECT_LE(o.diff.median_px, o.diff.p90_px);
  EXPECT_LE(o.diff.p90_px, o.diff.max_px);
  EXPECT_EQ(o.diff.grid_width, 60);
  EXPECT_EQ(o.diff.grid_height, 45);
  ASSERT_TRUE(o.inliers_only_diff && o.inliers_only_diff->band_max_px);
  EXPECT_LT(*o.inliers_only_diff->band_max_px, 0.5);
  EXPECT_TRUE(IsPng(o.figure)) << o.figure;

  // The diff command, given the same two models, measures the same thing.
  const ProjectionDiff diff =
      DiffCalibrations(Model(calibration, 0), o.model, (dir / "diff" / "diff.json").string(),
                       (dir / "diff" / "diff.png").string());
  EXPECT_NEAR(diff.median_px, o.diff.median_px, 1e-6);
  EXPECT_NEAR(diff.max_px, o.diff.max_px, 1e-6);
  EXPECT_NEAR(diff.rotation_deg, o.diff.rotation_deg, 1e-6);
  EXPECT_EQ(diff.rotation_fit, "uncertainty-weighted");
  EXPECT_FALSE(diff.uncertainty_of_a);
  EXPECT_TRUE(IsPng(diff.heatmap_png));
  EXPECT_TRUE(fs::is_regular_file(dir / "diff" / "diff.log"));
}

// The slope figure is the flight method's: without its steps the analysis
// has every other figure and says why the slope one is missing.
TEST(CalibrationAnalysis, WithoutTheFlightMethodsStepsTheSlopeFigureSaysWhy) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options;
  options.slope_samples = 2;
  const CalibrationAnalysis analysis = AnalyseCalibration({Model(calibration, 0)}, dir.string(), options);
  ASSERT_EQ(analysis.cameras.size(), 1u);
  EXPECT_FALSE(analysis.cameras[0].slope.rms_deg);
  EXPECT_NE(analysis.cameras[0].slope.error.find("the flight method's steps"), std::string::npos)
      << analysis.cameras[0].slope.error;
  EXPECT_TRUE(analysis.cameras[0].uncertainty);
  EXPECT_EQ(ReadText(analysis.json_path).find("\"solved\""), std::string::npos);
}

TEST(CalibrationAnalysis, SameInputsGiveSameJsonBytes) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.slope_samples = 2;  // repeatability needs a Monte Carlo, not a long one
  options.seed = 7;
  const CalibrationAnalysis first =
      AnalyseCalibration({Model(calibration, 0)}, (dir / "a").string(), options);
  const CalibrationAnalysis second =
      AnalyseCalibration({Model(calibration, 0)}, (dir / "b").string(), options);
  const std::string bytes = ReadText(first.json_path);
  EXPECT_FALSE(bytes.empty());
  EXPECT_EQ(bytes, ReadText(second.json_path));
  EXPECT_EQ(ReadText(dir / "a" / "opencv" / "camera-0.cameramodel"),
            ReadText(dir / "b" / "opencv" / "camera-0.cameramodel"));
  ASSERT_TRUE(first.cameras[0].slope.rms_deg);
  EXPECT_EQ(first.cameras[0].slope.ok, 2);
  // No temporary file is left beside the record.
  for (const auto& entry : fs::directory_iterator(dir / "a")) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
  }

  // The seed reached the script (a third run with another seed would show
  // other statistics, at the cost of another run).
  EXPECT_NE(bytes.find("\"seed\": 7"), std::string::npos);
}

TEST(CalibrationAnalysis, StereoPairGivesTheRelativePose) {
  const fs::path calibration = Calibration({"left", "right"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.slope_samples = 0;  // the Monte Carlo is covered by the mono tests
  const CalibrationAnalysis analysis =
      AnalyseCalibration({Model(calibration, 0), Model(calibration, 1)}, dir.string(), options);
  ASSERT_EQ(analysis.cameras.size(), 2u);
  for (const CameraAnalysis& c : analysis.cameras) {
    EXPECT_EQ(c.icam_intrinsics, c.index);
    EXPECT_LT(c.residuals.rms_px, 0.5) << c.model;
    EXPECT_EQ(c.residuals.images.size(), 13u) << c.model;
    EXPECT_FALSE(c.slope.error.empty());  // skipped, and says so
    EXPECT_EQ(c.slope.samples, 0);
    EXPECT_TRUE(c.uncertainty) << c.uncertainty_error;
    EXPECT_TRUE(c.opencv) << c.opencv_error;
  }
  EXPECT_EQ(analysis.cameras[1].residuals.images.front().image, "right01.jpg");
  EXPECT_TRUE(fs::is_regular_file(dir / "opencv" / "camera-1.cameramodel"));
  EXPECT_TRUE(IsPng((dir / "figures" / "coverage-camera-1.png").string()));

  // The data's README: the third party's stereo calibration has T of about
  // [-3.34, 0.05, 0] squares (camera 1's centre at about +3.34 x in camera 0).
  ASSERT_EQ(analysis.relative_poses.size(), 1u);
  const RelativePose& pose = analysis.relative_poses[0];
  EXPECT_TRUE(pose.same_solve);
  ASSERT_TRUE(pose.baseline && pose.rotation_deg && pose.translation);
  EXPECT_NEAR(*pose.baseline, 3.34, 0.1);
  EXPECT_GT((*pose.translation)[0], 3.2);
  EXPECT_LT(*pose.rotation_deg, 2.0);
}

TEST(CalibrationDiff, AModelAgainstItselfIsZeroAndWithinItsUncertainty) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  DiffOptions options;
  options.with_uncertainty_of_a = true;
  options.gridn = 32;
  const ProjectionDiff diff =
      DiffCalibrations(Model(calibration, 0), Model(calibration, 0), (dir / "self.json").string(),
                       (dir / "self.png").string(), options);
  // Not exactly 0: mrcal's rotation fit starts from a small random rotation
  // and stops within its tolerance (about 1e-6 degrees, 2e-5 px here).
  EXPECT_LT(diff.max_px, 1e-3);
  EXPECT_LT(diff.rotation_deg, 1e-4);
  EXPECT_EQ(diff.grid_width, 32);
  EXPECT_EQ(diff.grid_height, 24);
  EXPECT_EQ(diff.points, 32 * 24);
  ASSERT_TRUE(diff.uncertainty_of_a);
  EXPECT_GT(diff.uncertainty_of_a->median_px, 0.0);
  EXPECT_EQ(diff.uncertainty_of_a->points, 32 * 24);
  EXPECT_EQ(diff.uncertainty_of_a->within_1_sigma, 1.0);
  EXPECT_EQ(diff.uncertainty_of_a->within_3_sigma, 1.0);
  EXPECT_EQ(diff.log_path, (dir / "self.log").string());
  EXPECT_TRUE(IsPng(diff.heatmap_png));
}

TEST(CalibrationDiff, DifferentImagerSizesAreAnInputError) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  const CameraModel model = CameraModel::Load(Model(calibration, 0));
  const std::string small = (dir / "small.cameramodel").string();
  CameraModel(model.LensModelName(), model.Intrinsics(), 320, 240).Save(small);
  try {
    DiffCalibrations(Model(calibration, 0), small, (dir / "d.json").string(),
                     (dir / "d.png").string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(small), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("imager"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "d.json"));
}

TEST(CalibrationAnalysis, AModelWithoutOptimizationInputsIsAnInputError) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  // The bench's own writer keeps the lens, not mrcal's optimization_inputs.
  const std::string bare = (dir / "bare.cameramodel").string();
  CameraModel::Load(Model(calibration, 0)).Save(bare);
  try {
    AnalyseCalibration({bare}, (dir / "out").string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bare), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("optimization_inputs"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "out" / "analysis.json"));

  DiffOptions options;
  options.with_uncertainty_of_a = true;
  EXPECT_THROW(DiffCalibrations(bare, Model(calibration, 0), (dir / "d.json").string(),
                                (dir / "d.png").string(), options),
               InputError);
  // Without the uncertainty, a bare model is fine to diff.
  const ProjectionDiff diff = DiffCalibrations(bare, Model(calibration, 0),
                                               (dir / "d.json").string(), (dir / "d.png").string());
  EXPECT_LT(diff.max_px, 1e-3);
}

// The calibration's modes (calib/intrinsics_modes.h) are about the model's
// own intrinsics, at most one per intrinsic, and hold the compensated
// variance they promise; a model without optimization_inputs has none.
TEST(IntrinsicsModes, ACalibrationGivesItsModesAndABareModelNone) {
  const fs::path calibration = Calibration({"left"});
  const std::string path = Model(calibration, 0);
  const CameraModel model = CameraModel::Load(path);
  EXPECT_TRUE(ModelHasOptimizationInputs(path));
  const IntrinsicsModes modes = ComputeIntrinsicsModes(path);
  EXPECT_EQ(modes.model, path);
  EXPECT_EQ(modes.lensmodel, model.LensModelName());
  EXPECT_EQ(modes.intrinsics, model.Intrinsics());
  ASSERT_GE(modes.modes.size(), 1u);
  EXPECT_LE(modes.modes.size(), model.Intrinsics().size());
  EXPECT_GE(modes.variance_kept, 0.999);
  EXPECT_GT(modes.noise_stdev_px, 0.0);
  EXPECT_GT(modes.imager_worst_stdev_median_px, 0.0);
  EXPECT_GT(modes.compensated_worst_stdev_median_px, 0.0);
  for (const IntrinsicsMode& mode : modes.modes) {
    EXPECT_EQ(mode.intrinsics_delta.size(), model.Intrinsics().size());
    EXPECT_GT(mode.projection_rms_px, 0.0);
    EXPECT_TRUE(mode.rotation_rad.allFinite());
  }
  // The same model, the same modes.
  const IntrinsicsModes again = ComputeIntrinsicsModes(path);
  ASSERT_EQ(again.modes.size(), modes.modes.size());
  for (size_t k = 0; k < modes.modes.size(); ++k) {
    EXPECT_EQ(again.modes[k].intrinsics_delta, modes.modes[k].intrinsics_delta);
  }

  const fs::path dir = FreshTestDir();
  const std::string bare = (dir / "bare.cameramodel").string();
  model.Save(bare);
  EXPECT_FALSE(ModelHasOptimizationInputs(bare));
  EXPECT_FALSE(ModelHasOptimizationInputs((dir / "missing.cameramodel").string()));
  try {
    ComputeIntrinsicsModes(bare);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(bare), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("optimization_inputs"), std::string::npos) << e.what();
  }
}

TEST(CalibrationAnalysis, AMissingModelIsAnInputError) {
  const fs::path dir = FreshTestDir();
  const std::string missing = (dir / "missing.cameramodel").string();
  try {
    AnalyseCalibration({missing}, (dir / "out").string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_THROW(
      DiffCalibrations(missing, missing, (dir / "d.json").string(), (dir / "d.png").string()),
      InputError);
}

TEST(CalibrationAnalysis, InvalidOptionsAreAnInputError) {
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.hda.band_x1 = 0.2;  // left of band_x0
  options.slope_samples = -1;
  try {
    AnalyseCalibration({"unused.cameramodel"}, dir.string(), options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("band_x1"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("slope_samples"), std::string::npos) << e.what();
  }
  DiffOptions diff_options;
  diff_options.gridn = 1;
  EXPECT_THROW(
      DiffCalibrations("a", "b", (dir / "d.json").string(), (dir / "d.png").string(), diff_options),
      InputError);
}

TEST(CalibrationAnalysis, AMissingPythonIsAnExternalError) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.python = "/nonexistent/python3";
  try {
    AnalyseCalibration({Model(calibration, 0)}, dir.string(), options);
    FAIL() << "expected ExternalError";
  } catch (const ExternalError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/python3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("analysis.log"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "analysis.json"));
}

TEST(CalibrationAnalysis, ScriptFailuresMapToTheRightErrors) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  // Stand-ins for python: a crash with a traceback's last line, and the
  // script's own "unusable input" exit.
  const fs::path crash = dir / "crash.sh";
  WriteText(crash,
            "#!/bin/sh\necho 'Traceback (most recent call last):' >&2\n"
            "echo 'ValueError: something broke' >&2\nexit 1\n");
  const fs::path unusable = dir / "unusable.sh";
  WriteText(unusable,
            "#!/bin/sh\necho 'hdabench-calibration-analysis: x.cameramodel: bad input' >&2\n"
            "echo 'a later warning' >&2\nexit 3\n");
  fs::permissions(crash, fs::perms::owner_all);
  fs::permissions(unusable, fs::perms::owner_all);

  AnalysisOptions options = WithFlightSlope();
  options.python = crash.string();
  try {
    AnalyseCalibration({Model(calibration, 0)}, (dir / "crash").string(), options);
    FAIL() << "expected ExternalError";
  } catch (const ExternalError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(crash.string()), std::string::npos) << what;
    EXPECT_NE(what.find("exited with code 1"), std::string::npos) << what;
    EXPECT_NE(what.find((dir / "crash" / "logs" / "analysis.log").string()), std::string::npos)
        << what;
    EXPECT_NE(what.find("ValueError: something broke"), std::string::npos) << what;
  }
  options.python = unusable.string();
  try {
    AnalyseCalibration({Model(calibration, 0)}, (dir / "unusable").string(), options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "x.cameramodel: bad input");
  }
}

TEST(CalibrationAnalysis, ATimeoutIsAnExternalErrorAndLeavesNoRecord) {
  const fs::path calibration = Calibration({"left"});
  const fs::path dir = FreshTestDir();
  AnalysisOptions options = WithFlightSlope();
  options.timeout_s = 0.3;  // python alone takes longer to import mrcal and matplotlib
  try {
    AnalyseCalibration({Model(calibration, 0)}, dir.string(), options);
    FAIL() << "expected ExternalError";
  } catch (const ExternalError& e) {
    EXPECT_NE(std::string(e.what()).find("timed out"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "analysis.json"));
}

TEST(CalibrationAnalysis, TheCompiledInScriptIsTheSourceFile) {
  const std::string source =
      ReadText(fs::path(HDABENCH_SOURCE_DIR) / "calib" / "calibration_analysis.py");
  ASSERT_FALSE(source.empty());
  EXPECT_EQ(CalibrationAnalysisScript(), source);
}

}  // namespace
}  // namespace hdabench::calib
