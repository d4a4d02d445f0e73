// The gate's metrics: every entry's results read back from its files and
// pooled per method and fault by the one rule of
// reference/flight/slope_statistics.h (the slopes) and
// reference/flight/decision_statistics.h (the landing decisions), checked
// against thresholds and a baseline, and their file.
#include "reference/gate/gate.h"

#include <algorithm>
#include <map>
#include <tuple>

#include "reference/compare/compare.h"
#include "reference/flight/decision_statistics.h"
#include "reference/flight/slope_statistics.h"
#include "reference/gate/internal/common.h"
#include "tools/util/statistics.h"

namespace hdabench::reference {

using namespace gate_internal;  // NOLINT(google-build-using-namespace): the gate's own helpers

namespace {

// An observability setting whose plane is missing in more than 5 % of the
// trials has no finite p95: it counts as the largest slope error there is.
constexpr double kObservabilityUnjudgedDeg = 90.0;

// One method's ROIs, failures and time over the entries of one pool.
struct MetricPool {
  SlopeErrorPool slopes;
  DecisionPool decisions;
  int failed = 0;
  double flight_seconds = -1.0;
  // Per flight ROI with a slope and a calibration term: its calibration
  // sigma over the method's own.
  std::vector<double> calibration_shares;
};

// A pool: a method, a fault (empty: the entries without one) and a named
// pool (empty: the main one).
struct PoolKey {
  std::string method, fault, pool;
  bool operator<(const PoolKey& o) const {
    return std::tie(method, fault, pool) < std::tie(o.method, o.fault, o.pool);
  }
};

struct MetricPools {
  std::map<PoolKey, MetricPool> by_key;
  std::vector<PoolKey> order;  // the pools with metrics, in the order first met

