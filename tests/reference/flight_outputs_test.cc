// The outputs of a flight run (reference/flight/flight_outputs.h) on a hand-made
// HdaResult: result.json's fields and nulls, rois.csv, the PLY clouds, the
// figures and the report's table.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/images/codecs.h"
#include "tools/util/angles.h"
#include "tools/util/error.h"
#include "reference/flight/flight_outputs.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

namespace fs = std::filesystem;
using testing_support::FreshTestDir;
using testing_support::ReadText;
using testing_support::SplitLines;

constexpr double kInf = std::numeric_limits<double>::infinity();

// An ROI with what every one has.
hda::RoiResult BaseRoi(int id, hda::RoiStatus status, const std::string& reason,
                       const cv::Rect& box1_px, int order, double ils_distance_m) {
  hda::RoiResult roi;
  roi.id = id;
  roi.status = status;
  roi.reason = reason;
  roi.box1_px = box1_px;
  roi.order = order;
  roi.ils_distance_m = ils_distance_m;
  return roi;
}

hda::RoiResult EvaluatedRoi() {
  hda::RoiResult roi =
      BaseRoi(1, hda::RoiStatus::kEvaluated, "slope 2.50 deg", cv::Rect(4, 6, 16, 16), 1, 12.5);
  roi.box2_px = cv::Rect(20, 2, 32, 30);
  roi.prediction_margin_px = 8.0;
  roi.counts.keypoints1 = 40;
  roi.counts.keypoints2 = 90;
  roi.counts.matches = 30;
  roi.counts.ransac_inliers = 26;
  roi.counts.epipolar_inliers = 25;
  roi.counts.triangulated = 25;
  roi.counts.depth_inliers = 25;
  roi.matched = true;
  roi.matching_status = hda::MatchingStatus::kOk;
  for (int i = 0; i < 25; ++i) {
    const double u = 5.0 + (i % 5) * 3.0;
    const double v = 7.0 + (i / 5) * 3.0;
    roi.points1_px.emplace_back(u, v);
    roi.points2_px.emplace_back(u + 22.0, v - 3.0);
    roi.points_in_local_m.emplace_back(0.5 * i, -0.25 * i, 0.01 * i);
  }
  roi.has_fit = true;
  roi.slope_deg = 2.5;
  roi.slope_sigma_deg = 0.4;
  roi.slope_sigma_terms.pixel_deg = 0.35;
  roi.slope_sigma_terms.baseline_deg = 0.1;
  roi.slope_sigma_terms.attitude_deg = 0.1;
  roi.pixel_sigma_px = 0.12;
  roi.roughness_rms_m = 0.08;
  roi.roughness_max_m = 0.2;
  roi.noise_rms_m = 0.05;
  roi.roughness_excess_m = 0.0625;
  roi.median_parallax_deg = 3.0;
  roi.area_m2 = 110.0;
  roi.normal_in_local = Eigen::Vector3d(0.0, 0.0436, 0.999);
  roi.centroid_in_local_m = Eigen::Vector3d(1.0, 2.0, 3.0);
  roi.score = 0.75;
  roi.rank = 1;
  roi.wall_s = 0.0123;
  return roi;
}

// No prediction into image 2: no box2, no matching, no fit, and a centre ray
// that missed the ground (infinite ILS distance).
hda::RoiResult NotInImage2Roi() {
  return BaseRoi(2, hda::RoiStatus::kNotInImage2, "prediction: outside image 2",
                 cv::Rect(40, 40, 16, 16), 3, kInf);
}

