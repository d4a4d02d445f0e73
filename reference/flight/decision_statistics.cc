#include "reference/flight/decision_statistics.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "reference/flight/slope_statistics.h"
#include "tools/util/text.h"

namespace hdabench::reference {

namespace decision_records {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// The decision-error bins: 1 deg each from 6 to 14 deg of the lander's slope.
constexpr double kSlopeBinLowDeg = 6.0;
constexpr int kSlopeBins = 8;
// The rock-height bins' edges, metres: around the 0.30 m clearance.
constexpr std::array<double, 6> kRockEdgesM = {0.0, 0.2, 0.3, 0.5, 1.0, 1e9};

bool IsTrue(const nlohmann::json& value) { return value.is_boolean() && value.get<bool>(); }

}  // namespace decision_records

const char* ToString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kSafe:
      return "safe";
    case Verdict::kUnsafe:
      return "unsafe";
    case Verdict::kNone:
      break;
  }
  return "no verdict";
}

Verdict DeclaredVerdict(bool is_flight, const std::string& status, double slope_deg, double max_slope_deg) {
  if (is_flight) {
    if (status == "evaluated") return Verdict::kSafe;
    if (status == "unsafe slope" || status == "unsafe roughness") return Verdict::kUnsafe;
    return Verdict::kNone;
  }
  if (!std::isfinite(slope_deg) || !StatusHasSlope(false, status) || !std::isfinite(max_slope_deg)) {
    return Verdict::kNone;
  }
  return slope_deg > max_slope_deg ? Verdict::kUnsafe : Verdict::kSafe;
}

nlohmann::ordered_json LandingJson(const datasets::synth::LandingVerdict& landing) {
  using Json = nlohmann::ordered_json;
  if (!landing.defined) return {{"defined", false}, {"why", landing.why}};
  return {{"defined", true},
          {"safe", landing.safe},
          {"unsafe_by_slope", landing.unsafe_by_slope},
          {"unsafe_by_clearance", landing.unsafe_by_clearance},
          {"slope_deg", Json(landing.slope_deg)},
          {"clearance_m", Json(landing.clearance_m)},
          {"yaw_deg", Json(landing.yaw_deg)}};
}

DecisionSample DecisionOfRoi(Verdict declared, const RoiTruthValue* truth, int rank) {
  DecisionSample s;
  s.declared = declared;
  s.rank = rank;
  if (truth == nullptr || !truth->available || !truth->landing.defined) return s;
  s.has_truth = true;
  s.truly_safe = truth->landing.safe;
  s.unsafe_by_slope = truth->landing.unsafe_by_slope;
  s.unsafe_by_clearance = truth->landing.unsafe_by_clearance;
  s.true_slope_deg = truth->landing.slope_deg;
  s.rock_height_m = truth->max_rock_height_m;
  return s;
}

void ReadDecisionTruth(const nlohmann::json& truth, DecisionSample* sample) {
  const nlohmann::json& landing = slope_records::Member(truth, "landing");
  if (!decision_records::IsTrue(slope_records::Member(landing, "defined"))) return;
  sample->has_truth = true;
  sample->truly_safe = decision_records::IsTrue(slope_records::Member(landing, "safe"));
  sample->unsafe_by_slope = decision_records::IsTrue(slope_records::Member(landing, "unsafe_by_slope"));
  sample->unsafe_by_clearance = decision_records::IsTrue(slope_records::Member(landing, "unsafe_by_clearance"));
  sample->true_slope_deg = slope_records::NumberOrNaN(landing, "slope_deg");
  sample->rock_height_m = slope_records::NumberOrNaN(truth, "max_rock_height_m");
}

DecisionSample DecisionOfCompareRecord(const std::string& method, const nlohmann::json& entry,
                                       const nlohmann::json& roi_record, double max_slope_deg) {
  DecisionSample s;
  const bool is_flight = method == kMethodFlight;
  s.declared = DeclaredVerdict(is_flight, entry.at("status").get<std::string>(),
                               slope_records::NumberOrNaN(entry, "slope_deg"), max_slope_deg);
  ReadDecisionTruth(slope_records::Member(roi_record, "truth"), &s);
  const nlohmann::json& rank = slope_records::Member(roi_record, "rank");
  if (is_flight && rank.is_number_integer()) s.rank = rank.get<int>();
  return s;
}

