#include "reference/flight/hda_params.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "tools/util/error.h"
#include "tests/support/test_support.h"

namespace hdabench::reference {
namespace {

using Json = nlohmann::ordered_json;

// A pinhole camera, 1024 x 1024, principal point at the centre.
calib::CameraModel Pinhole(double f_px, int side_px = 1024) {
  const double c = 0.5 * (side_px - 1);
  return calib::CameraModel("LENSMODEL_PINHOLE", {f_px, f_px, c, c}, side_px, side_px);
}

using testing_support::InputErrorOf;

TEST(HdaParams, EveryKeyIsWrittenAndReadBack) {
  hda::HdaOptions options;
  options.max_relief_m = 7.5;
  options.quadtree.site_size_m = 40.0;
  options.matching.orb_levels = 5;
  options.matching.cross_check = false;
  const Json written = HdaOptionsJson(options);
  // Nested as result.json has always been: quadtree, prediction, matching, triangulation.
  EXPECT_EQ(written["quadtree"]["site_size_m"], 40.0);
  EXPECT_EQ(written["matching"]["orb_levels"], 5);
  EXPECT_EQ(written["matching"]["cross_check"], false);
  size_t leaves = 0;
  for (const auto& item : written.items()) leaves += item.value().is_object() ? item.value().size() : 1;
  EXPECT_EQ(leaves, HdaParamKeys().size());

  HdaSettings settings;
  settings.SetAll(written, "test");
  EXPECT_EQ(HdaOptionsJson(settings.options), written);
  EXPECT_EQ(settings.given.size(), HdaParamKeys().size());
  // The given keys, dotted, read back to the same options.
  HdaSettings again;
  again.SetAll(settings.GivenJson(), "test");
  EXPECT_EQ(HdaOptionsJson(again.options), written);
}

TEST(HdaParams, UnknownKeyListsTheKnownOnes) {
  HdaSettings settings;
  const std::string message = InputErrorOf([&] { settings.SetText("max_releif_m", "5", "--set hda.max_releif_m=5"); });
  EXPECT_NE(message.find("--set hda.max_releif_m=5"), std::string::npos) << message;
  EXPECT_NE(message.find("unknown flight-method parameter 'max_releif_m'"), std::string::npos) << message;
  EXPECT_NE(message.find("max_relief_m"), std::string::npos) << message;
  EXPECT_NE(message.find("quadtree.site_size_m"), std::string::npos) << message;
  EXPECT_TRUE(settings.given.empty());
}

TEST(HdaParams, ValuesAreTypedAndTextParsedWhole) {
  HdaSettings settings;
  settings.SetText("matching.orb_levels", "4", "w");
  EXPECT_EQ(settings.options.matching.orb_levels, 4);
  settings.SetText("max_relief_m", "2.5e1", "w");
  EXPECT_EQ(settings.options.max_relief_m, 25.0);
  settings.SetText("matching.cross_check", "false", "w");
  EXPECT_FALSE(settings.options.matching.cross_check);
  EXPECT_NE(InputErrorOf([&] { settings.SetText("matching.orb_levels", "4.5", "w"); }).find("whole number"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { settings.SetText("max_relief_m", "5m", "w"); }).find("not a number"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { settings.SetText("max_relief_m", "nan", "w"); }), "");
  // A flag's value (--processor-scale nan) is named as given, not as JSON's null.
  EXPECT_NE(InputErrorOf([&] { settings.Set("max_relief_m", Json(std::nan("")), "w"); })
                .find("expected a finite number, got nan"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { settings.Set("max_relief_m", Json(-HUGE_VAL), "w"); }).find("got -inf"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { settings.SetText("max_relief_m", "", "w"); }), "");
  EXPECT_NE(InputErrorOf([&] { settings.Set("matching.cross_check", Json(1), "w"); }).find("true or false"),
            std::string::npos);
  EXPECT_NE(InputErrorOf([&] { settings.Set("max_relief_m", Json("5"), "w"); }).find("finite number"),
            std::string::npos);
  EXPECT_EQ(settings.options.max_relief_m, 25.0);  // a refused value changes nothing
}

TEST(HdaParams, FileNestedOrDottedWithReasons) {
  const std::filesystem::path dir = testing_support::FreshTestDir();
  const std::string path = (dir / "p.json").string();
  {
    std::ofstream out(path);
    out << R"({"format": "hdabench-flight-params", "description": "x",
               "parameters": {"quadtree": {"site_size_m": 0.4, "site_size_m_why": "truck"},
                              "prediction.range_sigma_m": 0.01, "min_points": 12}})";
  }
  HdaSettings settings;
  settings.ReadFile(path);
  EXPECT_EQ(settings.options.quadtree.site_size_m, 0.4);
  EXPECT_EQ(settings.options.prediction.range_sigma_m, 0.01);
  EXPECT_EQ(settings.options.min_points, 12);
  EXPECT_EQ(settings.given.size(), 3u);

