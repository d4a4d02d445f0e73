// WriteDataset / LoadDataset round trips, determinism of the example, and the
// `hdabench dataset` commands on good input.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tools/util/random_vectors.h"
#include "datasets/dataset.h"
#include "datasets/example.h"
#include "datasets/navigation.h"
#include "tests/support/constructed_pair.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::CurrentTestSeed;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;

// Every regular file under `dir`, by relative path, with its bytes.
std::map<std::string, std::string> FilesUnder(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file()) {
      files[fs::relative(entry.path(), dir).generic_string()] = ReadText(entry.path());
    }
  }
  return files;
}

bool SameBytes(const cv::Mat& a, const cv::Mat& b) {
  if (a.type() != b.type() || a.size() != b.size()) return false;
  const size_t bytes = a.total() * a.elemSize();
  return a.isContinuous() && b.isContinuous() && std::memcmp(a.data, b.data, bytes) == 0;
}

LoadOptions KeepEverything() {
  LoadOptions options;
  options.keep_images = true;
  options.keep_truth = true;
  return options;
}

TEST(WriteDataset, LoadGivesIdenticalValues) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const fs::path dir = FreshTestDir() / "dataset";
  const Dataset written = MakeExampleDataset(seed);
  WriteDataset(written, dir.string());
  const DatasetLoadResult result = LoadDataset(dir.string(), KeepEverything());
  ASSERT_TRUE(result.Ok()) << result.Summary() << ": "
                           << (result.problems.empty() ? "" : result.problems[0].ToString());
  const Dataset& read = *result.dataset;

  EXPECT_EQ(read.name, written.name);
  EXPECT_EQ(read.description, written.description);
  EXPECT_EQ(read.dir, dir.string());
  EXPECT_EQ(read.camera_model_file, written.camera_model_file);
  EXPECT_EQ(read.camera.LensModelName(), written.camera.LensModelName());
  EXPECT_EQ(read.camera.Intrinsics(), written.camera.Intrinsics());
  EXPECT_EQ(read.camera.WidthPx(), written.camera.WidthPx());
  EXPECT_EQ(read.camera.HeightPx(), written.camera.HeightPx());

  EXPECT_EQ(read.cam_from_body.rotation.coeffs(), written.cam_from_body.rotation.coeffs());
  EXPECT_EQ(read.cam_from_body.translation, written.cam_from_body.translation);
  EXPECT_EQ(read.gravity_in_local_mps2, written.gravity_in_local_mps2);
  EXPECT_EQ(read.ils_in_local_m, written.ils_in_local_m);
  EXPECT_EQ(read.lrf_origin_in_body_m, written.lrf_origin_in_body_m);

  ASSERT_EQ(read.frames.size(), written.frames.size());
  for (size_t i = 0; i < read.frames.size(); ++i) {
    EXPECT_EQ(read.frames[i].index, written.frames[i].index);
    EXPECT_EQ(read.frames[i].time_s, written.frames[i].time_s);
    EXPECT_EQ(read.frames[i].image_path, written.frames[i].image_path);
    EXPECT_TRUE(SameBytes(read.frames[i].image, written.frames[i].image)) << "frame " << i;
  }
  ASSERT_EQ(read.nav.size(), written.nav.size());
  EXPECT_EQ(read.nav_has_velocity, written.nav_has_velocity);
  EXPECT_EQ(read.nav_has_sigmas, written.nav_has_sigmas);
  for (size_t i = 0; i < read.nav.size(); ++i) {
    const NavSample& a = read.nav[i];
    const NavSample& b = written.nav[i];
    EXPECT_EQ(a.time_s, b.time_s);
    EXPECT_EQ(a.local_from_body.translation, b.local_from_body.translation);
    EXPECT_EQ(a.local_from_body.rotation.coeffs(), b.local_from_body.rotation.coeffs());
    EXPECT_EQ(a.velocity_in_local_mps, b.velocity_in_local_mps);
    EXPECT_EQ(a.sigma_position_in_local_m, b.sigma_position_in_local_m);
    EXPECT_EQ(a.sigma_attitude_in_body_rad, b.sigma_attitude_in_body_rad);
  }
  ASSERT_EQ(read.lrf.size(), written.lrf.size());
  for (size_t i = 0; i < read.lrf.size(); ++i) {
    EXPECT_EQ(read.lrf[i].time_s, written.lrf[i].time_s);
    EXPECT_EQ(read.lrf[i].range_m, written.lrf[i].range_m);
    EXPECT_EQ(read.lrf[i].boresight_in_body, written.lrf[i].boresight_in_body);
  }
  ASSERT_EQ(read.truth.points.size(), written.truth.points.size());
  for (size_t i = 0; i < read.truth.points.size(); ++i) {
    EXPECT_EQ(read.truth.points[i].frame, written.truth.points[i].frame);
    EXPECT_EQ(read.truth.points[i].file, written.truth.points[i].file);
    EXPECT_TRUE(SameBytes(read.truth.points[i].points_in_local_m,
                          written.truth.points[i].points_in_local_m));
  }
  ASSERT_TRUE(read.truth.dem.has_value());
  EXPECT_EQ(read.truth.dem->origin_in_local_m, written.truth.dem->origin_in_local_m);
  EXPECT_EQ(read.truth.dem->spacing_m, written.truth.dem->spacing_m);
  EXPECT_EQ(read.truth.dem->width_cells, written.truth.dem->width_cells);
  EXPECT_EQ(read.truth.dem->height_cells, written.truth.dem->height_cells);
  EXPECT_TRUE(SameBytes(read.truth.dem->height_in_local_m, written.truth.dem->height_in_local_m));

  // Poses derived from the loaded values are the same bits too.
  const Rigid3d a = read.Cam2FromCam1(0, 5);
  const Rigid3d b = written.Cam2FromCam1(0, 5);
  EXPECT_EQ(a.rotation.coeffs(), b.rotation.coeffs());
  EXPECT_EQ(a.translation, b.translation);
}