DecisionSample DecisionOfFlightRecord(const nlohmann::json& roi) {
  DecisionSample s;
  const nlohmann::json& status = slope_records::Member(roi, "status");
  s.declared = DeclaredVerdict(true, status.is_string() ? status.get<std::string>() : "",
                               decision_records::kNaN, decision_records::kNaN);
  ReadDecisionTruth(slope_records::Member(roi, "truth"), &s);
  const nlohmann::json& rank = slope_records::Member(roi, "rank");
  if (rank.is_number_integer()) s.rank = rank.get<int>();
  return s;
}

Interval WilsonInterval(int successes, int n) {
  if (n <= 0) return Interval();
  constexpr double z = 1.959963984540054;
  const double p = static_cast<double>(successes) / n;
  const double z2n = z * z / n;
  const double centre = (p + 0.5 * z2n) / (1.0 + z2n);
  const double half = z * std::sqrt(p * (1.0 - p) / n + 0.25 * z2n / n) / (1.0 + z2n);
  return Interval{std::max(0.0, centre - half), std::min(1.0, centre + half)};
}

DecisionPool::DecisionPool() {
  for (int i = 0; i < decision_records::kSlopeBins; ++i) {
    slope_bins_.push_back({decision_records::kSlopeBinLowDeg + i, decision_records::kSlopeBinLowDeg + i + 1, 0, 0});
  }
  const auto& edges = decision_records::kRockEdgesM;
  for (size_t i = 0; i + 1 < edges.size(); ++i) rock_bins_.push_back({edges[i], edges[i + 1], 0, 0});
}

void DecisionPool::AddRun(const std::vector<DecisionSample>& samples) {
  std::map<int, const DecisionSample*> ranked;  // rank -> site, with a truth
  for (const DecisionSample& s : samples) {
    if (!s.has_truth) {
      ++without_truth_;
      continue;
    }
    ++sites_;
    if (!s.truly_safe) ++truly_unsafe_;
    if (s.unsafe_by_slope) ++by_slope_;
    if (s.unsafe_by_clearance) ++by_clearance_;
    ++counts_[static_cast<size_t>(s.declared)][s.truly_safe ? 0 : 1];
    if (s.rank > 0) ranked[s.rank] = &s;
    if (s.declared == Verdict::kNone) continue;
    const bool wrong = (s.declared == Verdict::kSafe) != s.truly_safe;
    for (DecisionBin& bin : slope_bins_) {
      if (s.true_slope_deg >= bin.low && s.true_slope_deg < bin.high) {
        ++bin.sites;
        if (wrong) ++bin.hits;
      }
    }
    if (s.unsafe_by_clearance && std::isfinite(s.rock_height_m)) {
      for (DecisionBin& bin : rock_bins_) {
        if (s.rock_height_m >= bin.low && s.rock_height_m < bin.high) {
          ++bin.sites;
          if (s.declared == Verdict::kUnsafe) ++bin.hits;
        }
      }
    }
  }
  if (ranked.empty()) return;
  ++ranked_runs_;
  if (!ranked.begin()->second->truly_safe) ++top_unsafe_runs_;
  int taken = 0;
  bool any_unsafe = false;
  for (const auto& [rank, site] : ranked) {
    if (taken++ == kTopK) break;
    any_unsafe = any_unsafe || !site->truly_safe;
  }
  if (any_unsafe) ++top_k_unsafe_runs_;
}

double DecisionPool::FalseSafeRate() const {
  const int declared_safe = DeclaredSafe();
  return declared_safe == 0 ? decision_records::kNaN
                            : static_cast<double>(Count(Verdict::kSafe, false)) / declared_safe;
}