// A fit whose predicted sigma is infinite.
hda::RoiResult DegenerateRoi() {
  hda::RoiResult roi = BaseRoi(3, hda::RoiStatus::kDegenerate, "predicted slope sigma inf",
                               cv::Rect(40, 4, 16, 16), 2, 30.0);
  roi.box2_px = cv::Rect(30, 0, 30, 28);
  roi.counts.matches = 3;
  roi.counts.ransac_inliers = 3;
  roi.counts.depth_inliers = 3;
  roi.matched = true;
  roi.matching_status = hda::MatchingStatus::kOk;
  roi.points1_px = {{41.0, 5.0}, {50.0, 9.0}, {45.0, 17.0}};
  roi.points2_px = {{31.0, 2.0}, {40.0, 6.0}, {35.0, 14.0}};
  roi.points_in_local_m = {{1.0, 2.0, 3.0}, {2.0, 2.0, 3.0}, {1.0, 3.0, 3.5}};
  roi.has_fit = true;
  roi.slope_deg = 26.5;
  roi.slope_sigma_deg = kInf;
  roi.roughness_excess_m = 0.0;
  return roi;
}

RoiTruthValue Truth(double slope_deg, double rms_m) {
  RoiTruthValue truth;
  truth.available = true;
  truth.num_points = 256;
  truth.slope_deg = slope_deg;
  truth.roughness_rms_m = rms_m;
  truth.roughness_max_m = 3.0 * rms_m;
  truth.hazard_height_m = 4.0 * rms_m;
  // Tilted toward +y, as the ROIs of MakeRun are.
  truth.normal_in_local = Eigen::Vector3d(0.0, std::sin(slope_deg * util::kDegToRad),
                                          std::cos(slope_deg * util::kDegToRad));
  return truth;
}

FlightRun MakeRun() {
  FlightRun run;
  run.dataset_name = "handmade";
  run.frame1 = 0;
  run.frame2 = 6;
  run.lens_model = "LENSMODEL_OPENCV8";
  run.image_width_px = 64;
  run.image_height_px = 64;
  run.baseline_m = 31.25;
  run.lrf_range_m = 566.0;
  run.options.quadtree.site_size_m = 12.0;
  run.result.quadtree.min_block_px = 16;
  run.result.quadtree.blocks_visited = 21;
  run.result.quadtree.rejected_dark = 2;
  run.result.quadtree.rejected_boxes = {cv::Rect(0, 48, 16, 16), cv::Rect(16, 48, 16, 16)};
  for (const hda::RoiResult& roi : {EvaluatedRoi(), NotInImage2Roi(), DegenerateRoi()}) {
    hda::Roi block;
    block.id = roi.id;
    block.box_px = roi.box1_px;
    block.mean_dn = 100.0 + roi.id;
    block.stddev_dn = 5.0;
    run.result.quadtree.rois.push_back(block);
    run.result.rois.push_back(roi);
  }
  run.result.ranking = {1};
  run.result.budget_s = 1.0;
  run.result.times.total_s = 0.5;
  RoiTruthValue missing;
  missing.why = "fewer than 3 truth points";
  run.truths = {Truth(2.0, 0.05), missing, Truth(1.0, 0.1)};
  return run;
}

// A textured 64 x 64 image.
cv::Mat TestImage(int depth) {
  cv::Mat image(64, 64, depth);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) {
      const int value = 40 + (r * 7 + c * 13) % 180;
      if (depth == CV_8U) {
        image.at<uchar>(r, c) = static_cast<uchar>(value);
      } else {
        image.at<unsigned short>(r, c) = static_cast<unsigned short>(value * 257);
      }
    }
  }
  return image;
}

