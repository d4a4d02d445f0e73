// Which slopes count, and their statistics: the one rule that `run`,
// `compare`, the report (and the plots it hands to Python) and the gate
// apply to every method (docs/flight-results.md, docs/compare-results.md).
//
// An ROI's slope counts when
//   - the method stands by it (StatusHasSlope: the flight method's
//     "evaluated", "unsafe slope", "unsafe roughness"; every reference's
//     "ok"; a degenerate ROI's plane is a diagnostic, never a slope),
//   - the ROI has a truth, so that the error is finite, and
//   - the fit has at least kMinPointsForSlopeStats points.
// Over those ROIs: |slope error| (median, p90, max), the tilt error, the
// signed bias, the roughness error where both sides have one, the share
// with |error| <= 2 predicted sigmas (WithinTwoSigma), and, where the method's
// own support has a truth, the tilt error's definition and estimation parts.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hdabench::reference {

// ROIs with fewer points than this are left out of the slope error statistics
// (the paper's table lists ROIs down to 15 points; its two largest errors are
// both 15-point ROIs).
inline constexpr int kMinPointsForSlopeStats = 20;

// The flight method's name in every record (compare.json, the gate's metrics).
inline constexpr char kMethodFlight[] = "flight";

// Whether a method stands by the slope of an ROI with this status (the
// records' status names): for the flight method (is_flight) "evaluated",
// "unsafe slope" and "unsafe roughness" (hda::HasSlope), for every other
// method "ok".
bool StatusHasSlope(bool is_flight, const std::string& status);

// |error| <= 2 sigma; false where the sigma is not finite (none predicted).
bool WithinTwoSigma(double abs_error, double sigma);

// Statistics of absolute errors (degrees for slopes, metres for roughness):
// quantiles linear between order statistics (util::Quantile). Non-finite
// values are left out; all zero when none is left.
struct ErrorStats {
  int count = 0;
  double median = 0.0;
  double p90 = 0.0;
  double max = 0.0;
};
ErrorStats ComputeErrorStats(std::vector<double> values);

// One method's slope on one ROI, as the statistics see it. NaN where a value
// does not apply (no truth, no roughness, no predicted sigma).
struct SlopeSample {
  bool has_slope = false;  // the method stands by it (StatusHasSlope and a fitted plane)
  int num_points = 0;
  double error_deg = std::numeric_limits<double>::quiet_NaN();            // slope - truth, signed
  double tilt_error_deg = std::numeric_limits<double>::quiet_NaN();       // angle to the true plane
  double roughness_error_m = std::numeric_limits<double>::quiet_NaN();    // |roughness - truth's|
  double sigma_deg = std::numeric_limits<double>::quiet_NaN();            // predicted slope sigma
  // The error taken apart against the truth of the method's own support (its
  // own truth): the definition part, own truth against the site's truth, and
  // the estimation part, the method against its own truth. NaN without an
  // own truth.
  double definition_tilt_deg = std::numeric_limits<double>::quiet_NaN();
  double estimation_tilt_deg = std::numeric_limits<double>::quiet_NaN();
  double definition_error_deg = std::numeric_limits<double>::quiet_NaN();  // own truth's slope - truth, signed
  double estimation_error_deg = std::numeric_limits<double>::quiet_NaN();  // slope - own truth's, signed
  // The rule of the file comment: has_slope, a finite error and enough points.
  bool Counts() const;
};

// The records' readers share these. A record's number, NaN where it is null
// or absent (a value that does not apply); a record's member, null where it
// is absent or the record is no object.
namespace slope_records {
double NumberOrNaN(const nlohmann::json& object, const char* key);
const nlohmann::json& Member(const nlohmann::json& object, const char* key);
}  // namespace slope_records

// One ROI's method entry of compare.json ("rois"[i]."methods"[name]) with
// the ROI's "truth", and one ROI of result.json ("rois"[i]), read into a
// sample. Throws nlohmann::json's errors on a record of the wrong shape (the
// callers check their records first or report the error as theirs).
SlopeSample SampleOfCompareRecord(const std::string& method, const nlohmann::json& entry,
                                  const nlohmann::json& truth);
SlopeSample SampleOfFlightRecord(const nlohmann::json& roi);

// The statistics of the samples that count (SlopeSample::Counts).
class SlopeErrorPool {
 public:
  void Add(const SlopeSample& sample);
  int rois() const { return rois_; }                      // every sample added
  int rois_with_slope() const { return rois_with_slope_; }  // those the method stands by
  int count() const { return static_cast<int>(slope_errors_.size()); }  // those that count
  ErrorStats Slope() const { return ComputeErrorStats(slope_errors_); }
  ErrorStats Tilt() const { return ComputeErrorStats(tilt_errors_); }
  ErrorStats Roughness() const { return ComputeErrorStats(roughness_errors_); }
  // The tilt error's parts, over the samples that count and have both
  // (SlopeSample::definition_tilt_deg, estimation_tilt_deg), and the mean of
  // each part's signed slope error (0 when none has them).
  ErrorStats DefinitionTilt() const { return ComputeErrorStats(definition_tilts_); }
  ErrorStats EstimationTilt() const { return ComputeErrorStats(estimation_tilts_); }
  double DefinitionBias() const;
  double EstimationBias() const;
  // Mean of the signed errors; 0 when none counts.
  double Bias() const;
  // Share within two predicted sigmas, of those that count; 0 when none counts.
  double WithinTwoSigmaShare() const;

 private:
  int rois_ = 0;
  int rois_with_slope_ = 0;
  std::vector<double> slope_errors_, tilt_errors_, roughness_errors_;
  std::vector<double> definition_tilts_, estimation_tilts_;
  double signed_sum_ = 0.0;
  double definition_signed_sum_ = 0.0, estimation_signed_sum_ = 0.0;
  int within_two_sigma_ = 0;
};

}  // namespace hdabench::reference