  {
    std::ofstream out(path);
    out << R"({"quadtree": {"site_size": 3}})";
  }
  const std::string message = InputErrorOf([&] { HdaSettings().ReadFile(path); });
  EXPECT_NE(message.find(path), std::string::npos) << message;
  EXPECT_NE(message.find("'quadtree.site_size'"), std::string::npos) << message;
  {
    std::ofstream out(path);
    out << "{\"max_relief_m\": ";
  }
  EXPECT_NE(InputErrorOf([&] { HdaSettings().ReadFile(path); }).find("not valid JSON"), std::string::npos);
  EXPECT_NE(InputErrorOf([&] { HdaSettings().ReadFile((dir / "missing.json").string()); }).find("cannot read"),
            std::string::npos);
  // A key beside "parameters" is not silently dropped.
  {
    std::ofstream out(path);
    out << R"({"parameters": {"min_points": 12}, "max_relief_m": 5})";
  }
  EXPECT_NE(InputErrorOf([&] { HdaSettings().ReadFile(path); }).find("field 'max_relief_m' beside 'parameters'"),
            std::string::npos);
  // A whole number beyond 64 bits signed is refused, not wrapped.
  HdaSettings huge;
  EXPECT_NE(InputErrorOf([&] { huge.Set("min_points", Json::parse("18446744073709551615"), "w"); })
                .find("expected a whole number"),
            std::string::npos);
  EXPECT_EQ(huge.options.min_points, hda::HdaOptions().min_points);
}

PairGeometry Geometry(double range_m, double baseline_m, double keypoints_per_1000_px2 = 0.0) {
  PairGeometry geometry;
  geometry.lrf_range_m = range_m;
  geometry.baseline_m = baseline_m;
  geometry.keypoints_per_px = keypoints_per_1000_px2 / 1000.0;
  return geometry;
}

// At the design point (566 m, 30 m; the NOVA-C camera's 1911 px focal
// length: the site is 33.8 px) every length keeps the NOVA-C value.
TEST(ResolveHdaOptions, DesignPointKeepsTheNovaCValues) {
  std::vector<DerivedParam> derived;
  const hda::HdaOptions o = ResolveHdaOptions(HdaSettings(), Pinhole(1910.81),
                                              Geometry(kDesignRangeM, kDesignBaselineM, 92.0), &derived);
  const hda::HdaOptions d;
  EXPECT_EQ(o.quadtree.site_size_m, d.quadtree.site_size_m);
  EXPECT_NEAR(o.max_relief_m, d.max_relief_m, 1e-12);
  EXPECT_NEAR(o.prediction.range_sigma_m, d.prediction.range_sigma_m, 1e-12);
  EXPECT_NEAR(o.prediction.nav_position_sigma_m, d.prediction.nav_position_sigma_m, 1e-12);
  EXPECT_EQ(o.max_hazard_height_m, d.max_hazard_height_m);
  EXPECT_EQ(o.max_roughness_rms_m, d.max_roughness_rms_m);
  EXPECT_EQ(derived.size(), GeometryScaledKeys().size());
  for (const DerivedParam& p : derived) EXPECT_FALSE(p.rule.empty()) << p.key;
}

