#include "reference/compare/compare.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tools/util/error.h"
#include "tools/util/random_vectors.h"
#include "hda/geometry.h"
#include "reference/compare/compare_outputs.h"
#include "reference/compare/method.h"
#include "tests/support/synth_scene.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

namespace fs = std::filesystem;
using testing_support::CommandResult;
using testing_support::CurrentTestSeed;
using testing_support::FreshTestDir;
using testing_support::RunHdabench;

TEST(ParseMethodList, AllNamesAndFlightFirst) {
  const std::vector<std::string> all = AllMethodNames();
  ASSERT_EQ(all.size(), 11u);
  EXPECT_EQ(all.back(), "plane-nav");
  EXPECT_EQ(all.front(), "flight");
  EXPECT_EQ(ParseMethodList("all"), all);
  // Flight is added, and the order is the table's whatever the order given.
  EXPECT_EQ(ParseMethodList("opengv-two-point,colmap-nav"),
            (std::vector<std::string>{"flight", "colmap-nav", "opengv-two-point"}));
  EXPECT_EQ(ParseMethodList("flight"), (std::vector<std::string>{"flight"}));
}

TEST(ParseMethodList, UnknownOrRepeatedNamesAreRefusedWithTheList) {
  try {
    ParseMethodList("flight,colmap");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown method 'colmap'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("colmap-nav"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ParseMethodList("colmap-nav,colmap-nav"), InputError);
  EXPECT_THROW(ParseMethodList(""), InputError);
  EXPECT_THROW(ParseMethodList("flight,"), InputError);
}

// The overlap tiles of OpenGV's pair pose: the ROIs' size, spread over the
// whole image (the last row and column of the grid's stride reached), never
// more than the cap, never on an ROI.
TEST(OverlapTiles, SpreadOverTheImageClearOfTheRoisAndNoMoreThanTheCap) {
  const std::vector<cv::Rect> rois = {{100, 100, 32, 32}, {500, 600, 32, 32}, {992, 992, 32, 32}};
  const std::vector<cv::Rect> tiles = OverlapTiles(1024, 1024, rois, 256);
  // A 32 x 32 grid of 32 px tiles, every second row and column: 16 x 16, less
  // the tiles the ROIs meet: (128, 128) meets the first (x, y 100-131),
  // (512, 576) the second (x 500-531, y 600-631); the third lies between the
  // kept tiles.
  EXPECT_EQ(tiles.size(), 256u - 2u);
  int right = 0, bottom = 0;
  for (const cv::Rect& tile : tiles) {
    EXPECT_EQ(tile.size(), cv::Size(32, 32));
    EXPECT_EQ(tile & cv::Rect(0, 0, 1024, 1024), tile);
    EXPECT_EQ(tile.x % 64, 0);
    EXPECT_EQ(tile.y % 64, 0);
    for (const cv::Rect& roi : rois) EXPECT_EQ((tile & roi).area(), 0) << tile << " meets " << roi;
    right = std::max(right, tile.x + tile.width);
    bottom = std::max(bottom, tile.y + tile.height);
  }
  EXPECT_EQ(right, 1024 - 32);
  EXPECT_EQ(bottom, 1024 - 32);
  // The side follows the largest ROI side; the cap holds for any value.
  const std::vector<cv::Rect> wide = OverlapTiles(1000, 700, {{0, 0, 40, 24}}, 1000);
  ASSERT_FALSE(wide.empty());
  EXPECT_EQ(wide.front(), cv::Rect(40, 0, 40, 40));
  EXPECT_EQ(wide.size(), 25u * 17u - 1u);
  for (int cap = 1; cap < 40; ++cap) EXPECT_LE(OverlapTiles(1000, 700, {{0, 0, 40, 24}}, cap).size(), size_t(cap));
  EXPECT_TRUE(OverlapTiles(1024, 1024, rois, 0).empty());
  EXPECT_TRUE(OverlapTiles(1024, 1024, {}, 256).empty());
  EXPECT_TRUE(OverlapTiles(20, 20, rois, 256).empty());
}

TEST(ComputeErrorStats, MedianP90MaxIgnoringNonFinite) {
  const ErrorStats s = ComputeErrorStats({5, 1, 4, 2, 3, std::nan(""), 10, 6, 7, 8, 9});
  EXPECT_EQ(s.count, 10);
  EXPECT_DOUBLE_EQ(s.median, 5.5);
  EXPECT_DOUBLE_EQ(s.p90, 9.1);  // 1 + 0.9 * 9 = position 8.1 between 9 and 10
  EXPECT_DOUBLE_EQ(s.max, 10.0);
  EXPECT_EQ(ComputeErrorStats({}).count, 0);
}

// A DEM of the plane z = 0.1 x + 2 (slope atan(0.1)) on a 1 m grid.
datasets::TruthDem TiltedDem() {
  datasets::TruthDem dem;
  dem.spacing_m = 1.0;
  dem.origin_in_local_m = Eigen::Vector2d(-50.0, 50.0);
  dem.width_cells = dem.height_cells = 101;
  dem.height_in_local_m = cv::Mat(101, 101, CV_32FC1);
  for (int r = 0; r < 101; ++r) {
    for (int c = 0; c < 101; ++c) {
      const double x = -50.0 + c;
      dem.height_in_local_m.at<float>(r, c) = static_cast<float>(0.1 * x + 2.0);
    }
  }
  return dem;
}

TEST(ComputePointAccuracy, DistanceToTheTrueSurfaceAlongItsNormal) {
  const datasets::TruthDem dem = TiltedDem();
  const double along_normal = 1.0 / std::sqrt(1.0 + 0.01);  // 1 m up is this far from the plane
  std::vector<Eigen::Vector3d> points;
  // Heights above the surface 0.05, 0.2, 0.5, 2 m (and one outside the DEM).
  for (const double dz : {0.05, 0.2, 0.5, 2.0}) {
    const double x = 3.3, y = -7.6;
    points.emplace_back(x, y, 0.1 * x + 2.0 + dz);
  }
  points.emplace_back(500.0, 0.0, 0.0);
  const PointAccuracy a = ComputePointAccuracy(points, dem);
  ASSERT_TRUE(a.available);
  EXPECT_EQ(a.num_points, 4);
  EXPECT_NEAR(a.median_m, 0.5 * (0.2 + 0.5) * along_normal, 1e-5);
  EXPECT_DOUBLE_EQ(a.within_0_1_m, 0.25);
  EXPECT_DOUBLE_EQ(a.within_0_3_m, 0.5);
  EXPECT_DOUBLE_EQ(a.within_1_m, 0.75);
  EXPECT_FALSE(ComputePointAccuracy({{500.0, 0.0, 0.0}}, dem).available);
}

// Points on a 10 m patch of known slope at about 565 m, triangulated from two
// cameras 31 m apart with pixel noise: the noise is stretched along the line
// of sight (about 10 x), which tilts a TLS fit; FitRoiPoints weights it out.
TEST(FitRoiPoints, RecoversTheSlopeOfANoisyTwoViewCloud) {
  std::mt19937_64 rng(CurrentTestSeed());
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-5.0, 5.0);
  const double slope_deg = 6.0;
  const double tan_slope = std::tan(slope_deg * M_PI / 180.0);
  const Eigen::Vector3d c1(0.0, -400.0, 400.0), c2(31.0, -400.0, 400.0);
  const double sigma_rad = 0.3 / 1900.0;
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector2d xy = util::DrawVector2(uniform, rng);
    const Eigen::Vector3d p(xy.x(), xy.y(), 0.0);
    Eigen::Vector3d truth = p;
    truth.z() = tan_slope * p.y();
    // Depth noise along the line of sight from camera 1, as two-view
    // triangulation makes it: range^2 sigma / baseline; across: range sigma.
    const Eigen::Vector3d los = (truth - c1).normalized();
    const double range = (truth - c1).norm();
    const Eigen::Vector3d across = los.cross(Eigen::Vector3d::UnitX()).normalized();
    const Eigen::Vector3d n = util::DrawVector3(noise, rng);  // along los, across, the third axis
    points.push_back(truth + los * n.x() * range * range * sigma_rad / 31.0 + across * n.y() * range * sigma_rad +
                     los.cross(across) * n.z() * range * sigma_rad);
  }
  const RoiFit fit = FitRoiPoints(points, c1, c2, Eigen::Vector3d(0, 0, -1.62), 10);
  ASSERT_EQ(fit.status, MethodRoiStatus::kOk);
  EXPECT_EQ(fit.num_points, 400);
  // Predicted 1-sigma at 400 points is about 0.6 deg (hda::PredictSlopeSigmaDeg
  // geometry); 3 sigma.
  EXPECT_NEAR(fit.slope_deg, slope_deg, 1.8);
  // The plain TLS fit of the same cloud is pulled toward the line of sight.
  const hda::PlaneFitResult tls = hda::FitPlane(points, Eigen::Vector3d(0, 0, -1.62), 10);
  EXPECT_GT(std::abs(tls.slope_deg - slope_deg), std::abs(fit.slope_deg - slope_deg));

  EXPECT_EQ(FitRoiPoints({}, c1, c2, Eigen::Vector3d(0, 0, -1.62), 10).status, MethodRoiStatus::kTooFewPoints);
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 20; ++i) line.emplace_back(i, 0.0, 0.0);
  EXPECT_EQ(FitRoiPoints(line, c1, c2, Eigen::Vector3d(0, 0, -1.62), 10).status, MethodRoiStatus::kDegenerate);
}

