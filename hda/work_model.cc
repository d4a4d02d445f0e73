#include "hda/work_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hdabench::hda {

namespace {

struct UnitInfo {
  const char* name;
  Stage stage;
  double instructions;  // per unit (docs/flight-method.md, "Time budget")
};

// Fitted by tools/calibrate-work-model.py to callgrind's inclusive counts of
// each unit's code (the functions the script names) on the ten runs of
// docs/flight-method.md ("Time budget"), where the whole is within 2 % of
// callgrind's count on every run; ordered as WorkUnit. No pair of the
// calibration had 16-bit images: their conversion is counted but not priced.
constexpr UnitInfo kUnits[kNumWorkUnits] = {
    {"converted_pixels", Stage::kConvert, 0.0},
    {"quadtree_pixels", Stage::kQuadtree, 7.112},
    {"quadtree_blocks", Stage::kQuadtree, 448.3},
    {"predicted_rois", Stage::kPrediction, 30720.0},
    {"iterated_predictions", Stage::kPrediction, 196100.0},
    {"orb_pixels", Stage::kMatching, 44.56},
    {"orb_keypoints", Stage::kMatching, 23450.0},
    {"descriptor_pairs", Stage::kMatching, 78.91},
    {"prewarp_pixels", Stage::kMatching, 62.14},
    {"tracked_points", Stage::kMatching, 41500.0},
    {"refine_pixels", Stage::kMatching, 50.55},
    {"unprojected_pixels", Stage::kMatching, 1271.0},
    {"iterated_pixels", Stage::kMatching, 11130.0},
    {"ransac_hypotheses", Stage::kMatching, 1680000.0},
    {"ransac_tests", Stage::kMatching, 2591.0},
    {"rejection_points", Stage::kRejection, 1440.0},
    {"plane_points", Stage::kPlane, 39510.0},
};

const UnitInfo& Info(WorkUnit unit) { return kUnits[static_cast<size_t>(unit)]; }

}  // namespace

const char* ToString(Stage stage) {
  switch (stage) {
    case Stage::kConvert:
      return "convert";
    case Stage::kQuadtree:
      return "quadtree";
    case Stage::kPrediction:
      return "prediction";
    case Stage::kMatching:
      return "matching";
    case Stage::kRejection:
      return "rejection";
    case Stage::kPlane:
      return "plane";
    case Stage::kRanking:
      return "ranking";
  }
  return "unknown";
}

const char* ToString(WorkUnit unit) { return Info(unit).name; }
Stage StageOf(WorkUnit unit) { return Info(unit).stage; }
double WorkUnitInstructions(WorkUnit unit) { return Info(unit).instructions; }

WorkCounts& WorkCounts::operator+=(const WorkCounts& other) {
  for (size_t i = 0; i < units.size(); ++i) units[i] += other.units[i];
  return *this;
}

double WorkCounts::Instructions() const {
  double total = 0.0;
  for (int i = 0; i < kNumWorkUnits; ++i) {
    total += static_cast<double>(units[static_cast<size_t>(i)]) * kUnits[i].instructions;
  }
  return total;
}

double WorkCounts::Instructions(Stage stage) const {
  double total = 0.0;
  for (int i = 0; i < kNumWorkUnits; ++i) {
    if (kUnits[i].stage == stage) total += static_cast<double>(units[static_cast<size_t>(i)]) * kUnits[i].instructions;
  }
  return total;
}

bool UnprojectsIteratively(const std::string& lens_model) {
  for (const char* closed_form : {"LENSMODEL_PINHOLE", "LENSMODEL_STEREOGRAPHIC", "LENSMODEL_LONLAT",
                                  "LENSMODEL_LATLON"}) {
    if (lens_model == closed_form) return false;
  }
  return true;
}

std::int64_t RansacHypotheses(int points, int inliers, double confidence, int max_iterations) {
  constexpr int kSample = 5;
  if (points < kSample || max_iterations < 1) return 0;
  const double inlier_share = std::clamp(static_cast<double>(inliers) / points, 0.0, 1.0);
  const double miss = std::log(std::max(1.0 - std::clamp(confidence, 0.0, 1.0), std::numeric_limits<double>::min()));
  const double all_inliers = std::pow(inlier_share, kSample);
  const double fail = 1.0 - all_inliers;
  if (fail < std::numeric_limits<double>::min()) return 1;  // every point an inlier: one draw suffices
  const double per_draw = std::log(fail);
  if (per_draw >= 0.0 || -miss >= max_iterations * -per_draw) return max_iterations;
  return std::max<std::int64_t>(1, std::llround(miss / per_draw));
}

}  // namespace hdabench::hda
