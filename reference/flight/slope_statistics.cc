#include "reference/flight/slope_statistics.h"

#include <algorithm>
#include <cmath>

#include "hda/calibration_sigma.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

namespace slope_records {

using Json = nlohmann::json;

double NumberOrNaN(const Json& object, const char* key) {
  constexpr double kNoValue = std::numeric_limits<double>::quiet_NaN();
  if (!object.is_object()) return kNoValue;
  const auto it = object.find(key);
  return it != object.end() && it->is_number() ? it->get<double>() : kNoValue;
}

const Json& Member(const Json& object, const char* key) {
  static const Json null;
  if (!object.is_object()) return null;
  const auto it = object.find(key);
  return it == object.end() ? null : *it;
}

}  // namespace slope_records

bool StatusHasSlope(bool is_flight, const std::string& status) {
  if (is_flight) return status == "evaluated" || status == "unsafe slope" || status == "unsafe roughness";
  return status == "ok";
}

bool WithinTwoSigma(double abs_error, double sigma) { return std::isfinite(sigma) && abs_error <= 2.0 * sigma; }

ErrorStats ComputeErrorStats(std::vector<double> values) {
  ErrorStats stats;
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return !std::isfinite(v); }),
               values.end());
  if (values.empty()) return stats;
  std::sort(values.begin(), values.end());
  stats.count = static_cast<int>(values.size());
  stats.median = util::Quantile(values, 0.5);
  stats.p90 = util::Quantile(values, 0.9);
  stats.max = values.back();
  return stats;
}

bool SlopeSample::Counts() const {
  return has_slope && std::isfinite(error_deg) && num_points >= kMinPointsForSlopeStats;
}

SlopeSample SampleOfCompareRecord(const std::string& method, const nlohmann::json& entry,
                                  const nlohmann::json& truth) {
  SlopeSample s;
  const double slope = slope_records::NumberOrNaN(entry, "slope_deg");
  s.has_slope =
      std::isfinite(slope) && StatusHasSlope(method == kMethodFlight, entry.at("status").get<std::string>());
  s.num_points = entry.at("num_points").get<int>();
  if (truth.is_object()) {
    // The record's own difference (the in-memory values' difference, printed
    // to read back exactly); slope - truth for a record without it.
    s.error_deg = entry.contains("slope_error_deg") ? slope_records::NumberOrNaN(entry, "slope_error_deg")
                                                    : slope - slope_records::NumberOrNaN(truth, "slope_deg");
    s.roughness_error_m = std::abs(slope_records::NumberOrNaN(entry, "roughness_rms_m") -
                                   slope_records::NumberOrNaN(truth, "roughness_rms_m"));
  }
  s.tilt_error_deg = slope_records::NumberOrNaN(entry, "tilt_error_deg");
  // The flight method's sigma with the calibration's term in quadrature,
  // where the record has one.
  s.sigma_deg = hda::CombinedSlopeSigmaDeg(slope_records::NumberOrNaN(entry, "slope_sigma_deg"),
                                           slope_records::NumberOrNaN(entry, "slope_sigma_calibration_deg"));
  s.definition_tilt_deg = slope_records::NumberOrNaN(entry, "tilt_definition_deg");
  s.estimation_tilt_deg = slope_records::NumberOrNaN(entry, "tilt_estimation_deg");
  s.definition_error_deg = slope_records::NumberOrNaN(entry, "slope_definition_error_deg");
  s.estimation_error_deg = slope_records::NumberOrNaN(entry, "slope_estimation_error_deg");
  return s;
}

SlopeSample SampleOfFlightRecord(const nlohmann::json& roi) {
  SlopeSample s;
  const nlohmann::json& fit = slope_records::Member(roi, "fit");
  const double slope = slope_records::NumberOrNaN(fit, "slope_deg");
  const nlohmann::json& status = slope_records::Member(roi, "status");
  s.has_slope = std::isfinite(slope) && status.is_string() && StatusHasSlope(true, status.get<std::string>());
  const nlohmann::json& points = slope_records::Member(slope_records::Member(roi, "counts"), "depth_inliers");
  s.num_points = points.is_number_integer() ? points.get<int>() : 0;
  const nlohmann::json& truth = slope_records::Member(roi, "truth");
  s.error_deg = slope_records::NumberOrNaN(roi, "slope_error_deg");
  s.tilt_error_deg = slope_records::NumberOrNaN(roi, "tilt_error_deg");
  if (slope_records::Member(truth, "available") == true) {
    s.roughness_error_m = std::abs(slope_records::NumberOrNaN(fit, "roughness_rms_m") -
                                   slope_records::NumberOrNaN(truth, "roughness_rms_m"));
  }
  s.sigma_deg = hda::CombinedSlopeSigmaDeg(slope_records::NumberOrNaN(fit, "slope_sigma_deg"),
                                           slope_records::NumberOrNaN(fit, "slope_sigma_calibration_deg"));
  return s;
}

void SlopeErrorPool::Add(const SlopeSample& sample) {
  ++rois_;
  if (sample.has_slope) ++rois_with_slope_;
  if (!sample.Counts()) return;
  const double error = std::abs(sample.error_deg);
  slope_errors_.push_back(error);
  signed_sum_ += sample.error_deg;
  if (std::isfinite(sample.tilt_error_deg)) tilt_errors_.push_back(sample.tilt_error_deg);
  if (std::isfinite(sample.roughness_error_m)) roughness_errors_.push_back(sample.roughness_error_m);
  if (WithinTwoSigma(error, sample.sigma_deg)) ++within_two_sigma_;
  if (std::isfinite(sample.definition_tilt_deg) && std::isfinite(sample.estimation_tilt_deg) &&
      std::isfinite(sample.definition_error_deg) && std::isfinite(sample.estimation_error_deg)) {
    definition_tilts_.push_back(sample.definition_tilt_deg);
    estimation_tilts_.push_back(sample.estimation_tilt_deg);
    definition_signed_sum_ += sample.definition_error_deg;
    estimation_signed_sum_ += sample.estimation_error_deg;
  }
}

double SlopeErrorPool::Bias() const {
  return slope_errors_.empty() ? 0.0 : signed_sum_ / static_cast<double>(slope_errors_.size());
}

double SlopeErrorPool::DefinitionBias() const {
  return definition_tilts_.empty() ? 0.0 : definition_signed_sum_ / static_cast<double>(definition_tilts_.size());
}

double SlopeErrorPool::EstimationBias() const {
  return estimation_tilts_.empty() ? 0.0 : estimation_signed_sum_ / static_cast<double>(estimation_tilts_.size());
}

double SlopeErrorPool::WithinTwoSigmaShare() const {
  return slope_errors_.empty() ? 0.0
                               : static_cast<double>(within_two_sigma_) / static_cast<double>(slope_errors_.size());
}

}  // namespace hdabench::reference