// A dataset with one ROI box and a reconstruction with points in only part of
// it: the other ROI gets "too few points" with 0 points, a failed
// reconstruction fails every ROI with its reason.
TEST(RoisOfReconstruction, AnRoiWithoutPointsAndAFailedMethodGetClearStatuses) {
  datasets::Dataset dataset(calib::CameraModel("LENSMODEL_PINHOLE", {1000, 1000, 49.5, 49.5}, 100, 100));
  hda::HdaResult flight;
  flight.rois.resize(2);
  flight.rois[0].id = 1;
  flight.rois[0].box1_px = cv::Rect(0, 0, 50, 50);
  flight.rois[1].id = 2;
  flight.rois[1].box1_px = cv::Rect(50, 50, 50, 50);
  PairReconstruction recon;
  recon.method = "colmap-nav";
  recon.ok = true;
  std::mt19937_64 rng(CurrentTestSeed());
  std::uniform_real_distribution<double> pixel(0.0, 49.0), ground(-5.0, 5.0);
  for (int i = 0; i < 30; ++i) {
    ReconstructedPoint p;
    p.pixel1 = util::DrawVector2(pixel, rng);
    const Eigen::Vector2d ground_xy = util::DrawVector2(ground, rng);
    p.point_in_local_m = Eigen::Vector3d(ground_xy.x(), ground_xy.y(), 0.0);
    recon.points.push_back(p);
  }
  const Rigid3d local_from_cam1(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, -400, 400));
  const Rigid3d local_from_cam2(Eigen::Quaterniond::Identity(), Eigen::Vector3d(31, -400, 400));
  std::vector<MethodRoi> rois =
      RoisOfReconstruction(recon, flight, dataset, local_from_cam1, local_from_cam2, 10);
  ASSERT_EQ(rois.size(), 2u);
  EXPECT_EQ(rois[0].status, MethodRoiStatus::kOk);
  EXPECT_EQ(rois[0].num_points, 30);
  EXPECT_TRUE(rois[0].has_fit);
  EXPECT_NEAR(rois[0].slope_deg, 0.0, 1e-6);
  EXPECT_EQ(rois[1].status, MethodRoiStatus::kTooFewPoints);
  EXPECT_EQ(rois[1].num_points, 0);
  EXPECT_FALSE(rois[1].has_fit);

  recon.ok = false;
  recon.failure = "mapper exited with code 1 (log: colmap/logs/04-mapper.log)";
  rois = RoisOfReconstruction(recon, flight, dataset, local_from_cam1, local_from_cam2, 10);
  for (const MethodRoi& roi : rois) {
    EXPECT_EQ(roi.status, MethodRoiStatus::kFailed);
    EXPECT_EQ(roi.reason, recon.failure);
    EXPECT_FALSE(roi.has_fit);
  }
}

// The default scene with exact navigation, written to disk (COLMAP reads
// files), shared by the end-to-end tests of this file.
class CompareOnSyntheticScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(testing_support::CachedExactNavLateralScene(HDABENCH_TEST_TMP));
  }
  static void TearDownTestSuite() {
    delete dir_;
    dir_ = nullptr;
  }
  // The scene, or with a 512 x 512 imager (small): for the checks whose
  // claim does not depend on the image size, at a quarter of the pixels.
  static datasets::Dataset Load(bool small = false) {
    datasets::LoadOptions load;
    load.keep_images = true;
    load.keep_truth = true;
    const fs::path dir = small ? testing_support::CachedExactNavLateralScene(HDABENCH_TEST_TMP, 512) : *dir_;
    datasets::DatasetLoadResult loaded = datasets::LoadDataset(dir.string(), load);
    if (!loaded.Ok()) throw std::runtime_error(loaded.Summary());
    return std::move(*loaded.dataset);
  }
  static fs::path* dir_;
};
fs::path* CompareOnSyntheticScene::dir_ = nullptr;