// Far away the site grows to one ORB patch, or to the side holding
// kSiteKeypointsPerFitPoint * min_points keypoints where the image is
// sparser; the relief band and the LRF sigma grow with the range, the nav
// sigma with the baseline.
TEST(ResolveHdaOptions, FarAwayTheSiteHoldsEnoughKeypoints) {
  const hda::HdaOptions d;
  // f = 600 px at 30 km: the 10 m site is 0.2 px.
  hda::HdaOptions o = ResolveHdaOptions(HdaSettings(), Pinhole(600.0, 512), Geometry(30000.0, 2000.0), nullptr);
  EXPECT_NEAR(o.quadtree.site_size_m, 31.0 * 30000.0 / 600.0, 1e-6);  // one 31 px patch
  // The 1550 m site stands for a lander 155 times the size: its hazard limits
  // scale as much (the lander's 0.15 m relief is far under the noise there).
  EXPECT_NEAR(o.max_hazard_height_m, d.max_hazard_height_m * o.quadtree.site_size_m / 10.0, 1e-9);
  EXPECT_NEAR(o.max_roughness_rms_m, d.max_roughness_rms_m * o.quadtree.site_size_m / 10.0, 1e-9);
  EXPECT_EQ(o.max_slope_deg, d.max_slope_deg);  // an angle does not scale
  // Given limits stay as given.
  HdaSettings given;
  given.Set("max_roughness_rms_m", Json(0.2), "test");
  EXPECT_EQ(ResolveHdaOptions(given, Pinhole(600.0, 512), Geometry(30000.0, 2000.0), nullptr).max_roughness_rms_m,
            0.2);
  EXPECT_NEAR(o.max_relief_m, d.max_relief_m * 30000.0 / kDesignRangeM, 1e-9);
  EXPECT_NEAR(o.prediction.range_sigma_m, d.prediction.range_sigma_m * 30000.0 / kDesignRangeM, 1e-12);
  EXPECT_NEAR(o.prediction.nav_position_sigma_m,
              d.prediction.nav_position_sigma_m * 2000.0 / kDesignBaselineM, 1e-12);
  // 20 keypoints per 1000 px^2: 50 keypoints need 50 px.
  o = ResolveHdaOptions(HdaSettings(), Pinhole(600.0, 512), Geometry(30000.0, 2000.0, 20.0), nullptr);
  EXPECT_NEAR(o.quadtree.site_size_m, 50.0 * 30000.0 / 600.0, 1e-6);
  // A dense image does not shrink the site below one patch.
  o = ResolveHdaOptions(HdaSettings(), Pinhole(600.0, 512), Geometry(30000.0, 2000.0, 500.0), nullptr);
  EXPECT_NEAR(o.quadtree.site_size_m, 31.0 * 30000.0 / 600.0, 1e-6);
}

// Close by (a truck at 3 m) the site shrinks to a quarter of the image.
TEST(ResolveHdaOptions, CloseByTheSiteIsAQuarterOfTheImage) {
  std::vector<DerivedParam> derived;
  const hda::HdaOptions o =
      ResolveHdaOptions(HdaSettings(), Pinhole(1000.0), Geometry(3.0, 0.15, 92.0), &derived);
  EXPECT_NEAR(o.quadtree.site_size_m, 256.0 * 3.0 / 1000.0, 1e-9);
  EXPECT_NE(derived[0].rule.find("quarter of the image"), std::string::npos) << derived[0].rule;
}

// With a distorted lens the side is not proportional to the site far off the
// axis: the truck camera's 10 m site at 2.8 m or 0.57 m reaches 60-83 deg off
// it, where the distortion polynomial puts its edges thousands to a million
// pixels out. The scaled site is the one whose own side is the quarter image
// (a proportional scaling gave 259 px at 2.8 m and 8 px at 0.57 m: 6929 ROIs).
// A barrel polynomial (k1 = -0.3) folds back out there: the 10 m site at
// 2.76 m measured 107 px, and was kept as "within [31, 256] px".
TEST(ResolveHdaOptions, WithADistortedLensTheScaledSiteHasTheTargetSide) {
  const calib::CameraModel truck("LENSMODEL_OPENCV8",
                                 {1910.81, 1910.81, 511.5, 511.5, -0.02, 0.005, 1e-5, -1e-5, 0, 0, 0, 0}, 1024,
                                 1024);
  const calib::CameraModel barrel("LENSMODEL_OPENCV8",
                                  {1910.81, 1910.81, 511.5, 511.5, -0.3, 0, 0, 0, 0, 0, 0, 0}, 1024, 1024);
  for (const auto& [camera, range_m] : {std::make_pair(truck, 2.8), std::make_pair(truck, 0.57),
                                        std::make_pair(barrel, 2.74), std::make_pair(barrel, 2.76)}) {
    SCOPED_TRACE(camera.Intrinsics()[4]);
    SCOPED_TRACE(range_m);
    std::vector<DerivedParam> derived;
    const hda::HdaOptions o = ResolveHdaOptions(HdaSettings(), camera, Geometry(range_m, 0.15, 92.0), &derived);
    EXPECT_NEAR(hda::ProjectedSiteSidePx(camera, range_m, o.quadtree.site_size_m, "test"), 256.0, 0.5);
    EXPECT_NE(derived[0].rule.find("the site scaled to 256 px"), std::string::npos) << derived[0].rule;
    EXPECT_EQ(derived[0].rule.find("in proportion"), std::string::npos) << derived[0].rule;
  }
}

// An image too small for the lower bounds (96 px: a quarter is 24 px, under
// one ORB patch) still gets sites of a quarter of its side.
TEST(ResolveHdaOptions, TheQuarterImageBoundWins) {
  std::vector<DerivedParam> derived;
  const hda::HdaOptions o =
      ResolveHdaOptions(HdaSettings(), Pinhole(180.0, 96), Geometry(566.0, 30.0, 20.0), &derived);
  EXPECT_NEAR(o.quadtree.site_size_m, 24.0 * 566.0 / 180.0, 1e-9);
  EXPECT_NE(derived[0].rule.find("over a quarter"), std::string::npos) << derived[0].rule;
}

