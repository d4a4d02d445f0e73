// The observability study of the NOVA-C paper ("Trajectory design"): a Monte
// Carlo of the slope error against the baseline between the two images, for
// motion across the line of sight at constant altitude (lateral), toward the
// site at constant altitude (forward, the paper's approach: the camera pitched
// to keep the site in view) and along the optical axis (boresight), at several
// pixel noises and numbers of points
// (docs/observability.md).
//
// One trial: a site (a plane of drawn slope and azimuth through the ILS, plus
// Gaussian small-scale relief) with feature points drawn uniformly over it;
// camera 1 at `altitude_m` above and `downrange_m` short of the ILS, looking
// at it, camera 2 moved by the baseline (east for lateral, north toward the
// site for forward, along the optical axis for boresight), same attitude; the points projected through the
// camera model into both images with Gaussian pixel noise; the navigation's
// relative pose and camera 1's attitude perturbed by the nav noise, the LRF
// range by its noise; then the flight method's own steps after matching
// (hda::EvaluateMatchedSite: nav epipolar test, triangulation, depth test,
// plane fit, predicted slope sigma, status). The slope error is the method's
// slope minus the truth's (the plane fitted to the true points, the bench's
// truth definition).
//
// Determinism: every trial's random numbers come from (seed, the setting's
// values, the trial index) alone, so results do not depend on the thread
// count, on the order of the settings, or on how the study is split into
// shards (a shard takes every setting whose index is congruent to k - 1
// modulo n, whole).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "calib/camera_model.h"
#include "hda/hda_options.h"
#include "reference/flight/hda_params.h"
#include "tools/util/parallel_for.h"