// The example with a truth navigation (the measured poses shifted and turned a
// little, as a navigation error would, with velocities but no sigmas) and
// truth rocks whose values need all 17 digits.
Dataset ExampleWithTruthNavigationAndRocks(std::uint64_t seed) {
  Dataset dataset = MakeExampleDataset(seed);
  dataset.truth.navigation_file = "truth/navigation.csv";
  for (const NavSample& measured : dataset.nav) {
    NavSample truth = measured;
    truth.local_from_body.translation += Eigen::Vector3d(0.3, -1.0 / 3.0, 0.1 * measured.time_s);
    truth.local_from_body.rotation =
        (measured.local_from_body.rotation *
         Eigen::Quaterniond(Eigen::AngleAxisd(1e-3, Eigen::Vector3d(1.0, 2.0, 3.0).normalized())))
            .normalized();
    truth.sigma_position_in_local_m.setZero();
    truth.sigma_attitude_in_body_rad.setZero();
    dataset.truth.navigation.push_back(truth);
  }
  dataset.truth.rocks_file = "truth/rocks.csv";
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int i = 0; i < 7; ++i) {
    TruthRock rock;
    const Eigen::Vector3d u = util::DrawVector3(unit, rng);
    rock.center_in_local_m = Eigen::Vector3d(400.0 * u.x() - 200.0, 400.0 * u.y() + 100.0, u.z());
    rock.diameter_m = 0.2 + 3.0 * unit(rng);
    rock.height_above_ground_m = rock.diameter_m * (0.1 + 0.9 * unit(rng));
    dataset.truth.rocks.push_back(rock);
  }
  TruthImaging imaging;
  imaging.sun_in_local = Eigen::Vector3d(0.3, -1.0 / 3.0, 0.5).normalized();
  imaging.gain_electrons_per_dn = 40.0 / 3.0;
  imaging.read_noise_dn = 0.1;
  dataset.truth.imaging = imaging;
  return dataset;
}