TEST(FlightOutputs, ResultJsonHoldsEveryFieldWithNullsWhereNothingApplies) {
  const FlightRun run = MakeRun();
  const nlohmann::json j = nlohmann::json::parse(FlightResultJson(run));
  EXPECT_EQ(j["format"], "hdabench-flight-result");
  EXPECT_EQ(j["format_version"], 1);
  EXPECT_EQ(j["dataset"], "handmade");
  EXPECT_EQ(j["frames"], nlohmann::json::array({0, 6}));
  EXPECT_EQ(j["options"]["quadtree"]["site_size_m"], 12.0);
  EXPECT_EQ(j["options"]["max_slope_deg"], run.options.max_slope_deg);
  EXPECT_EQ(j["options"]["matching"]["cross_check"], run.options.matching.cross_check);
  EXPECT_EQ(j["options"]["flight_instructions_per_s"], run.options.flight_instructions_per_s);
  EXPECT_EQ(j["camera"]["lens_model"], "LENSMODEL_OPENCV8");
  EXPECT_EQ(j["camera"]["width_px"], 64);
  EXPECT_EQ(j["inputs"]["baseline_m"], 31.25);
  EXPECT_EQ(j["inputs"]["lrf_range_m"], 566.0);
  EXPECT_EQ(j["quadtree"]["min_block_px"], 16);
  EXPECT_EQ(j["quadtree"]["num_rois"], 3);
  EXPECT_EQ(j["quadtree"]["rejected_dark"], 2);
  EXPECT_EQ(j["quadtree"]["rejected_boxes"][1], nlohmann::json::array({16, 48, 16, 16}));
  EXPECT_EQ(j["budget_s"], 1.0);
  EXPECT_EQ(j["budget_exhausted"], false);
  EXPECT_EQ(j["status_counts"]["degenerate"], 1);
  EXPECT_EQ(j["ranking"], nlohmann::json::array({1}));
  ASSERT_EQ(j["rois"].size(), 3u);

  const nlohmann::json& evaluated = j["rois"][0];
  EXPECT_EQ(evaluated["id"], 1);
  EXPECT_EQ(evaluated["status"], "evaluated");
  EXPECT_EQ(evaluated["box1"], nlohmann::json::array({4, 6, 16, 16}));
  EXPECT_EQ(evaluated["box2"], nlohmann::json::array({20, 2, 32, 30}));
  EXPECT_EQ(evaluated["ils_distance_m"], 12.5);
  EXPECT_EQ(evaluated["mean_dn"], 101.0);
  EXPECT_EQ(evaluated["counts"]["depth_inliers"], 25);
  EXPECT_EQ(evaluated["counts"]["refine_rejected"], 0);
  EXPECT_EQ(evaluated["matching_status"], "ok");
  EXPECT_EQ(evaluated["fit"]["slope_deg"], 2.5);
  EXPECT_EQ(evaluated["fit"]["sigma_terms"]["pixel_deg"], 0.35);
  EXPECT_EQ(evaluated["fit"]["normal_in_local"][1], 0.0436);
  EXPECT_EQ(evaluated["fit"]["centroid_in_local_m"], nlohmann::json::array({1.0, 2.0, 3.0}));
  EXPECT_EQ(evaluated["score"], 0.75);
  EXPECT_EQ(evaluated["rank"], 1);
  EXPECT_EQ(evaluated["truth"]["available"], true);
  EXPECT_EQ(evaluated["truth"]["slope_deg"], 2.0);
  EXPECT_EQ(evaluated["truth"]["num_points"], 256);
  EXPECT_DOUBLE_EQ(evaluated["slope_error_deg"].get<double>(), 0.5);
  EXPECT_EQ(evaluated["ply"], "points/roi_001.ply");
  EXPECT_FALSE(evaluated.contains("seconds"));

  const nlohmann::json& outside = j["rois"][1];
  EXPECT_EQ(outside["status"], "not in image 2");
  EXPECT_TRUE(outside["box2"].is_null());
  EXPECT_TRUE(outside["prediction_margin_px"].is_null());
  EXPECT_TRUE(outside["ils_distance_m"].is_null());
  EXPECT_TRUE(outside["matching_status"].is_null());
  EXPECT_TRUE(outside["fit"].is_null());
  EXPECT_TRUE(outside["score"].is_null());
  EXPECT_TRUE(outside["rank"].is_null());
  EXPECT_EQ(outside["truth"]["available"], false);
  EXPECT_EQ(outside["truth"]["why"], "fewer than 3 truth points");
  EXPECT_TRUE(outside["slope_error_deg"].is_null());
  EXPECT_TRUE(outside["ply"].is_null());

  const nlohmann::json& degenerate = j["rois"][2];
  EXPECT_EQ(degenerate["fit"]["slope_deg"], 26.5);
  EXPECT_TRUE(degenerate["fit"]["slope_sigma_deg"].is_null());
  EXPECT_DOUBLE_EQ(degenerate["slope_error_deg"].get<double>(), 25.5);
  EXPECT_TRUE(degenerate["rank"].is_null());

  // Deterministic: no wall times, the same bytes for the same run.
  EXPECT_EQ(FlightResultJson(run), FlightResultJson(MakeRun()));
  FlightRun slower = MakeRun();
  slower.result.times.total_s = 9.0;
  slower.result.rois[0].wall_s = 3.0;
  EXPECT_EQ(FlightResultJson(run), FlightResultJson(slower));
}

