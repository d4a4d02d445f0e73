// Field logs into datasets (datasets/field_log.h): WGS84 geodesy, a
// constructed log with geodetic navigation, a 45 deg mount, a clock offset
// and an LRF log whose ingested poses and ranges match the truth it was made
// from, every malformed input named by file and line, and
// `hdabench ingest field`. Synthetic scenes through a field log are
// field_log_scenes_test.cc.
#include "datasets/field_log.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "datasets/example.h"
#include "tools/images/codecs.h"
#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::datasets {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::RunHdabench;
using testing_support::WriteText;

constexpr double kDeg = 3.14159265358979323846 / 180.0;

std::string Num(double v) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.17g", v);
  return text;
}

using testing_support::InputErrorOf;

TEST(Wgs84, GeodeticRoundTripAndGravity) {
  for (const Geodetic& g : {Geodetic{32.38, -106.48, 1200.0}, Geodetic{-89.9, 10.0, -50.0}, Geodetic{0.0, 179.0, 8000.0}}) {
    const Geodetic back = GeodeticFromEcef(EcefFromGeodetic(g));
    EXPECT_NEAR(back.lat_deg, g.lat_deg, 1e-11);
    EXPECT_NEAR(back.lon_deg, g.lon_deg, 1e-11);
    EXPECT_NEAR(back.height_m, g.height_m, 1e-6);
  }
  // The equator on the ellipsoid is the semi-major axis from the centre.
  EXPECT_NEAR(EcefFromGeodetic({0.0, 0.0, 0.0}).x(), 6378137.0, 1e-6);
  // WGS84's defining normal gravity at the equator and the poles (NIMA TR8350.2).
  EXPECT_NEAR(NormalGravityMps2(0.0, 0.0), 9.7803253359, 1e-9);
  EXPECT_NEAR(NormalGravityMps2(90.0, 0.0), 9.8321849378, 1e-8);
  // The free-air gradient: about 3.086e-6 s^-2.
  EXPECT_NEAR(NormalGravityMps2(45.0, 0.0) - NormalGravityMps2(45.0, 1000.0), 3.086e-3, 1e-5);
  // ENU at (lat, lon): up is the ellipsoid normal.
  const Eigen::Matrix3d enu = EnuFromEcef(32.38, -106.48);
  const Eigen::Vector3d a = EcefFromGeodetic({32.38, -106.48, 0.0});
  const Eigen::Vector3d b = EcefFromGeodetic({32.38, -106.48, 100.0});
  EXPECT_LT((enu * (b - a) - Eigen::Vector3d(0, 0, 100)).norm(), 1e-6);
}