// A given key is kept whatever the geometry; the others still follow it.
TEST(ResolveHdaOptions, GivenKeysAreKept) {
  HdaSettings settings;
  settings.Set("quadtree.site_size_m", Json(40.0), "test");
  settings.Set("max_relief_m", Json(5.0), "test");
  std::vector<DerivedParam> derived;
  const hda::HdaOptions o =
      ResolveHdaOptions(settings, Pinhole(600.0, 512), Geometry(30000.0, 2000.0), &derived);
  EXPECT_EQ(o.quadtree.site_size_m, 40.0);
  EXPECT_EQ(o.max_relief_m, 5.0);
  EXPECT_NEAR(o.prediction.range_sigma_m, 30000.0 / kDesignRangeM, 1e-12);
  EXPECT_EQ(derived.size(), 2u);
}

// No baseline: the nav sigma keeps its default (the method reports the ROIs
// degenerate); a range that is not finite and > 0 is an error.
TEST(ResolveHdaOptions, DegenerateGeometry) {
  const hda::HdaOptions o =
      ResolveHdaOptions(HdaSettings(), Pinhole(1000.0), Geometry(500.0, 0.0), nullptr);
  EXPECT_EQ(o.prediction.nav_position_sigma_m, hda::HdaOptions().prediction.nav_position_sigma_m);
  for (const double range : {0.0, -5.0, std::nan("")}) {
    EXPECT_NE(InputErrorOf([&] { ResolveHdaOptions(HdaSettings(), Pinhole(1000.0), Geometry(range, 1.0), nullptr); })
                  .find("LRF range"),
              std::string::npos);
  }
}

// The density counts lit pixels only: a half-black image has the density of
// its lit half.
TEST(OrbKeypointDensity, CountsLitPixelsOnly) {
  cv::Mat image(256, 256, CV_8UC1);
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<int> dn(60, 200);
  for (int r = 0; r < image.rows; ++r) {
    for (int c = 0; c < image.cols; ++c) image.at<unsigned char>(r, c) = static_cast<unsigned char>(dn(rng));
  }
  const hda::MatchingOptions matching;
  const double full = OrbKeypointDensity(image, matching, 40.0);
  EXPECT_GT(full, 0.0);
  cv::Mat half = image.clone();
  half(cv::Rect(128, 0, 128, 256)).setTo(0);
  const double lit_half = OrbKeypointDensity(half, matching, 40.0);
  EXPECT_GT(lit_half, 0.5 * full);
  EXPECT_LT(lit_half, 1.5 * full);
  EXPECT_EQ(OrbKeypointDensity(cv::Mat::zeros(64, 64, CV_8UC1), matching, 40.0), 0.0);
}

// Every campaign preset in params/ reads, is usable, and gives each value
// its reason ("<key>_why").
TEST(HdaParams, CampaignPresetsReadWithAReasonForEachValue) {
  const std::filesystem::path dir = std::filesystem::path(HDABENCH_SOURCE_DIR) / "params";
  std::vector<std::filesystem::path> presets;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() == ".json") presets.push_back(entry.path());
  }
  std::sort(presets.begin(), presets.end());
  ASSERT_GE(presets.size(), 5u);  // novac, truck, aircraft, helicopter, planar-target
  for (const std::filesystem::path& path : presets) {
    SCOPED_TRACE(path.string());
    HdaSettings settings;
    ASSERT_EQ(InputErrorOf([&] { settings.ReadFile(path.string()); }), "");
    EXPECT_EQ(InputErrorOf([&] { settings.Validate(path.string()); }), "");
    EXPECT_FALSE(settings.given.empty());
    std::ifstream in(path);
    const Json j = Json::parse(in);
    EXPECT_FALSE(j["description"].get<std::string>().empty());
    const auto check_reasons = [&](const Json& object) {
      for (const auto& item : object.items()) {
        const std::string& key = item.key();
        if (item.value().is_object() || (key.size() > 4 && key.compare(key.size() - 4, 4, "_why") == 0)) continue;
        EXPECT_TRUE(object.contains(key + "_why")) << key;
      }
    };
    check_reasons(j["parameters"]);
    for (const auto& item : j["parameters"].items()) {
      if (item.value().is_object()) check_reasons(item.value());
    }
  }
  // novac pins every length the geometry would set.
  HdaSettings novac;
  novac.ReadFile((dir / "novac.json").string());
  for (const std::string& key : GeometryScaledKeys()) EXPECT_EQ(novac.given.count(key), 1u) << key;
}

}  // namespace
}  // namespace hdabench::reference