TEST(FlightOutputs, TimingsJsonHoldsTheStagesAndEachRoi) {
  const nlohmann::json j = nlohmann::json::parse(FlightTimingsJson(MakeRun()));
  EXPECT_EQ(j["format"], "hdabench-flight-timings");
  EXPECT_EQ(j["stages"]["total_s"], 0.5);
  EXPECT_EQ(j["budget_s"], 1.0);
  ASSERT_EQ(j["rois"].size(), 3u);
  EXPECT_EQ(j["rois"][0]["id"], 1);
  EXPECT_EQ(j["rois"][0]["seconds"], 0.0123);
}

TEST(FlightOutputs, RoisCsvHasAHeaderAndOneRowPerRoi) {
  const std::vector<std::string> lines = SplitLines(FlightRoisCsv(MakeRun()));
  ASSERT_EQ(lines.size(), 4u);
  EXPECT_EQ(lines[0],
            "id,status,x1,y1,w1,h1,x2,y2,w2,h2,order,keypoints1,keypoints2,matches,ransac_inliers,"
            "epipolar_inliers,triangulated,depth_inliers,slope_deg,slope_sigma_deg,roughness_rms_m,"
            "roughness_excess_m,area_m2,score,rank,truth_slope_deg,slope_error_deg,tilt_error_deg,"
            "slope_sigma_calibration_deg,slope_sigma_combined_deg");
  for (const std::string& line : lines) {
    EXPECT_EQ(std::count(line.begin(), line.end(), ','), 29) << line;
  }
  // ROI 1's normal (0, 0.0436, 0.999) is 2.499 deg from the vertical, toward
  // the truth's tilt of 2 deg: a tilt error of 0.499 deg.
  EXPECT_EQ(lines[1], "1,evaluated,4,6,16,16,20,2,32,30,1,40,90,30,26,25,25,25,2.5,0.4,0.08,0.0625,"
                      "110.0,0.75,1,2.0,0.5,0.49901071024847216,,0.4");
  EXPECT_EQ(lines[2], "2,not in image 2,40,40,16,16,,,,,3,0,0,0,0,0,0,0,,,,,,,,,,,,");
  // The infinite sigma is an empty cell; without a calibration term the
  // combined sigma is the method's.
  EXPECT_EQ(lines[3], "3,degenerate,40,4,16,16,30,0,30,28,2,0,0,3,3,0,0,3,26.5,,0.0,0.0,0.0,,,1.0,25.5,1.0,,");
}