TEST(WriteDataset, TruthNavigationAndRocksLoadIdentical) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const fs::path root = FreshTestDir();
  const Dataset written = ExampleWithTruthNavigationAndRocks(seed);
  WriteDataset(written, (root / "first").string());
  const DatasetLoadResult result = LoadDataset((root / "first").string(), KeepEverything());
  ASSERT_TRUE(result.Ok()) << result.Summary() << ": "
                           << (result.problems.empty() ? "" : result.problems[0].ToString());
  const Dataset& read = *result.dataset;

  EXPECT_EQ(read.truth.navigation_file, written.truth.navigation_file);
  ASSERT_EQ(read.truth.navigation.size(), written.truth.navigation.size());
  for (size_t i = 0; i < read.truth.navigation.size(); ++i) {
    const NavSample& a = read.truth.navigation[i];
    const NavSample& b = written.truth.navigation[i];
    EXPECT_EQ(a.time_s, b.time_s);
    EXPECT_EQ(a.local_from_body.translation, b.local_from_body.translation);
    EXPECT_EQ(a.local_from_body.rotation.coeffs(), b.local_from_body.rotation.coeffs());
    EXPECT_EQ(a.velocity_in_local_mps, b.velocity_in_local_mps);
    EXPECT_EQ(a.sigma_position_in_local_m, b.sigma_position_in_local_m);
    EXPECT_EQ(a.sigma_attitude_in_body_rad, b.sigma_attitude_in_body_rad);
  }
  // Velocities are written (non-zero), sigmas are not (all zero).
  EXPECT_EQ(testing_support::SplitLines(ReadText(root / "first/truth/navigation.csv"))[0],
            "time_s,x_m,y_m,z_m,qw,qx,qy,qz,vx_mps,vy_mps,vz_mps");
  EXPECT_EQ(read.truth.rocks_file, written.truth.rocks_file);
  ASSERT_EQ(read.truth.rocks.size(), written.truth.rocks.size());
  for (size_t i = 0; i < read.truth.rocks.size(); ++i) {
    EXPECT_EQ(read.truth.rocks[i].center_in_local_m, written.truth.rocks[i].center_in_local_m);
    EXPECT_EQ(read.truth.rocks[i].diameter_m, written.truth.rocks[i].diameter_m);
    EXPECT_EQ(read.truth.rocks[i].height_above_ground_m,
              written.truth.rocks[i].height_above_ground_m);
  }
  ASSERT_TRUE(read.truth.imaging.has_value());
  EXPECT_EQ(read.truth.imaging->sun_in_local, written.truth.imaging->sun_in_local);
  EXPECT_EQ(read.truth.imaging->gain_electrons_per_dn, written.truth.imaging->gain_electrons_per_dn);
  EXPECT_EQ(read.truth.imaging->read_noise_dn, written.truth.imaging->read_noise_dn);
  // True poses derived from the loaded values are the same bits, and differ
  // from the measured ones.
  for (int frame = 0; frame < 6; ++frame) {
    const Rigid3d a = read.TrueCamFromLocal(frame);
    const Rigid3d b = written.TrueCamFromLocal(frame);
    EXPECT_EQ(a.rotation.coeffs(), b.rotation.coeffs());
    EXPECT_EQ(a.translation, b.translation);
  }
  EXPECT_GT((read.TrueCam2FromCam1(0, 5).translation - read.Cam2FromCam1(0, 5).translation).norm(),
            1e-3);

  // Writing the loaded dataset again gives the same files.
  WriteDataset(read, (root / "second").string());
  EXPECT_EQ(FilesUnder(root / "first"), FilesUnder(root / "second"));
}

TEST(WriteDataset, NoRocksIsAHeaderOnlyTable) {
  const fs::path dir = FreshTestDir() / "dataset";
  Dataset dataset = ExampleWithTruthNavigationAndRocks(CurrentTestSeed());
  dataset.truth.rocks.clear();
  WriteDataset(dataset, dir.string());
  EXPECT_EQ(ReadText(dir / "truth/rocks.csv"), "x_m,y_m,z_m,diameter_m,height_above_ground_m\n");
  const DatasetLoadResult result = LoadDataset(dir.string());
  ASSERT_TRUE(result.Ok()) << result.problems[0].ToString();
  EXPECT_EQ(result.dataset->truth.rocks_file, "truth/rocks.csv");
  EXPECT_TRUE(result.dataset->truth.rocks.empty());
}