// With exact navigation, colmap-nav's points are triangulated with the true
// poses: its slope error is its SIFT keypoint noise propagated through the
// two-view geometry. The 10 m ROIs of the default quadtree are 32 px wide and
// smooth, where SIFT finds about 10 points (too few for a slope). 20 m sites
// (64 px ROIs; their brightness varies more, so the variable-block limit is
// raised to 60 DN) hold 20-40: each ROI's error must be within 3 predicted sigmas
// (hda::PredictSlopeSigmaDeg with its own points, 0.5 px per axis: SIFT's
// keypoint localisation at these contrasts; exact nav) plus 0.5 deg for the
// plane of the sparse points against the dense truth plane.
TEST_F(CompareOnSyntheticScene, EveryMethodRunsAndColmapNavSlopesAreWithinTheirGeometryBound) {
  const datasets::Dataset dataset = Load();
  CompareOptions options;
  options.hda.Set("quadtree.site_size_m", 20.0, "test");
  options.hda.Set("quadtree.max_roi_stddev", 60.0, "test");
  options.hda.Set("compute_budget_s", 1000.0, "test");  // a loaded or sanitized build keeps every ROI
  const fs::path out = FreshTestDir();
  const CompareRun run = RunCompare(dataset, 0, 6, options, (out / "colmap").string());
  ASSERT_EQ(run.methods, AllMethodNames());
  ASSERT_EQ(run.rois.size(), run.methods.size());
  ASSERT_GT(run.flight.result.rois.size(), 3u);
  for (size_t m = 0; m < run.methods.size(); ++m) {
    EXPECT_TRUE(run.summaries[m].ok) << run.methods[m] << ": " << run.summaries[m].failure;
    ASSERT_EQ(run.rois[m].size(), run.flight.result.rois.size());
  }
  const size_t nav = 2;
  ASSERT_EQ(run.methods[nav], "colmap-nav");
  const Rigid3d local_from_cam1 = dataset.CamFromLocal(0).Inverse();
  const Rigid3d cam2_from_cam1 = dataset.Cam2FromCam1(0, 6);
  std::vector<double> errors;
  std::vector<int> counts;
  for (size_t i = 0; i < run.flight.result.rois.size(); ++i) {
    const MethodRoi& roi = run.rois[nav][i];
    const RoiTruthValue& truth = run.flight.truths[i];
    if (!roi.has_fit || roi.num_points < kMinPointsForSlopeStats || !truth.available) continue;
    hda::SlopeSigmaOptions sigma;
    sigma.pixel_sigma_px = 0.5;
    sigma.focal_px = dataset.camera.Intrinsics()[0];
    std::vector<Eigen::Vector3d> points_in_cam1;
    for (const Eigen::Vector3d& p : roi.points_in_local_m) points_in_cam1.push_back(local_from_cam1.Inverse() * p);
    const double predicted = hda::PredictSlopeSigmaDeg(
        sigma, points_in_cam1, cam2_from_cam1,
        local_from_cam1.rotation.inverse() * (-dataset.gravity_in_local_mps2.normalized()));
    const double error = std::abs(roi.slope_deg - truth.slope_deg);
    EXPECT_LE(error, 3.0 * predicted + 0.5)
        << "ROI " << run.flight.result.rois[i].id << ": " << roi.num_points << " points, slope "
        << roi.slope_deg << " vs truth " << truth.slope_deg << ", predicted sigma " << predicted;
    errors.push_back(error);
    counts.push_back(roi.num_points);
  }
  ASSERT_GE(errors.size(), 3u) << "colmap-nav has enough points in too few ROIs";
  const ErrorStats stats = ComputeErrorStats(errors);
  std::sort(counts.begin(), counts.end());
  std::printf("[ compare  ] colmap-nav, exact nav, 20 m sites: %d ROIs, slope error median %.2f deg, "
              "90%% %.2f deg, max %.2f deg; points per ROI %d..%d (median %d)\n",
              stats.count, stats.median, stats.p90, stats.max, counts.front(), counts.back(),
              counts[counts.size() / 2]);
  EXPECT_EQ(run.summaries[nav].slope_vs_truth_deg.count, stats.count);

  // OpenGV on the whole pair, whose ground is nearly a plane seen from 566 m:
  // the free solvers report the pair planar on every ROI, never a confident
  // slope from a degenerate geometry, with their pose errors still given; the
  // 2-point solver (nav rotation held) is not degenerate on a plane and gives
  // a slope wherever the flight method has one.
  int flight_slopes = 0, two_point_slopes = 0;
  for (size_t m = 4; m < run.methods.size(); ++m) {
    if (run.methods[m].rfind(kOpenGvMethodPrefix, 0) != 0) continue;
    const bool two_point = run.methods[m] == "opengv-two-point";
    EXPECT_TRUE(run.summaries[m].has_pose_error) << run.methods[m];
    // The pose pools the overlap tiles' matches with the ROIs': 64 px tiles,
    // every second of the 16 x 16 grid, less those on the ROIs (40 here), each
    // matched as an ROI is (134 matches per tile measured; at least the 10 an
    // ROI needs for a plane, on average).
    std::smatch pooled;
    ASSERT_TRUE(std::regex_search(run.summaries[m].note, pooled,
                                  std::regex("([0-9]+) from the ROIs, ([0-9]+) from ([0-9]+) overlap tiles")))
        << run.summaries[m].note;
    const int tiles = std::stoi(pooled[3].str());
    EXPECT_GE(tiles, 20) << run.summaries[m].note;
    EXPECT_LE(tiles, 64) << run.summaries[m].note;
    EXPECT_GE(std::stoi(pooled[2].str()), 10 * tiles) << run.summaries[m].note;
    for (size_t i = 0; i < run.rois[m].size(); ++i) {
      const MethodRoi& roi = run.rois[m][i];
      EXPECT_EQ(roi.configuration, "planar") << run.methods[m];
      if (run.flight.result.rois[i].box2_px.area() <= 0) continue;
      if (!two_point) {
        EXPECT_EQ(roi.status, MethodRoiStatus::kPlanar) << run.methods[m];
        EXPECT_FALSE(roi.has_fit) << run.methods[m];
        continue;
      }
      if (!run.rois[0][i].HasSlope()) continue;
      ++flight_slopes;
      if (roi.HasSlope()) ++two_point_slopes;
    }
  }
  EXPECT_GE(two_point_slopes, 0.8 * flight_slopes) << two_point_slopes << " of " << flight_slopes;

  // plane-nav: a plane on every ROI the flight method has a slope for but a
  // handful, each with its sigma and no roughness (a plane has none).
  const size_t plane_nav = run.methods.size() - 1;
  ASSERT_EQ(run.methods[plane_nav], "plane-nav");
  int plane_slopes = 0;
  for (size_t i = 0; i < run.rois[plane_nav].size(); ++i) {
    const MethodRoi& roi = run.rois[plane_nav][i];
    if (!roi.HasSlope()) {
      EXPECT_FALSE(roi.reason.empty());
      continue;
    }
    EXPECT_TRUE(roi.has_sigma);
    EXPECT_GT(roi.slope_sigma_deg, 0.0);
    EXPECT_TRUE(std::isnan(roi.roughness_rms_m));
    if (run.rois[0][i].HasSlope()) ++plane_slopes;
  }
  EXPECT_GE(plane_slopes, 0.8 * flight_slopes) << plane_slopes << " of " << flight_slopes;

  // dense-nav: a plane on at least 80 % of the flight method's ROIs, each
  // from at least half of the ROI's pixels; an ROI without one says why.
  const size_t dense_nav = run.methods.size() - 2;
  ASSERT_EQ(run.methods[dense_nav], "dense-nav");
  int dense_slopes = 0;
  for (size_t i = 0; i < run.rois[dense_nav].size(); ++i) {
    const MethodRoi& roi = run.rois[dense_nav][i];
    if (!roi.HasSlope()) {
      EXPECT_FALSE(roi.reason.empty());
      EXPECT_NE(roi.status, MethodRoiStatus::kOk);
      continue;
    }
    EXPECT_GE(roi.num_points, run.flight.result.rois[i].box1_px.area() / 2);
    if (run.rois[0][i].HasSlope()) ++dense_slopes;
  }
  EXPECT_GE(dense_slopes, 0.8 * flight_slopes) << dense_slopes << " of " << flight_slopes;

  // The outputs: the table has one column per method.
  const std::vector<std::string> written = WriteCompareOutputs(
      run, dataset.frames[0].image, dataset.frames[6].image, out.string(), false);
  EXPECT_FALSE(written.empty());
  const std::string markdown = testing_support::ReadText(out / "compare.md");
  EXPECT_NE(markdown.find("| ROI | truth | flight | flight-refined | colmap-nav | colmap-free | "
                          "opengv-stewenius |"),
            std::string::npos);
  const nlohmann::json json = nlohmann::json::parse(testing_support::ReadText(out / "compare.json"));
  EXPECT_EQ(json["format"], "hdabench-compare-result");
  EXPECT_EQ(json["methods"].size(), run.methods.size());
  EXPECT_EQ(json["rois"].size(), run.flight.result.rois.size());
  // Every ROI with a flight plane and truth has a tilt error, at least the
  // difference of the slope magnitudes (the angle between two planes is never
  // less than the difference of their tilts), and the summary its statistics.
  int tilts = 0;
  for (const nlohmann::json& roi : json["rois"]) {
    const nlohmann::json& flight = roi["methods"]["flight"];
    if (flight["slope_error_deg"].is_null()) continue;
    ASSERT_TRUE(flight["tilt_error_deg"].is_number()) << roi["id"];
    EXPECT_GE(flight["tilt_error_deg"].get<double>() + 1e-9, std::abs(flight["slope_error_deg"].get<double>()))
        << roi["id"];
    EXPECT_EQ(roi["truth"]["normal"].size(), 3u);
    ++tilts;
  }
  EXPECT_GT(tilts, 10);
  EXPECT_GT(json["methods"][0]["tilt_error_vs_truth_deg"]["count"].get<int>(), 10);
  EXPECT_TRUE(json["methods"][0]["slope_bias_vs_truth_deg"].is_number());

  // The error taken apart: every method but external names its support, so
  // every ROI with a plane and a truth has an own truth, and the tilt error,
  // an angle between two planes, is at most the sum of the angles through the
  // third (the own truth).
  for (size_t m = 0; m < run.methods.size(); ++m) {
    SCOPED_TRACE(run.methods[m]);
    int parts = 0;
    for (size_t i = 0; i < run.flight.result.rois.size(); ++i) {
      const nlohmann::json& r = json["rois"][i]["methods"][run.methods[m]];
      const MethodRoi& roi = run.rois[m][i];
      if (!roi.has_fit || !run.flight.truths[i].available) {
        EXPECT_TRUE(r["tilt_definition_deg"].is_null());
        EXPECT_FALSE(r["own_truth"]["why"].get<std::string>().empty());
        continue;
      }
      ASSERT_TRUE(roi.own_truth.available) << "ROI " << r << ": " << roi.own_truth.why;
      EXPECT_GE(roi.own_truth.num_points, 3);
      EXPECT_LE(roi.own_truth.num_points, static_cast<int>(roi.support_px.size()));
      const double tilt = r["tilt_error_deg"].get<double>();
      const double definition = r["tilt_definition_deg"].get<double>();
      const double estimation = r["tilt_estimation_deg"].get<double>();
      EXPECT_LE(tilt, definition + estimation + 1e-9) << "ROI " << json["rois"][i]["id"];
      EXPECT_NEAR(r["slope_definition_error_deg"].get<double>() + r["slope_estimation_error_deg"].get<double>(),
                  r["slope_error_deg"].get<double>(), 1e-9);
      ++parts;
    }
    if (run.summaries[m].rois_with_fit > 0) {  // the free solvers find this pair planar
      EXPECT_GT(parts, 0);
    }
    // Every ROI that counts for the tilt error has both parts.
    EXPECT_EQ(json["methods"][m]["tilt_definition_part_deg"]["count"].get<int>(),
              json["methods"][m]["tilt_error_vs_truth_deg"]["count"].get<int>());
  }
  // plane-nav's support is its grown box, weighted by what each pixel tells of its depth.
  for (const MethodRoi& roi : run.rois[plane_nav]) {
    if (!roi.HasSlope()) continue;
    EXPECT_EQ(roi.support_weights.size(), roi.support_px.size());
    EXPECT_GT(*std::max_element(roi.support_weights.begin(), roi.support_weights.end()), 0.0);
  }
}