// The tilt error sees the direction of the tilt, which the difference of
// slope magnitudes does not, and does not depend on which way a normal points.
TEST(FlightOutputs, TiltErrorIsTheAngleBetweenThePlanes) {
  const auto tilted = [](double slope_deg, double azimuth_deg) {
    const double s = slope_deg * util::kDegToRad;
    const double a = azimuth_deg * util::kDegToRad;
    return Eigen::Vector3d(std::sin(s) * std::cos(a), std::sin(s) * std::sin(a), std::cos(s));
  };
  // The same 3 deg slope facing the other way: 0 deg of slope error, 6 deg of tilt.
  EXPECT_NEAR(TiltErrorDeg(tilted(3.0, 0.0), tilted(3.0, 180.0)), 6.0, 1e-9);
  // Facing 90 deg apart: the angle between the normals, acos(cos^2 3 deg).
  EXPECT_NEAR(TiltErrorDeg(tilted(3.0, 0.0), tilted(3.0, 90.0)),
              std::acos(std::pow(std::cos(3.0 * util::kDegToRad), 2)) * util::kRadToDeg, 1e-9);
  EXPECT_NEAR(TiltErrorDeg(tilted(2.0, 45.0), tilted(5.0, 45.0)), 3.0, 1e-9);
  EXPECT_NEAR(TiltErrorDeg(-tilted(2.0, 45.0), 4.0 * tilted(5.0, 45.0)), 3.0, 1e-9);  // sign, scale
  EXPECT_NEAR(TiltErrorDeg(Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitZ()), 90.0, 1e-9);
  EXPECT_TRUE(std::isnan(TiltErrorDeg(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ())));
  EXPECT_TRUE(std::isnan(TiltErrorDeg(Eigen::Vector3d(std::nan(""), 0.0, 1.0), Eigen::Vector3d::UnitZ())));
}

TEST(FlightOutputs, PlyHeaderCountsThePoints) {
  const hda::RoiResult roi = EvaluatedRoi();
  const std::vector<std::string> lines = SplitLines(RoiPly(roi));
  ASSERT_GE(lines.size(), 3u);
  EXPECT_EQ(lines[0], "ply");
  EXPECT_EQ(lines[1], "format ascii 1.0");
  const auto end = std::find(lines.begin(), lines.end(), "end_header");
  ASSERT_NE(end, lines.end());
  EXPECT_NE(std::find(lines.begin(), end, "element vertex 25"), end);
  EXPECT_NE(std::find(lines.begin(), end, "property double u1"), end);
  EXPECT_EQ(static_cast<size_t>(lines.end() - end - 1), roi.points_in_local_m.size());
  EXPECT_EQ(lines.back(), "12.0 -6.0 0.24 17.0 19.0");
  EXPECT_EQ(RoiFileStem(7), "roi_007");
  EXPECT_EQ(RoiFileStem(1234), "roi_1234");
}

TEST(FlightOutputs, ReportTableWithTruth) {
  const std::string report = FlightReport(MakeRun());
  const std::vector<std::string> lines = SplitLines(report);
  ASSERT_EQ(lines.size(), 9u) << report;
  EXPECT_EQ(lines[0].rfind("hda: 3 ROIs, 1 evaluated", 0), 0u) << lines[0];
  EXPECT_NE(lines[0].find("frames 0,6, baseline 31.25 m"), std::string::npos) << lines[0];
  EXPECT_EQ(lines[1],
            "ROI  status          truth slope (deg)  est. slope (deg)  sigma (deg)  # points  "
            "truth rough. RMS (m)  est. relief (m)");
  EXPECT_EQ(lines[2].find_first_not_of("- "), std::string::npos);
  EXPECT_EQ(lines[3],
            "  1  evaluated                    2.00              2.50         0.40        25  "
            "               0.050            0.062");
  EXPECT_EQ(lines[4],
            "  2  not in image 2                  -                 -            -         0  "
            "                   -                -");
  EXPECT_EQ(lines[5],
            "  3  degenerate                   1.00             26.50            -         3  "
            "               0.100            0.000");
  // Only ROI 1 has a slope and >= 20 points: error 0.5 deg, within 2 sigma
  // (0.8), tilted the same way as the truth.
  EXPECT_EQ(lines[6],
            "slope error over 1 ROI(s) with a slope, truth and >= 20 points: median |error| 0.50 deg, "
            "90th percentile 0.50 deg, 100 % within 2 predicted sigmas");
  EXPECT_EQ(lines[7],
            "tilt error (angle to the true plane) median 0.50 deg, 90th percentile 0.50 deg; slope bias "
            "(mean of estimated - true) +0.50 deg");
  // The run's truth has no DEM: no lander truth, and the line says so.
  EXPECT_EQ(lines[8], "landing decision: no site has a lander truth (no truth DEM)");
}