TEST(WriteDataset, TruthWithoutAFileNameThrows) {
  const fs::path root = FreshTestDir();
  Dataset dataset = ExampleWithTruthNavigationAndRocks(CurrentTestSeed());
  dataset.truth.navigation_file.clear();
  try {
    WriteDataset(dataset, (root / "dataset").string());
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "WriteDataset: the truth navigation has samples but no file name");
  }
  dataset = ExampleWithTruthNavigationAndRocks(CurrentTestSeed());
  dataset.truth.rocks_file = "nav.csv";
  try {
    WriteDataset(dataset, (root / "dataset").string());
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "WriteDataset: truth rocks path 'nav.csv' is used twice");
  }
  EXPECT_TRUE(fs::is_empty(root));
}

NavSample PoseSample(double time_s, const Rigid3d& local_from_body) {
  NavSample sample;
  sample.time_s = time_s;
  sample.local_from_body = local_from_body;
  return sample;
}

// The true relative pose against truth built so that it is known (as for
// Cam2FromCam1 in navigation_test.cc): pick the mount, cam1_from_local and
// cam2_from_cam1, then put local_from_body(t_i) = inverse(cam_i_from_local) *
// cam_from_body in the truth navigation. The measured navigation is something
// else, so a mix-up shows.
TEST(TrueCam2FromCam1, MatchesConstructedTruth) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  std::mt19937_64 rng(seed);
  for (int trial = 0; trial < 50; ++trial) {
    SCOPED_TRACE("trial " + std::to_string(trial));
    const testing_support::ConstructedPair pair = testing_support::DrawConstructedPair(&rng);
    const Rigid3d& cam1_from_local = pair.cam1_from_local;
    const Rigid3d& cam2_from_cam1 = pair.cam2_from_cam1;
    Dataset dataset = testing_support::TwoFrameDataset(pair);
    dataset.truth.navigation = pair.Navigation();
    // The measured navigation: other, random poses.
    const auto random_pose = [&] {
      const Eigen::Vector3d translation = testing_support::RandomVector(&rng, 600.0);  // drawn first
      return Rigid3d(testing_support::RandomRotation(&rng), translation);
    };
    dataset.nav = {PoseSample(0.0, random_pose()), PoseSample(4.0, random_pose())};

    const Rigid3d estimate = dataset.TrueCam2FromCam1(0, 1);
    EXPECT_LT(RotationAngleRad(estimate.rotation * cam2_from_cam1.rotation.conjugate()), 1e-12);
    EXPECT_LT((estimate.translation - cam2_from_cam1.translation).norm(), 1e-9);
    const Rigid3d true_cam1_from_local = dataset.TrueCamFromLocal(0);
    EXPECT_LT(RotationAngleRad(true_cam1_from_local.rotation * cam1_from_local.rotation.conjugate()),
              1e-12);
    EXPECT_LT((true_cam1_from_local.translation - cam1_from_local.translation).norm(), 1e-9);
    // The reverse pair is the inverse.
    const Rigid3d reverse = dataset.TrueCam2FromCam1(1, 0);
    EXPECT_LT(RotationAngleRad(reverse.rotation * cam2_from_cam1.rotation), 1e-12);
    // The measured navigation gives another answer.
    EXPECT_GT((dataset.Cam2FromCam1(0, 1).translation - cam2_from_cam1.translation).norm(), 1e-3);
  }
}

TEST(TrueCam2FromCam1, WithoutTruthOrOutsideItsSpanThrowsNamingIt) {
  Dataset dataset(calib::CameraModel("LENSMODEL_PINHOLE", {500.0, 500.0, 127.5, 127.5}, 256, 256));
  FrameRecord frame;
  frame.time_s = 2.5;
  dataset.frames = {frame};
  dataset.nav = {PoseSample(0.0, Rigid3d()), PoseSample(3.0, Rigid3d())};
  try {
    dataset.TrueCamFromLocal(0);
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(),
                 "the dataset has no truth navigation (manifest.json field 'truth.navigation')");
  }
  dataset.truth.navigation = {PoseSample(0.0, Rigid3d()), PoseSample(2.0, Rigid3d())};
  try {
    dataset.TrueCam2FromCam1(0, 0);
    FAIL() << "expected std::out_of_range";
  } catch (const std::out_of_range& e) {
    EXPECT_STREQ(e.what(), "time 2.5 s is outside the truth navigation span [0, 2] s");
  }
  EXPECT_THROW(dataset.TrueLocalFromBodyAt(std::nan("")), std::out_of_range);
  EXPECT_THROW(dataset.TrueCamFromLocal(1), std::out_of_range);
  EXPECT_EQ(dataset.TrueLocalFromBodyAt(2.0).translation, Eigen::Vector3d::Zero());
  EXPECT_NO_THROW(dataset.CamFromLocal(0));
}