Interval DecisionPool::FalseSafeInterval() const { return WilsonInterval(Count(Verdict::kSafe, false), DeclaredSafe()); }

double DecisionPool::MissedSafeRate() const {
  const int truly_safe = Count(Verdict::kSafe, true) + Count(Verdict::kUnsafe, true);
  return truly_safe == 0 ? decision_records::kNaN : static_cast<double>(Count(Verdict::kUnsafe, true)) / truly_safe;
}

double DecisionPool::UnsafeCaughtRate() const {
  const int truly_unsafe = Count(Verdict::kSafe, false) + Count(Verdict::kUnsafe, false);
  return truly_unsafe == 0 ? decision_records::kNaN
                           : static_cast<double>(Count(Verdict::kUnsafe, false)) / truly_unsafe;
}

double DecisionPool::TopSiteUnsafeShare() const {
  return ranked_runs_ == 0 ? decision_records::kNaN : static_cast<double>(top_unsafe_runs_) / ranked_runs_;
}

double DecisionPool::TopKUnsafeShare() const {
  return ranked_runs_ == 0 ? decision_records::kNaN : static_cast<double>(top_k_unsafe_runs_) / ranked_runs_;
}

nlohmann::ordered_json DecisionJson(const DecisionPool& pool) {
  using Json = nlohmann::ordered_json;
  const auto number = [](double v) { return std::isfinite(v) ? Json(v) : Json(nullptr); };
  Json j;
  j["sites"] = pool.sites();
  j["sites_without_truth"] = pool.sites_without_truth();
  j["truly_unsafe"] = pool.truly_unsafe();
  j["truly_unsafe_by_slope"] = pool.truly_unsafe_by_slope();
  j["truly_unsafe_by_clearance"] = pool.truly_unsafe_by_clearance();
  Json confusion;
  for (const Verdict v : {Verdict::kSafe, Verdict::kUnsafe, Verdict::kNone}) {
    confusion[std::string("declared ") + ToString(v)] = {{"truly safe", pool.Count(v, true)},
                                                         {"truly unsafe", pool.Count(v, false)}};
  }
  j["confusion"] = confusion;
  j["false_safe_rate"] = number(pool.FalseSafeRate());
  const Interval interval = pool.FalseSafeInterval();
  j["false_safe_rate_95"] = pool.DeclaredSafe() > 0 ? Json::array({interval.low, interval.high}) : Json(nullptr);
  j["missed_safe_rate"] = number(pool.MissedSafeRate());
  j["unsafe_caught_rate"] = number(pool.UnsafeCaughtRate());
  j["ranked_runs"] = pool.ranked_runs();
  j["top_site_unsafe_share"] = number(pool.TopSiteUnsafeShare());
  j["top_k"] = DecisionPool::kTopK;
  j["top_k_unsafe_share"] = number(pool.TopKUnsafeShare());
  const auto bins = [](const std::vector<DecisionBin>& list, const char* hits) {
    Json a = Json::array();
    for (const DecisionBin& b : list) {
      a.push_back({{"low", b.low}, {"high", b.high > 1e8 ? Json(nullptr) : Json(b.high)}, {"sites", b.sites},
                   {hits, b.hits}});
    }
    return a;
  };
  j["wrong_by_true_slope"] = bins(pool.SlopeBins(), "wrong");
  j["clearance_caught_by_rock_height"] = bins(pool.RockBins(), "declared_unsafe");
  return j;
}

