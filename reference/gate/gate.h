// The merge gate (`hdabench gate`): a checked-in suite of datasets, the
// comparison (reference/compare/compare.h) on each, metrics per method pooled over the
// suite, checked against checked-in thresholds and, optionally, against the
// stored metrics of main (a baseline). Formats and metric definitions:
// docs/gate.md.
//
// Running a suite: every entry's dataset is generated (synthetic) or found,
// then compared; the entry's folder is written under a temporary name and
// renamed into place when complete, with a record of what it was run with. A
// rerun skips every entry whose folder is complete and was run with the same
// settings, so an interrupted gate resumes where it stopped and never trusts a
// half-written entry. Metrics are always computed from the files on disk.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "datasets/faults.h"
#include "reference/compare/compare.h"
#include "reference/flight/hda_params.h"
#include "reference/observability/observability.h"
#include "tools/util/parallel_for.h"

#include "datasets/synth/synth.h"

namespace hdabench::reference {

inline constexpr char kGateSuiteFormatName[] = "hdabench-gate-suite";
inline constexpr char kGateThresholdsFormatName[] = "hdabench-gate-thresholds";
inline constexpr char kGateMetricsFormatName[] = "hdabench-gate-metrics";
inline constexpr int kGateFormatVersion = 1;

// One dataset of the suite.
struct GateEntry {
  std::string name;            // unique, [A-Za-z0-9._-]+: the entry's folder name
  // Exactly one source: a synthetic scene (preset, terrain, seed, overrides,
  // image size as `hdabench synth`), an existing dataset folder (relative to
  // the suite file's folder), or a StereoLunar pair folder (relative to the
  // suite file's folder) with the sun index.
  std::optional<std::string> synth_preset;
  std::string synth_terrain;   // empty: the preset's
  std::uint64_t synth_seed = 1;
  int synth_image_size_px = 0; // 0: the preset's
  std::vector<std::pair<std::string, std::string>> synth_overrides;  // key=value, in order
  std::optional<std::string> dataset_dir;
  std::optional<std::string> stereolunar_pair_dir;
  int stereolunar_sun = 0;
  // Or, instead of a dataset, an observability study (docs/observability.md)
  // through the flight method's triangulation and plane fit: its options as
  // read ("observability": {...}, docs/gate.md), the camera model (relative
  // to the suite file's folder; empty: the synthetic scenes' camera) and the
  // object's text, which the entry's record keeps.
  std::optional<StudyOptions> observability;
  std::string observability_camera;
  std::string observability_spec;
  // The flight method's parameters for this entry: "site_size_m" and the
  // "hda" object (HdaSettings::SetAll); the keys not given follow the
  // geometry, as in compare.
  HdaSettings hda;
  // A sensor fault ("fault": "NAME[=M]", datasets/faults.h) applied in memory
  // to the dataset for its frame pair before the comparison. The entry uses
  // the dataset of the first entry with the same source (made once), and its
  // metrics are pooled apart from the entries without a fault, per fault
  // (GateMetric::fault).
  std::optional<datasets::Fault> fault;
  // A pool of its own ("pool": "NAME"): its metrics are pooled apart from the
  // other entries', with the other entries of that pool (GateMetric::pool),
  // so that scenes of another kind (the steep ground of the landing decision)
  // have thresholds of their own. Empty: the suite's main pool.
  std::string pool;
  // The methods compared on this entry ("methods"); empty: the suite's.
  std::vector<std::string> methods;
};

struct GateSuite {
  std::string file;                      // where it was read from
  std::string description;
  std::vector<std::string> methods;      // compared on every entry (reference::ParseMethodList)
  ColmapSettings colmap;                 // COLMAP's settings for every entry ("colmap": {...})
  // The external method's program for every entry that lists it ("external":
  // {"program", "args", "timeout_s"}; the program's path resolved against the
  // suite's folder when it names a folder).
  ExternalMethodOptions external;
  std::vector<GateEntry> entries;
};

// Reads a suite file (JSON, docs/gate.md). Throws InputError naming the file
// and the field for anything malformed: unknown fields, missing or repeated
// names, an entry with no source or two, unknown methods.
GateSuite ReadGateSuite(const std::string& path);

// One threshold: the metric of a method must stay at or below `max` (or at or
// above `min`). `tolerance` is how far it may move against the baseline before
// the gate calls it a regression (same unit as the metric).
struct GateThreshold {
  std::string method;
  std::string metric;
  std::optional<double> max;
  std::optional<double> min;
  double tolerance = 0.0;
  std::string why;  // where the number comes from (measured value and margin)
  // The pool it checks: empty, the entries without a fault; else the entries
  // under this fault (datasets::FaultLabel, "lrf-scale=0.05"); and of the
  // named pool `pool` (empty: the main one).
  std::string fault;
  std::string pool;
};

struct GateThresholds {
  std::string file;
  std::vector<GateThreshold> thresholds;
};
GateThresholds ReadGateThresholds(const std::string& path);

// The suite's entries named in `names` (`gate --entries`), in the suite's
// order, the rest of the suite as it is. Throws InputError for a name the
// suite does not hold, naming the suite's entries.
GateSuite SelectGateEntries(const GateSuite& suite, const std::vector<std::string>& names);

// The suite with each entry's methods cut to those named in `methods` and the
// flight method, which every comparison runs (`gate --methods`), in the
// entry's order. Throws InputError for a name no entry compares, naming the
// methods the suite compares.
GateSuite SelectGateMethods(const GateSuite& suite, const std::vector<std::string>& methods);

// Whether an entry of `suite` gives the pool a threshold checks: a method of
// an entry with the threshold's fault and pool (an observability entry's
// metrics are the flight method's, on the main pool). A threshold of a pool no
// entry gives is not checked when the suite is a selection of entries.
bool SuiteGivesThresholdPool(const GateSuite& suite, const GateThreshold& threshold);

// The metrics, per method (docs/gate.md):
//   slope_error_median_deg, slope_error_p90_deg, slope_error_max_deg
//       |slope - truth| over the suite's ROIs with a slope, truth and at least
//       kMinPointsForSlopeStats points
//   roughness_error_median_m    |roughness rms - truth rms| over the same ROIs
//   rois_with_slope_share       ROIs with a slope (flight: evaluated, unsafe
//                               slope or unsafe roughness; others: ok) / all ROIs
//   within_two_sigma_share      flight: share of the slope-error ROIs with
//                               |error| <= 2 predicted sigmas
//   flight_seconds_per_pair     flight: the largest time of an entry on the
//                               flight computer, predicted from the counted work
//                               (compare_timings.json's flight_computer_s)
//   failed_entries              entries where the method failed for the run
//   slope_error_rois            how many ROIs the slope errors are over
//   observability_p95_deg       flight: the largest p95 of |slope error| over
//                               the settings of the suite's observability
//                               entries; a setting where more than 5 % of
//                               the trials have no plane counts as 90 deg
//   observability_median_deg    flight: the largest median, alike
//   observability_sigma_ratio   flight: the largest ratio between the Monte
//                               Carlo standard deviation and the RMS predicted
//                               sigma, either way up (>= 1; 1 is agreement)
//   decision_sites              sites with a lander truth (decision_statistics.h)
//   truly_unsafe_share          of those, the share the lander's truth calls unsafe
//   false_safe_rate             truly unsafe among the sites the method declares safe
//   false_safe_upper_95         its Wilson 95 % upper bound
//   missed_safe_rate            declared unsafe among the truly safe sites with a verdict
//   unsafe_caught_rate          declared unsafe among the truly unsafe sites with a verdict
//   top_site_unsafe_share       flight: the share of entries whose top-ranked site is unsafe
//   calibration_sigma_share_p90 flight: p90 over the ROIs with a slope and a calibration term
//                               of slope_sigma_calibration_deg / slope_sigma_deg (absent
//                               when no dataset's model carries its calibration)
// A metric without data (no ROI with truth, say) is absent. The entries with
// a fault are pooled per method and fault (GateEntry::fault), apart from the
// others, and those of a named pool per pool (GateEntry::pool).
struct GateMetric {
  std::string method;
  std::string metric;
  double value = 0.0;
  std::string fault;  // the pool: empty, the entries without a fault; else the fault's label
  std::string pool;   // and the named pool (GateEntry::pool); empty: the main one
};
std::vector<std::string> GateMetricNames();

// One entry's results on disk (its compare.json and compare_timings.json, or
// an observability entry's settings.csv; its fault from gate_entry.json).
std::vector<GateMetric> ComputeGateMetrics(const std::vector<std::string>& entry_dirs);

// The verdict of one threshold.
struct GateCheck {
  GateThreshold threshold;
  bool has_value = false;       // false: the metric has no data in this run (a failure)
  double value = 0.0;
  bool passed = false;
  double margin = 0.0;          // how far inside the threshold (negative: outside), metric units
  bool has_baseline = false;
  double baseline = 0.0;
  bool regressed = false;       // worse than the baseline by more than the tolerance
  std::string Summary() const;  // one line: "flight slope_error_p90_deg = 5.2 > 4.0 (threshold)",
                                // "flight under lrf-absent slope_error_p90_deg = ..." for a fault's pool
};
std::vector<GateCheck> CheckGate(const std::vector<GateMetric>& metrics,
                                 const GateThresholds& thresholds,
                                 const std::vector<GateMetric>* baseline);

// Metrics as JSON (the baseline format) and back.
std::string GateMetricsJson(const std::vector<GateMetric>& metrics);
std::vector<GateMetric> ReadGateMetrics(const std::string& path);

// The table of every check: method, metric, value, threshold, margin,
// baseline, verdict. Markdown.
std::string GateTable(const std::vector<GateCheck>& checks);

// gate.html: one self-contained page with the table of every check (failing
// rows marked) and the suite's entries, each linked to its own report
// (entries/<name>/report.html) or with the reason it failed.
struct GateEntryOutcome;
std::string GateHtml(const std::string& suite_file, const std::vector<GateCheck>& checks,
                     const std::vector<GateEntryOutcome>& outcomes);

struct GateRunOptions {
  std::string out_dir;
  int jobs = 2;                       // entries run at once (>= 1)
  int synth_threads = 1;              // threads of each synthetic scene (the output does not depend on it)
  double fault_match_noise_px = 0.0;  // passed to the flight method (tests of the gate only)
  std::string colmap_executable = "colmap";
  util::Shard shard;                  // the entries to run: entry i when shard.Holds(i)
  // The build the cached datasets and entries must come from: a dataset or
  // entry folder made by another is made again. Empty: the running program's
  // (util::BuildIdentity).
  std::string build_identity;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

struct GateEntryOutcome {
  std::string name;
  std::string dir;        // the entry's complete folder (empty when it failed)
  bool reused = false;    // complete from an earlier run with the same settings
  bool ok = false;
  std::string error;      // when not ok: why (one line)
  double wall_s = 0.0;
  std::string page;       // the entry's page, relative to its folder: report.html or settings.csv
};

using GateProgress = std::function<void(const std::string& line)>;

// Runs every entry of the suite that the shard holds (in parallel, `jobs` at
// a time), skipping the complete ones; returns their outcomes in the suite's
// order. An entry that cannot be run (a dataset that cannot be made or
// loaded) is reported, not thrown; the others still run.
std::vector<GateEntryOutcome> RunGateSuite(const GateSuite& suite, const GateRunOptions& options,
                                           const GateProgress& progress);

// ---------------------------------------------------------------------------
// Shards (docs/gate.md): `gate --shard K/N` runs the entries the shard holds
// into its own folder and records their outcomes in gate_shard.json; `gate
// merge` gathers the shards' entries into one folder, from which the metrics,
// the table and the verdict are those of the whole suite run on one machine.

inline constexpr char kGateShardFileName[] = "gate_shard.json";

// gate_shard.json's text: the suite (its file's FNV-1a digest, so shards of
// another suite are refused), the shard and its entries' outcomes.
std::string GateShardJson(const GateSuite& suite, const util::Shard& shard,
                          const std::vector<GateEntryOutcome>& outcomes);

// Reads every shard folder's gate_shard.json, checks that they are the shards
// 1..n of this suite once each, and copies each complete entry into
// out_dir/entries (hard links where the file system allows; a shard folder
// that is out_dir itself is left as it is). Returns every entry's outcome in
// the suite's order, with its folder under out_dir. Throws InputError naming
// the folder and what is wrong (a shard missing or repeated, another suite, an
// entry recorded complete without its folder).
std::vector<GateEntryOutcome> MergeGateShards(const GateSuite& suite, const std::vector<std::string>& shard_dirs,
                                              const std::string& out_dir);

}  // namespace hdabench::reference