TEST(FlightOutputs, ReportTableWithoutTruthDropsTheTruthColumns) {
  FlightRun run = MakeRun();
  run.truths.clear();
  const std::vector<std::string> lines = SplitLines(FlightReport(run));
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[1], "ROI  status          est. slope (deg)  sigma (deg)  # points  est. relief (m)");
  EXPECT_EQ(lines[3], "  1  evaluated                   2.50         0.40        25            0.062");
  EXPECT_EQ(lines[5].find("slope error"), std::string::npos);
  EXPECT_FALSE(run.AnyTruth());
  // No ROI at all: the summary line only.
  run.result.rois.clear();
  EXPECT_EQ(SplitLines(FlightReport(run)).size(), 1u);
}

TEST(FlightOutputs, SlopeErrorStatsUseRoisWithEnoughPoints) {
  FlightRun run = MakeRun();
  run.result.rois = {};
  run.truths = {};
  const double errors[] = {0.5, -1.0, 2.0, -4.0, 0.1};
  for (size_t i = 0; i < 5; ++i) {
    hda::RoiResult roi = EvaluatedRoi();
    roi.id = static_cast<int>(i) + 1;
    roi.slope_deg = 3.0 + errors[i];
    roi.slope_sigma_deg = 0.6;  // within 2 sigma: |error| <= 1.2
    run.result.rois.push_back(roi);
    run.truths.push_back(Truth(3.0, 0.05));
  }
  hda::RoiResult few = EvaluatedRoi();  // under 20 points: left out
  few.id = 6;
  few.counts.depth_inliers = 19;
  few.slope_deg = 100.0;
  run.result.rois.push_back(few);
  run.truths.push_back(Truth(3.0, 0.05));
  const SlopeErrorStats stats = ComputeSlopeErrorStats(run);
  EXPECT_EQ(stats.count, 5);
  EXPECT_NEAR(stats.median_abs_deg, 1.0, 1e-12);               // 0.1 0.5 1 2 4
  EXPECT_NEAR(stats.p90_abs_deg, 2.0 + 0.6 * 2.0, 1e-12);      // position 3.6
  EXPECT_NEAR(stats.within_two_sigma_fraction, 3.0 / 5.0, 1e-12);
}

