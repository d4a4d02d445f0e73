// The flight method on a real planar target: the 13 left/right pairs of the
// OpenCV stereo sample images (tests/data/opencv-stereo-chessboard) with the
// bench's own mrcal calibration of them, each pair a dataset whose navigation
// is PnP on each image (datasets/planar_target.h), the board as the one ROI,
// the parameters of params/planar-target.json. The flight method's plane is
// judged against the board's (docs/planar-target.md).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "datasets/planar_target.h"
#include "reference/flight/flight_run.h"
#include "reference/flight/hda_params.h"

namespace hdabench::reference {
namespace {

namespace fs = std::filesystem;

const fs::path kData = fs::path(HDABENCH_SOURCE_DIR) / "tests/data/opencv-stereo-chessboard";
const char* const kPairs[] = {"01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14"};

struct PairResult {
  std::string pair;
  hda::RoiResult roi;       // with the preset
  hda::RoiResult unguided;  // with the defaults (no nav-guided matching)
  double angle_deg = 0.0;   // between the flight method's normal and the board's
};

// Each pair made into a dataset once, run with the preset and without it.
std::vector<PairResult> RunPairs() {
  HdaSettings preset;
  preset.ReadFile((fs::path(HDABENCH_SOURCE_DIR) / "params/planar-target.json").string());
  const calib::CameraModel left = calib::CameraModel::Load((kData / "mrcal/camera-0.cameramodel").string());
  const calib::CameraModel right = calib::CameraModel::Load((kData / "mrcal/camera-1.cameramodel").string());
  std::vector<PairResult> results;
  for (const char* pair : kPairs) {
    const datasets::PlanarTargetPair target = datasets::MakePlanarTargetPair(
        (kData / (std::string("left") + pair + ".jpg")).string(), left,
        (kData / (std::string("right") + pair + ".jpg")).string(), right, {9, 6, 1.0});
    const FlightRun run = RunFlight(target.dataset, 0, 1, preset, {target.board_box_px});
    const FlightRun unguided = RunFlight(target.dataset, 0, 1, HdaSettings(), {target.board_box_px});
    EXPECT_EQ(run.result.rois.size(), 1u);
    EXPECT_EQ(unguided.result.rois.size(), 1u);
    PairResult result;
    result.pair = pair;
    result.roi = run.result.rois.at(0);
    result.unguided = unguided.result.rois.at(0);
    result.angle_deg = TiltErrorDeg(result.roi.normal_in_local, Eigen::Vector3d::UnitZ());
    results.push_back(result);
  }
  return results;
}

// With the preset (nav-guided matching) every pair gives the board a plane.
// Bounds:
//  - each angle within 3 predicted sigmas, and at least 11 of 13 within 2
//    (the method's claim of 95 % within 2 sigmas: 11 or fewer of 13 has a
//    chance of 3 % if the claim holds);
//  - each angle under 1 deg: the largest predicted sigma is 0.44 deg;
//  - roughness RMS under 0.05 squares (about 1.5 mm for a 30 mm square): the
//    printed board is flatter than that (mrcal's calibration of these images
//    finds its bow at 0.006 squares), and the matching noise alone predicts
//    0.006-0.016 squares.
// Without the guidance a chessboard defeats descriptor matching over the
// whole box (every corner looks like its neighbours): most pairs keep too
// few points. The preset's reason, kept visible.
TEST(PlanarTargetFlight, EveryPairGivesTheBoardsPlaneWithinItsPredictedSigmaOnlyWhenGuided) {
  const std::vector<PairResult> results = RunPairs();
  int within_2_sigma = 0, unguided_with_slope = 0;
  std::printf("pair  status     points  angle (deg)  sigma (deg)  roughness rms  noise rms  (squares)\n");
  for (const PairResult& r : results) {
    std::printf("%s    %-10s %6zu  %11.3f  %11.3f  %13.4f  %9.4f   unguided: %s\n", r.pair.c_str(),
                hda::ToString(r.roi.status), r.roi.points_in_local_m.size(), r.angle_deg, r.roi.slope_sigma_deg,
                r.roi.roughness_rms_m, r.roi.noise_rms_m, r.unguided.reason.c_str());
    SCOPED_TRACE("pair " + r.pair + ": " + r.roi.reason);
    if (hda::HasSlope(r.unguided.status)) ++unguided_with_slope;
    ASSERT_EQ(r.roi.status, hda::RoiStatus::kEvaluated);
    EXPECT_GE(r.roi.points_in_local_m.size(), 20u);
    EXPECT_LE(r.angle_deg, 3.0 * r.roi.slope_sigma_deg);
    EXPECT_LT(r.angle_deg, 1.0);
    EXPECT_LT(r.roi.roughness_rms_m, 0.05);
    if (r.angle_deg <= 2.0 * r.roi.slope_sigma_deg) ++within_2_sigma;
  }
  EXPECT_GE(within_2_sigma, 11);
  EXPECT_LT(unguided_with_slope, 7);
}

}  // namespace
}  // namespace hdabench::reference
