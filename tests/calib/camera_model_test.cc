#include "calib/camera_model.h"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "tools/util/error.h"
#include "tools/util/random_vectors.h"
#include "tests/support/test_support.h"

namespace hdabench::calib {
namespace {

namespace fs = std::filesystem;

using testing_support::CurrentTestSeed;
using testing_support::FreshTestDir;

CameraModel Pinhole() { return CameraModel("LENSMODEL_PINHOLE", {1200.5, 1190.25, 511.5, 498.75}, 1024, 1024); }

CameraModel OpenCv8() {
  return CameraModel("LENSMODEL_OPENCV8",
                     {1100.0, 1105.0, 515.25, 509.75, -0.12, 0.035, 4e-4, -3e-4, -0.004, 0.01,
                      -0.002, 0.0005},
                     1024, 1024);
}

// A splined stereographic model with small, smooth control-point offsets: a
// mild but real distortion of the stereographic projection.
CameraModel Splined() {
  const std::string name = "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=11_Ny=8_fov_x_deg=70";
  std::vector<double> intrinsics = {720.0, 722.0, 511.5, 383.5};
  const int nx = 11;
  const int ny = 8;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const double u = (i - (nx - 1) / 2.0) / nx;
      const double v = (j - (ny - 1) / 2.0) / ny;
      intrinsics.push_back(2e-3 * u * (u * u + v * v));
      intrinsics.push_back(-1.5e-3 * v * (u * u + v * v) + 4e-4 * u * v);
    }
  }
  return CameraModel(name, intrinsics, 1024, 768);
}

// Every pixel centre on a grid covering the whole imager, edges and corners included.
std::vector<Eigen::Vector2d> ImagerGrid(const CameraModel& model, int step_px) {
  std::vector<Eigen::Vector2d> pixels;
  for (int y = 0;; y += step_px) {
    const int yy = std::min(y, model.HeightPx() - 1);
    for (int x = 0;; x += step_px) {
      const int xx = std::min(x, model.WidthPx() - 1);
      pixels.emplace_back(xx, yy);
      if (xx == model.WidthPx() - 1) break;
    }
    if (yy == model.HeightPx() - 1) break;
  }
  return pixels;
}

void ExpectUnprojectProjectIdentity(const CameraModel& model) {
  const std::vector<Eigen::Vector2d> pixels = ImagerGrid(model, 8);
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  ASSERT_EQ(model.Unproject(pixels, &bearings, &valid), static_cast<int>(pixels.size()));
  for (const Eigen::Vector3d& b : bearings) ASSERT_NEAR(b.norm(), 1.0, 1e-12);
  std::vector<Eigen::Vector2d> reprojected;
  ASSERT_EQ(model.Project(bearings, &reprojected, &valid), static_cast<int>(pixels.size()));
  double worst = 0.0;
  Eigen::Vector2d worst_pixel = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < pixels.size(); ++i) {
    const double error = (reprojected[i] - pixels[i]).norm();
    if (error > worst) {
      worst = error;
      worst_pixel = pixels[i];
    }
  }
  EXPECT_LT(worst, 1e-9) << model.LensModelName() << ": worst at pixel " << worst_pixel.transpose();
}

TEST(CameraModelUnproject, ProjectInvertsItOverTheWholeImagerPinhole) {
  ExpectUnprojectProjectIdentity(Pinhole());
}
TEST(CameraModelUnproject, ProjectInvertsItOverTheWholeImagerOpenCv8) {
  ExpectUnprojectProjectIdentity(OpenCv8());
}
TEST(CameraModelUnproject, ProjectInvertsItOverTheWholeImagerSplined) {
  ExpectUnprojectProjectIdentity(Splined());
}

TEST(CameraModelProject, MarksPointsItCannotProject) {
  const CameraModel model = OpenCv8();
  const std::vector<Eigen::Vector3d> points = {
      {0.1, 0.2, 5.0}, {0.0, 0.0, -3.0}, {0.0, 0.0, 0.0}, {std::nan(""), 0.0, 1.0}};
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  EXPECT_EQ(model.Project(points, &pixels, &valid), 1);
  EXPECT_EQ(valid, (std::vector<unsigned char>{1, 0, 0, 0}));
  for (const Eigen::Vector2d& p : pixels) EXPECT_TRUE(p.allFinite());
  // A stereographic-family model can project behind the camera.
  EXPECT_TRUE(Splined().CanProjectBehindCamera());
  EXPECT_FALSE(model.CanProjectBehindCamera());
}