TEST(WriteDataset, RewritingALoadedDatasetIsByteIdentical) {
  const fs::path root = FreshTestDir();
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), (root / "first").string());
  const DatasetLoadResult loaded = LoadDataset((root / "first").string(), KeepEverything());
  ASSERT_TRUE(loaded.Ok());
  WriteDataset(*loaded.dataset, (root / "second").string());
  EXPECT_EQ(FilesUnder(root / "first"), FilesUnder(root / "second"));
}

TEST(MakeExampleDataset, SameSeedGivesByteIdenticalFiles) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const fs::path root = FreshTestDir();
  WriteDataset(MakeExampleDataset(seed), (root / "a").string());
  WriteDataset(MakeExampleDataset(seed), (root / "b").string());
  WriteDataset(MakeExampleDataset(seed + 1), (root / "c").string());
  const std::map<std::string, std::string> a = FilesUnder(root / "a");
  const std::map<std::string, std::string> b = FilesUnder(root / "b");
  const std::map<std::string, std::string> c = FilesUnder(root / "c");
  ASSERT_EQ(a.size(), 1U + 1U + 3U + 6U + 6U + 1U);  // manifest, camera, tables, images, truth, DEM
  EXPECT_EQ(a, b);
  // Another seed: other texture, so other images; same geometry and tables.
  ASSERT_EQ(a.size(), c.size());
  for (const auto& [path, bytes] : a) {
    SCOPED_TRACE(path);
    if (path.rfind("images/", 0) == 0 || path == "manifest.json") {
      EXPECT_NE(bytes, c.at(path));
    } else {
      EXPECT_EQ(bytes, c.at(path));
    }
  }
}

TEST(WriteDataset, RefusesAFolderThatIsNotEmpty) {
  const fs::path dir = FreshTestDir() / "dataset";
  fs::create_directories(dir);
  testing_support::WriteText(dir / "keep.txt", "mine");
  try {
    WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              dir.string() + ": exists and is not an empty folder; the dataset needs a new folder");
  }
  EXPECT_EQ(FilesUnder(dir).size(), 1U);
}

TEST(WriteDataset, FillsAnEmptyFolder) {
  const fs::path dir = FreshTestDir() / "dataset";
  fs::create_directories(dir);
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
  EXPECT_TRUE(LoadDataset(dir.string()).Ok());
}

TEST(WriteDataset, MissingImageThrowsAndLeavesNothingBehind) {
  const fs::path root = FreshTestDir();
  Dataset dataset = MakeExampleDataset(CurrentTestSeed());
  dataset.frames[3].image.release();
  try {
    WriteDataset(dataset, (root / "dataset").string());
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "WriteDataset: frame 3 has no image in memory");
  }
  EXPECT_TRUE(fs::is_empty(root));
}

TEST(WriteDataset, RepeatedImagePathThrows) {
  const fs::path root = FreshTestDir();
  Dataset dataset = MakeExampleDataset(CurrentTestSeed());
  dataset.frames[2].image_path = "images/./frame_000001.png";
  try {
    WriteDataset(dataset, (root / "dataset").string());
    FAIL() << "expected std::invalid_argument";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(),
                 "WriteDataset: frame 2 image path 'images/./frame_000001.png' is used twice");
  }
  EXPECT_TRUE(fs::is_empty(root));
}