std::string DecisionLine(const DecisionPool& pool) {
  std::ostringstream s;
  const auto percent = [](double v) { return std::isfinite(v) ? util::FixedText(100.0 * v, 1) + " %" : "-"; };
  s << pool.sites() << " sites with a lander truth (" << pool.truly_unsafe() << " truly unsafe: "
    << pool.truly_unsafe_by_slope() << " by slope, " << pool.truly_unsafe_by_clearance() << " by clearance)";
  if (pool.sites_without_truth() > 0) s << ", " << pool.sites_without_truth() << " without";
  s << "; declared safe " << pool.DeclaredSafe() << ", unsafe "
    << pool.Count(Verdict::kUnsafe, true) + pool.Count(Verdict::kUnsafe, false) << ", no verdict "
    << pool.Count(Verdict::kNone, true) + pool.Count(Verdict::kNone, false) << "; false-safe "
    << percent(pool.FalseSafeRate());
  if (pool.DeclaredSafe() > 0) {
    const Interval i = pool.FalseSafeInterval();
    s << " [" << util::FixedText(100.0 * i.low, 1) << ", " << util::FixedText(100.0 * i.high, 1) << "]";
  }
  s << ", missed-safe " << percent(pool.MissedSafeRate()) << ", unsafe caught "
    << percent(pool.UnsafeCaughtRate());
  if (pool.ranked_runs() > 0) s << ", top site unsafe " << percent(pool.TopSiteUnsafeShare());
  return s.str();
}

Verdict ProbabilityVerdict(double probability_safe, double min_probability) {
  if (!std::isfinite(probability_safe)) return Verdict::kNone;
  return probability_safe >= min_probability ? Verdict::kSafe : Verdict::kUnsafe;
}

SafetyCalibration::SafetyCalibration(double called_at) : called_at_(called_at) {
  const std::array<double, 6> edges = {0.0, 0.5, 0.9, 0.99, 0.999, 1.0};
  for (size_t i = 0; i + 1 < edges.size(); ++i) {
    Bin b;
    b.low = edges[i];
    b.high = edges[i + 1];
    bins_.push_back(b);
  }
}

void SafetyCalibration::Add(double probability_safe, const DecisionSample& sample) {
  if (!std::isfinite(probability_safe) || !sample.has_truth) return;
  size_t k = 0;
  while (k + 1 < bins_.size() && probability_safe >= bins_[k].high) ++k;
  Bin& b = bins_[k];
  ++b.sites;
  b.probability_sum += probability_safe;
  if (sample.truly_safe) ++b.truly_safe;
  if (probability_safe >= called_at_) {
    ++called_safe_;
    if (sample.truly_safe) ++called_truly_safe_;
  }
}

nlohmann::ordered_json SafetyCalibrationJson(const SafetyCalibration& calibration) {
  using OrderedJson = nlohmann::ordered_json;
  OrderedJson j;
  j["called_at"] = calibration.called_at();
  j["called_safe"] = calibration.called_safe();
  j["called_truly_safe"] = calibration.called_truly_safe();
  const int n = calibration.called_safe();
  j["called_truly_safe_share"] =
      n > 0 ? OrderedJson(static_cast<double>(calibration.called_truly_safe()) / n) : OrderedJson(nullptr);
  const Interval interval = WilsonInterval(calibration.called_truly_safe(), n);
  j["called_truly_safe_share_95"] = n > 0 ? OrderedJson::array({interval.low, interval.high}) : OrderedJson(nullptr);
  OrderedJson bins = OrderedJson::array();
  for (const SafetyCalibration::Bin& b : calibration.bins()) {
    bins.push_back({{"low", b.low},
                    {"high", b.high},
                    {"sites", b.sites},
                    {"truly_safe", b.truly_safe},
                    {"mean_probability", b.sites > 0 ? OrderedJson(b.probability_sum / b.sites) : OrderedJson(nullptr)}});
  }
  j["bins"] = bins;
  return j;
}

std::string SafetyCalibrationLine(const SafetyCalibration& calibration) {
  std::ostringstream s;
  const int n = calibration.called_safe();
  s << "sites called >= " << util::FixedText(100.0 * calibration.called_at(), 0) << " % safe: " << n;
  if (n > 0) {
    const Interval i = WilsonInterval(calibration.called_truly_safe(), n);
    s << ", truly safe " << calibration.called_truly_safe() << " ("
      << util::FixedText(100.0 * calibration.called_truly_safe() / n, 1) << " % [" << util::FixedText(100.0 * i.low, 1)
      << ", " << util::FixedText(100.0 * i.high, 1) << "])";
  }
  return s.str();
}

}  // namespace hdabench::reference
