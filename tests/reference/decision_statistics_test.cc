// The decision statistics (reference/flight/decision_statistics.h) on
// samples whose figures are worked out by hand.
#include "reference/flight/decision_statistics.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hdabench::reference {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(WilsonInterval, MatchesTheScoreIntervalAtNinetyFivePercent) {
  // 0 of 10: [0, z^2 / (n + z^2)] = [0, 3.8415 / 13.8415] = [0, 0.2775].
  const Interval none = WilsonInterval(0, 10);
  EXPECT_DOUBLE_EQ(none.low, 0.0);
  EXPECT_NEAR(none.high, 0.27753, 1e-5);
  // 5 of 10: 0.5 -/+ 1.96 sqrt(0.025 + 0.009604) / 1.38415 = [0.2366, 0.7634].
  const Interval half = WilsonInterval(5, 10);
  EXPECT_NEAR(half.low, 0.23659, 1e-5);
  EXPECT_NEAR(half.high, 0.76341, 1e-5);
  // No sample: nothing known.
  EXPECT_EQ(WilsonInterval(0, 0).low, 0.0);
  EXPECT_EQ(WilsonInterval(0, 0).high, 1.0);
}

TEST(DeclaredVerdict, TheFlightMethodByStatusAReferenceBySlope) {
  EXPECT_EQ(DeclaredVerdict(true, "evaluated", kNaN, kNaN), Verdict::kSafe);
  EXPECT_EQ(DeclaredVerdict(true, "unsafe slope", 3.0, 10.0), Verdict::kUnsafe);
  EXPECT_EQ(DeclaredVerdict(true, "unsafe roughness", 3.0, 10.0), Verdict::kUnsafe);
  for (const char* status : {"degenerate", "too few points", "not in image 2", "not evaluated"}) {
    EXPECT_EQ(DeclaredVerdict(true, status, 3.0, 10.0), Verdict::kNone) << status;
  }
  EXPECT_EQ(DeclaredVerdict(false, "ok", 10.0, 10.0), Verdict::kSafe);  // at the limit: safe, as the method's rule
  EXPECT_EQ(DeclaredVerdict(false, "ok", 10.01, 10.0), Verdict::kUnsafe);
  EXPECT_EQ(DeclaredVerdict(false, "ok", kNaN, 10.0), Verdict::kNone);
  EXPECT_EQ(DeclaredVerdict(false, "degenerate", 3.0, 10.0), Verdict::kNone);
  EXPECT_EQ(DeclaredVerdict(false, "ok", 3.0, kNaN), Verdict::kNone);  // a record without the limit
}

DecisionSample Site(Verdict declared, bool safe, double slope_deg, int rank = 0) {
  DecisionSample s;
  s.declared = declared;
  s.has_truth = true;
  s.truly_safe = safe;
  s.unsafe_by_slope = !safe && slope_deg > 10.0;
  s.unsafe_by_clearance = !safe && slope_deg <= 10.0;
  s.true_slope_deg = slope_deg;
  s.rock_height_m = s.unsafe_by_clearance ? 0.45 : 0.0;
  s.rank = rank;
  return s;
}

// Two runs. Run 1: ranks 1 (safe), 2 (unsafe by slope, 10.5 deg), 3 (safe);
// an unsafe site (12.2 deg) declared unsafe; a safe one (9.5 deg) declared
// unsafe; one without a verdict; one without a truth. Run 2: its top site
// is unsafe by clearance (0.45 m rock, 8.2 deg).
// Declared safe 4, of them truly unsafe 2: false-safe 1/2. Truly safe with a
// verdict 3 (two safe, one unsafe): missed-safe 1/3. Top site unsafe in 1 of
// 2 runs, an unsafe one among the top 3 in both.
TEST(DecisionPool, CountsTheConfusionRatesTopSitesAndBins) {
  DecisionPool pool;
  DecisionSample no_truth;
  no_truth.declared = Verdict::kSafe;
  pool.AddRun({Site(Verdict::kSafe, true, 3.0, 1), Site(Verdict::kSafe, false, 10.5, 2),
               Site(Verdict::kSafe, true, 6.4, 3), Site(Verdict::kUnsafe, false, 12.2),
               Site(Verdict::kUnsafe, true, 9.5), Site(Verdict::kNone, false, 13.0), no_truth});
  pool.AddRun({Site(Verdict::kSafe, false, 8.2, 1)});
  EXPECT_EQ(pool.sites(), 7);
  EXPECT_EQ(pool.sites_without_truth(), 1);
  EXPECT_EQ(pool.truly_unsafe(), 4);
  EXPECT_EQ(pool.truly_unsafe_by_slope(), 3);
  EXPECT_EQ(pool.truly_unsafe_by_clearance(), 1);
  EXPECT_EQ(pool.DeclaredSafe(), 4);
  EXPECT_DOUBLE_EQ(pool.FalseSafeRate(), 0.5);
  EXPECT_DOUBLE_EQ(pool.MissedSafeRate(), 1.0 / 3.0);
  // Truly unsafe with a verdict: 10.5, 12.2, 8.2 (13.0 has none); caught: 12.2.
  EXPECT_DOUBLE_EQ(pool.UnsafeCaughtRate(), 1.0 / 3.0);
  EXPECT_EQ(pool.ranked_runs(), 2);
  EXPECT_DOUBLE_EQ(pool.TopSiteUnsafeShare(), 0.5);
  EXPECT_DOUBLE_EQ(pool.TopKUnsafeShare(), 1.0);
  // Decided wrongly by the lander's slope: 10.5 (declared safe) and 9.5
  // (declared unsafe) and 8.2 (declared safe, unsafe by clearance); 6.4 and
  // 12.2 right; 13.0 has no verdict.
  const auto bin = [&](double low) {
    for (const DecisionBin& b : pool.SlopeBins()) {
      if (b.low == low) return b;
    }
    return DecisionBin();
  };
  EXPECT_EQ(bin(6.0).sites, 1);
  EXPECT_EQ(bin(6.0).hits, 0);
  EXPECT_EQ(bin(8.0).hits, 1);
  EXPECT_EQ(bin(9.0).hits, 1);
  EXPECT_EQ(bin(10.0).hits, 1);
  EXPECT_EQ(bin(12.0).sites, 1);
  EXPECT_EQ(bin(12.0).hits, 0);
  EXPECT_EQ(bin(13.0).sites, 0);
  // The clearance hazard (a 0.45 m rock) was declared safe: not caught.
  for (const DecisionBin& b : pool.RockBins()) {
    EXPECT_EQ(b.sites, b.low == 0.3 ? 1 : 0) << b.low;
    EXPECT_EQ(b.hits, 0) << b.low;
  }
  EXPECT_NE(DecisionLine(pool).find("false-safe 50.0 % ["), std::string::npos) << DecisionLine(pool);
}

