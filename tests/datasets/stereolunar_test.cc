// The StereoLunar converter (datasets/stereolunar.h) on the shared pairs
// (../shared/data/stereolunar-nadir): a valid dataset, poses and depths that
// agree with each other, a radial local vertical, slopes in the documented
// range, clear errors on bad sources, and `hdabench ingest stereolunar`.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tools/util/error.h"
#include "datasets/dataset.h"
#include "datasets/stereolunar.h"
#include "datasets/synth/truth.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;
using testing_support::SplitLines;
using testing_support::WriteText;

constexpr double kRadToDeg = 57.295779513082320876798;

// A copy of ../shared/data/stereolunar-nadir (Apache-2.0, LICENSE beside it).
const fs::path kSourceDir = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "stereolunar-nadir";

std::string PairDir(int pair) { return (kSourceDir / ("paire" + std::to_string(pair))).string(); }
std::string CamerasFile() { return (kSourceDir / "cameras.txt").string(); }

// Converts, writes and loads back with images and truth in memory.
Dataset ConvertWriteLoad(int pair, int sun, const fs::path& dir) {
  const Dataset converted = ConvertStereoLunarPair(PairDir(pair), CamerasFile(), sun);
  WriteDataset(converted, dir.string());
  LoadOptions options;
  options.keep_images = true;
  options.keep_truth = true;
  DatasetLoadResult result = LoadDataset(dir.string(), options);
  std::string problems;
  for (const Problem& problem : result.problems) problems += problem.ToString() + "\n";
  EXPECT_TRUE(result.Ok()) << problems;
  if (!result.Ok()) throw std::runtime_error("dataset did not load");
  return std::move(*result.dataset);
}