namespace hdabench::reference {

// The values are part of each trial's seed: a new geometry goes at the end.
enum class StudyGeometry { kLateral, kBoresight, kForward };
const char* ToString(StudyGeometry geometry);  // "lateral", "boresight", "forward"
// The inverse; throws InputError listing the names.
StudyGeometry ParseStudyGeometry(const std::string& name);

// The most trials per setting a study takes: each setting's errors are kept
// in memory to rank them (percentiles).
inline constexpr int kMaxStudyTrials = 10000000;

struct StudyOptions {
  std::vector<StudyGeometry> geometries = {StudyGeometry::kLateral, StudyGeometry::kForward,
                                           StudyGeometry::kBoresight};
  std::vector<double> baselines_m;          // distance between the two camera centres, metres
  std::vector<double> pixel_noises_px = {0.05, 0.1, 0.25, 0.5};  // per axis, per image, 1 sigma
  std::vector<int> points = {50};           // feature points drawn on each site
  int trials = 1000;                        // per setting, in [1, kMaxStudyTrials]
  double altitude_m = 400.0;                // camera 1 above the ILS
  double downrange_m = 400.0;               // camera 1 short of the ILS, horizontally
  double site_size_m = 10.0;                // side of the square site
  double min_slope_deg = 4.0;               // drawn site slopes, uniform in [min, max]
  double max_slope_deg = 12.0;
  double relief_sigma_m = 0.02;             // small-scale relief off the plane, 1 sigma
  double nav_position_sigma_m = 0.25;       // relative translation error per axis, 1 sigma
  double nav_attitude_sigma_deg = 0.02;     // relative rotation and camera 1 attitude, per axis, 1 sigma
  double lrf_sigma_m = 1.0;                 // LRF range error, 1 sigma
  double requirement_deg = 2.0;             // the slope requirement the baselines are judged by
  std::uint64_t seed = 1;
  hda::HdaOptions hda;                      // the flight method's options

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// The flight method's options for a study: `settings` (a params file and
// --set), the lengths not given following the slant range and the largest
// baseline as in `run` (docs/flight-parameters.md), and the nav and LRF sigmas
// the method assumes, when not given, following the study's noise. Sets
// options->hda.
void ResolveStudyHdaOptions(const HdaSettings& settings, const calib::CameraModel& camera, StudyOptions* options);

// One point of the sweep.
struct StudySetting {
  int index = 0;  // position in the study's order: geometry, points, pixel noise, baseline (innermost)
  StudyGeometry geometry = StudyGeometry::kLateral;
  int points = 0;
  double pixel_noise_px = 0.0;
  double baseline_m = 0.0;
};

// Every setting, in the study's order.
std::vector<StudySetting> StudySettings(const StudyOptions& options);

// One trial's outcome.
struct TrialResult {
  bool has_fit = false;          // the method fitted a plane (any status with a fit)
  bool has_slope = false;        // and stands by its slope (hda::HasSlope)
  double error_deg = 0.0;        // method's slope - true slope (with a fit)
  double sigma_deg = 0.0;        // the method's predicted 1-sigma (with a fit)
  double true_slope_deg = 0.0;
};

// Runs trial `trial` of `setting` (deterministic, as the header says). Throws
// InputError when the geometry is unusable (the site out of camera 1's view).
TrialResult RunTrial(const StudyOptions& options, const calib::CameraModel& camera, const StudySetting& setting,
                     int trial);

// A setting's statistics. Quantiles count a trial without a fit as an
// infinite error (a site the method could not judge misses the requirement);
// mean, standard deviation and the sigma figures are over trials with a fit.
struct SettingStats {
  StudySetting setting;
  int trials = 0;
  int fits = 0;
  int with_slope = 0;
  double median_abs_error_deg = 0.0;
  double p90_abs_error_deg = 0.0;
  double p95_abs_error_deg = 0.0;
  double mean_abs_error_deg = 0.0;
  double sd_error_deg = 0.0;        // standard deviation of the signed error: the Monte Carlo sigma
  double rms_sigma_deg = 0.0;       // RMS of the predicted sigmas
  double within_2_sigma = 0.0;      // share of fits with |error| <= 2 predicted sigmas
  bool MeetsRequirement(double requirement_deg) const { return p95_abs_error_deg <= requirement_deg; }
};

// Runs every trial of `setting` on `threads` threads.
SettingStats RunSetting(const StudyOptions& options, const calib::CameraModel& camera, const StudySetting& setting,
                        int threads);

// settings.csv: the header line, and one line per setting (shortest
// round-trip numbers, "inf" for an infinite quantile), so shards' lines merge
// as they are.
std::string SettingsCsvHeader();
std::string SettingsCsvRow(const SettingStats& stats);
// Reads rows back (the header checked); throws InputError "path:line: ...".
std::vector<SettingStats> ParseSettingsCsv(const std::string& text, const std::string& path);

// Per geometry, points and pixel noise: the smallest baseline whose p95 meets
// the requirement (none when no baseline does), and at that baseline the other
// geometries' p95.
struct BaselineVerdict {
  StudyGeometry geometry = StudyGeometry::kLateral;
  int points = 0;
  double pixel_noise_px = 0.0;
  bool met = false;
  double baseline_m = 0.0;
  double p95_abs_error_deg = 0.0;
  std::vector<std::pair<StudyGeometry, double>> others_p95_deg;  // the other geometries at that baseline
};
std::vector<BaselineVerdict> SmallestBaselines(const std::vector<SettingStats>& stats, double requirement_deg);
std::string BaselinesCsv(const std::vector<BaselineVerdict>& verdicts);

// ---------------------------------------------------------------------------
// A study on disk (docs/observability.md): study.json (the options, the
// camera, the shard), settings.csv (one row per setting the run computed) and,
// for a whole study (one run, or shards merged), baselines.csv.

// A study's shard: the settings whose index is congruent to k - 1 modulo n.
using StudyShard = util::Shard;
// study.json's text: everything that decides the numbers, and the shard.
std::string StudyJsonText(const StudyOptions& options, const calib::CameraModel& camera, const StudyShard& shard);

// Runs the shard's settings in the study's order; `progress` (may be empty)
// gets each setting's statistics as it finishes.
std::vector<SettingStats> RunStudy(const StudyOptions& options, const calib::CameraModel& camera,
                                   const StudyShard& shard, int threads,
                                   const std::function<void(const SettingStats&, int done, int total)>& progress);

// Writes study.json and settings.csv into `dir` (created), and for a whole
// study baselines.csv; returns the files written (relative names).
std::vector<std::string> WriteStudyFolder(const std::string& dir, const std::string& study_json_text,
                                          const std::vector<SettingStats>& stats, bool whole,
                                          double requirement_deg);

// Shards of one study merged: their study.json must agree but for the shard,
// their shards be 1..n once each and their settings cover the study once.
// Throws InputError naming the folder and what is wrong.
struct MergedStudy {
  std::string study_json_text;  // the whole study's (shard 1/1)
  double requirement_deg = 0.0;
  std::vector<SettingStats> stats;  // every setting, in order
};
MergedStudy MergeStudyFolders(const std::vector<std::string>& dirs);

// The plotting script (observability_plots.py, compiled in).
const std::string& ObservabilityPlotsScript();
// Draws a whole study's figures into dir/figures (slope_error_vs_baseline.png,
// sigma_check.png) with `python` (a path or a name looked up in PATH).
// Returns "" when drawn, else why not (Python or matplotlib missing, the
// script failing: its last line); the study's files are untouched either way.
std::string WriteStudyPlots(const std::string& dir, const std::string& python);

}  // namespace hdabench::reference