  // The pool of a method that ran, listed among the metrics.
  MetricPool& Listed(const PoolKey& key) {
    if (by_key.count(key) == 0) order.push_back(key);
    return by_key[key];
  }
};

// The worst setting of any of the suite's observability entries.
struct StudyWorst {
  bool present = false;
  double p95 = 0.0, median = 0.0, sigma_ratio = 1.0;
};

// An observability entry's settings.csv into the worst setting so far.
void AddStudyEntry(const fs::path& dir, StudyWorst* study) {
  const std::string path = (dir / "settings.csv").string();
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot read the file");
  std::stringstream text;
  text << in.rdbuf();
  for (const SettingStats& s : ParseSettingsCsv(text.str(), path)) {
    study->present = true;
    const bool judged = s.fits >= 0.95 * s.trials;
    study->p95 = std::max(study->p95, judged ? s.p95_abs_error_deg : kObservabilityUnjudgedDeg);
    study->median = std::max(study->median, std::isfinite(s.median_abs_error_deg) ? s.median_abs_error_deg
                                                                                   : kObservabilityUnjudgedDeg);
    if (s.sd_error_deg > 0.0 && s.rms_sigma_deg > 0.0) {
      study->sigma_ratio = std::max({study->sigma_ratio, s.sd_error_deg / s.rms_sigma_deg,
                                     s.rms_sigma_deg / s.sd_error_deg});
    }
  }
}

// An entry's record's field ("fault", "pool"), empty for a folder without
// one or a record without it.
std::string EntryRecordField(const fs::path& dir, const char* field) {
  const fs::path record = dir / kEntryRecord;
  if (!fs::exists(record)) return "";
  const Json r = ReadJsonFile(record.string());
  if (!r.contains("entry") || !r["entry"].contains(field) || r["entry"][field].is_null()) return "";
  return StringField(r["entry"], field, record.string());
}

// A comparison entry (compare.json and compare_timings.json) into the pools
// of its fault.
void AddCompareEntry(const fs::path& dir, MetricPools* pools) {
  const std::string fault = EntryRecordField(dir, "fault");
  const std::string named_pool = EntryRecordField(dir, "pool");
  const std::string path = (dir / "compare.json").string();
  const Json j = ReadJsonFile(path);
  for (const Json& m : j.at("methods")) {
    MetricPool& pool = pools->Listed({m.at("name").get<std::string>(), fault, named_pool});
    if (!m.at("ok").get<bool>()) ++pool.failed;
  }
  // A record without the slope limit (written before the decisions were
  // scored) gives the references no verdict.
  const double max_slope_deg = j.contains("max_slope_deg") && j["max_slope_deg"].is_number()
                                   ? j["max_slope_deg"].get<double>()
                                   : std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, std::vector<DecisionSample>> decisions;
  for (const Json& roi : j.at("rois")) {
    for (const auto& item : roi.at("methods").items()) {
      MetricPool& pool = pools->by_key[{item.key(), fault, named_pool}];
      const SlopeSample sample = SampleOfCompareRecord(item.key(), item.value(), roi.at("truth"));
      pool.slopes.Add(sample);
      const Json& v = item.value();
      if (item.key() == kMethodFlight && sample.has_slope && v.contains("slope_sigma_calibration_deg") &&
          v["slope_sigma_calibration_deg"].is_number() && v["slope_sigma_deg"].is_number() &&
          v["slope_sigma_deg"].get<double>() > 0.0) {
        pool.calibration_shares.push_back(v["slope_sigma_calibration_deg"].get<double>() /
                                          v["slope_sigma_deg"].get<double>());
      }
      decisions[item.key()].push_back(DecisionOfCompareRecord(item.key(), item.value(), roi, max_slope_deg));
    }
  }
  for (const auto& [method, samples] : decisions) {
    pools->by_key[{method, fault, named_pool}].decisions.AddRun(samples);
  }
  // The flight computer's predicted time; a record written before it was
  // counted gives no flight_seconds_per_pair.
  const Json t = ReadJsonFile((dir / "compare_timings.json").string());
  for (const Json& m : t.at("methods")) {
    if (m.at("name") != kMethodFlight || !m.contains("flight_computer_s") || !m["flight_computer_s"].is_number()) {
      continue;
    }
    MetricPool& pool = pools->by_key[{kMethodFlight, fault, named_pool}];
    pool.flight_seconds = std::max(pool.flight_seconds, m["flight_computer_s"].get<double>());
  }
}

// The metrics of one pool (docs/gate.md), those without data left out.
void AddPoolMetrics(const PoolKey& key, const MetricPool& pool, const StudyWorst& study,
                    std::vector<GateMetric>* metrics) {
  const std::string& method = key.method;
  const auto add = [&](const std::string& metric, double value) {
    metrics->push_back({method, metric, value, key.fault, key.pool});
  };
  const SlopeErrorPool& slopes = pool.slopes;
  if (slopes.count() > 0) {
    const ErrorStats errors = slopes.Slope();
    add("slope_error_median_deg", errors.median);
    add("slope_error_p90_deg", errors.p90);
    add("slope_error_max_deg", errors.max);
    add("slope_bias_abs_deg", std::abs(slopes.Bias()));
  }
  const ErrorStats tilts = slopes.Tilt();
  if (tilts.count > 0) {
    add("tilt_error_median_deg", tilts.median);
    add("tilt_error_p90_deg", tilts.p90);
  }
  const ErrorStats roughness = slopes.Roughness();
  if (roughness.count > 0) add("roughness_error_median_m", roughness.median);
  if (slopes.rois() > 0) {
    add("rois_with_slope_share", static_cast<double>(slopes.rois_with_slope()) / slopes.rois());
  }
  if (method == kMethodFlight && slopes.count() > 0) add("within_two_sigma_share", slopes.WithinTwoSigmaShare());
  if (method == kMethodFlight && pool.flight_seconds >= 0.0) add("flight_seconds_per_pair", pool.flight_seconds);
  if (!pool.calibration_shares.empty()) {
    std::vector<double> shares = pool.calibration_shares;
    std::sort(shares.begin(), shares.end());
    add("calibration_sigma_share_p90", util::Quantile(shares, 0.9));
  }
  const DecisionPool& decisions = pool.decisions;
  if (decisions.sites() > 0) {
    add("decision_sites", decisions.sites());
    add("truly_unsafe_share", static_cast<double>(decisions.truly_unsafe()) / decisions.sites());
    if (decisions.DeclaredSafe() > 0) {
      add("false_safe_rate", decisions.FalseSafeRate());
      add("false_safe_upper_95", decisions.FalseSafeInterval().high);
    }
    if (std::isfinite(decisions.MissedSafeRate())) add("missed_safe_rate", decisions.MissedSafeRate());
    if (std::isfinite(decisions.UnsafeCaughtRate())) add("unsafe_caught_rate", decisions.UnsafeCaughtRate());
    if (decisions.ranked_runs() > 0) add("top_site_unsafe_share", decisions.TopSiteUnsafeShare());
  }
  add("failed_entries", pool.failed);
  add("slope_error_rois", static_cast<double>(slopes.count()));
  if (method == kMethodFlight && key.fault.empty() && key.pool.empty() && study.present) {
    add("observability_p95_deg", study.p95);
    add("observability_median_deg", study.median);
    add("observability_sigma_ratio", study.sigma_ratio);
  }
}

}  // namespace

std::vector<std::string> GateMetricNames() { return MetricNames(); }

std::vector<GateMetric> ComputeGateMetrics(const std::vector<std::string>& entry_dirs) {
  MetricPools pools;
  StudyWorst study;
  for (const std::string& dir : entry_dirs) {
    if (fs::exists(fs::path(dir) / "study.json")) {
      AddStudyEntry(dir, &study);
      // The study's metrics are the flight method's.
      if (study.present) pools.Listed({kMethodFlight, "", ""});
    } else {
      AddCompareEntry(dir, &pools);
    }
  }
  std::vector<GateMetric> metrics;
  for (const PoolKey& key : pools.order) AddPoolMetrics(key, pools.by_key[key], study, &metrics);
  return metrics;
}

std::string GateCheck::Summary() const {
  const std::string name = MethodLabel(threshold.method, threshold.fault, threshold.pool) + " " + threshold.metric;
  if (!has_value) return name + ": no value in this run (no data for the metric)";
  std::string text = name + " = " + FormatValue(value);
  if (!passed) {
    text += threshold.max ? " > " + FormatValue(*threshold.max) + " (threshold)"
                          : " < " + FormatValue(*threshold.min) + " (threshold)";
  }
  if (regressed) {
    text += std::string(passed ? "" : ";") + " regressed from the baseline's " + FormatValue(baseline) +
            " by more than " + FormatValue(threshold.tolerance);
  }
  return text;
}

std::vector<GateCheck> CheckGate(const std::vector<GateMetric>& metrics,
                                 const GateThresholds& thresholds,
                                 const std::vector<GateMetric>* baseline) {
  const auto find = [](const std::vector<GateMetric>& list, const GateThreshold& t) -> const GateMetric* {
    for (const GateMetric& m : list) {
      if (m.method == t.method && m.metric == t.metric && m.fault == t.fault && m.pool == t.pool) return &m;
    }
    return nullptr;
  };
  std::vector<GateCheck> checks;
  for (const GateThreshold& t : thresholds.thresholds) {
    GateCheck check;
    check.threshold = t;
    const GateMetric* m = find(metrics, t);
    if (m != nullptr) {
      check.has_value = true;
      check.value = m->value;
      check.margin = t.max ? *t.max - m->value : m->value - *t.min;
      check.passed = check.margin >= 0.0;
    }
    if (baseline != nullptr && m != nullptr) {
      if (const GateMetric* b = find(*baseline, t)) {
        check.has_baseline = true;
        check.baseline = b->value;
        const double worse = HigherIsBetter(t.metric) ? b->value - m->value : m->value - b->value;
        check.regressed = worse > t.tolerance;
      }
    }
    checks.push_back(check);
  }
  return checks;
}

std::string GateMetricsJson(const std::vector<GateMetric>& metrics) {
  Json j;
  j["format"] = kGateMetricsFormatName;
  j["format_version"] = kGateFormatVersion;
  Json list = Json::array();
  for (const GateMetric& m : metrics) {
    Json item = {{"method", m.method}, {"metric", m.metric}, {"value", m.value}};
    if (!m.fault.empty()) item["fault"] = m.fault;  // only then: the baselines without faults keep their bytes
    if (!m.pool.empty()) item["pool"] = m.pool;
    list.push_back(item);
  }
  j["metrics"] = list;
  return j.dump(1) + "\n";
}

std::vector<GateMetric> ReadGateMetrics(const std::string& path) {
  const Json j = ReadJsonFile(path);
  CheckFormat(j, kGateMetricsFormatName, path);
  std::vector<GateMetric> metrics;
  if (!j.contains("metrics") || !j["metrics"].is_array()) {
    throw InputError(path + ": field 'metrics' must be a list");
  }
  for (size_t i = 0; i < j["metrics"].size(); ++i) {
    const Json& m = j["metrics"][i];
    const std::string where = path + ": metrics[" + std::to_string(i) + "]";
    if (!m.is_object()) throw InputError(where + ": expected an object");
    metrics.push_back({StringField(m, "method", where), StringField(m, "metric", where),
                       NumberField(m, "value", where),
                       m.contains("fault") ? StringField(m, "fault", where) : std::string(),
                       m.contains("pool") ? StringField(m, "pool", where) : std::string()});
  }
  return metrics;
}

}  // namespace hdabench::reference