Eigen::Vector3d TruthPoint(const Dataset& dataset, int frame, int col, int row) {
  const cv::Vec3f p = dataset.truth.points.at(static_cast<size_t>(frame))
                          .points_in_local_m.at<cv::Vec3f>(row, col);
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

// Bilinear interpolation of a frame's truth points at a sub-pixel position
// (mrcal convention); false when a neighbour is NaN or outside the image.
bool TruthPointAt(const Dataset& dataset, int frame, const Eigen::Vector2d& pixel,
                  Eigen::Vector3d* point) {
  const int c0 = static_cast<int>(std::floor(pixel.x()));
  const int r0 = static_cast<int>(std::floor(pixel.y()));
  if (c0 < 0 || r0 < 0 || c0 + 1 >= dataset.camera.WidthPx() ||
      r0 + 1 >= dataset.camera.HeightPx()) {
    return false;
  }
  const double u = pixel.x() - c0;
  const double v = pixel.y() - r0;
  *point = (1 - u) * (1 - v) * TruthPoint(dataset, frame, c0, r0) +
           u * (1 - v) * TruthPoint(dataset, frame, c0 + 1, r0) +
           (1 - u) * v * TruthPoint(dataset, frame, c0, r0 + 1) +
           u * v * TruthPoint(dataset, frame, c0 + 1, r0 + 1);
  return point->allFinite();
}

Eigen::Vector2d ProjectInto(const Dataset& dataset, int frame, const Eigen::Vector3d& point_in_local,
                            bool* ok) {
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  dataset.camera.Project({dataset.TrueCamFromLocal(frame) * point_in_local}, &pixels, &valid);
  *ok = valid[0] != 0;
  return pixels[0];
}

TEST(StereoLunar, Pair1GivesAValidDataset) {
  const fs::path dir = FreshTestDir() / "dataset";
  const Dataset dataset = ConvertWriteLoad(1, 0, dir);
  ASSERT_EQ(dataset.frames.size(), 2u);
  EXPECT_EQ(dataset.name, "stereolunar-paire1-sun0");
  EXPECT_EQ(dataset.camera.LensModelName(), "LENSMODEL_PINHOLE");
  ASSERT_EQ(dataset.camera.Intrinsics().size(), 4u);
  EXPECT_NEAR(dataset.camera.Intrinsics()[2], 255.5, 1e-12);  // cx 256 in corner convention
  EXPECT_NEAR(dataset.camera.Intrinsics()[3], 255.5, 1e-12);
  EXPECT_EQ(dataset.truth.points.size(), 2u);
  EXPECT_EQ(dataset.truth.navigation.size(), 2u);
  EXPECT_FALSE(dataset.truth.dem.has_value());
  // Nadir, 25-45 km up, baseline 0.02-0.10 of the height.
  const double height_m = dataset.CameraCenterInLocal(0).z();
  EXPECT_GT(height_m, 25e3);
  EXPECT_LT(height_m, 45e3);
  const double ratio = dataset.BaselineM(0, 1) / height_m;
  EXPECT_GT(ratio, 0.02);
  EXPECT_LT(ratio, 0.10);
  // Measured navigation = truth.
  for (int frame = 0; frame < 2; ++frame) {
    const Rigid3d measured = dataset.CamFromLocal(frame);
    const Rigid3d truth = dataset.TrueCamFromLocal(frame);
    EXPECT_LT((measured.translation - truth.translation).norm(), 1e-9);
    EXPECT_LT(measured.rotation.angularDistance(truth.rotation), 1e-12);
  }
}

TEST(StereoLunar, CentreTruthPointIsTheOriginAndProjectsToTheCentrePixel) {
  const Dataset dataset = ConvertWriteLoad(1, 0, FreshTestDir() / "dataset");
  const Eigen::Vector2d centre = StereoLunarCentrePixel(512, 512);
  const Eigen::Vector3d point =
      TruthPoint(dataset, 0, static_cast<int>(centre.x()), static_cast<int>(centre.y()));
  EXPECT_LT(point.norm(), 0.05);  // the local origin (float32 rounding of a point near 0)
  bool ok = false;
  const Eigen::Vector2d pixel = ProjectInto(dataset, 0, point, &ok);
  ASSERT_TRUE(ok);
  EXPECT_LT((pixel - centre).norm(), 1e-3);
  // The LRF at frame 0 hits that point: origin + range * boresight.
  const Rigid3d local_from_body = dataset.TrueLocalFromBodyAt(0.0);
  const LrfSample& lrf = dataset.lrf.front();
  const Eigen::Vector3d spot =
      local_from_body * (dataset.lrf_origin_in_body_m + lrf.range_m * lrf.boresight_in_body);
  EXPECT_LT((spot - point).norm(), 0.05);
}

TEST(StereoLunar, Frame1PointsReprojectThroughFrame2Truth) {
  for (int pair = 1; pair <= 3; ++pair) {
    SCOPED_TRACE("paire" + std::to_string(pair));
    const Dataset dataset = ConvertWriteLoad(pair, 0, FreshTestDir() / ("p" + std::to_string(pair)));
    // Pixel c of frame 0 -> its truth point P -> pixel q of P in frame 1 ->
    // frame 1's truth point P' at q -> P' projected into frame 0 is c again
    // when poses and depths agree.
    std::vector<double> errors;
    for (int row = 8; row < 512; row += 16) {
      for (int col = 8; col < 512; col += 16) {
        const Eigen::Vector3d point = TruthPoint(dataset, 0, col, row);
        if (!point.allFinite()) continue;
        bool ok = false;
        const Eigen::Vector2d q = ProjectInto(dataset, 1, point, &ok);
        Eigen::Vector3d seen_by_2;
        if (!ok || !TruthPointAt(dataset, 1, q, &seen_by_2)) continue;
        const Eigen::Vector2d back = ProjectInto(dataset, 0, seen_by_2, &ok);
        ASSERT_TRUE(ok);
        errors.push_back((back - Eigen::Vector2d(col, row)).norm());
      }
    }
    ASSERT_GT(errors.size(), 500u);
    std::sort(errors.begin(), errors.end());
    EXPECT_LT(errors[errors.size() / 2], 0.5) << "median, px";
    EXPECT_LT(errors[errors.size() * 95 / 100], 1.0) << "95th percentile, px";
  }
}

TEST(StereoLunar, LocalUpIsRadialAndEastIsPerpendicularToTheSpinAxis) {
  const Dataset dataset = ConvertWriteLoad(1, 0, FreshTestDir() / "dataset");
  const std::vector<StereoLunarCamera> cameras = ReadStereoLunarCameras(CamerasFile());
  const auto found = std::find_if(cameras.begin(), cameras.end(), [](const StereoLunarCamera& c) {
    return c.key == "paire1/im_00594";
  });
  ASSERT_NE(found, cameras.end());
  // moon_from_local = moon_from_cam0 * cam0_from_local.
  const Eigen::Matrix3d moon_from_cam_rotation = found->cam2world.topLeftCorner<3, 3>();
  const Eigen::Vector3d moon_from_cam_translation = found->cam2world.topRightCorner<3, 1>();
  const Rigid3d cam_from_local = dataset.TrueCamFromLocal(0);
  const Eigen::Matrix3d moon_from_local_rotation =
      moon_from_cam_rotation * cam_from_local.RotationMatrix();
  const Eigen::Vector3d origin_in_moon =
      moon_from_cam_rotation * cam_from_local.translation + moon_from_cam_translation;
  // About the Moon's radius (1737.4 km; the south-polar terrain is lower).
  EXPECT_NEAR(origin_in_moon.norm(), 1737.4e3, 10e3);
  // (cam2world is float32: its rotation is orthonormal to about 1e-7 only.)
  const Eigen::Vector3d up_in_moon =
      (moon_from_local_rotation * (-dataset.gravity_in_local_mps2.normalized())).normalized();
  EXPECT_LT(up_in_moon.cross(origin_in_moon.normalized()).norm(), 1e-6);  // sine of the angle
  EXPECT_NEAR(dataset.gravity_in_local_mps2.norm(), 1.62, 1e-12);
  // x east: perpendicular to the spin axis (z of the Moon-centred frame).
  const Eigen::Vector3d east_in_moon = moon_from_local_rotation.col(0).normalized();
  EXPECT_LT(std::abs(east_in_moon.z()), 1e-6);
  EXPECT_LT((Eigen::Vector3d::UnitZ().cross(origin_in_moon).normalized() - east_in_moon).norm(),
            1e-6);
}

TEST(StereoLunar, PatchSlopesAreInTheDocumentedRange) {
  const Dataset dataset = ConvertWriteLoad(1, 0, FreshTestDir() / "dataset");
  // 64 x 64 px patches (about 3 km) on a 4 x 4 grid.
  double min_deg = 90.0;
  double max_deg = 0.0;
  for (int y = 0; y < 512; y += 128) {
    for (int x = 0; x < 512; x += 128) {
      const synth::RoiTruth truth = synth::ComputeRoiTruth(dataset, 0, {x + 32, y + 32, 64, 64});
      EXPECT_EQ(truth.num_points, 64 * 64);
      min_deg = std::min(min_deg, truth.slope_deg);
      max_deg = std::max(max_deg, truth.slope_deg);
    }
  }
  EXPECT_GE(min_deg, 0.0);
  EXPECT_LE(max_deg, 35.0);
  // The centre patch of paire1 (docs/stereolunar.md: 4-29 deg across the pairs).
  const synth::RoiTruth centre = synth::ComputeRoiTruth(dataset, 0, {224, 224, 64, 64});
  EXPECT_GE(centre.slope_deg, 4.0);
  EXPECT_LE(centre.slope_deg, 29.0);
}

TEST(StereoLunar, EverySunAndPairConverts) {
  for (int pair = 1; pair <= 3; ++pair) {
    for (int sun = 0; sun < 3; ++sun) {
      const Dataset dataset = ConvertStereoLunarPair(PairDir(pair), CamerasFile(), sun);
      EXPECT_EQ(dataset.frames.size(), 2u);
      EXPECT_EQ(dataset.name, "stereolunar-paire" + std::to_string(pair) + "-sun" +
                                  std::to_string(sun));
    }
  }
  // paire2's first pose sees beyond the terrain in a corner: those points are NaN.
  const Dataset pair2 = ConvertStereoLunarPair(PairDir(2), CamerasFile(), 0);
  const cv::Mat& points = pair2.truth.points[0].points_in_local_m;
  int nan_points = 0;
  for (int row = 0; row < points.rows; ++row) {
    for (int col = 0; col < points.cols; ++col) {
      if (std::isnan(points.at<cv::Vec3f>(row, col)[0])) ++nan_points;
    }
  }
  EXPECT_EQ(nan_points, 2165);
  EXPECT_THROW(ConvertStereoLunarPair(PairDir(1), CamerasFile(), 3), InputError);
}

// Runs `convert` expecting an InputError whose message contains every one of `parts`.
template <typename Convert>
void ExpectInputError(Convert convert, const std::vector<std::string>& parts) {
  try {
    convert();
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    for (const std::string& part : parts) {
      EXPECT_NE(std::string(e.what()).find(part), std::string::npos)
          << "'" << part << "' not in: " << e.what();
    }
  }
}

// A writable copy of paire1 in `dir`/paire1 with its cameras.txt beside it.
fs::path CopyPair1(const fs::path& dir) {
  const fs::path pair = dir / "paire1";
  fs::create_directories(pair);
  for (const fs::directory_entry& entry : fs::directory_iterator(PairDir(1))) {
    if (entry.path().extension() != ".npz") fs::copy_file(entry.path(), pair / entry.path().filename());
  }
  WriteText(dir / "cameras.txt", ReadText(CamerasFile()));
  return pair;
}

TEST(StereoLunar, BadSourcesGiveErrorsNamingTheFile) {
  const fs::path dir = FreshTestDir();
  ExpectInputError(
      [&] { ConvertStereoLunarPair((dir / "nowhere").string(), CamerasFile(), 0); },
      {(dir / "nowhere").string(), "no such folder"});

  const fs::path pair = CopyPair1(dir);
  const std::string cameras = (dir / "cameras.txt").string();
  ASSERT_NO_THROW(ConvertStereoLunarPair(pair.string(), cameras, 0));
  EXPECT_EQ(DefaultStereoLunarCamerasFile(pair.string()),
            fs::canonical(dir / "cameras.txt").string());

  // A malformed line: a value that is not a number, then a missing value.
  std::vector<std::string> lines = SplitLines(ReadText(CamerasFile()));
  std::vector<std::string> bad = lines;
  bad[2].replace(bad[2].find(" 618.038696 0 256"), 11, " 618.0x8696");
  WriteText(cameras, testing_support::JoinLines(bad));
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {cameras + ":3:", "'618.0x8696' is not a finite number"});
  // A focal length no camera has (1e-300 px ended in infinite ranges and exit 70).
  bad = lines;
  bad[2].replace(bad[2].find(" 618.038696 0 256"), 11, " 1e-300");
  WriteText(cameras, testing_support::JoinLines(bad));
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {cameras, "has fx 1e-300", "expected focal lengths of 1 to 1e7 px"});
  bad = lines;
  bad[3] = bad[3].substr(0, bad[3].rfind(' '));
  WriteText(cameras, testing_support::JoinLines(bad));
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {cameras + ":4:", "25 fields; expected 26"});
  bad = lines;
  bad[1] = "# no camera here";
  WriteText(cameras, testing_support::JoinLines(bad));
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {cameras, "no line for paire1/im_00594"});
  ExpectInputError(
      [&] { ConvertStereoLunarPair(pair.string(), (dir / "none.txt").string(), 0); },
      {(dir / "none.txt").string(), "file not found"});
  WriteText(cameras, testing_support::JoinLines(lines));

  // A missing depth file, then a depth file that is not an EXR.
  fs::remove(pair / "im_00595.exr");
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {(pair / "im_00595.exr").string(), "file not found"});
  WriteText(pair / "im_00595.exr", "not an image");
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {(pair / "im_00595.exr").string(), "cannot be decoded"});
  // A frame missing from the sequence.
  fs::remove(pair / "im_00596.jpg");
  ExpectInputError([&] { ConvertStereoLunarPair(pair.string(), cameras, 0); },
                   {pair.string(), "not consecutive", "im_00595", "im_00597"});
}