TEST(DecisionPool, WithoutDeclaredSafeSitesTheRateIsUnknown) {
  DecisionPool pool;
  pool.AddRun({Site(Verdict::kUnsafe, false, 12.0)});
  EXPECT_TRUE(std::isnan(pool.FalseSafeRate()));
  EXPECT_TRUE(std::isnan(pool.TopSiteUnsafeShare()));
  EXPECT_TRUE(DecisionJson(pool)["false_safe_rate"].is_null());
  EXPECT_TRUE(DecisionJson(pool)["false_safe_rate_95"].is_null());
}

TEST(ProbabilityVerdict, SafeAtOrOverTheStatedProbability) {
  EXPECT_EQ(ProbabilityVerdict(0.9, 0.9), Verdict::kSafe);
  EXPECT_EQ(ProbabilityVerdict(0.899, 0.9), Verdict::kUnsafe);
  EXPECT_EQ(ProbabilityVerdict(kNaN, 0.9), Verdict::kNone);
}

TEST(SafetyCalibration, CountsTheTrulySafeByProbability) {
  SafetyCalibration calibration(0.9);
  // Four sites called at least 90 % safe, three of them truly safe; one at
  // 0.6, truly unsafe; one without a truth and one without a probability,
  // both left out.
  calibration.Add(0.95, Site(Verdict::kSafe, true, 5.0));
  calibration.Add(0.9999, Site(Verdict::kSafe, true, 5.0));
  calibration.Add(1.0, Site(Verdict::kSafe, true, 5.0));
  calibration.Add(0.92, Site(Verdict::kSafe, false, 11.0));
  calibration.Add(0.6, Site(Verdict::kUnsafe, false, 11.0));
  DecisionSample no_truth;
  calibration.Add(0.99, no_truth);
  calibration.Add(kNaN, Site(Verdict::kNone, true, 5.0));
  EXPECT_EQ(calibration.called_safe(), 4);
  EXPECT_EQ(calibration.called_truly_safe(), 3);
  const auto& bins = calibration.bins();
  ASSERT_EQ(bins.size(), 5u);  // [0, .5) [.5, .9) [.9, .99) [.99, .999) [.999, 1]
  EXPECT_EQ(bins[1].sites, 1);
  EXPECT_EQ(bins[1].truly_safe, 0);
  EXPECT_EQ(bins[2].sites, 2);
  EXPECT_EQ(bins[2].truly_safe, 1);
  EXPECT_EQ(bins[3].sites, 0);
  EXPECT_EQ(bins[4].sites, 2);  // 0.9999 and 1 (the last bin holds 1)
  const nlohmann::ordered_json j = SafetyCalibrationJson(calibration);
  EXPECT_DOUBLE_EQ(j["called_truly_safe_share"].get<double>(), 0.75);
  EXPECT_NEAR(j["bins"][2]["mean_probability"].get<double>(), 0.935, 1e-12);
  EXPECT_TRUE(j["bins"][0]["mean_probability"].is_null());
  // 3 of 4: Wilson [0.3006, 0.9544].
  EXPECT_NEAR(j["called_truly_safe_share_95"][0].get<double>(), 0.30064, 1e-4);
  EXPECT_NE(SafetyCalibrationLine(calibration).find("sites called >= 90 % safe: 4, truly safe 3 (75.0 % ["),
            std::string::npos)
      << SafetyCalibrationLine(calibration);
  EXPECT_TRUE(SafetyCalibrationJson(SafetyCalibration(0.9))["called_truly_safe_share"].is_null());
}

}  // namespace
}  // namespace hdabench::reference