TEST(CameraModelUnproject, MarksNonFinitePixels) {
  std::vector<Eigen::Vector3d> bearings;
  std::vector<unsigned char> valid;
  EXPECT_EQ(Pinhole().Unproject({{10.0, 20.0}, {std::nan(""), 1.0}}, &bearings, &valid), 1);
  EXPECT_EQ(valid, (std::vector<unsigned char>{1, 0}));
  EXPECT_TRUE(bearings[1].isZero());
}

TEST(CameraModelSave, RoundTripGivesIdenticalDoubles) {
  std::mt19937_64 rng(CurrentTestSeed());
  std::uniform_real_distribution<double> small(-1e-3, 1e-3);
  std::vector<double> intrinsics = {1100.0 + small(rng), 1105.123456789012345, 0.1 + 0.2,
                                    509.75 + small(rng), -0.12, 1.2e-7, 4e-4 / 3.0, -3e-4,
                                    -0.004, 0.01, 5e-310 /* subnormal */, small(rng)};
  const std::array<double, 6> rt = {0.1 / 3.0, -0.2, 1e-17, 12.5 / 7.0, -0.0, 3e100};
  const CameraModel model("LENSMODEL_OPENCV8", intrinsics, 1280, 960, rt);
  const fs::path path = FreshTestDir() / "model.cameramodel";
  model.Save(path.string());
  const CameraModel back = CameraModel::Load(path.string());
  EXPECT_EQ(back.LensModelName(), "LENSMODEL_OPENCV8");
  EXPECT_EQ(back.WidthPx(), 1280);
  EXPECT_EQ(back.HeightPx(), 960);
  ASSERT_EQ(back.Intrinsics().size(), intrinsics.size());
  for (size_t i = 0; i < intrinsics.size(); ++i) {
    EXPECT_EQ(back.Intrinsics()[i], intrinsics[i]) << "intrinsics[" << i << "]";
  }
  for (size_t i = 0; i < 6; ++i) EXPECT_EQ(back.RtCamRef()[i], rt[i]) << "extrinsics[" << i << "]";
}

TEST(CameraModelSave, RoundTripOfASplinedModelGivesIdenticalDoubles) {
  const CameraModel model = Splined();
  const fs::path path = FreshTestDir() / "splined.cameramodel";
  model.Save(path.string());
  const CameraModel back = CameraModel::Load(path.string());
  EXPECT_EQ(back.LensModelName(), model.LensModelName());
  EXPECT_EQ(back.Intrinsics(), model.Intrinsics());
}

TEST(CameraModelSave, WrittenFileOpensInMrcalsPython) {
  const fs::path path = FreshTestDir() / "model.cameramodel";
  OpenCv8().Save(path.string());
  const std::string command =
      "/usr/bin/python3 -c \"import mrcal,sys; m=mrcal.cameramodel(sys.argv[1]); "
      "l,i=m.intrinsics(); assert l=='LENSMODEL_OPENCV8' and abs(i[0]-1100.0)==0 and "
      "tuple(m.imagersize())==(1024,1024)\" " +
      path.string();
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
}