// COLMAP missing: both COLMAP columns fail with the reason, every other
// method's results are written, and the command exits 4.
TEST_F(CompareOnSyntheticScene, AMissingColmapFailsItsColumnsAndKeepsTheOthers) {
  const fs::path out = FreshTestDir();
  const CommandResult result =
      RunHdabench({"compare", dir_->string(), "--frames", "0,6", "--methods",
                   "flight,colmap-nav,colmap-free,opengv-two-point", "--colmap",
                   "/nonexistent/colmap", "--out", (out / "cmp").string(), "--no-figures"},
                  out);
  EXPECT_EQ(result.exit_code, 4) << result.err;
  EXPECT_NE(result.err.find("/nonexistent/colmap"), std::string::npos) << result.err;
  const nlohmann::json json =
      nlohmann::json::parse(testing_support::ReadText(out / "cmp" / "compare.json"));
  ASSERT_EQ(json["methods"].size(), 4u);
  EXPECT_EQ(json["methods"][0]["name"], "flight");
  EXPECT_TRUE(json["methods"][0]["ok"].get<bool>());
  for (const int m : {1, 2}) {
    EXPECT_FALSE(json["methods"][m]["ok"].get<bool>());
    EXPECT_NE(json["methods"][m]["failure"].get<std::string>().find("/nonexistent/colmap"),
              std::string::npos);
  }
  EXPECT_TRUE(json["methods"][3]["ok"].get<bool>());
  int flight_fits = 0;
  for (const auto& roi : json["rois"]) {
    EXPECT_EQ(roi["methods"]["colmap-nav"]["status"], "failed");
    if (!roi["methods"]["flight"]["slope_deg"].is_null()) ++flight_fits;
  }
  EXPECT_GT(flight_fits, 0);
  EXPECT_TRUE(fs::exists(out / "cmp" / "flight" / "result.json"));
}

// Every method runs inside the guard: one of each family made to throw (a
// table entry of the same name replacing it) fails its own column with the
// message, and every other column is what it is without the failure.
// Over 60 s (120 s in CI): six comparisons of six methods, one clean and one
// per family that throws; dense-nav and plane-nav take most of each.
TEST_F(CompareOnSyntheticScene, AMethodThatThrowsFailsOnlyItsOwnColumn) {
  const datasets::Dataset dataset = Load(/*small=*/true);
  CompareOptions options;
  options.methods = {kMethodFlight, kMethodFlightRefined, kMethodColmapNav, "opengv-two-point",
                     kMethodDenseNav, kMethodPlaneNav};
  options.colmap.executable = "/nonexistent/colmap";  // its column fails on its own; no COLMAP run here
  const fs::path out = FreshTestDir();
  const CompareRun clean = RunCompare(dataset, 0, 6, options, (out / "clean").string());
  const std::string clean_json = CompareResultJson(clean);
  for (const std::string& thrower : {std::string(kMethodFlightRefined), std::string(kMethodColmapNav),
                                     std::string("opengv-two-point"), std::string(kMethodDenseNav),
                                     std::string(kMethodPlaneNav)}) {
    SCOPED_TRACE(thrower);
    const std::unique_ptr<MethodEntry> original = FindMethod(thrower);
    ASSERT_NE(original, nullptr);
    MethodEntry failing = *original;
    // It reads what it needs first (the pair's matches, COLMAP's results),
    // then throws.
    failing.run = [run = original->run, thrower](const PairContext& ctx, std::vector<MethodRoi>* rois,
                                                 MethodSummary* summary) {
      run(ctx, rois, summary);
      throw std::runtime_error(thrower + " broke here");
    };
    const ScopedMethodRegistration registration(failing);
    const CompareRun run = RunCompare(dataset, 0, 6, options, (out / thrower).string());
    ASSERT_EQ(run.methods, clean.methods);
    for (size_t m = 0; m < run.methods.size(); ++m) {
      ASSERT_EQ(run.rois[m].size(), clean.flight.result.rois.size());
      if (run.methods[m] != thrower) {
        EXPECT_EQ(run.summaries[m].ok, clean.summaries[m].ok) << run.methods[m];
        continue;
      }
      EXPECT_FALSE(run.summaries[m].ok);
      EXPECT_EQ(run.summaries[m].failure, thrower + " broke here");
      for (const MethodRoi& roi : run.rois[m]) {
        EXPECT_EQ(roi.status, MethodRoiStatus::kFailed);
        EXPECT_FALSE(roi.has_fit);
      }
    }
    // The other columns are byte for byte those of the clean run.
    nlohmann::json broken = nlohmann::json::parse(CompareResultJson(run));
    nlohmann::json expected = nlohmann::json::parse(clean_json);
    for (nlohmann::json* j : {&broken, &expected}) {
      for (nlohmann::json& m : (*j)["methods"]) {
        if (m["name"] == thrower) m = nullptr;
      }
      for (nlohmann::json& roi : (*j)["rois"]) roi["methods"].erase(thrower);
    }
    EXPECT_EQ(broken.dump(), expected.dump());
  }
}

// A method of a test's own joins compare through the table alone: it is
// listed, parsed by --methods, run in the guarded loop with the pair's
// context, written to compare.json and summarised by the one rule.
TEST_F(CompareOnSyntheticScene, AMethodRegisteredInTheTableJoinsCompare) {
  MethodEntry level;
  level.name = "level-ground";
  level.summary = "every ROI level, from the flight method's own points (a test's method)";
  level.run = [](const PairContext& ctx, std::vector<MethodRoi>* rois, MethodSummary* summary) {
    for (const hda::RoiResult& r : ctx.flight().result.rois) {
      MethodRoi roi;
      roi.num_points = static_cast<int>(r.points_in_local_m.size());
      roi.status = roi.num_points >= 3 ? MethodRoiStatus::kOk : MethodRoiStatus::kTooFewPoints;
      roi.has_fit = roi.status == MethodRoiStatus::kOk;
      roi.slope_deg = 0.0;
      roi.reason = "level by assumption";
      rois->push_back(roi);
    }
    summary->note = "a test's method";
  };
  const ScopedMethodRegistration registration(level);
  EXPECT_EQ(AllMethodNames().back(), "level-ground");
  EXPECT_NE(MethodListText().find("level-ground"), std::string::npos);
  CompareOptions options;
  options.methods = ParseMethodList("flight,level-ground");
  ASSERT_EQ(options.methods, (std::vector<std::string>{"flight", "level-ground"}));
  const CompareRun run = RunCompare(Load(), 0, 6, options, (FreshTestDir() / "colmap").string());
  ASSERT_EQ(run.summaries.size(), 2u);
  EXPECT_TRUE(run.summaries[1].ok) << run.summaries[1].failure;
  EXPECT_EQ(run.summaries[1].note, "a test's method");
  int level_rois = 0;
  for (size_t i = 0; i < run.rois[1].size(); ++i) {
    const MethodRoi& roi = run.rois[1][i];
    if (roi.has_fit) ++level_rois;
    EXPECT_EQ(roi.num_points, static_cast<int>(run.flight.result.rois[i].points_in_local_m.size()));
  }
  EXPECT_GT(level_rois, 0);
  EXPECT_EQ(run.summaries[1].rois_with_fit, level_rois);
  EXPECT_GT(run.summaries[1].slope_vs_truth_deg.count, 0);  // the truth's own slopes are its errors
  const nlohmann::json json = nlohmann::json::parse(CompareResultJson(run));
  EXPECT_EQ(json["methods"][1]["name"], "level-ground");
  EXPECT_EQ(json["rois"][0]["methods"]["level-ground"]["reason"], "level by assumption");
}