TEST(FlightOutputs, WritesEveryFileAndRemovesStaleRoiFiles) {
  const fs::path dir = FreshTestDir() / "out";
  // An earlier run's cloud of an ROI this run has no points for, and a file of
  // the user's: the first goes, the second stays.
  fs::create_directories(dir / "points");
  testing_support::WriteText(dir / "points" / "roi_002.ply", "stale");
  testing_support::WriteText(dir / "points" / "notes.txt", "mine");
  testing_support::WriteText(dir / "result.json", "old");
  const FlightRun run = MakeRun();
  const std::vector<std::string> written =
      WriteFlightOutputs(run, TestImage(CV_8U), TestImage(CV_16U), dir.string(), true);
  for (const char* name : {"result.json", "timings.json", "rois.csv", "points/roi_001.ply",
                           "points/roi_003.ply", "figures/quadtree.png", "figures/matches.png",
                           "figures/roi_pairs/roi_001.png", "figures/roi_pairs/roi_003.png",
                           "figures/decision.png"}) {
    EXPECT_TRUE(fs::is_regular_file(dir / name)) << name;
    EXPECT_NE(std::find(written.begin(), written.end(), name), written.end()) << name;
  }
  EXPECT_EQ(written.size(), 10u);
  EXPECT_FALSE(fs::exists(dir / "points" / "roi_002.ply"));
  EXPECT_FALSE(fs::exists(dir / "figures" / "roi_pairs" / "roi_002.png"));
  EXPECT_TRUE(fs::exists(dir / "points" / "notes.txt"));
  EXPECT_EQ(ReadText(dir / "result.json"), FlightResultJson(run));
  EXPECT_EQ(ReadText(dir / "points" / "roi_003.ply"), RoiPly(run.result.rois[2]));
  // No temporary file left behind.
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
  }
  // The figures are 8-bit colour PNGs of sensible sizes.
  const cv::Mat quadtree = hdabench::images::Read((dir / "figures" / "quadtree.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(quadtree.empty());
  EXPECT_EQ(quadtree.type(), CV_8UC3);
  EXPECT_EQ(quadtree.cols, 64 * 3);  // enlarged so a 16 px block is 48 px
  EXPECT_GT(quadtree.rows, 64 * 3);  // plus the legend
  const cv::Mat pair = hdabench::images::Read((dir / "figures" / "roi_pairs" / "roi_001.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(pair.empty());
  EXPECT_EQ(pair.rows, kFigureGridHeightPx);  // the report's grid height; the title not shortened
  const cv::Mat matches = hdabench::images::Read((dir / "figures" / "matches.png").string(), cv::IMREAD_COLOR);
  ASSERT_FALSE(matches.empty());
  EXPECT_LE(matches.cols, kFigureShownWidthPx);

  // Without figures: the same data files, no figures written.
  const fs::path plain = dir.parent_path() / "plain";
  const std::vector<std::string> data_only =
      WriteFlightOutputs(run, TestImage(CV_8U), TestImage(CV_8U), plain.string(), false);
  EXPECT_EQ(data_only.size(), 5u);
  EXPECT_FALSE(fs::exists(plain / "figures"));
}

// The figures are drawn at most as large as the report shows them: the
// quadtree enlarged by a whole factor only while that fits the page's width,
// scaled to that width otherwise; both images side by side no wider.
TEST(FlightOutputs, FiguresAreNoWiderThanTheReportShowsThem) {
  FlightRun run = MakeRun();
  const cv::Mat small = TestImage(CV_8U);
  EXPECT_EQ(QuadtreeFigure(small, run.result).cols, small.cols * 3);  // a 16 px block at 48 px
  for (const int side : {500, 1024, 2048}) {
    const cv::Mat image(side, side, CV_8UC1, cv::Scalar(90));
    run.result.quadtree.min_block_px = 30;  // a factor of 2 would make a block 60 px
    const int whole = 2 * side;
    const cv::Mat quadtree = QuadtreeFigure(image, run.result);
    EXPECT_EQ(quadtree.cols, std::min(whole, kFigureShownWidthPx)) << side;
    EXPECT_GT(quadtree.rows, quadtree.cols) << side;  // the image's square and the legend below
    EXPECT_EQ(MatchesFigure(image, image, run.result).cols, std::min(2 * side + 8, kFigureShownWidthPx)) << side;
    int pairs = 0;
    for (const hda::RoiResult& roi : run.result.rois) {
      if (roi.counts.matches > 0 && roi.box2_px.area() > 0) {
        EXPECT_EQ(RoiPairFigure(image, image, roi).rows, kFigureGridHeightPx) << side;
        ++pairs;
      }
    }
    EXPECT_GT(pairs, 0) << side;
  }
}

TEST(FlightOutputs, AnOutputFolderUnderAFileIsAnInputErrorNamingIt) {
  const fs::path file = FreshTestDir() / "file";
  testing_support::WriteText(file, "x");
  const std::string dir = (file / "out").string();
  try {
    WriteFlightOutputs(MakeRun(), TestImage(CV_8U), TestImage(CV_8U), dir, false);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(dir), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hdabench::reference