TEST(LoadDataset, KeepsImagesAndTruthOnlyWhenAsked) {
  const fs::path dir = FreshTestDir() / "dataset";
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
  const DatasetLoadResult lean = LoadDataset(dir.string());
  ASSERT_TRUE(lean.Ok());
  EXPECT_EQ(lean.Summary(), "ok: " + lean.dataset->name + ", 6 frames");
  EXPECT_TRUE(lean.dataset->frames[0].image.empty());
  EXPECT_TRUE(lean.dataset->truth.points[0].points_in_local_m.empty());
  EXPECT_EQ(lean.dataset->truth.dem->width_cells, lean.dataset->truth.dem->width_cells);
  LoadOptions headers_only;
  headers_only.decode_images = false;
  headers_only.check_truth_values = false;
  EXPECT_TRUE(LoadDataset(dir.string(), headers_only).Ok());
  const DatasetLoadResult full = LoadDataset(dir.string(), KeepEverything());
  ASSERT_TRUE(full.Ok());
  EXPECT_EQ(full.dataset->frames[0].image.type(), CV_8UC1);
  EXPECT_EQ(full.dataset->truth.points[0].points_in_local_m.type(), CV_32FC3);
}

// A command that uses two frames reads only their images and truth points
// whole; every other file is still checked as a file (its PNG structure, its
// .npy header and size), and the DEM's heights are read only when asked.
TEST(LoadDataset, ReadsWholeOnlyTheFramesItIsToldAreUsed) {
  const fs::path dir = FreshTestDir() / "dataset";
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
  // A NaN in one coordinate of frame 0's first point: a bad value, found only
  // when the values are read.
  std::string npy = ReadText(dir / "truth" / "points_000000.npy");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&npy[npy.size() - sizeof(float)], &nan, sizeof(float));
  testing_support::WriteText(dir / "truth" / "points_000000.npy", npy);

  LoadOptions lazy = KeepEverything();
  std::vector<int> asked_with_frames;
  lazy.frames_used = [&](const Dataset& tables) {
    asked_with_frames.push_back(static_cast<int>(tables.frames.size()));
    return std::vector<int>{1, 4};
  };
  lazy.read_dem = false;
  const DatasetLoadResult result = LoadDataset(dir.string(), lazy);
  ASSERT_TRUE(result.Ok()) << result.problems[0].ToString();
  EXPECT_EQ(asked_with_frames, std::vector<int>{6});  // once, with every frame's record
  for (const FrameRecord& frame : result.dataset->frames) {
    EXPECT_EQ(frame.image.empty(), frame.index != 1 && frame.index != 4) << frame.index;
  }
  ASSERT_EQ(result.dataset->truth.points.size(), 6u);
  for (const TruthPoints& truth : result.dataset->truth.points) {
    EXPECT_EQ(truth.points_in_local_m.empty(), truth.frame != 1 && truth.frame != 4) << truth.frame;
  }
  ASSERT_TRUE(result.dataset->truth.dem.has_value());
  EXPECT_TRUE(result.dataset->truth.dem->height_in_local_m.empty());
  EXPECT_GT(result.dataset->truth.dem->width_cells, 0);

  // Frame 0 used: its bad value is found, as by a load of everything.
  lazy.frames_used = [](const Dataset&) { return std::vector<int>{0, 4}; };
  const DatasetLoadResult bad = LoadDataset(dir.string(), lazy);
  ASSERT_FALSE(bad.Ok());
  EXPECT_NE(bad.problems[0].ToString().find("points_000000.npy"), std::string::npos) << bad.problems[0].ToString();
  EXPECT_EQ(LoadDataset(dir.string(), KeepEverything()).problems.size(), bad.problems.size());
  // A choice that throws: every frame, so the bad value is found too.
  lazy.frames_used = [](const Dataset&) -> std::vector<int> { throw InputError("no pair"); };
  EXPECT_FALSE(LoadDataset(dir.string(), lazy).Ok());

  // An unused frame's truncated file is still found, from its size.
  lazy.frames_used = [](const Dataset&) { return std::vector<int>{1, 4}; };
  const std::string points2 = ReadText(dir / "truth" / "points_000002.npy");
  testing_support::WriteText(dir / "truth" / "points_000002.npy", points2.substr(0, points2.size() - 4));
  const DatasetLoadResult truncated = LoadDataset(dir.string(), lazy);
  ASSERT_FALSE(truncated.Ok());
  EXPECT_NE(truncated.problems[0].ToString().find("points_000002.npy"), std::string::npos);
  EXPECT_NE(truncated.problems[0].ToString().find("(truncated file?)"), std::string::npos)
      << truncated.problems[0].ToString();
}

