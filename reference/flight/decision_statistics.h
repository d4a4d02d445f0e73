// The landing decision scored against the lander's truth: the one rule that
// `run`, `compare`, the report and the gate apply to every method
// (docs/flight-results.md, "The landing decision").
//
// What a method declares of a site (DeclaredVerdict):
//   - the flight method, by its status: "evaluated" is safe, "unsafe slope"
//     and "unsafe roughness" unsafe, every other status no verdict;
//   - every reference, by its slope alone, with the flight method's slope
//     limit: a slope it stands by (StatusHasSlope) over the limit is unsafe,
//     one at or under it safe, no slope no verdict. A reference's roughness is
//     that of its points, noise and all (none has the flight method's noise
//     correction), so it says nothing of a hazard and is not used.
// What the site is: the lander's truth at the site's centre
// (datasets/synth/lander_truth.h). A site without one (no truth DEM, or a
// footprint off it) is left out and counted apart.
//
// Over the sites: the confusion matrix (declared safe / unsafe / no verdict
// against truly safe / unsafe), the false-safe rate (truly unsafe among the
// sites declared safe) with its Wilson 95 % interval, the missed-safe rate
// (declared unsafe among the truly safe sites with a verdict), the unsafe-
// caught rate (declared unsafe among the truly unsafe sites with a verdict),
// the share of
// runs whose top-ranked site is unsafe and whose top k hold an unsafe one
// (ranked methods only), the share decided wrongly by the lander's true slope
// in 1-deg bins, and the share of clearance hazards declared unsafe by the
// height of the tallest rock in the site.
#pragma once

#include <array>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "reference/flight/flight_run.h"

namespace hdabench::reference {

enum class Verdict { kSafe, kUnsafe, kNone };
const char* ToString(Verdict verdict);  // "safe", "unsafe", "no verdict"

// What a method declares of a site with this status (the records' names) and
// slope (NaN: none), under the flight method's slope limit (file comment).
Verdict DeclaredVerdict(bool is_flight, const std::string& status, double slope_deg, double max_slope_deg);

// One method's decision on one site, and the site's truth.
struct DecisionSample {
  Verdict declared = Verdict::kNone;
  bool has_truth = false;  // the lander's truth is defined there
  bool truly_safe = false;
  bool unsafe_by_slope = false;
  bool unsafe_by_clearance = false;
  double true_slope_deg = std::numeric_limits<double>::quiet_NaN();  // the lander's slope
  double rock_height_m = std::numeric_limits<double>::quiet_NaN();   // tallest rock in the site; 0 none
  int rank = 0;  // 1: the method's best site; 0: not ranked (every reference)
};

// A site's truth in the records ("truth"."landing"): defined, and then safe,
// unsafe_by_slope, unsafe_by_clearance, slope_deg, clearance_m, yaw_deg; or
// why not.
nlohmann::ordered_json LandingJson(const datasets::synth::LandingVerdict& landing);

// One method's decision on an ROI in memory: what it declared, the ROI's
// truth (nullptr: none) and its rank (0: none). The records' readers below
// give the same sample from the files.
DecisionSample DecisionOfRoi(Verdict declared, const RoiTruthValue* truth, int rank);

// The site's truth from a record's "truth" object (result.json's or
// compare.json's "rois"[i]."truth": its "landing" and "max_rock_height_m").
void ReadDecisionTruth(const nlohmann::json& truth, DecisionSample* sample);

// One method's entry of compare.json ("rois"[i]."methods"[name]) on its ROI
// record ("rois"[i]: its "truth" and the flight method's "rank"), and one ROI
// of result.json, read into a sample. Throw nlohmann::json's errors on a
// record of the wrong shape, as SampleOfCompareRecord does.
DecisionSample DecisionOfCompareRecord(const std::string& method, const nlohmann::json& entry,
                                       const nlohmann::json& roi_record, double max_slope_deg);
DecisionSample DecisionOfFlightRecord(const nlohmann::json& roi);

// A share's Wilson score interval at 95 % (z = 1.96); [0, 1] when n is 0.
struct Interval {
  double low = 0.0;
  double high = 1.0;
};
Interval WilsonInterval(int successes, int n);

// Sites counted in the 1-deg bins of DecisionPool::SlopeBins and the rock
// height bins of DecisionPool::RockBins.
struct DecisionBin {
  double low = 0.0;   // bin [low, high)
  double high = 0.0;
  int sites = 0;
  int hits = 0;  // SlopeBins: decided wrongly; RockBins: declared unsafe
};

class DecisionPool {
 public:
  // The sites of one run (one pair), ranks as the method gave them.
  void AddRun(const std::vector<DecisionSample>& samples);