TEST(Mount, PointingAngles) {
  // 45 deg down toward the nose: the optical axis forward and down.
  const Eigen::Matrix3d nose = BodyFromCamPointing(0.0, 45.0, 0.0);
  EXPECT_LT((nose.col(2) - Eigen::Vector3d(std::sqrt(0.5), 0, std::sqrt(0.5))).norm(), 1e-12);
  EXPECT_LT((nose.col(0) - Eigen::Vector3d::UnitY()).norm(), 1e-12);  // image right = body right
  // Out of the rear (the truck): backward and down, image right = body left.
  const Eigen::Matrix3d rear = BodyFromCamPointing(180.0, 45.0, 0.0);
  EXPECT_LT((rear.col(2) - Eigen::Vector3d(-std::sqrt(0.5), 0, std::sqrt(0.5))).norm(), 1e-12);
  EXPECT_LT((rear.col(0) + Eigen::Vector3d::UnitY()).norm(), 1e-12);
  // Nadir, image up toward the nose.
  const Eigen::Matrix3d nadir = BodyFromCamPointing(0.0, 90.0, 0.0);
  EXPECT_LT((nadir.col(2) - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  EXPECT_LT((nadir.col(1) + Eigen::Vector3d::UnitX()).norm(), 1e-12);  // image down = backward
  EXPECT_NEAR(nose.determinant(), 1.0, 1e-12);
  // Z-Y-X angles round trip.
  const Eigen::Vector3d angles = ZyxAnglesDeg(FrameFromBodyZyx(-150.0, 20.0, 35.0));
  EXPECT_LT((angles - Eigen::Vector3d(-150.0, 20.0, 35.0)).norm(), 1e-9);
}

// A field log made from a known truth: an aircraft-like pass at 1800 m over
// White Sands, 80 m/s east and 10 m/s north, turning 2 deg/s, camera 45 deg
// down toward the nose 0.5 m ahead of the navigation point, a 50 ms clock
// offset, the LRF along the optical axis.
struct FieldLog {
  fs::path dir;
  Geodetic origin{32.38, -106.48, 1200.0};
  double offset_s = 0.05;
  Eigen::Vector3d cam_in_body{0.5, 0.0, 0.2};
  std::vector<double> nav_times;
  std::vector<double> camera_times = {0.15, 0.55, 0.95, 1.35, 1.75, 5.0};  // the last outside the log

  Eigen::Vector3d TruePosition(double t) const { return {80.0 * t, 10.0 * t, 600.0 + 0.5 * t}; }
  // Attitude against the NED axes at the origin.
  Eigen::Matrix3d TrueNedFromBody(double t) const { return FrameFromBodyZyx(30.0 + 2.0 * t, 2.0, -1.0); }
  double TrueRange(double t) const { return 850.0 + 10.0 * t; }
  Rigid3d TrueLocalFromBody(double t) const {
    Eigen::Matrix3d enu_from_ned;
    enu_from_ned << 0, 1, 0, 1, 0, 0, 0, 0, -1;
    return Rigid3d(Eigen::Quaterniond(enu_from_ned * TrueNedFromBody(t)), TruePosition(t));
  }

  // Writes the log; `edit_nav` may change the nav rows (text lines without the header).
  void Write(const std::function<void(std::vector<std::string>*)>& edit_nav = nullptr,
             const std::string& attitude_kind = "euler_zyx_deg") {
    fs::create_directories(dir / "images");
    calib::CameraModel("LENSMODEL_PINHOLE", {300.0, 300.0, 99.5, 79.5}, 200, 160).Save((dir / "cam.cameramodel").string());
    const Eigen::Matrix3d local_from_ecef = EnuFromEcef(origin.lat_deg, origin.lon_deg);
    const Eigen::Vector3d origin_ecef = EcefFromGeodetic(origin);
    Eigen::Matrix3d enu_from_ned;
    enu_from_ned << 0, 1, 0, 1, 0, 0, 0, 0, -1;
    std::vector<std::string> rows;
    nav_times.clear();
    for (int i = 0; i <= 20; ++i) {
      const double t = 0.1 * i;
      nav_times.push_back(t);
      const Geodetic g = GeodeticFromEcef(origin_ecef + local_from_ecef.transpose() * TruePosition(t));
      // The attitude against the NED axes at the sample's own position.
      const Eigen::Matrix3d ned_here_from_ecef = enu_from_ned.transpose() * EnuFromEcef(g.lat_deg, g.lon_deg);
      const Eigen::Matrix3d ned_here_from_body =
          ned_here_from_ecef * local_from_ecef.transpose() * TrueLocalFromBody(t).rotation.toRotationMatrix();
      const Eigen::Vector3d ypr = ZyxAnglesDeg(ned_here_from_body);
      rows.push_back(Num(t) + "," + Num(g.lat_deg) + "," + Num(g.lon_deg) + "," + Num(g.height_m) + "," +
                     Num(ypr[0]) + "," + Num(ypr[1]) + "," + Num(ypr[2]) + ",7");
    }
    if (edit_nav) edit_nav(&rows);
    std::string nav = "time_s,lat_deg,lon_deg,height_m,yaw_deg,pitch_deg,roll_deg,satellites\n";
    for (const std::string& row : rows) nav += row + "\n";
    WriteText(dir / "nav.csv", nav);
    std::string lrf = "t_ms,range_m\n";
    for (int i = 0; i <= 40; ++i) lrf += Num(50.0 * i) + "," + Num(TrueRange(0.05 * i)) + "\n";
    WriteText(dir / "lrf.csv", lrf);
    cv::Mat image(160, 200, CV_8UC1);
    cv::randu(image, 30, 220);
    for (const double t : camera_times) {
      hdabench::images::Write((dir / "images" / ("cam_" + std::to_string(static_cast<long>(std::lround(t * 1000))) + ".png")).string(),
                  image);
    }
    WriteText(dir / "log.json", R"({"format": "hdabench-field-log", "format_version": 1, "name": "constructed",
      "camera_model": "cam.cameramodel",
      "mount": {"azimuth_deg": 0, "depression_deg": 45, "position_in_body_m": [0.5, 0, 0.2]},
      "images": {"folder": "images", "pattern": "cam_{time_ms}.png"},
      "clock_offset_s": 0.05,
      "origin": {"lat_deg": 32.38, "lon_deg": -106.48, "height_m": 1200},
      "navigation": {"csv": "nav.csv", "time_column": "time_s",
        "position": {"frame": "wgs84", "columns": ["lat_deg", "lon_deg", "height_m"]},
        "attitude": {"kind": ")" + attitude_kind + R"(", "frame": "ned", "columns": ["yaw_deg", "pitch_deg", "roll_deg"]},
        "max_gap_s": 0.3},
      "lrf": {"csv": "lrf.csv", "time_column": "t_ms", "time_unit": "ms", "range_column": "range_m"}})");
  }
};

TEST(FieldLog, GeodeticNavMountClockOffsetAndLrfMatchTheTruth) {
  FieldLog log;
  log.dir = FreshTestDir();
  log.Write();
  FieldIngestReport report;
  const Dataset dataset = IngestFieldLog((log.dir / "log.json").string(), &report);
  ASSERT_EQ(dataset.frames.size(), 5u);
  EXPECT_EQ(report.frames_found, 6);
  bool dropped_named = false;
  for (const std::string& line : report.lines) {
    if (line.find("cam_5000.png") != std::string::npos && line.find("outside the navigation span") != std::string::npos) {
      dropped_named = true;
    }
  }
  EXPECT_TRUE(dropped_named);
  const Rigid3d cam_from_body =
      Rigid3d(Eigen::Quaterniond(BodyFromCamPointing(0.0, 45.0, 0.0)), log.cam_in_body).Inverse();
  for (size_t i = 0; i < dataset.frames.size(); ++i) {
    SCOPED_TRACE(i);
    const double t = log.camera_times[i] + log.offset_s;  // navigation time of the frame
    EXPECT_NEAR(dataset.frames[i].time_s, t, 1e-12);
    const Rigid3d truth = cam_from_body * log.TrueLocalFromBody(t).Inverse();
    const Rigid3d got = dataset.CamFromLocal(static_cast<int>(i));
    // Bounds: the geodetic round trip is good to 1e-9 m; interpolation
    // between samples is exact for this motion (linear position, a turn
    // about one axis) up to the slerp's rounding.
    EXPECT_LT(got.rotation.angularDistance(truth.rotation), 1e-9);
    EXPECT_LT((dataset.CameraCenterInLocal(static_cast<int>(i)) - (log.TrueLocalFromBody(t) * log.cam_in_body)).norm(),
              1e-6);
    EXPECT_NEAR(dataset.LrfRangeAt(t), log.TrueRange(t), 1e-9);
  }
  // The LRF along the optical axis, from the camera.
  EXPECT_LT((dataset.lrf.front().boresight_in_body - Eigen::Vector3d(std::sqrt(0.5), 0, std::sqrt(0.5))).norm(), 1e-12);
  EXPECT_LT((dataset.lrf_origin_in_body_m - log.cam_in_body).norm(), 1e-12);
  EXPECT_NEAR(dataset.gravity_in_local_mps2.z(), -NormalGravityMps2(32.38, 1200.0), 1e-12);
  EXPECT_NEAR(dataset.BaselineM(0, 1), std::hypot(80.0, 10.0) * 0.4, 0.01);
}

// Image names with epoch nanoseconds (19 digits) and a clock offset that
// brings them onto the navigation's clock.
TEST(FieldLog, EpochNanosecondNames) {
  FieldLog log;
  log.dir = FreshTestDir();
  log.Write();
  for (const double t : log.camera_times) {
    const std::string ms = std::to_string(static_cast<long>(std::lround(t * 1000)));
    fs::rename(log.dir / "images" / ("cam_" + ms + ".png"),
               log.dir / "images" / ("cam_" + std::to_string(1700000000000000000LL + std::llround(t * 1e9)) + ".png"));
  }
  std::string config = ReadText(log.dir / "log.json");
  config.replace(config.find("cam_{time_ms}.png"), 17, "cam_{time_ns}.png");
  config.replace(config.find("\"clock_offset_s\": 0.05"), 22, "\"clock_offset_s\": -1699999999.95");
  WriteText(log.dir / "log.json", config);
  const Dataset dataset = IngestFieldLog((log.dir / "log.json").string(), nullptr);
  ASSERT_EQ(dataset.frames.size(), 5u);
  // Epoch seconds as doubles: steps of 2.4e-7 s.
  for (size_t i = 0; i < dataset.frames.size(); ++i) EXPECT_NEAR(dataset.frames[i].time_s, log.camera_times[i] + 0.05, 1e-6);
}

// A clock offset that puts a frame outside a 64-bit nanosecond count is
// refused before anything is written (it had collapsed every image onto one
// name, with exit 0).
TEST(FieldLog, AClockOffsetBeyondTheNanosecondRangeIsRefusedBeforeWriting) {
  ExampleDatasetOptions options;
  options.image_size_px = 32;
  options.num_frames = 3;
  const Dataset dataset = MakeExampleDataset(options);
  const fs::path dir = FreshTestDir() / "log";
  const Geodetic origin{32.38, -106.48, 1200.0};
  for (const double offset : {1e300, -1e10, 1e10}) {
    try {
      WriteFieldLog(dataset, dir.string(), origin, offset);
      ADD_FAILURE() << "offset " << offset << " accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("outside the camera clock's range"), std::string::npos) << e.what();
    }
    EXPECT_FALSE(fs::exists(dir / "images")) << offset;
  }
  WriteFieldLog(dataset, dir.string(), origin, -1.7e9);  // epoch-sized offsets fit
  size_t images = 0;
  for (const auto& entry : fs::directory_iterator(dir / "images")) images += entry.is_regular_file() ? 1 : 0;
  EXPECT_EQ(images, 3u);
}

TEST(FieldLog, AGapLeavesTheFrameOutAndSaysSo) {
  FieldLog log;
  log.dir = FreshTestDir();
  // The rows of t = 0.8, 0.9 and 1.0 missing: a 0.4 s gap (max_gap_s 0.3) around the frame at 1.0 s.
  log.Write([](std::vector<std::string>* rows) { rows->erase(rows->begin() + 8, rows->begin() + 11); });
  FieldIngestReport report;
  const Dataset dataset = IngestFieldLog((log.dir / "log.json").string(), &report);
  EXPECT_EQ(dataset.frames.size(), 4u);
  bool gap = false;
  for (const std::string& line : report.lines) gap = gap || (line.find("cam_950.png") != std::string::npos &&
                                                             line.find("navigation gap of 0.4") != std::string::npos);
  EXPECT_TRUE(gap);
}

// Found by the field_log fuzz harness: a number too large for a double in
// log.json made the JSON parser throw out_of_range, which escaped the ingest.
TEST(FieldLog, ANumberTooLargeForADoubleIsNamedNotACrash) {
  const fs::path dir = FreshTestDir();
  WriteText(dir / "log.json", "{\"format\": \"hdabench-field-log\", \"format_version\": 8e94994948}");
  const std::string message = InputErrorOf([&] { IngestFieldLog((dir / "log.json").string(), nullptr); });
  EXPECT_NE(message.find((dir / "log.json").string() + ": not valid JSON"), std::string::npos) << message;
  EXPECT_NE(message.find("number overflow"), std::string::npos) << message;
}

TEST(FieldLog, MalformedLogsAreNamedByFileAndLine) {
  const fs::path dir = FreshTestDir();
  int n = 0;
  const auto expect = [&](const std::function<void(FieldLog*)>& make, const std::vector<std::string>& needles) {
    FieldLog log;
    log.dir = dir / std::to_string(++n);
    make(&log);
    const std::string message = InputErrorOf([&] { IngestFieldLog((log.dir / "log.json").string(), nullptr); });
    for (const std::string& needle : needles) {
      EXPECT_NE(message.find(needle), std::string::npos) << "case " << n << ": '" << needle << "' in\n" << message;
    }
  };
  // A missing column.
  expect([](FieldLog* log) {
    log->Write();
    std::string nav = ReadText(log->dir / "nav.csv");
    nav.replace(nav.find("roll_deg"), 8, "rol_deg");
    WriteText(log->dir / "nav.csv", nav);
  }, {"nav.csv:1", "roll_deg"});
  // A bad number, at its line (header line 1, rows from line 2).
  expect([](FieldLog* log) {
    log->Write([](std::vector<std::string>* rows) { (*rows)[3].replace(0, (*rows)[3].find(','), "0.3x"); });
  }, {"nav.csv:5", "'0.3x' is not a number"});
  // Time not increasing.
  expect([](FieldLog* log) {
    log->Write([](std::vector<std::string>* rows) { std::swap((*rows)[6], (*rows)[7]); });
  }, {"nav.csv:9", "times must increase"});
  // An unknown angle convention.
  expect([](FieldLog* log) { log->Write(nullptr, "euler_xyz_deg"); },
         {"log.json: navigation.attitude.kind", "'euler_xyz_deg' is not a known convention", "euler_zyx_deg"});
  // The images' times from a table, frames.csv, instead of their names.
  const auto times_from_table = [](FieldLog* log, const std::string& table) {
    log->Write();
    WriteText(log->dir / "frames.csv", table);
    std::string config = ReadText(log->dir / "log.json");
    const std::string pattern = R"("pattern": "cam_{time_ms}.png")";
    config.replace(config.find(pattern), pattern.size(),
                   R"("times_csv": "frames.csv", "file_column": "file", "time_column": "t")");
    WriteText(log->dir / "log.json", config);
  };
  // An image without a time: a times table that misses one image.
  expect([&](FieldLog* log) { times_from_table(log, "file,t\ncam_150.png,0.15\ncam_550.png,0.55\n"); },
         {"cam_950.png", "image without a time: not listed in"});
  // One image listed twice, under two names: two frames of the same pixels.
  expect([&](FieldLog* log) {
    times_from_table(log, "file,t\ncam_150.png,0.15\ncam_550.png,0.55\ncam_950.png,0.95\n./cam_950.png,1.2\n");
  }, {"frames.csv:5", "image './cam_950.png' is listed already at line 4"});
  // The same placeholder twice.
  expect([](FieldLog* log) {
    log->Write();
    std::string config = ReadText(log->dir / "log.json");
    config.replace(config.find("{time_ms}"), 9, "{time_ms}{time_ms}");
    WriteText(log->dir / "log.json", config);
  }, {"'cam_{time_ms}{time_ms}.png' has more than one time placeholder"});
  // A folder where the navigation table should be.
  expect([](FieldLog* log) {
    log->Write();
    fs::remove(log->dir / "nav.csv");
    fs::create_directories(log->dir / "nav.csv");
  }, {"nav.csv: is a directory; expected a file"});
  // A bad LRF range.
  expect([](FieldLog* log) {
    log->Write();
    WriteText(log->dir / "lrf.csv", "t_ms,range_m\n0,850\n50,-3\n2000,870\n");
  }, {"lrf.csv:3", "range -3 m; expected > 0"});
  // Finite but absurd: a range, a height, gravity (they ended in infinite
  // baselines or an internal error).
  expect([](FieldLog* log) {
    log->Write();
    WriteText(log->dir / "lrf.csv", "t_ms,range_m\n0,850\n50,1e300\n2000,870\n");
  }, {"lrf.csv:3", "expected > 0 and at most 1e+07 m"});
  expect([](FieldLog* log) {
    log->Write([](std::vector<std::string>* rows) {
      std::string& row = (*rows)[2];
      size_t at = 0;
      for (int comma = 0; comma < 3; ++comma) at = row.find(',', at) + 1;
      row.replace(at, row.find(',', at) - at, "1e200");
    });
  }, {"nav.csv:4", "position 1e+200 m from the frame's origin"});
  expect([](FieldLog* log) {
    log->Write();
    std::string config = ReadText(log->dir / "log.json");
    config.replace(config.find('{'), 1, R"({"gravity_mps2": 1e300, )");
    WriteText(log->dir / "log.json", config);
  }, {"gravity_mps2", "expected > 0 and at most 100"});
}

// Spreadsheet programs put a byte-order mark before UTF-8 text: the first
// column keeps its name.
TEST(FieldLog, ATableWithAByteOrderMarkReads) {
  FieldLog log;
  log.dir = FreshTestDir() / "log";
  log.Write();
  const Dataset plain = IngestFieldLog((log.dir / "log.json").string(), nullptr);
  WriteText(log.dir / "nav.csv", "\xEF\xBB\xBF" + ReadText(log.dir / "nav.csv"));
  const Dataset marked = IngestFieldLog((log.dir / "log.json").string(), nullptr);
  ASSERT_EQ(marked.nav.size(), plain.nav.size());
  EXPECT_EQ(marked.nav.front().time_s, plain.nav.front().time_s);
}

TEST(FieldLog, CommandWritesADatasetThatChecksOrNothing) {
  FieldLog log;
  log.dir = FreshTestDir() / "log";
  log.Write();
  const fs::path out = log.dir.parent_path() / "dataset";
  const testing_support::CommandResult ingest =
      RunHdabench({"ingest", "field", (log.dir / "log.json").string(), "--out", out.string()}, log.dir.parent_path());
  ASSERT_EQ(ingest.exit_code, 0) << ingest.err;
  EXPECT_NE(ingest.out.find("5 of 6 frames"), std::string::npos) << ingest.out;
  EXPECT_NE(ingest.out.find("outside the navigation span"), std::string::npos) << ingest.out;
  EXPECT_EQ(RunHdabench({"dataset", "check", out.string()}, log.dir.parent_path()).exit_code, 0);

  // Exported back, the log goes neither among the dataset's files nor over
  // another command's results: exit 3, nothing written.
  for (const fs::path& into : {out / "log", out}) {
    const testing_support::CommandResult inside =
        RunHdabench({"export", "field", out.string(), "--out", into.string()}, log.dir.parent_path());
    EXPECT_EQ(inside.exit_code, 3) << inside.err;
    EXPECT_NE(inside.err.find("is the dataset folder"), std::string::npos) << inside.err;
  }
  EXPECT_FALSE(fs::exists(out / "log"));
  EXPECT_FALSE(fs::exists(out / "log.json"));

  // A malformed log: exit 3, the line named, no folder written.
  WriteText(log.dir / "lrf.csv", "t_ms,range_m\n0,850\n50,abc\n");
  const fs::path bad = log.dir.parent_path() / "bad";
  const testing_support::CommandResult failed =
      RunHdabench({"ingest", "field", (log.dir / "log.json").string(), "--out", bad.string()}, log.dir.parent_path());
  EXPECT_EQ(failed.exit_code, 3);
  EXPECT_NE(failed.err.find("lrf.csv:3"), std::string::npos) << failed.err;
  EXPECT_FALSE(fs::exists(bad));
}

}  // namespace
}  // namespace hdabench::datasets
