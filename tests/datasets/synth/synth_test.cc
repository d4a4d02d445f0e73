#include "datasets/synth/synth.h"

#include <cmath>
#include <limits>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "datasets/example.h"
#include "datasets/synth/truth.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets::synth {
namespace {

namespace fs = std::filesystem;
using testing_support::CurrentTestSeed;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;

// A preset shrunk for tests: a small imager (the DEM spacing follows the pixel
// footprint, so the scene shrinks with it) and fewer frames.
SynthOptions SmallPreset(const std::string& name) {
  SynthOptions options = SynthPreset(name);
  options.image_size_px = 96;
  options.frame_rate_hz = 1.0;
  return options;
}

TerrainOptions TerrainFor(const SynthOptions& options) {
  TerrainOptions terrain = TerrainPreset(options.terrain);
  ScaleTerrain(options.terrain_scale, &terrain);
  return terrain;
}

TEST(GenerateSynthDataset, EveryPresetPassesTheDatasetCheck) {
  for (const std::string& name : SynthPresetNames()) {
    SCOPED_TRACE(name);
    const SynthOptions options = SmallPreset(name);
    SynthSummary summary;
    const Dataset dataset =
        GenerateSynthDataset(options, TerrainFor(options), CurrentTestSeed(), {}, &summary);
    const fs::path dir = FreshTestDir() / name;
    WriteDataset(dataset, dir.string());
    const DatasetLoadResult loaded = LoadDataset(dir.string());
    ASSERT_TRUE(loaded.Ok()) << (loaded.problems.empty() ? "" : loaded.problems[0].ToString());
    EXPECT_EQ(static_cast<int>(loaded.dataset->frames.size()), summary.frames);
    EXPECT_FALSE(loaded.dataset->truth.navigation.empty());
    // Every frame sees terrain: most truth points are hits.
    for (const TruthPoints& points : dataset.truth.points) {
      int hits = 0;
      for (int r = 0; r < points.points_in_local_m.rows; ++r) {
        for (int c = 0; c < points.points_in_local_m.cols; ++c) {
          hits += std::isfinite(points.points_in_local_m.at<cv::Vec3f>(r, c)[0]) ? 1 : 0;
        }
      }
      EXPECT_EQ(hits, points.points_in_local_m.rows * points.points_in_local_m.cols);
    }
    // The CLI agrees.
    const auto check = RunHdabench({"dataset", "check", dir.string()}, dir.parent_path());
    EXPECT_EQ(check.exit_code, 0) << check.err;
  }
}

TEST(GenerateSynthDataset, LateralPresetHasAPairAbout30MetresApart) {
  const SynthOptions options = SynthPreset("novac-lateral");
  EXPECT_EQ(options.image_size_px, 1024);
  // 13 m/s over the 5 s window at 2.5 Hz: frames 0 and 6 are 2.4 s apart.
  EXPECT_NEAR(options.speed_mps * 6.0 / options.frame_rate_hz, 31.2, 1e-9);
}

// The presets fly as the paper's campaigns flew (docs/synthetic-scenes.md):
// the approach and the aircraft level toward the site, the truck's lift
// straight up, each at constant attitude with the camera 45 deg off nadir
// toward the north; the pair is the one at NOVA-C's baseline-to-range ratio.
TEST(GenerateSynthDataset, PresetsFlyAsTheCampaignsFlew) {
  struct Flight {
    const char* preset;
    int second_frame;            // the pair (0, second_frame)
    Eigen::Vector3d motion_m;    // camera centre of the second frame minus the first's, local ENU
  };
  const Flight flights[] = {
      {"novac-lateral", 6, {31.2, 0.0, 0.0}},   // east, 2.4 s at 13 m/s
      {"novac-forward", 6, {0.0, 31.2, 0.0}},   // north, level
      {"aircraft", 8, {0.0, 128.0, 0.0}},       // north, level, 1.6 s at 80 m/s
      {"truck", 6, {0.0, 0.0, 0.30}},           // up, 2.4 s at 0.125 m/s
  };
  for (const Flight& flight : flights) {
    SCOPED_TRACE(flight.preset);
    SynthOptions options = SmallPreset(flight.preset);
    options.frame_rate_hz = SynthPreset(flight.preset).frame_rate_hz;  // the preset's frames
    SynthSummary summary;
    const Dataset dataset = GenerateSynthDataset(options, TerrainFor(options), CurrentTestSeed(), {}, &summary);
    EXPECT_EQ(summary.pair_frames, std::make_pair(0, flight.second_frame));
    const Rigid3d first = dataset.TrueCamFromLocal(0).Inverse();
    const Rigid3d second = dataset.TrueCamFromLocal(flight.second_frame).Inverse();
    const Eigen::Vector3d motion = second.translation - first.translation;
    EXPECT_LT((motion - flight.motion_m).norm(), 1e-6 * flight.motion_m.norm()) << motion.transpose();
    // The attitude does not change: the camera keeps its pitch.
    EXPECT_LT(first.rotation.angularDistance(second.rotation), 1e-9);
    // The optical axis points 45 deg below the horizon toward the north.
    const Eigen::Vector3d axis = first.rotation * Eigen::Vector3d::UnitZ();
    EXPECT_NEAR(axis.y(), std::sqrt(0.5), 1e-9);
    EXPECT_NEAR(axis.z(), -std::sqrt(0.5), 1e-9);
    // The pair's baseline over the slant range is NOVA-C's 30 m at 566 m,
    // within half a frame's step.
    const double range_m = std::hypot(options.altitude_m, options.standoff_m);
    const double step_m = options.speed_mps / options.frame_rate_hz;
    EXPECT_NEAR(motion.norm(), 30.0 / 566.0 * range_m, 0.5 * step_m);
  }
}

// attitude=track: every frame's optical axis passes through the ILS, so the
// axes of two frames differ by the angle their baseline subtends there; with
// the default attitude they are parallel.
TEST(GenerateSynthDataset, TrackingAttitudeKeepsTheIlsOnTheOpticalAxis) {
  SynthOptions options = SmallPreset("novac-lateral");
  options.speed_mps = 100.0;  // 500 m across the window: the axes 60-odd degrees apart
  TerrainOptions terrain = TerrainFor(options);
  TerrainOptions unused;
  ApplyOverride("attitude", "track", &options, &unused);
  ASSERT_EQ(options.attitude, Attitude::kTrack);
  options.horizontal_fov_deg = 10.0;
  const Dataset dataset = GenerateSynthDataset(options, terrain, CurrentTestSeed());
  const int last = static_cast<int>(dataset.frames.size()) - 1;
  std::vector<Eigen::Vector3d> axes;
  for (const int frame : {0, last}) {
    const Rigid3d local_from_cam = dataset.TrueCamFromLocal(frame).Inverse();
    const Eigen::Vector3d axis = local_from_cam.rotation * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d to_ils = -local_from_cam.translation.normalized();
    EXPECT_LT(axis.cross(to_ils).norm(), 1e-9) << "frame " << frame;
    EXPECT_GT(axis.dot(to_ils), 0.0);
    axes.push_back(axis);
  }
  const Eigen::Vector3d c0 = dataset.TrueCamFromLocal(0).Inverse().translation;
  const Eigen::Vector3d c1 = dataset.TrueCamFromLocal(last).Inverse().translation;
  const double subtended = std::acos(c0.normalized().dot(c1.normalized()));
  EXPECT_NEAR(std::acos(std::min(1.0, axes[0].dot(axes[1]))), subtended, 1e-9);
  EXPECT_GT(subtended, 0.5);
  EXPECT_THROW(ApplyOverride("attitude", "tumbling", &options, &unused), InputError);
}

TEST(GenerateSynthDataset, MeasuredNavigationEqualsTruthWithoutErrorsAndDriftsWithThem) {
  SynthOptions options = SmallPreset("novac-lateral");
  options.nav_velocity_bias_mps = 0.0;
  options.nav_position_noise_m = 0.0;
  options.nav_attitude_drift_deg_per_s = 0.0;
  options.nav_attitude_noise_deg = 0.0;
  options.lrf_noise_m = 0.0;
  const Dataset exact = GenerateSynthDataset(options, TerrainFor(options), CurrentTestSeed());
  ASSERT_EQ(exact.nav.size(), exact.truth.navigation.size());
  for (size_t i = 0; i < exact.nav.size(); ++i) {
    EXPECT_LT((exact.nav[i].local_from_body.translation - exact.truth.navigation[i].local_from_body.translation).norm(), 1e-12);
    EXPECT_LT(exact.nav[i].local_from_body.rotation.angularDistance(exact.truth.navigation[i].local_from_body.rotation), 1e-12);
  }
  // The LRF range is the distance to the terrain along the boresight: the
  // boresight passes near the ILS, about 566 m away at the window's middle.
  const double mid_s = 0.5 * options.collection_s;
  EXPECT_NEAR(exact.LrfRangeAt(mid_s), std::hypot(400.0, 400.0), 15.0);

  options.nav_velocity_bias_mps = 0.05;
  const Dataset biased = GenerateSynthDataset(options, TerrainFor(options), CurrentTestSeed());
  // A constant velocity error drifts the relative position by bias * dt.
  const int last = static_cast<int>(biased.frames.size()) - 1;
  const Rigid3d measured = biased.Cam2FromCam1(0, last);
  const Rigid3d truth = biased.TrueCam2FromCam1(0, last);
  const double dt = biased.frames[last].time_s - biased.frames[0].time_s;
  EXPECT_NEAR((measured.translation - truth.translation).norm(), 0.05 * dt, 1e-6);
}

TEST(GenerateSynthDataset, SameSeedSameBytesWhateverTheThreadCount) {
  SynthOptions options = SmallPreset("novac-lateral");
  const fs::path dir = FreshTestDir();
  options.threads = 1;
  WriteDataset(GenerateSynthDataset(options, TerrainFor(options), 7), (dir / "one").string());
  options.threads = 2;
  WriteDataset(GenerateSynthDataset(options, TerrainFor(options), 7), (dir / "two").string());
  WriteDataset(GenerateSynthDataset(options, TerrainFor(options), 8), (dir / "other").string());
  size_t files = 0;
  bool any_differs = false;
  for (const auto& entry : fs::recursive_directory_iterator(dir / "one")) {
    if (!entry.is_regular_file()) continue;
    const fs::path relative = fs::relative(entry.path(), dir / "one");
    EXPECT_EQ(ReadText(entry.path()), ReadText(dir / "two" / relative)) << relative;
    any_differs |= ReadText(entry.path()) != ReadText(dir / "other" / relative);
    ++files;
  }
  EXPECT_GT(files, 8u);
  EXPECT_TRUE(any_differs) << "seed 8 gave the same files as seed 7";
}

// Rendering some frames changes nothing else: those frames' images and truth
// points, the navigation, the LRF and the truth DEM are the bytes of the whole
// render; the other frames keep their times without an image, and a command
// that needs one of them is told which frames have images.
TEST(GenerateSynthDataset, SomeFramesRenderedAreTheSameBytesAsInTheWholeRender) {
  const SynthOptions whole_options = SmallPreset("novac-lateral");
  SynthOptions some_options = whole_options;
  some_options.frames_to_render = [](const Dataset&) { return std::vector<int>{3, 1}; };
  const fs::path dir = FreshTestDir();
  SynthSummary summary;
  const Dataset some = GenerateSynthDataset(some_options, TerrainFor(some_options), 5, {}, &summary);
  EXPECT_EQ(summary.rendered_frames, (std::vector<int>{1, 3}));
  EXPECT_NE(summary.Summary().find("(images for 1, 3)"), std::string::npos) << summary.Summary();
  WriteDataset(GenerateSynthDataset(whole_options, TerrainFor(whole_options), 5), (dir / "whole").string());
  WriteDataset(some, (dir / "some").string());
  ASSERT_GE(some.frames.size(), 4u);
  for (const FrameRecord& frame : some.frames) {
    EXPECT_EQ(frame.HasImage(), frame.index == 1 || frame.index == 3) << frame.index;
  }
  EXPECT_EQ(FramesWithImages(some.frames), (std::vector<int>{1, 3}));
  for (const char* file : {"images/frame_000001.png", "images/frame_000003.png", "truth/points_000001.npy",
                           "truth/points_000003.npy", "nav.csv", "lrf.csv", "truth/dem.npy", "truth/rocks.csv",
                           "truth/nav_truth.csv", "camera.cameramodel"}) {
    EXPECT_EQ(ReadText(dir / "some" / file), ReadText(dir / "whole" / file)) << file;
  }
  EXPECT_FALSE(fs::exists(dir / "some" / "images" / "frame_000000.png"));
  EXPECT_FALSE(fs::exists(dir / "some" / "truth" / "points_000000.npy"));
  EXPECT_NE(ReadText(dir / "some" / "frames.csv").find("\n0,0,\n"), std::string::npos) << ReadText(dir / "some" / "frames.csv");

  const DatasetLoadResult loaded = LoadDataset((dir / "some").string());
  ASSERT_TRUE(loaded.Ok()) << (loaded.problems.empty() ? "" : loaded.problems[0].ToString());
  EXPECT_EQ(loaded.dataset->frames.size(), some.frames.size());
  EXPECT_EQ(FramesWithImages(loaded.dataset->frames), (std::vector<int>{1, 3}));
  LoadOptions pair_0_3;
  pair_0_3.frames_used = [](const Dataset&) { return std::vector<int>{0, 3}; };
  const DatasetLoadResult refused = LoadDataset((dir / "some").string(), pair_0_3);
  ASSERT_EQ(refused.problems.size(), 1u);
  EXPECT_EQ(refused.problems[0].ToString(),
            "frames.csv:2: frame 0 has no image (its image cell is empty), but the command uses it; frames with "
            "images: 1, 3");

  // Bad choices are refused before anything is rendered.
  for (const auto& [chosen, expected] : std::vector<std::pair<std::vector<int>, std::string>>{
           {{1}, "render at least 2 frames"}, {{1, 1}, "frame 1 is given twice"},
           {{0, 99}, "frame 99 is not a frame of the scene, which has frames 0.."}}) {
    SynthOptions bad = whole_options;
    bad.frames_to_render = [chosen = chosen](const Dataset&) { return chosen; };
    try {
      GenerateSynthDataset(bad, TerrainFor(bad), 5);
      ADD_FAILURE() << "expected InputError containing: " << expected;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
    }
  }
}

void ExpectInputError(const SynthOptions& options, const TerrainOptions& terrain, const std::string& expected) {
  try {
    GenerateSynthDataset(options, terrain, 1);
    ADD_FAILURE() << "expected InputError containing: " << expected;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(GenerateSynthDataset, BadParametersGiveClearErrors) {
  SynthOptions options = SmallPreset("novac-lateral");
  const TerrainOptions terrain = TerrainFor(options);
  SynthOptions negative = options;
  negative.altitude_m = -5.0;
  ExpectInputError(negative, terrain, "altitude_m = -5: expected > 0");
  SynthOptions dark = options;
  dark.render.sun_elevation_deg = -3.0;
  ExpectInputError(dark, terrain, "render.sun_elevation_deg");
  SynthOptions sky = options;
  sky.off_nadir_deg = 70.0;
  sky.horizontal_fov_deg = 60.0;
  ExpectInputError(sky, terrain, "the camera sees no terrain");
  SynthOptions no_camera = options;
  no_camera.camera_model_file = (FreshTestDir() / "absent.cameramodel").string();
  ExpectInputError(no_camera, terrain, "absent.cameramodel: camera model file: file not found");
  EXPECT_THROW(SynthPreset("lander"), InputError);
}

TEST(SynthCommand, FailureLeavesNoDatasetBehind) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "out";
  const auto run = RunHdabench({"synth", "--out", out.string(), "--image-size", "64", "--set",
                                "render.sun_elevation_deg=-5", "--quiet"},
                               dir);
  EXPECT_EQ(run.exit_code, 2) << run.err;
  EXPECT_NE(run.err.find("hdabench synth: invalid synthetic dataset options"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("sun_elevation_deg"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(out));
  const auto bad_key = RunHdabench({"synth", "--out", out.string(), "--set", "warp_factor=9"}, dir);
  EXPECT_EQ(bad_key.exit_code, 2) << bad_key.err;
  EXPECT_NE(bad_key.err.find("warp_factor"), std::string::npos) << bad_key.err;
  // The named keys are listed with the numeric ones.
  for (const char* key : {"terrain.rock_law", "render.anti_aliasing", "render.shot_noise", "terrain.rock_k"}) {
    EXPECT_NE(bad_key.err.find(key), std::string::npos) << key << ": " << bad_key.err;
  }
  EXPECT_FALSE(fs::exists(out));
}

// Everything synth makes a scene from is a flag, so what the scene cannot
// have is a bad flag value (exit 2), found before anything is rendered; only
// an unusable camera model file is exit 3.
TEST(SynthCommand, BadOptionsAreUsageErrorsAndABadCameraModelAnInputError) {
  const fs::path dir = FreshTestDir();
  const fs::path out = dir / "out";
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--preset", "lander"}, "unknown preset 'lander'"},
      {{"--terrain", "swamp"}, "swamp"},
      {{"--set", "render.shot_noise=2"}, "render.shot_noise=2: expected 0 or 1"},
      {{"--set", "motion=sideways"}, "motion=sideways"},
      {{"--set", "altitude_m"}, "--set expects key=value"},
      {{"--set", "image_size_px=2.5"}, "expected a whole number"},
      {{"--set", "altitude_m=-5"}, "altitude_m = -5"},
      {{"--set", "off_nadir_deg=75", "--set", "horizontal_fov_deg=60"}, "the camera sees no terrain"},
      // Finite, but a blur whose taps outgrow the render's margins (this crashed).
      {{"--set", "render.f_number=1e308"}, "give a diffraction blur of sigma"},
      {{"--set", "render.pixel_pitch_um=1e-300"}, "expected at most 10 px"},
      {{"--frames", "0,x"}, "--frames: 'x' is not a frame index or a range FIRST-LAST"},
      {{"--frames", "6-2"}, "--frames: '6-2' is not a frame index"},
      {{"--frames", "0,99"}, "frame 99 is not a frame of the scene, which has frames 0..12"},
      // A range far past the scene is refused as quickly, naming its first frame too many.
      {{"--frames", "0-2000000000"}, "frame 13 is not a frame of the scene, which has frames 0..12"},
      {{"--frames", "3"}, "render at least 2 frames"},
  };
  for (const auto& [flags, message] : cases) {
    std::vector<std::string> args = {"synth", "--out", out.string(), "--image-size", "64", "--quiet"};
    args.insert(args.end(), flags.begin(), flags.end());
    const auto run = RunHdabench(args, dir);
    EXPECT_EQ(run.exit_code, 2) << flags.back() << ": " << run.err;
    EXPECT_NE(run.err.find("hdabench synth: "), std::string::npos) << run.err;
    EXPECT_NE(run.err.find(message), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(out)) << flags.back();
  }
  std::ofstream(dir / "broken.cameramodel") << "{ 'lensmodel': 'LENSMODEL_PINHOLE',";
  for (const fs::path& model : {dir / "absent.cameramodel", dir / "broken.cameramodel"}) {
    const auto run = RunHdabench({"synth", "--out", out.string(), "--image-size", "64", "--quiet",
                                  "--camera-model", model.string()},
                                 dir);
    EXPECT_EQ(run.exit_code, 3) << run.err;
    EXPECT_NE(run.err.find("hdabench synth: --camera-model: " + model.string()), std::string::npos) << run.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(ComputeRoiTruth, FlatGroundHasZeroSlopeAndRoughness) {
  ExampleDatasetOptions example;
  example.image_size_px = 64;
  const Dataset dataset = MakeExampleDataset(example);
  const RoiTruth truth = ComputeRoiTruth(dataset, 0, PixelRoi{10, 10, 20, 20});
  EXPECT_EQ(truth.num_points, 400);
  EXPECT_LT(truth.slope_deg, 0.01);
  // Truth points are float32: about 1e-5 m of rounding at 500 m.
  EXPECT_LT(truth.roughness_rms_m, 1e-3);
  EXPECT_EQ(truth.max_rock_height_m, 0.0);
}

TEST(ComputeRoiTruth, TiltedPlaneGivesItsSlopeAndBadRoisAreRefused) {
  ExampleDatasetOptions example;
  example.image_size_px = 32;
  Dataset dataset = MakeExampleDataset(example);
  // Replace frame 0's truth by a plane rising 20 degrees toward the north.
  cv::Mat& raster = dataset.truth.points[0].points_in_local_m;
  const double tan20 = std::tan(20.0 * 3.14159265358979323846 / 180.0);
  for (int r = 0; r < raster.rows; ++r) {
    for (int c = 0; c < raster.cols; ++c) {
      const float x = static_cast<float>(c * 0.5);
      const float y = static_cast<float>(-r * 0.5);
      raster.at<cv::Vec3f>(r, c) = cv::Vec3f(x, y, static_cast<float>(static_cast<double>(y) * tan20));
    }
  }
  raster.at<cv::Vec3f>(3, 3) = cv::Vec3f(NAN, NAN, NAN);  // a ray that hit nothing
  const RoiTruth truth = ComputeRoiTruth(dataset, 0, PixelRoi{0, 0, 8, 8});
  EXPECT_EQ(truth.num_points, 63);
  EXPECT_NEAR(truth.slope_deg, 20.0, 1e-4);
  EXPECT_THROW(ComputeRoiTruth(dataset, 0, PixelRoi{30, 30, 8, 8}), InputError);
  EXPECT_THROW(ComputeRoiTruth(dataset, 0, PixelRoi{0, 0, 0, 8}), InputError);
  // Sides whose sum with the corner overflows an int are outside too.
  EXPECT_THROW(ComputeRoiTruth(dataset, 0, PixelRoi{10, 10, std::numeric_limits<int>::max(), 8}), InputError);
  EXPECT_THROW(ComputeRoiTruth(dataset, 0, PixelRoi{std::numeric_limits<int>::max() - 100,
                                                    std::numeric_limits<int>::max() - 100, 2000, 2000}),
               InputError);
  EXPECT_THROW(ComputeRoiTruth(dataset, 42, PixelRoi{0, 0, 8, 8}), InputError);
}

// A raster of two planes, split at column `split`: left rising `left_deg`
// toward the north, right `right_deg`.
void PutTwoPlanes(cv::Mat* raster, int split, double left_deg, double right_deg) {
  for (int r = 0; r < raster->rows; ++r) {
    for (int c = 0; c < raster->cols; ++c) {
      const double slope = c < split ? left_deg : right_deg;
      const double x = c * 0.5;
      const double y = -r * 0.5;
      raster->at<cv::Vec3f>(r, c) =
          cv::Vec3f(static_cast<float>(x), static_cast<float>(y),
                    static_cast<float>(y * std::tan(slope * 3.14159265358979323846 / 180.0)));
    }
  }
}

TEST(ComputeSupportTruth, IsThePlaneOfTheSupportWeightedAsGiven) {
  ExampleDatasetOptions example;
  example.image_size_px = 32;
  Dataset dataset = MakeExampleDataset(example);
  cv::Mat& raster = dataset.truth.points[0].points_in_local_m;
  PutTwoPlanes(&raster, 16, 3.0, 10.0);
  // Every pixel of a box alike: the box's truth.
  std::vector<Eigen::Vector2d> box;
  for (int r = 4; r < 28; ++r) {
    for (int c = 4; c < 28; ++c) box.emplace_back(c, r);
  }
  const RoiTruth site = ComputeRoiTruth(dataset, 0, PixelRoi{4, 4, 24, 24});
  const SupportTruth all = ComputeSupportTruth(dataset, 0, box, {});
  EXPECT_EQ(all.num_points, site.num_points);
  EXPECT_NEAR(all.slope_deg, site.slope_deg, 1e-9);
  EXPECT_LT((all.normal_in_local - site.normal_in_local).norm(), 1e-9);
  // Pixels of the left half only, at sub-pixel positions: its 3 deg.
  std::vector<Eigen::Vector2d> left;
  for (int r = 4; r < 28; ++r) {
    for (int c = 4; c < 14; ++c) left.emplace_back(c + 0.25, r + 0.5);
  }
  EXPECT_NEAR(ComputeSupportTruth(dataset, 0, left, {}).slope_deg, 3.0, 1e-3);
  // The whole box, the right half weighted a thousand times the left: near its 10 deg.
  std::vector<double> weights;
  for (const Eigen::Vector2d& p : box) weights.push_back(p.x() >= 16 ? 1000.0 : 1.0);
  const SupportTruth leaning = ComputeSupportTruth(dataset, 0, box, weights);
  EXPECT_GT(leaning.slope_deg, 9.9);
  EXPECT_LT(leaning.slope_deg, 10.0 + 1e-6);
  // A weight of zero leaves its pixel out; a position beside a pixel without truth is left out.
  std::vector<double> left_only;
  for (const Eigen::Vector2d& p : box) left_only.push_back(p.x() < 16 ? 1.0 : 0.0);
  EXPECT_NEAR(ComputeSupportTruth(dataset, 0, box, left_only).slope_deg, 3.0, 1e-3);
  raster.at<cv::Vec3f>(10, 10) = cv::Vec3f(NAN, NAN, NAN);
  EXPECT_EQ(ComputeSupportTruth(dataset, 0, {{9.5, 9.5}, {10.0, 10.0}, {4, 4}, {5, 4}, {4, 6}}, {}).num_points, 3);
  // Bad supports are refused with the reason.
  EXPECT_THROW(ComputeSupportTruth(dataset, 0, box, {1.0, 2.0}), InputError);
  EXPECT_THROW(ComputeSupportTruth(dataset, 0, {{4, 4}, {5, 4}, {6, 4}}, {}), InputError);  // collinear
  EXPECT_THROW(ComputeSupportTruth(dataset, 0, {{4, 4}, {40, 4}, {4, 6}}, {}), InputError);  // one is off the raster
  std::vector<double> negative(box.size(), 1.0);
  negative[5] = -1.0;
  EXPECT_THROW(ComputeSupportTruth(dataset, 0, box, negative), InputError);
  EXPECT_THROW(ComputeSupportTruth(dataset, 42, box, {}), InputError);
}

}  // namespace
}  // namespace hdabench::datasets::synth