  int sites() const { return sites_; }                  // with a truth
  int sites_without_truth() const { return without_truth_; }
  int truly_unsafe() const { return truly_unsafe_; }
  int truly_unsafe_by_slope() const { return by_slope_; }
  int truly_unsafe_by_clearance() const { return by_clearance_; }
  // Sites with a truth declared `declared` that are truly safe (or not).
  int Count(Verdict declared, bool truly_safe) const {
    return counts_[static_cast<size_t>(declared)][truly_safe ? 0 : 1];
  }
  int DeclaredSafe() const { return Count(Verdict::kSafe, true) + Count(Verdict::kSafe, false); }
  // Truly unsafe among those declared safe; NaN when none is declared safe.
  double FalseSafeRate() const;
  Interval FalseSafeInterval() const;
  // Declared unsafe among the truly safe sites with a verdict; NaN when none.
  double MissedSafeRate() const;
  // Declared unsafe among the truly unsafe sites with a verdict: how many of
  // the hazards the method catches; NaN when none.
  double UnsafeCaughtRate() const;
  // Runs with a top-ranked site (with a truth), and the share of them whose
  // top site is unsafe; NaN when none.
  int ranked_runs() const { return ranked_runs_; }
  double TopSiteUnsafeShare() const;
  // The share of runs whose k best sites (with a truth) hold an unsafe one.
  double TopKUnsafeShare() const;
  static constexpr int kTopK = 3;
  // Sites with a verdict and a truth by the lander's true slope, [6, 14) deg
  // in 1-deg bins: how many were decided wrongly.
  const std::vector<DecisionBin>& SlopeBins() const { return slope_bins_; }
  // Sites truly unsafe by clearance with a verdict, by the tallest rock's
  // height: how many were declared unsafe.
  const std::vector<DecisionBin>& RockBins() const { return rock_bins_; }

  DecisionPool();

 private:
  int sites_ = 0, without_truth_ = 0, truly_unsafe_ = 0, by_slope_ = 0, by_clearance_ = 0;
  std::array<std::array<int, 2>, 3> counts_{};
  int ranked_runs_ = 0, top_unsafe_runs_ = 0, top_k_unsafe_runs_ = 0;
  std::vector<DecisionBin> slope_bins_, rock_bins_;
};

// The pool's figures as JSON (result.json's and compare.json's "decision"):
// sites, the confusion matrix, the rates (null where NaN) and the bins.
nlohmann::ordered_json DecisionJson(const DecisionPool& pool);

// The probability rule (hda::HdaOptions::decide_on_probability) applied to a
// site of the flight method: safe when its probability of safety reaches
// min_probability, unsafe under it, no verdict without one (NaN).
Verdict ProbabilityVerdict(double probability_safe, double min_probability);

// How often the sites given a probability of safety are truly safe (the
// lander's truth): the sites with both, in bins of the probability, and
// those at or over a stated probability with a Wilson interval. A
// probability is honest when the truly safe share in each bin lies within
// the bin.
class SafetyCalibration {
 public:
  explicit SafetyCalibration(double called_at = 0.9);
  void Add(double probability_safe, const DecisionSample& sample);  // skipped without both

  struct Bin {
    double low = 0.0;   // [low, high); the last bin holds 1
    double high = 0.0;
    int sites = 0;
    int truly_safe = 0;
    double probability_sum = 0.0;  // for the bin's mean probability
  };
  const std::vector<Bin>& bins() const { return bins_; }
  double called_at() const { return called_at_; }
  int called_safe() const { return called_safe_; }          // sites with probability >= called_at
  int called_truly_safe() const { return called_truly_safe_; }

 private:
  double called_at_;
  std::vector<Bin> bins_;
  int called_safe_ = 0, called_truly_safe_ = 0;
};

// As JSON: "called_at", "called_safe", "called_truly_safe",
// "called_truly_safe_share" and its "_95" Wilson interval (null without a
// site), and "bins" (low, high, sites, truly_safe, mean_probability).
nlohmann::ordered_json SafetyCalibrationJson(const SafetyCalibration& calibration);

// "sites called >= 90 % safe: K, truly safe T (S % [lo, hi])".
std::string SafetyCalibrationLine(const SafetyCalibration& calibration);

// One line: "decision (N sites with a lander truth, U truly unsafe: S by
// slope, C by clearance): declared safe A (false-safe F % [lo, hi]), ...".
std::string DecisionLine(const DecisionPool& pool);

}  // namespace hdabench::reference