TEST(StereoLunar, CommandWritesADatasetThatChecks) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "dataset";
  const testing_support::CommandResult ingest =
      RunHdabench({"ingest", "stereolunar", PairDir(3), "--out", out.string(), "--sun", "2"}, dir);
  ASSERT_EQ(ingest.exit_code, 0) << ingest.err;
  EXPECT_NE(ingest.out.find("stereolunar-paire3-sun2"), std::string::npos) << ingest.out;
  const testing_support::CommandResult check =
      RunHdabench({"dataset", "check", out.string()}, dir);
  EXPECT_EQ(check.exit_code, 0) << check.err;
  EXPECT_NE(check.out.find("true navigation (2 samples)"), std::string::npos) << check.out;

  // The folder is now in use; a bad sun; a missing pair folder.
  EXPECT_EQ(RunHdabench({"ingest", "stereolunar", PairDir(3), "--out", out.string()}, dir).exit_code,
            2);
  EXPECT_EQ(RunHdabench({"ingest", "stereolunar", PairDir(3), "--out", (dir / "b").string(),
                         "--sun", "3"},
                        dir)
                .exit_code,
            2);
  const testing_support::CommandResult missing = RunHdabench(
      {"ingest", "stereolunar", (dir / "nowhere").string(), "--out", (dir / "c").string()}, dir);
  EXPECT_EQ(missing.exit_code, 3);
  EXPECT_NE(missing.err.find("nowhere: no such folder"), std::string::npos) << missing.err;
}

