// The flight method's work, counted in units that do not depend on the
// machine that runs it, and the flight computer's time predicted from them.
// The budget's kick-out reads this prediction, never a clock, so the same
// inputs evaluate the same ROIs on any machine and under any load
// (docs/flight-method.md, "Time budget").
//
// The model: each unit costs a fixed number of x86-64 instructions
// (WorkUnitInstructions, fitted once to callgrind's counts of the stages,
// tools/calibrate-work-model.py), and the flight computer runs
// HdaOptions::flight_instructions_per_s of them per second.
#pragma once

#include <array>
#include <cstdint>
#include <string>

namespace hdabench::hda {

// The stages of the method, as StageTimes times them.
enum class Stage { kConvert, kQuadtree, kPrediction, kMatching, kRejection, kPlane, kRanking };
constexpr int kNumStages = static_cast<int>(Stage::kRanking) + 1;
const char* ToString(Stage stage);  // "convert", "quadtree", ...

// What the method counts. Each unit belongs to one stage.
enum class WorkUnit {
  kConvertedPixels,    // convert: 16-bit pixels taken to 8 bits
  kQuadtreePixels,     // quadtree: image-1 pixels
  kQuadtreeBlocks,     // quadtree: blocks visited
  kPredictedRois,      // prediction: ROIs placed on the ground and predicted into image 2
  kIteratedPredictions,  // prediction: the same, under a lens model unprojected by iteration
  kOrbPixels,          // matching: ORB pyramid pixels, both boxes, every level
  kOrbKeypoints,       // matching: keypoints oriented and described, both boxes
  kDescriptorPairs,    // matching: descriptor pairs compared
  kPrewarpPixels,      // matching: pixels resampled by the pre-warp
  kTrackedPoints,      // matching: Lucas-Kanade tracks
  kRefinePixels,       // matching: window pixels the nav-aided refinement reads (set-up and steps)
  kUnprojectedPixels,  // matching: match pixels unprojected through the camera model
  kIteratedPixels,     // matching: the same, under a lens model unprojected by iteration
  kRansacHypotheses,   // matching: RANSAC's 5-point hypotheses (RansacHypotheses)
  kRansacTests,        // matching: hypotheses x points tested
  kRejectionPoints,    // rejection: RANSAC inliers through the nav tests and triangulation
  kPlanePoints,        // plane: points of the fit
};
constexpr int kNumWorkUnits = static_cast<int>(WorkUnit::kPlanePoints) + 1;
const char* ToString(WorkUnit unit);  // "converted_pixels", ... (result.json's keys)
Stage StageOf(WorkUnit unit);
// Instructions (x86-64, as callgrind counts them) one unit costs.
double WorkUnitInstructions(WorkUnit unit);

struct WorkCounts {
  std::array<std::int64_t, kNumWorkUnits> units{};

  std::int64_t& operator[](WorkUnit unit) { return units[static_cast<size_t>(unit)]; }
  std::int64_t operator[](WorkUnit unit) const { return units[static_cast<size_t>(unit)]; }
  WorkCounts& operator+=(const WorkCounts& other);
  // The predicted instructions of the whole count, or of one stage's units.
  double Instructions() const;
  double Instructions(Stage stage) const;
};

// Whether mrcal unprojects this lens model (mrcal's name) by iteration, at
// many times the cost of the closed forms of the pinhole, stereographic,
// lonlat and latlon models.
bool UnprojectsIteratively(const std::string& lens_model);

// How many hypotheses OpenCV's adaptive RANSAC draws for `points`
// correspondences of which `inliers` fit the best model: the count after
// which another draw of five would find an all-inlier sample with less than
// 1 - confidence probability, capped at max_iterations (OpenCV lowers its
// limit to this each time it finds a better model). 0 below five points.
std::int64_t RansacHypotheses(int points, int inliers, double confidence, int max_iterations);

}  // namespace hdabench::hda