// The external method runs only when named, and only with a program.
TEST(ExternalMethod, RunsOnlyWhenNamedAndNeedsAProgram) {
  const std::vector<std::string> all = AllMethodNames();
  EXPECT_EQ(std::find(all.begin(), all.end(), kMethodExternal), all.end());
  const std::vector<std::string> known = KnownMethodNames();
  EXPECT_NE(std::find(known.begin(), known.end(), kMethodExternal), known.end());
  EXPECT_EQ(ParseMethodList("external"), (std::vector<std::string>{"flight", "external"}));
  CompareOptions options;
  options.methods = {kMethodFlight, kMethodExternal};
  const std::vector<std::string> without = options.Validate();
  ASSERT_EQ(without.size(), 1u);
  EXPECT_NE(without[0].find("needs a program"), std::string::npos) << without[0];
  options.external.program = "/bin/true";
  EXPECT_TRUE(options.Validate().empty());
  options.external.timeout_s = 0.0;
  ASSERT_EQ(options.Validate().size(), 1u);
  EXPECT_NE(options.Validate()[0].find("external.timeout_s"), std::string::npos);
}

// The output's text: anything unusable is an InputError naming the file and
// the record (a number past a double's range included: the JSON parser's
// out-of-range error, found by the fuzz harness); a huge but finite normal
// still has a direction.
TEST(ExternalMethod, AnUnusableOutputIsAnInputErrorNamingTheFileAndRecord) {
  const std::vector<int> ids = {4, 9};
  const Eigen::Vector3d gravity(0.0, 0.0, -1.62);
  const std::string head = R"({"format": "hdabench-external-output", "format_version": 1, "rois": [)";
  const auto message = [&](const std::string& text) {
    std::vector<MethodRoi> rois;
    std::string note;
    try {
      ParseExternalOutput(text, "out.json", ids, gravity, nullptr, &rois, &note);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("2773888e7777772").find("out.json: not JSON"), std::string::npos);
  EXPECT_NE(message(head + R"({"id": 4, "status": "ok", "normal_in_local": [0, 0, 1e999]}]})").find("not JSON"),
            std::string::npos);
  EXPECT_NE(message("[]").find("expected an object with \"format\""), std::string::npos);
  EXPECT_NE(message(head + R"({"id": 4, "status": "degenerate"}, {"id": 4, "status": "ok"}]})")
                .find("out.json: rois[1]: ROI 4 is given twice"),
            std::string::npos);
  EXPECT_NE(message(head + R"({"id": 4, "status": "ok", "normal_in_local": [0, 0]}]})")
                .find("rois[0]: normal_in_local: expected a list of 3 numbers"),
            std::string::npos);
  EXPECT_NE(message(head + R"({"id": 9, "status": "too few points", "num_points": -1}]})").find("num_points"),
            std::string::npos);
  std::vector<MethodRoi> rois;
  std::string note;
  ParseExternalOutput(head + R"({"id": 9, "status": "ok", "normal_in_local": [1e308, 0, 1e308]}]})", "out.json", ids,
                      gravity, nullptr, &rois, &note);
  ASSERT_EQ(rois.size(), 2u);
  EXPECT_EQ(rois[0].status, MethodRoiStatus::kFailed);
  EXPECT_EQ(rois[0].reason, "the program gave no result for ROI 4");
  EXPECT_EQ(rois[1].status, MethodRoiStatus::kOk);
  EXPECT_NEAR(rois[1].slope_deg, 45.0, 1e-12);
  EXPECT_EQ(note, "1 ROI(s) without a result from the program");
}

// The example program fits the flight method's own points by total least
// squares: where an ROI has enough of them, its plane is hda::FitPlane's of
// the same points (numpy against Eigen, through JSON's shortest round-trip
// decimals: the same plane to far under 1e-6 deg), and it says why where it
// has none. Its input, output and log stay in the method's folder.
TEST_F(CompareOnSyntheticScene, TheExampleExternalProgramFitsTheFlightPoints) {
  CompareOptions options;
  options.methods = ParseMethodList("external");
  options.external.program = std::string(HDABENCH_SOURCE_DIR) + "/tools/external/plane_fit.py";
  const fs::path out = FreshTestDir();
  options.external.work_dir = (out / "external").string();
  const datasets::Dataset dataset = Load();
  const CompareRun run = RunCompare(dataset, 0, 6, options, (out / "colmap").string());
  ASSERT_EQ(run.methods, (std::vector<std::string>{"flight", "external"}));
  ASSERT_TRUE(run.summaries[1].ok) << run.summaries[1].failure;
  EXPECT_NE(run.summaries[1].note.find("plane_fit.py"), std::string::npos) << run.summaries[1].note;
  for (const char* file : {"input.json", "output.json", "image1.png", "image2.png", "camera.cameramodel"}) {
    EXPECT_TRUE(fs::exists(out / "external" / file)) << file;
  }
  int fitted = 0;
  for (size_t i = 0; i < run.rois[1].size(); ++i) {
    const std::vector<Eigen::Vector3d>& points = run.flight.result.rois[i].points_in_local_m;
    const MethodRoi& roi = run.rois[1][i];
    EXPECT_EQ(roi.num_points, static_cast<int>(points.size()));
    if (static_cast<int>(points.size()) < std::max(3, options.min_points)) {
      EXPECT_EQ(roi.status, MethodRoiStatus::kTooFewPoints) << i;
      EXPECT_FALSE(roi.has_fit);
      continue;
    }
    ASSERT_EQ(roi.status, MethodRoiStatus::kOk) << i << ": " << roi.reason;
    const hda::PlaneFitResult tls = hda::FitPlane(points, dataset.gravity_in_local_mps2, options.min_points);
    ASSERT_EQ(tls.status, hda::PlaneFitStatus::kOk);
    EXPECT_NEAR(roi.slope_deg, tls.slope_deg, 1e-6) << i;
    EXPECT_NEAR((roi.normal_in_local - tls.normal_in_local).norm(), 0.0, 1e-8) << i;
    EXPECT_NEAR(roi.roughness_rms_m, tls.roughness_rms_m, 1e-9) << i;
    EXPECT_NEAR(roi.roughness_max_m, tls.roughness_max_m, 1e-9) << i;
    ++fitted;
  }
  EXPECT_GT(fitted, 10);
  EXPECT_EQ(run.summaries[1].rois_with_fit, fitted);
  const nlohmann::json json = nlohmann::json::parse(CompareResultJson(run));
  EXPECT_EQ(json["methods"][1]["name"], "external");
}

// A program that fails, hangs past its time limit or writes an output the
// bench cannot use fails the external column with a reason that says which;
// the flight method's column is the same as without it.
TEST_F(CompareOnSyntheticScene, AFailingHangingOrGarbledExternalProgramFailsOnlyItsColumn) {
  const datasets::Dataset dataset = Load();
  const fs::path dir = FreshTestDir();
  CompareOptions flight_only;
  flight_only.methods = {kMethodFlight};
  const CompareRun clean = RunCompare(dataset, 0, 6, flight_only, (dir / "colmap").string());
  const std::string flight_json = nlohmann::json::parse(CompareResultJson(clean))["rois"].dump();
  // One line of the output, for ROI `id`, in a valid file.
  const auto output_with = [](const std::string& roi) {
    return "printf '%s' '{\"format\": \"hdabench-external-output\", \"format_version\": 1, \"rois\": [" + roi +
           "]}' > \"$2\"\n";
  };
  const std::string id = std::to_string(clean.flight.result.rois[0].id);
  struct Case {
    std::string name, script, expected;
    double timeout_s = 600.0;
  };
  const std::vector<Case> cases = {
      {"exits-3", "echo 'cannot read the images' >&2\nexit 3\n", "exited with code 3; its last line: cannot read the images"},
      {"hangs", "sleep 30\n", "timed out after 1 s", 1.0},
      {"garbled", "printf '{\"format\": \"hdabench-external-output\", ' > \"$2\"\n", "output.json: not JSON"},
      {"no-output", "exit 0\n", "the program exited 0 but wrote no"},
      {"wrong-format", "echo '{\"format\": \"something\"}' > \"$2\"\n", "expected an object with \"format\""},
      {"unknown-id", output_with("{\"id\": 99999, \"status\": \"ok\", \"normal_in_local\": [0, 0, 1]}"),
       "id 99999 is not an ROI of the input"},
      {"unknown-status", output_with("{\"id\": " + id + ", \"status\": \"fine\"}"), "unknown status 'fine'"},
      {"zero-normal", output_with("{\"id\": " + id + ", \"status\": \"ok\", \"normal_in_local\": [0, 0, 0]}"),
       "normal_in_local is the zero vector"},
      {"no-normal", output_with("{\"id\": " + id + ", \"status\": \"ok\"}"), "status 'ok' needs 'normal_in_local'"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const fs::path program = dir / (c.name + ".sh");
    testing_support::WriteText(program, "#!/bin/sh\n" + c.script);
    fs::permissions(program, fs::perms::owner_all, fs::perm_options::add);
    CompareOptions options;
    options.methods = {kMethodFlight, kMethodExternal};
    options.external.program = program.string();
    options.external.timeout_s = c.timeout_s;
    options.external.work_dir = (dir / c.name).string();
    const CompareRun run = RunCompare(dataset, 0, 6, options, (dir / "colmap").string());
    ASSERT_EQ(run.summaries.size(), 2u);
    EXPECT_TRUE(run.summaries[0].ok);
    EXPECT_FALSE(run.summaries[1].ok);
    EXPECT_NE(run.summaries[1].failure.find(c.expected), std::string::npos) << run.summaries[1].failure;
    for (const MethodRoi& roi : run.rois[1]) EXPECT_EQ(roi.status, MethodRoiStatus::kFailed);
    nlohmann::json json = nlohmann::json::parse(CompareResultJson(run));
    for (nlohmann::json& roi : json["rois"]) roi["methods"].erase(kMethodExternal);
    EXPECT_EQ(json["rois"].dump(), flight_json);
  }
}

// An ROI the program leaves out is "failed" with that reason; the others are its.
TEST_F(CompareOnSyntheticScene, AnRoiTheExternalProgramLeavesOutIsFailedWithTheReason) {
  const datasets::Dataset dataset = Load();
  const fs::path dir = FreshTestDir();
  CompareOptions options;
  options.methods = {kMethodFlight};
  const int id = RunCompare(dataset, 0, 6, options, (dir / "colmap").string()).flight.result.rois[0].id;
  const fs::path program = dir / "one-roi.sh";
  testing_support::WriteText(program, "#!/bin/sh\nprintf '%s' '{\"format\": \"hdabench-external-output\", "
                                      "\"format_version\": 1, \"rois\": [{\"id\": " +
                                          std::to_string(id) +
                                          ", \"status\": \"ok\", \"normal_in_local\": [0, 0.1, 1]}]}' > \"$2\"\n");
  fs::permissions(program, fs::perms::owner_all, fs::perm_options::add);
  options.methods = {kMethodFlight, kMethodExternal};
  options.external.program = program.string();
  const CompareRun run = RunCompare(dataset, 0, 6, options, (dir / "colmap").string());
  ASSERT_TRUE(run.summaries[1].ok) << run.summaries[1].failure;
  ASSERT_GT(run.rois[1].size(), 1u);
  EXPECT_EQ(run.rois[1][0].status, MethodRoiStatus::kOk);
  EXPECT_NEAR(run.rois[1][0].slope_deg, std::atan(0.1) * 180.0 / M_PI, 1e-9);
  for (size_t i = 1; i < run.rois[1].size(); ++i) {
    EXPECT_EQ(run.rois[1][i].status, MethodRoiStatus::kFailed);
    EXPECT_NE(run.rois[1][i].reason.find("the program gave no result for ROI"), std::string::npos);
  }
  EXPECT_NE(run.summaries[1].note.find("without a result from the program"), std::string::npos);
}

// Every method is deterministic: the same bytes on a second run, COLMAP's
// included (exact matching and one thread; see reference/colmap/colmap_runner.h).
// Over 60 s (160 s in CI beside another test): every method twice, COLMAP on
// one thread; determinism is only shown by running the whole comparison again.
TEST_F(CompareOnSyntheticScene, EveryMethodGivesTheSameBytesTwice) {
  const datasets::Dataset dataset = Load(/*small=*/true);
  const fs::path dir = FreshTestDir();
  CompareOptions options;
  options.methods = ParseMethodList("all");
  options.colmap.threads = 1;
  options.colmap.timeout_s = 120.0;
  const CompareRun first = RunCompare(dataset, 0, 6, options, (dir / "colmap1").string());
  const CompareRun second = RunCompare(dataset, 0, 6, options, (dir / "colmap2").string());
  for (size_t m = 0; m < first.methods.size(); ++m) {
    EXPECT_TRUE(first.summaries[m].ok) << first.methods[m] << ": " << first.summaries[m].failure;
  }
  EXPECT_EQ(CompareResultJson(first), CompareResultJson(second));
  EXPECT_EQ(CompareRoisCsv(first), CompareRoisCsv(second));
  // And the flight column is the flight method's own result.
  int fits = 0;
  for (size_t i = 0; i < first.flight.result.rois.size(); ++i) {
    const hda::RoiResult& flight = first.flight.result.rois[i];
    EXPECT_EQ(first.rois[0][i].has_fit, flight.has_fit);
    if (flight.has_fit) {
      EXPECT_EQ(first.rois[0][i].slope_deg, flight.slope_deg);
      ++fits;
    }
  }
  EXPECT_GT(fits, 0);
}

TEST_F(CompareOnSyntheticScene, BadFlagsAreUsageErrors) {
  const fs::path out = FreshTestDir();
  CommandResult result = RunHdabench(
      {"compare", dir_->string(), "--methods", "flight,colmap", "--out", (out / "a").string()}, out);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("unknown method 'colmap'"), std::string::npos) << result.err;
  result = RunHdabench({"compare", dir_->string(), "--frames", "0,99", "--out", (out / "b").string()}, out);
  EXPECT_EQ(result.exit_code, 2);
  EXPECT_NE(result.err.find("frame 99"), std::string::npos) << result.err;
  result = RunHdabench({"compare", (out / "missing").string(), "--out", (out / "c").string()}, out);
  EXPECT_EQ(result.exit_code, 3) << result.err;
}

// A real pair whose navigation gives both frames one pose (a cameras.txt
// that repeats the first frame's line for the second) has no parallax
// anywhere: each method with the nav pose says so on every ROI, in its own
// terms, and none calls it too few points, a divergence or an epipole.
// flight-refined, which refits the flight method's points, passes on its
// reason; colmap-nav, which COLMAP aborts on such a pair in its bundle
// adjustment, fails with the nav baseline in its reason.
// A 3 deg site inside 10 deg surroundings (a 20 m pad set into a slope, both
// tilting east, across the line of sight; craters and rocks off, the relief
// kept for texture), the site the box inside the image of the pad's central
// 16 m, with exact navigation. The bound is the noise's: three of the
// method's own predicted sigmas, or of the flight method's for the site (its
// matching noise through this geometry, 100 points) for a method that
// predicts none and has at least as many points. Every method estimates its
// own truth within it. Every method whose support is the box gives the
// site's slope within it, and its definition part is small. plane-nav's
// support is the box grown by half the warp window: it reads the 10 deg
// surroundings, and its definition part says by how much (1.96 deg of its
// 2.02 deg error, seed 1).
TEST(CompareOnAPad, EveryReferenceGivesTheSiteNotItsSurroundings) {
  datasets::synth::SynthOptions options = testing_support::ExactNavLateralPreset();
  options.collection_s = 2.4;
  options.frames_to_render = [](const datasets::Dataset&) { return std::vector<int>{0, 6}; };
  datasets::synth::TerrainOptions terrain = testing_support::TerrainOf(options);
  terrain.crater_k = 0.0;
  terrain.rock_k = 0.0;
  terrain.regional_slope_deg = 10.0;
  terrain.regional_slope_downhill_azimuth_deg = 90.0;
  datasets::synth::TerrainOptions::Pad pad;
  pad.side_m = 20.0;
  pad.slope_deg = 3.0;
  pad.downhill_azimuth_deg = 90.0;
  terrain.extra_pads = {pad};
  const datasets::Dataset dataset = datasets::synth::GenerateSynthDataset(options, terrain, CurrentTestSeed());

  // The site: the box inside the image of the pad's central 16 m square.
  std::vector<Eigen::Vector3d> corners;
  for (const double x : {-8.0, 8.0}) {
    for (const double y : {-8.0, 8.0}) corners.emplace_back(x, y, std::tan(3.0 * 3.14159265358979323846 / 180.0) * -x);
  }
  const Rigid3d cam_from_local = dataset.TrueCamFromLocal(0);
  std::vector<Eigen::Vector3d> in_cam;
  for (const Eigen::Vector3d& c : corners) in_cam.push_back(cam_from_local * c);
  std::vector<Eigen::Vector2d> pixels;
  std::vector<unsigned char> valid;
  dataset.camera.Project(in_cam, &pixels, &valid);
  double left = -1e9, right = 1e9, top = -1e9, bottom = 1e9;
  for (size_t k = 0; k < pixels.size(); ++k) {
    ASSERT_TRUE(valid[k]);
    (corners[k].x() < 0 ? left : right) =
        corners[k].x() < 0 ? std::max(left, pixels[k].x()) : std::min(right, pixels[k].x());
    (corners[k].y() > 0 ? top : bottom) =
        corners[k].y() > 0 ? std::max(top, pixels[k].y()) : std::min(bottom, pixels[k].y());
  }
  const cv::Rect site(static_cast<int>(std::ceil(left)), static_cast<int>(std::ceil(top)),
                      static_cast<int>(std::floor(right) - std::ceil(left)),
                      static_cast<int>(std::floor(bottom) - std::ceil(top)));
  ASSERT_GT(site.width, 10);
  ASSERT_GT(site.height, 10);

  CompareOptions compare;
  compare.methods = {kMethodFlight, kMethodFlightRefined, "opengv-two-point", kMethodDenseNav, kMethodPlaneNav};
  compare.given_rois_px = {site};
  compare.hda.Set("compute_budget_s", 1000.0, "test");
  const fs::path out = FreshTestDir();
  const CompareRun run = RunCompare(dataset, 0, 6, compare, (out / "colmap").string());
  ASSERT_EQ(run.flight.result.rois.size(), 1u);
  const RoiTruthValue& truth = run.flight.truths[0];
  ASSERT_TRUE(truth.available) << truth.why;
  // The pad's 3 deg, tilted by the relief's few tenths over 16 m.
  EXPECT_NEAR(truth.slope_deg, 3.0, 0.6);
  const MethodRoi& flight = run.rois[0][0];
  ASSERT_TRUE(flight.HasSlope() && flight.has_sigma) << flight.reason;
  for (size_t m = 0; m < run.methods.size(); ++m) {
    SCOPED_TRACE(run.methods[m]);
    const MethodRoi& roi = run.rois[m][0];
    ASSERT_TRUE(roi.HasSlope()) << roi.reason;
    ASSERT_TRUE(roi.own_truth.available) << roi.own_truth.why;
    const SlopeSample sample = SampleOfMethodRoi(roi, &truth);
    const double bound = 3.0 * (roi.has_sigma ? roi.slope_sigma_deg : flight.slope_sigma_deg);
    std::printf("[ compare  ] 3 deg pad in 10 deg: %-16s slope %5.2f (truth %.2f, own truth %.2f), bound %.2f; "
                "tilt %.2f: definition %.2f, estimation %.2f; %d points\n",
                run.methods[m].c_str(), roi.slope_deg, truth.slope_deg, roi.own_truth.slope_deg, bound,
                sample.tilt_error_deg, sample.definition_tilt_deg, sample.estimation_tilt_deg, roi.num_points);
    if (!roi.has_sigma) {
      EXPECT_GE(roi.num_points, flight.num_points);
    }
    EXPECT_LE(std::abs(sample.estimation_error_deg), bound);
    if (run.methods[m] == kMethodPlaneNav) {
      EXPECT_GT(sample.definition_tilt_deg, 1.0);
      EXPECT_GT(sample.definition_error_deg, 1.0);  // toward the steeper surroundings
    } else {
      EXPECT_LE(std::abs(sample.error_deg), bound);
      EXPECT_LT(sample.definition_tilt_deg, 0.3);
    }
  }
}

// A StereoLunar nadir pair (real renderings): the relief of the far side is
// seen well above the matches' noise, so the free solvers' pair is
// well-conditioned (GRIC picks the general model and the points are not flat
// to 1 % of their extent) and they give a slope wherever the flight method
// has one, but for a few ROIs; the note names the criterion's values. The
// NOVA-C pair of CompareOnSyntheticScene stays planar.
TEST(CompareOnStereoLunar, TheFreeSolversGiveSlopesWhereTheReliefIsSeen) {
  const fs::path out = FreshTestDir();
  const fs::path source = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "stereolunar-nadir";
  CommandResult result = RunHdabench(
      {"ingest", "stereolunar", (source / "paire1").string(), "--out", (out / "pair").string()}, out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const std::vector<std::string> free_solvers = {"opengv-stewenius", "opengv-nister",
                                                 "opengv-eigensolver"};
  result = RunHdabench({"compare", (out / "pair").string(), "--methods",
                        "flight,opengv-stewenius,opengv-nister,opengv-eigensolver", "--out",
                        (out / "cmp").string(), "--no-figures", "--no-report"},
                       out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  const nlohmann::json json =
      nlohmann::json::parse(testing_support::ReadText(out / "cmp" / "compare.json"));
  const std::string summary = testing_support::ReadText(out / "cmp" / "compare.md");
  const std::regex criterion(
      "- opengv-stewenius: pair: well-conditioned \\(median parallax [0-9.]+ deg, eigenvalue ratio "
      "([0-9.]+), homography residual [0-9.]+ px, noise ([0-9.]+) px, GRIC homography ([0-9.]+) / "
      "general ([0-9.]+),");
  std::smatch values;
  ASSERT_TRUE(std::regex_search(summary, values, criterion)) << summary;
  EXPECT_GE(std::stod(values[1].str()), 0.01);
  EXPECT_GT(std::stod(values[2].str()), 0.0);
  EXPECT_LT(std::stod(values[4].str()), std::stod(values[3].str()));
  for (const std::string& solver : free_solvers) {
    int flight_slopes = 0;
    int solver_slopes = 0;
    for (const auto& roi : json["rois"]) {
      const auto& methods = roi["methods"];
      if (methods["flight"]["slope_deg"].is_null()) continue;
      ++flight_slopes;
      EXPECT_EQ(methods[solver]["configuration"], "well-conditioned") << roi["id"];
      if (methods[solver]["status"] == "ok" && !methods[solver]["slope_deg"].is_null()) ++solver_slopes;
    }
    std::printf("[ compare  ] %s: a slope on %d of the flight method's %d\n", solver.c_str(),
                solver_slopes, flight_slopes);
    EXPECT_GE(flight_slopes, 20);
    EXPECT_GE(solver_slopes, 0.8 * flight_slopes) << solver;
  }
}

TEST(CompareWithoutBaseline, EveryMethodSaysPerRoiThatTheGeometryGivesNoDepth) {
  const fs::path out = FreshTestDir();
  const fs::path source = fs::path(HDABENCH_SOURCE_DIR) / "tests" / "data" / "stereolunar-nadir";
  std::string cameras = testing_support::ReadText(source / "cameras.txt");
  const auto line_of = [&](const std::string& frame) {
    const size_t start = cameras.find("\n" + frame + " ") + 1;
    return std::make_pair(start, cameras.find('\n', start) - start);
  };
  const auto [first, first_length] = line_of("paire1/im_00594");
  const auto [second, second_length] = line_of("paire1/im_00595");
  const std::string pose = cameras.substr(first + 16, first_length - 16);
  ASSERT_EQ(cameras.substr(second, 16), "paire1/im_00595 ");
  cameras.replace(second + 16, second_length - 16, pose);
  std::ofstream(out / "cameras.txt") << cameras;
  CommandResult result = RunHdabench({"ingest", "stereolunar", (source / "paire1").string(), "--cameras",
                                      (out / "cameras.txt").string(), "--out", (out / "pair").string()},
                                     out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  EXPECT_NE(result.out.find("baseline 0 m"), std::string::npos) << result.out;
  result = RunHdabench({"compare", (out / "pair").string(), "--methods", "flight,flight-refined,dense-nav,plane-nav,colmap-nav",
                        "--out", (out / "cmp").string(), "--no-figures", "--no-report"},
                       out);
  EXPECT_EQ(result.exit_code, 4) << "a failed method's exit code: " << result.err;
  EXPECT_NE(result.err.find("method colmap-nav failed"), std::string::npos) << result.err;
  const nlohmann::json json = nlohmann::json::parse(testing_support::ReadText(out / "cmp" / "compare.json"));
  ASSERT_GE(json["rois"].size(), 10u);
  ASSERT_EQ(json["methods"].size(), 5u);
  const auto method_summary = [&json](const std::string& name) {
    for (const auto& m : json["methods"]) {
      if (m["name"] == name) return m;
    }
    ADD_FAILURE() << "no summary of " << name;
    return nlohmann::json::object({{"ok", false}, {"failure", ""}});
  };
  EXPECT_TRUE(method_summary("flight-refined")["ok"].get<bool>());
  const std::string colmap_failure = method_summary("colmap-nav")["failure"].get<std::string>();
  EXPECT_NE(colmap_failure.find("no points triangulated"), std::string::npos) << colmap_failure;
  const std::string baseline_words = "the nav poses put the camera centres ";
  const size_t baseline_at = colmap_failure.find(baseline_words);
  ASSERT_NE(baseline_at, std::string::npos) << colmap_failure;
  EXPECT_LT(std::stod(colmap_failure.substr(baseline_at + baseline_words.size())), 1e-6) << colmap_failure;
  const std::string summary = testing_support::ReadText(out / "cmp" / "compare.md");
  EXPECT_NE(summary.find("- plane-nav: 0 planes, 0 converged within 30 iterations; " +
                         std::to_string(json["rois"].size()) + " ROIs not fitted: low parallax"),
            std::string::npos)
      << summary;
  for (const auto& roi : json["rois"]) {
    const auto& methods = roi["methods"];
    EXPECT_EQ(methods["flight"]["status"], "degenerate") << roi["id"];
    EXPECT_NE(methods["flight"]["reason"].get<std::string>().find("depth not observable"), std::string::npos);
    EXPECT_EQ(methods["dense-nav"]["status"], "not rectifiable") << roi["id"];
    EXPECT_NE(methods["dense-nav"]["reason"].get<std::string>().find("baseline too short"), std::string::npos)
        << methods["dense-nav"]["reason"];
    EXPECT_EQ(methods["plane-nav"]["status"], "low parallax") << roi["id"] << ": " << methods["plane-nav"]["reason"];
    EXPECT_EQ(methods["flight-refined"]["status"], "low parallax") << roi["id"];
    EXPECT_NE(methods["flight-refined"]["reason"].get<std::string>().find(
                  "the flight method fitted none here (degenerate: depth not observable"),
              std::string::npos)
        << methods["flight-refined"]["reason"];
    EXPECT_EQ(methods["colmap-nav"]["status"], "failed") << roi["id"];
  }
  // The flight method's own record: not matched, so no matching status.
  const nlohmann::json flight =
      nlohmann::json::parse(testing_support::ReadText(out / "cmp" / "flight" / "result.json"));
  for (const auto& roi : flight["rois"]) {
    EXPECT_FALSE(roi["box2"].is_null()) << roi["id"];
    EXPECT_TRUE(roi["matching_status"].is_null()) << roi["id"] << ": " << roi["matching_status"];
  }
}

// A synthetic pair whose camera did not move (speed 0) but whose nav pose
// drifted a fraction of a metre: the images have no parallax, the nav pose a
// baseline of 0.24 m at 564 m of LRF range. The flight method finds every
// ROI's depth unobservable; dense-nav, which can rectify along that baseline
// (its level ground gets about a pixel of disparity, over the matcher's 1/16
// px step), has plenty of points per ROI but no slope to stand by: its
// disparity step alone leaves each ROI's slope uncertain by 20-30 deg.
// Without that bound its planes were noise (a 64 deg median slope error).
// plane-nav's fits find no slope either (sigmas of 12-30 deg); the
// parallax alone, with every pixel located to the same 1/16 px, leaves
// 7-12 deg, so the cause it gives is the parallax, not the texture.
// colmap-free, without the nav pose, finds no initial pose: COLMAP tries the
// pair five times, relaxing its constraints, and the failure says so.
TEST(CompareWithoutMotion, TheNavReferencesAreLowParallaxWhereTheParallaxLeavesNoSlope) {
  const fs::path out = FreshTestDir();
  CommandResult result = RunHdabench({"synth", "--out", (out / "pair").string(), "--image-size", "512", "--set",
                                      "speed_mps=0", "--quiet"},
                                     out);
  ASSERT_EQ(result.exit_code, 0) << result.err;
  result = RunHdabench({"compare", (out / "pair").string(), "--methods",
                        "flight,flight-refined,dense-nav,plane-nav,colmap-free", "--out", (out / "cmp").string(),
                        "--no-figures", "--no-report"},
                       out);
  EXPECT_EQ(result.exit_code, 4) << "a failed method's exit code: " << result.err;
  const nlohmann::json json = nlohmann::json::parse(testing_support::ReadText(out / "cmp" / "compare.json"));
  for (const auto& m : json["methods"]) {
    EXPECT_EQ(m["ok"].get<bool>(), m["name"] != "colmap-free") << m["name"];
    if (m["name"] != "colmap-free") continue;
    const std::string failure = m["failure"].get<std::string>();
    EXPECT_NE(failure.find("colmap mapper: no initial pose from images 1 and 2 (COLMAP's initialisation failed 5 "
                           "times, the last asking for 12 inliers and a triangulation angle of 0.25 deg, relaxed "
                           "from 50 and 1 deg"),
              std::string::npos)
        << failure;
  }
  const double baseline_m = json["baseline_m"].get<double>();
  EXPECT_GT(baseline_m, 0.01);
  EXPECT_LT(baseline_m, 1.0);
  ASSERT_GE(json["rois"].size(), 10u);
  for (const auto& roi : json["rois"]) {
    const auto& methods = roi["methods"];
    EXPECT_EQ(methods["flight"]["status"], "degenerate") << roi["id"];
    EXPECT_EQ(methods["flight-refined"]["status"], "low parallax") << roi["id"];
    const auto& dense = methods["dense-nav"];
    EXPECT_EQ(dense["status"], "low parallax") << roi["id"] << ": " << dense["reason"];
    EXPECT_TRUE(dense["slope_deg"].is_null()) << roi["id"];
    EXPECT_GE(dense["num_points"].get<int>(), 10) << roi["id"];
    EXPECT_NE(dense["reason"].get<std::string>().find("disparity step alone leaves their slope uncertain by"),
              std::string::npos)
        << dense["reason"];
    const auto& plane = methods["plane-nav"];
    EXPECT_EQ(plane["status"], "low parallax") << roi["id"] << ": " << plane["reason"];
    EXPECT_TRUE(plane["slope_deg"].is_null()) << roi["id"];
    EXPECT_NE(plane["reason"].get<std::string>().find("the nav pose's parallax (baseline "), std::string::npos)
        << plane["reason"];
  }
  const std::string summary = testing_support::ReadText(out / "cmp" / "compare.md");
  const std::string rois = std::to_string(json["rois"].size());
  EXPECT_NE(summary.find(rois + " ROIs not fitted: low parallax (the disparity step"), std::string::npos) << summary;
  EXPECT_NE(summary.find("- flight-refined: nothing to refine: too few points: 0 usable of 0, need at least 5; " + rois +
                         " ROIs not fitted: low parallax (the flight method found their depth unobservable under the "
                         "nav pose)"),
            std::string::npos)
      << summary;
  EXPECT_NE(summary.find("- plane-nav: 0 planes, 0 converged within 30 iterations; " + rois +
                         " ROIs not fitted: low parallax (the nav pose's parallax leaves their plane unobservable)"),
            std::string::npos)
      << summary;
}

}  // namespace
}  // namespace hdabench::reference