TEST(CameraModelSave, UnwritablePathThrowsAndLeavesNothing) {
  const fs::path dir = FreshTestDir();
  const fs::path path = dir / "missing_folder" / "model.cameramodel";
  try {
    Pinhole().Save(path.string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path.string() + ": cannot write the camera model (No such file or directory)");
  }
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(CameraModelToOpenCv, MatchesMrcalProjection) {
  std::mt19937_64 rng(CurrentTestSeed());
  std::uniform_real_distribution<double> lateral(-0.5, 0.5);
  std::uniform_real_distribution<double> depth(2.0, 50.0);
  const std::vector<CameraModel> models = {
      Pinhole(), OpenCv8(),
      CameraModel("LENSMODEL_OPENCV4", {900, 910, 320, 240, -0.2, 0.05, 1e-3, -2e-3}, 640, 480),
      CameraModel("LENSMODEL_OPENCV5", {900, 910, 320, 240, -0.2, 0.05, 1e-3, -2e-3, 0.01}, 640, 480),
      CameraModel("LENSMODEL_OPENCV12",
                  {900, 910, 320, 240, -0.2, 0.05, 1e-3, -2e-3, 0.01, 0.02, -0.01, 0.003, 1e-3,
                   -2e-3, 5e-4, 1e-4},
                  640, 480)};
  for (const CameraModel& model : models) {
    SCOPED_TRACE(model.LensModelName());
    ASSERT_TRUE(model.HasOpenCvEquivalent());
    std::vector<Eigen::Vector3d> points;
    std::vector<cv::Point3d> cv_points;
    for (int i = 0; i < 500; ++i) {
      const double z = depth(rng);
      const Eigen::Vector2d xy = util::DrawVector2(lateral, rng);
      points.emplace_back(xy.x() * z, xy.y() * z, z);
      cv_points.emplace_back(points.back().x(), points.back().y(), points.back().z());
    }
    std::vector<Eigen::Vector2d> pixels;
    std::vector<unsigned char> valid;
    ASSERT_EQ(model.Project(points, &pixels, &valid), 500);
    cv::Mat k;
    cv::Mat distortion;
    model.ToOpenCv(&k, &distortion);
    EXPECT_EQ(distortion.cols, static_cast<int>(model.Intrinsics().size()) - 4);
    std::vector<cv::Point2d> cv_pixels;
    cv::projectPoints(cv_points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, distortion, cv_pixels);
    double worst = 0.0;
    for (size_t i = 0; i < points.size(); ++i) {
      worst = std::max(worst, (pixels[i] - Eigen::Vector2d(cv_pixels[i].x, cv_pixels[i].y)).norm());
    }
    EXPECT_LT(worst, 1e-9);
  }
}

TEST(CameraModelToOpenCv, RefusesModelsWithoutAnEquivalent) {
  const std::vector<CameraModel> models = {
      Splined(), CameraModel("LENSMODEL_STEREOGRAPHIC", {500, 500, 320, 240}, 640, 480),
      CameraModel("LENSMODEL_CAHVOR", {500, 500, 320, 240, 0.01, 0.02, 0.0, 0.0, 0.0}, 640, 480),
      CameraModel("LENSMODEL_LONLAT", {500, 500, 320, 240}, 640, 480)};
  for (const CameraModel& model : models) {
    EXPECT_FALSE(model.HasOpenCvEquivalent());
    cv::Mat k;
    cv::Mat distortion;
    try {
      model.ToOpenCv(&k, &distortion);
      ADD_FAILURE() << model.LensModelName() << " was converted";
    } catch (const UnsupportedError& e) {
      EXPECT_EQ(std::string(e.what()),
                "lens model " + model.LensModelName() +
                    " has no OpenCV equivalent (OpenCV's camera model covers only "
                    "LENSMODEL_PINHOLE and LENSMODEL_OPENCV4/5/8/12); undistort the images with "
                    "the mrcal model and use a pinhole camera instead");
    }
  }
}

TEST(CameraModel, EveryLibmrcalLensModelIsListed) {
  const std::vector<std::string> names = SupportedLensModels();
  for (const char* expected :
       {"LENSMODEL_PINHOLE", "LENSMODEL_STEREOGRAPHIC", "LENSMODEL_LONLAT", "LENSMODEL_LATLON",
        "LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8", "LENSMODEL_OPENCV12",
        "LENSMODEL_CAHVOR"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
}

TEST(CameraModel, EveryNoConfigLensModelProjectsAndUnprojects) {
  for (const std::string name :
       {"LENSMODEL_STEREOGRAPHIC", "LENSMODEL_LONLAT", "LENSMODEL_LATLON", "LENSMODEL_CAHVOR"}) {
    SCOPED_TRACE(name);
    std::vector<double> intrinsics = {500, 505, 319.5, 239.5};
    if (name == "LENSMODEL_CAHVOR") intrinsics.insert(intrinsics.end(), {1e-3, -2e-3, 0.0, 0.0, 0.0});
    ExpectUnprojectProjectIdentity(CameraModel(name, intrinsics, 640, 480));
  }
}

// --- Bad camera model files -------------------------------------------------

struct BadModelCase {
  const char* name;
  const char* text;
  const char* expected;  // the message after "<path>:"
};

const char kGood[] =
    "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
    " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n";

const BadModelCase kBadModels[] = {
    {"EmptyFile", "", "1:1: the file is empty (expected a { ... } dictionary)"},
    {"OnlyComments", "# nothing here\n\n", "3:1: the file is empty (expected a { ... } dictionary)"},
    {"MissingKey",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'imagersize': [640, 480],\n}\n",
     " missing key 'extrinsics' (a .cameramodel needs 'lensmodel', 'intrinsics', 'extrinsics', "
     "'imagersize')"},
    {"GarbageAfterBrace",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n  trailing words\n",
     "7:3: unexpected text after the closing '}': 'trailing words'"},
    {"UnknownLensModel",
     "{\n 'lensmodel': 'LENSMODEL_FISHEYE9',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "2:15: unknown lens model 'LENSMODEL_FISHEYE9'"},
    {"SplinedWithoutConfig",
     "{\n 'lensmodel': 'LENSMODEL_SPLINED_STEREOGRAPHIC',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "2:15: lens model 'LENSMODEL_SPLINED_STEREOGRAPHIC' has a missing or invalid configuration"},
    {"WrongIntrinsicsCount",
     "{\n 'lensmodel': 'LENSMODEL_OPENCV4',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "3:16: 'intrinsics' has 4 values; LENSMODEL_OPENCV4 takes 8"},
    {"NanIntrinsic",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, nan, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "3:23: 'intrinsics'[1] = 'nan' is not a finite decimal number"},
    {"OverflowingIntrinsic",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 4.5e400, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "3:29: 'intrinsics'[2] = '4.5e400' is not a finite decimal number"},
    {"NegativeImagerSize",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [-640, 480],\n}\n",
     "5:16: 'imagersize' must be two positive whole numbers of pixels, got -640, 480"},
    {"ShortExtrinsics",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "4:16: 'extrinsics' has 3 values; expected 6 (rt_cam_ref: rotation vector, translation)"},
    {"ZeroFocalLength",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [0, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     " focal lengths fx=0, fy=1000 must be positive"},
    {"NoClosingBrace",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n",
     "4:1: the file ends before the closing '}'"},
    {"NotADictionary", "[1, 2, 3]\n", "1:1: expected '{' to open the model, found '[1, 2, 3]'"},
    {"HexadecimalIntrinsic",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [0x3e8, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "3:17: 'intrinsics'[0] = '0x3e8' is not a finite decimal number"},
    // The two below pass the bench's own scan and are refused by libmrcal: its
    // stderr message is captured, located and folded into the error.
    {"EmptyListItemRefusedByLibmrcal",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5,,],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n}\n",
     "3:43: libmrcal: Didn't see the closing )/] for the intrinsics. Expected 4 values, but the "
     "given list has more. Giving up."},
    {"NestedValueRefusedByLibmrcal",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
     " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n 'extra': {'a': [1, {'b': 2}]},\n}\n",
     "6:10: libmrcal: Error parsing value for key 'extra'"},
    {"DuplicateKey",
     "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'lensmodel': 'LENSMODEL_PINHOLE',\n}\n",
     "3:2: key 'lensmodel' appears twice"},
};

class BadCameraModel : public testing::TestWithParam<BadModelCase> {};

TEST_P(BadCameraModel, GivesTheExactMessageAndPrintsNothing) {
  const BadModelCase& c = GetParam();
  const fs::path path = FreshTestDir() / "bad.cameramodel";
  {
    std::ofstream out(path);
    out << c.text;
  }
  testing::internal::CaptureStderr();
  testing::internal::CaptureStdout();
  try {
    CameraModel::Load(path.string());
    ADD_FAILURE() << "loaded a bad model";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path.string() + ":" + c.expected);
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_EQ(testing::internal::GetCapturedStdout(), "");
}

INSTANTIATE_TEST_SUITE_P(Catalogue, BadCameraModel, testing::ValuesIn(kBadModels),
                         [](const testing::TestParamInfo<BadModelCase>& param_info) {
                           return std::string(param_info.param.name);
                         });

// Found by the cameramodel fuzz harness: brackets nested thousands deep
// overflowed the stack of the scan, which recurses once a level. Values
// nested more than 32 levels deep are now an error at the bracket that opens
// the 33rd; 32 levels pass the scan (libmrcal then judges the value).
TEST(CameraModelParse, ValuesNestedThousandsDeepAreAnErrorNotAStackOverflow) {
  const std::string head =
      "{\n 'lensmodel': 'LENSMODEL_PINHOLE',\n 'intrinsics': [1000, 1000, 319.5, 239.5],\n"
      " 'extrinsics': [0, 0, 0, 0, 0, 0],\n 'imagersize': [640, 480],\n 'extra': ";
  const auto nested = [&](int levels) {
    return head + std::string(static_cast<size_t>(levels), '[') + "1" + std::string(static_cast<size_t>(levels), ']') +
           ",\n}\n";
  };
  for (const int levels : {33, 100000}) {
    try {
      CameraModel::Parse(nested(levels), "deep.cameramodel");
      ADD_FAILURE() << levels << " levels parsed";
    } catch (const InputError& e) {
      // Line 6, column 11 + 32: the 33rd '['.
      EXPECT_EQ(std::string(e.what()), "deep.cameramodel:6:43: values nested more than 32 levels deep") << levels;
    }
  }
  try {
    CameraModel::Parse(nested(32), "deep.cameramodel");
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).find("nested more than"), std::string::npos) << e.what();
  }
}

TEST(CameraModelLoad, MissingFileNamesThePath) {
  const fs::path path = FreshTestDir() / "absent.cameramodel";
  try {
    CameraModel::Load(path.string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              path.string() + ": camera model file: file not found");
  }
  // A folder is named as one, not read as an empty model.
  try {
    CameraModel::Load(path.parent_path().string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), path.parent_path().string() +
                                         ": camera model file: is a directory; expected a file");
  }
}

TEST(CameraModelLoad, AcceptsModelsWrittenByMrcalsPythonTools) {
  // mrcal's own writer adds comments, trailing commas and optional keys.
  const std::string text =
      "# generated by mrcal\n{\n    'lensmodel':  'LENSMODEL_OPENCV8',\n\n"
      "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n"
      "    'intrinsics': [ 800, 810, 511.5, 500.25, -0.1, 0.01, 0.0001, -0.0002, 1.2e-07, 0, 0, 0,],\n"
      "    'valid_intrinsics_region': [ [0, 0], [1023, 0], [1023, 1023], ],\n"
      "    'extrinsics': [ 0, 0, 0, 0, 0, 0,],\n    'imagersize': [ 1024, 1024,],\n"
      "    'icam_intrinsics': 0,\n}\n";
  const CameraModel model = CameraModel::Parse(text, "inline");
  EXPECT_EQ(model.LensModelName(), "LENSMODEL_OPENCV8");
  EXPECT_EQ(model.Intrinsics()[8], 1.2e-07);
  EXPECT_EQ(model.WidthPx(), 1024);
}

TEST(CameraModelParse, ACommentRunningToTheEndOfTheTextParses) {
  // libmrcal alone ends the process on such a text (found by the cameramodel
  // fuzzer); the bench hands it a newline at the end.
  const std::string model =
      "{'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [ 100, 110, 15.5, 16.5 ],\n"
      " 'extrinsics': [ 0, 0, 0, 0, 0, 0 ], 'imagersize': [ 32, 34 ] }\n";
  for (const std::string& ending : {std::string("#"), std::string("# written by hand"), std::string("  #x")}) {
    const CameraModel parsed = CameraModel::Parse(model + ending, "inline");
    EXPECT_EQ(parsed.Intrinsics()[1], 110.0) << ending;
    EXPECT_EQ(parsed.HeightPx(), 34) << ending;
  }
}

TEST(CameraModelParse, TheFuzzersCommentAtTheEndLoads) {
  // The input the cameramodel fuzzer found, as it wrote it (tests/data/fuzz-found/README.md).
  const CameraModel loaded = CameraModel::Load(
      (fs::path(HDABENCH_SOURCE_DIR) / "tests/data/fuzz-found/comment-at-end-without-newline.cameramodel")
          .string());
  EXPECT_EQ(loaded.LensModelName(), "LENSMODEL_OPENCV8");
  EXPECT_EQ(loaded.Intrinsics()[1], 50.7455168378114);
  EXPECT_EQ(loaded.WidthPx(), 32);
}

TEST(CameraModel, ConstructorRejectsBadValues) {
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, 2, 3}, 10, 10), InputError);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, 2, 3, std::nan("")}, 10, 10), InputError);
  EXPECT_THROW(CameraModel("LENSMODEL_PINHOLE", {1, 2, 3, 4}, 0, 10), InputError);
  EXPECT_THROW(CameraModel("LENSMODEL_NOPE", {1, 2, 3, 4}, 10, 10), InputError);
}

}  // namespace
}  // namespace hdabench::calib