// With no parameter chosen by hand, the flight method's lengths follow the
// geometry (30 km of range, 1.4-2.4 km of baseline, sparse texture): the site
// grows to hold enough ORB keypoints and the relief band to the terrain's
// scale, and at least half of the ROIs whose box reaches image 2 get a slope
// (with the NOVA-C values: 3 of 1917 on paire1). Measured: 33/53, 30/50,
// 34/55.
TEST(StereoLunar, GeometryDefaultsEvaluateHalfTheRois) {
  const fs::path dir = FreshTestDir();
  for (int pair = 1; pair <= 3; ++pair) {
    SCOPED_TRACE("paire" + std::to_string(pair));
    const fs::path data = dir / ("sl" + std::to_string(pair));
    const fs::path out = dir / ("run" + std::to_string(pair));
    ASSERT_EQ(RunHdabench({"ingest", "stereolunar", PairDir(pair), "--out", data.string()}, dir).exit_code, 0);
    const testing_support::CommandResult run = RunHdabench(
        {"run", data.string(), "--out", out.string(), "--no-figures", "--no-report", "--budget-s", "10000"},
        dir);
    ASSERT_EQ(run.exit_code, 0) << run.err;
    EXPECT_NE(run.err.find("from the geometry: quadtree.site_size_m"), std::string::npos) << run.err;
    const nlohmann::json result = nlohmann::json::parse(ReadText(out / "result.json"));
    ASSERT_TRUE(result.contains("options_from_geometry"));
    int in_both = 0, with_slope = 0;
    for (const nlohmann::json& roi : result["rois"]) {
      const std::string status = roi["status"];
      if (status == "not in image 2") continue;
      ++in_both;
      if (status == "evaluated" || status == "unsafe slope" || status == "unsafe roughness") ++with_slope;
    }
    EXPECT_GT(in_both, 20);
    EXPECT_GE(2 * with_slope, in_both) << with_slope << " of " << in_both;
    const double site = result["options"]["quadtree"]["site_size_m"];
    EXPECT_GT(site, 1000.0);
    EXPECT_LT(site, 5000.0);
  }
}

}  // namespace
}  // namespace hdabench::datasets
