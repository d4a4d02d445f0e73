// The sensor-fault study (docs/faults.md): the flight method on one pair of a
// dataset, clean and under each fault of datasets/faults.h at a sweep of
// magnitudes, judged against the dataset's truth and against the clean run:
// per case the share of ROIs evaluated, the slope error (median, 90th
// percentile, share within 2 predicted sigmas), how far the slopes moved from
// the clean run's, and the smallest magnitude at which each metric misses its
// requirement.
//
// Deterministic: the flight method's budget counts work, not time, and runs
// unlimited unless one is given (every ROI is studied); the only random
// numbers (kLrfNoise) come from the seed.
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "datasets/dataset.h"
#include "datasets/faults.h"
#include "reference/flight/flight_outputs.h"
#include "reference/flight/hda_params.h"

namespace hdabench::reference {

// What a case must show to meet the requirements. The slope ones are the
// gate's bar for the flight method (gate/thresholds-lateral.json); the two
// others are the bench's: at least half the ROIs with a slope the method
// stands by, and at least half as many ROIs as the clean run found (a fault
// must not shrink the search for sites unseen).
struct FaultRequirements {
  double max_median_deg = 1.0;
  double max_p90_deg = 3.0;
  double min_within_two_sigma = 0.8;
  double min_evaluated_share = 0.5;
  double min_rois_vs_clean = 0.5;

  // Every violated constraint, one message each, named by the faults
  // command's flags ("--max-median-deg = nan: expected finite and > 0"): the
  // slope limits finite and > 0, the shares and the fraction in [0, 1].
  std::vector<std::string> Validate() const;
};

// One case: the clean run (no fault) or one fault at one magnitude.
struct FaultCase {
  std::optional<datasets::Fault> fault;  // nothing: the clean run
  std::string label;                     // "clean", "lrf-scale=0.05"
  bool applied = true;                   // false: the fault does not apply to this dataset (the LRF log
                                         // does not reach back far enough, ...): not a result of the method
  bool ran = false;                      // false: no result (not applied, or the flight method gave none)
  std::string error;                     // when not ran: why (ApplyFault's or the method's own message)
  std::string range_source;              // when ran: "lrf" or "navigation" (reference::RangeSource)
  int rois = 0;                          // ROIs the quadtree found
  int with_slope = 0;                    // of those, with a slope the method stands by (hda::HasSlope)
  double evaluated_share = 0.0;          // with_slope / rois (0 without ROIs)
  double rois_vs_clean = 1.0;            // rois / the clean run's rois (1: the clean run, or one without ROIs)
  SlopeErrorStats stats;                 // against the truth (count 0: no ROI with truth)
  // Slopes against the clean run's, over the ROIs with the same box in image 1
  // and a slope in both: |faulted - clean|, degrees.
  int moved_count = 0;
  double moved_median_deg = 0.0;
  double moved_max_deg = 0.0;
  // The landing decisions against the lander's truth (decision_statistics.h),
  // and the sites (same box in image 1) that are false-safe under the fault
  // but were not in the clean run: the confident wrong decisions it made.
  DecisionPool decision;
  int new_false_safe = 0;
};

// Whether a case meets each requirement: a case without a result meets none;
// one without slope statistics meets only what it can show (the share).
struct FaultVerdicts {
  bool median = false;
  bool p90 = false;
  bool within = false;
  bool evaluated = false;
  bool rois = false;
  bool All() const { return median && p90 && within && evaluated && rois; }
};
FaultVerdicts VerdictsOf(const FaultCase& c, const FaultRequirements& requirements);

// Per fault and sign of its magnitude, the smallest |magnitude| of the sweep
// at which a metric misses its requirement (over the cases the fault applied
// to).
struct FaultCrossing {
  std::string fault;  // catalogue name
  int sign = 1;       // +1 or -1: which side of zero the magnitudes lie
  double largest_swept = 0.0;  // the largest |magnitude| swept on that side
  // The first failing magnitude (signed) per metric; nothing: met up to largest_swept.
  std::optional<double> median, p90, within, evaluated, rois;
};

struct FaultStudy {
  std::string dataset_name;
  int frame1 = 0;
  int frame2 = 1;
  std::uint64_t seed = 1;
  FaultRequirements requirements;
  std::vector<FaultCase> cases;  // the clean run first, then the faults in the order given
  std::vector<FaultCrossing> crossings;
};

// Runs the study on frames (frame1, frame2) of `dataset` (loaded with the
// pair's images and truth). `faults` in the order the cases are run and
// listed; `progress` (may be empty) gets one line per case. Throws InputError
// when the clean run itself fails (the faults could not be judged); a fault
// case that fails is recorded with its reason.
FaultStudy RunFaultStudy(const datasets::Dataset& dataset, int frame1, int frame2, const HdaSettings& settings,
                         const std::vector<datasets::Fault>& faults, const FaultRequirements& requirements,
                         std::uint64_t seed, const std::function<void(const std::string&)>& progress);

// Every fault of the catalogue at its default sweep (FaultInfo::sweep).
std::vector<datasets::Fault> DefaultFaultSweep();

// The study's files: faults.csv (one row per case), faults.json (cases,
// crossings, requirements; docs/faults.md) and faults.md (the table and the
// crossings, as printed).
std::string FaultStudyCsv(const FaultStudy& study);
std::string FaultStudyJson(const FaultStudy& study);
std::string FaultStudyMarkdown(const FaultStudy& study);

// Draws DIR/faults.png from DIR/faults.json (faults_plots.py: per fault with
// a magnitude, the slope error median and p90 and the shares with a slope and
// within 2 sigma against the magnitude, requirements dotted) with `python` (a
// path or a name looked up in PATH). Returns "" when drawn, else why not.
std::string WriteFaultPlots(const std::string& dir, const std::string& python);

// The text of faults_plots.py, compiled in.
const std::string& FaultsPlotsScript();

}  // namespace hdabench::reference