TEST(LoadDataset, AcceptsSixteenBitImagesAndCrlfTables) {
  const fs::path dir = FreshTestDir() / "dataset";
  Dataset dataset = MakeExampleDataset(CurrentTestSeed());
  for (FrameRecord& frame : dataset.frames) frame.image.convertTo(frame.image, CV_16UC1, 257.0);
  WriteDataset(dataset, dir.string());
  std::string nav = ReadText(dir / "nav.csv");
  std::string crlf;
  for (const char c : nav) crlf += (c == '\n' ? std::string("\r\n") : std::string(1, c));
  testing_support::WriteText(dir / "nav.csv", crlf);
  const DatasetLoadResult result = LoadDataset(dir.string(), KeepEverything());
  ASSERT_TRUE(result.Ok()) << result.problems[0].ToString();
  EXPECT_EQ(result.dataset->frames[0].image.type(), CV_16UC1);
  EXPECT_TRUE(SameBytes(result.dataset->frames[0].image, dataset.frames[0].image));
}

TEST(RunDatasetCheck, PrintsASummaryOfAValidDataset) {
  const fs::path root = FreshTestDir();
  const fs::path dir = root / "dataset";
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
  const testing_support::CommandResult run =
      RunHdabench({"dataset", "check", dir.string()}, root);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_EQ(run.err, "");
  EXPECT_NE(run.out.find("camera:      LENSMODEL_OPENCV8, 256 x 256 px"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("frames:      6, 0.100 .. 2.500 s (2.400 s)"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("frames 0 -> 5: dt 2.400 s, baseline 31.2"), std::string::npos)
      << run.out;
  EXPECT_NE(run.out.find("truth:       points for 6 of 6 frames; DEM"), std::string::npos)
      << run.out;

  const testing_support::CommandResult pair =
      RunHdabench({"dataset", "check", dir.string(), "--frames", "1,3"}, root);
  EXPECT_EQ(pair.exit_code, 0) << pair.err;
  EXPECT_NE(pair.out.find("frames 1 -> 3: dt 0.960 s, baseline 12.4"), std::string::npos)
      << pair.out;
}

TEST(RunDatasetCheck, FrameOutOfRangeIsAUsageError) {
  const fs::path root = FreshTestDir();
  const fs::path dir = root / "dataset";
  WriteDataset(MakeExampleDataset(CurrentTestSeed()), dir.string());
  const testing_support::CommandResult run =
      RunHdabench({"dataset", "check", dir.string(), "--frames", "0,6"}, root);
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_EQ(run.err, "hdabench dataset check: --frames: frame 6 is not in " + dir.string() +
                         ", which has frames 0..5\n");
}

TEST(RunDatasetCheck, MissingFolderIsAnInputError) {
  const fs::path root = FreshTestDir();
  const testing_support::CommandResult run =
      RunHdabench({"dataset", "check", (root / "nowhere").string()}, root);
  EXPECT_EQ(run.exit_code, 3);
  EXPECT_EQ(run.err, "hdabench dataset check: " + (root / "nowhere").string() + ": no such folder\n");
  testing_support::WriteText(root / "file.txt", "not a folder");
  const testing_support::CommandResult file =
      RunHdabench({"dataset", "check", (root / "file.txt").string()}, root);
  EXPECT_EQ(file.exit_code, 3);
}

TEST(RunDatasetCreate, WritesTheExampleAndRefusesToOverwrite) {
  const fs::path root = FreshTestDir();
  const fs::path dir = root / "made";
  const testing_support::CommandResult run =
      RunHdabench({"dataset", "create", dir.string(), "--seed", "7"}, root);
  EXPECT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("wrote example dataset 'example-lateral-seed7'"), std::string::npos)
      << run.out;
  EXPECT_TRUE(LoadDataset(dir.string()).Ok());
  // Same seed through the library: same bytes.
  WriteDataset(MakeExampleDataset(7), (root / "library").string());
  EXPECT_EQ(FilesUnder(dir), FilesUnder(root / "library"));

  const testing_support::CommandResult again =
      RunHdabench({"dataset", "create", dir.string()}, root);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_EQ(again.err, "hdabench dataset create: " + dir.string() +
                           ": exists and is not an empty folder; choose a new folder\n");
}

}  // namespace
}  // namespace hdabench::datasets
