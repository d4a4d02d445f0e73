#include "datasets/synth/terrain.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <initializer_list>
#include <sstream>

#include "tools/util/error.h"
#include "datasets/synth/noise.h"
#include "tools/util/angles.h"
#include "tools/util/parallel_for.h"
#include "tools/util/text.h"
#include "tools/util/options_check.h"

namespace hdabench::datasets::synth {

namespace {

using util::kDegToRad;

// Sub-seeds of the scene seed, one per independent random stream.
constexpr std::uint64_t kReliefStream = 0x52454c4945460001ULL;
constexpr std::uint64_t kCraterStream = 0x4352415445520002ULL;
constexpr std::uint64_t kRockStream = 0x524f434b53000003ULL;
constexpr std::uint64_t kAlbedoStream = 0x414c4245444f0004ULL;
// Index used for the stochastic rounding draw of a count (never a body index).
constexpr std::uint64_t kCountDraw = ~std::uint64_t{0};

constexpr int kBlockRows = 16;  // rows per unit of work: ~360 kB of doubles at 2801 columns
// Relief normalisation: RMS of the unit noise over a 128 x 128 grid of samples
// spaced a few coarsest wavelengths apart (incommensurate with the lattice).
constexpr int kReliefRmsSamplesPerSide = 128;
constexpr int kFitPoints = 20;
constexpr int kFitMinCount = 10;

std::uint64_t Stream(std::uint64_t seed, std::uint64_t stream) { return Mix64(seed ^ stream); }

// ---- Validation helpers: each appends "<field> = <value>: expected <what>".
class Checker {
 public:
  explicit Checker(std::vector<std::string>* errors) : errors_(errors) {}

  bool Finite(const std::string& name, double value) {
    return Check(std::isfinite(value), name, value, "a finite value");
  }
  bool Positive(const std::string& name, double value) {
    return Check(std::isfinite(value) && value > 0.0, name, value, "a finite value > 0");
  }
  bool NonNegative(const std::string& name, double value) {
    return Check(std::isfinite(value) && value >= 0.0, name, value, "a finite value >= 0");
  }
  bool Negative(const std::string& name, double value) {
    return Check(std::isfinite(value) && value < 0.0, name, value, "a finite value < 0");
  }
  bool InClosed(const std::string& name, double value, double lo, double hi) {
    return Check(std::isfinite(value) && value >= lo && value <= hi, name, value,
                 "a finite value in [" + util::ShortestText(lo) + ", " + util::ShortestText(hi) + "]");
  }
  bool InHalfOpen(const std::string& name, double value, double lo, double hi) {
    return Check(std::isfinite(value) && value > lo && value <= hi, name, value,
                 "a finite value in (" + util::ShortestText(lo) + ", " + util::ShortestText(hi) + "]");
  }
  // "a = 5 and b = 2: expected a < b".
  bool Less(const std::string& name_a, double a, const std::string& name_b, double b) {
    if (a < b) return true;
    errors_->push_back(name_a + " = " + util::ShortestText(a) + " and " + name_b + " = " + util::ShortestText(b) +
                       ": expected " + name_a + " < " + name_b);
    return false;
  }
  bool Check(bool ok, const std::string& name, double value, const std::string& expected) {
    if (!ok) errors_->push_back(name + " = " + util::ShortestText(value) + ": expected " + expected);
    return ok;
  }
  void Fail(const std::string& message) { errors_->push_back(message); }
  // True when every check passed. The checks are the elements of a braced
  // list, which C++ evaluates in order and in full, so each failing one adds
  // its error, in the order written (the operands of `a & b` would all run
  // too, but in an order each compiler chooses).
  static bool All(std::initializer_list<bool> passed) {
    return std::all_of(passed.begin(), passed.end(), [](bool ok) { return ok; });
  }

 private:
  std::vector<std::string>* errors_;
};

// Nodes needed to cover `span_m` at `spacing_m` (the last may overshoot).
double NodesToCover(double span_m, double spacing_m) {
  return std::ceil(span_m / spacing_m - 1e-9) + 1.0;
}

double CraterMarginM(const TerrainOptions& o) {
  return o.crater_ejecta_extent_radii * 0.5 * o.crater_d_max_m;
}

double ExtentAreaM2(const TerrainOptions& o) {
  return (o.max_x_m - o.min_x_m) * (o.max_y_m - o.min_y_m);
}

double CraterAreaM2(const TerrainOptions& o) {
  const double margin_m = CraterMarginM(o);
  return (o.max_x_m - o.min_x_m + 2.0 * margin_m) * (o.max_y_m - o.min_y_m + 2.0 * margin_m);
}

// Expected count of the law truncated to [d_min, d_max] over `area_m2`.
double ExpectedCount(double k, double exponent, double d_min_m, double d_max_m, double area_m2) {
  return k * (std::pow(d_min_m, exponent) - std::pow(d_max_m, exponent)) * area_m2;
}

// Expected number of rocks of the options' law in [rock_d_min_m, rock_d_max_m] over area_m2.
double ExpectedRockCount(const TerrainOptions& o, double area_m2) {
  return (CumulativeRocksPerM2(o, o.rock_d_min_m) - CumulativeRocksPerM2(o, o.rock_d_max_m)) * area_m2;
}

// floor(lambda), plus one with probability frac(lambda).
std::int64_t StochasticCount(double lambda, std::uint64_t stream_seed) {
  const double whole = std::floor(lambda);
  const bool extra = HashUniform(stream_seed, kCountDraw) < lambda - whole;
  return static_cast<std::int64_t>(whole) + (extra ? 1 : 0);
}

// Inverse CDF of the cumulative power law truncated to [d_min, d_max]:
// P(D' <= D) = (d_min^r - D^r) / (d_min^r - d_max^r).
double SampleDiameter(double u, double exponent, double d_min_m, double d_max_m) {
  const double a = std::pow(d_min_m, exponent);
  const double b = std::pow(d_max_m, exponent);
  return std::clamp(std::pow(a - u * (a - b), 1.0 / exponent), d_min_m, d_max_m);
}

// Inverse CDF of the options' rock law truncated to [d_min, d_max]: the power
// law in closed form, the exponential-area law by bisection on log D (N is
// decreasing in D).
double SampleRockDiameter(double u, const TerrainOptions& o) {
  if (o.rock_law_kind == TerrainOptions::RockLawKind::kPower) {
    return SampleDiameter(u, o.rock_exponent, o.rock_d_min_m, o.rock_d_max_m);
  }
  const double n_min = CumulativeRocksPerM2(o, o.rock_d_min_m);
  const double n_max = CumulativeRocksPerM2(o, o.rock_d_max_m);
  const double target = n_min - u * (n_min - n_max);
  double lo = std::log(o.rock_d_min_m);
  double hi = std::log(o.rock_d_max_m);
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (CumulativeRocksPerM2(o, std::exp(mid)) > target) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return std::clamp(std::exp(0.5 * (lo + hi)), o.rock_d_min_m, o.rock_d_max_m);
}

// A crater ready to be carved: centre, radius, depth, rim height, reach (m).
struct CraterShape {
  double center_x_m;
  double center_y_m;
  double radius_m;
  double depth_m;
  double rim_height_m;
  double reach_m;
};

struct Grid {
  int width = 0;
  int height = 0;
  double origin_x_m = 0.0;
  double origin_y_m = 0.0;
  double spacing_m = 0.0;
};

// Adds the craters to rows [row_begin, row_end) of `block` (row-major, full width).
void CarveBlock(const Grid& grid, const std::vector<CraterShape>& craters, double ejecta_extent,
                int row_begin, int row_end, std::vector<double>* block) {
  const double s = grid.spacing_m;
  for (const CraterShape& crater : craters) {
    // Rows with |y - cy| <= reach and columns with |x - cx| <= reach.
    const double row_lo = std::ceil((grid.origin_y_m - crater.center_y_m - crater.reach_m) / s);
    const double row_hi = std::floor((grid.origin_y_m - crater.center_y_m + crater.reach_m) / s);
    if (row_hi < row_begin || row_lo > row_end - 1) continue;
    const double col_lo = std::ceil((crater.center_x_m - crater.reach_m - grid.origin_x_m) / s);
    const double col_hi = std::floor((crater.center_x_m + crater.reach_m - grid.origin_x_m) / s);
    if (col_hi < 0.0 || col_lo > grid.width - 1) continue;
    // Clamp before converting: a huge reach must not overflow int.
    const int r0 = static_cast<int>(std::max<double>(row_begin, row_lo));
    const int r1 = static_cast<int>(std::min<double>(row_end - 1, row_hi));
    const int c0 = static_cast<int>(std::max(0.0, col_lo));
    const int c1 = static_cast<int>(std::min<double>(grid.width - 1, col_hi));
    const double reach2 = crater.reach_m * crater.reach_m;
    for (int r = r0; r <= r1; ++r) {
      const double dy = grid.origin_y_m - r * s - crater.center_y_m;
      double* row = block->data() + static_cast<size_t>(r - row_begin) * grid.width;
      for (int c = c0; c <= c1; ++c) {
        const double dx = grid.origin_x_m + c * s - crater.center_x_m;
        const double d2 = dx * dx + dy * dy;
        if (d2 >= reach2) continue;
        row[c] += CraterHeightChange(std::sqrt(d2), crater.radius_m, crater.depth_m,
                                     crater.rim_height_m, ejecta_extent);
      }
    }
  }
}

// Distance from (x, y) to the rectangle [x0, x1] x [y0, y1] (0 inside).
double DistanceToRect(double x, double y, double x0, double x1, double y0, double y1) {
  const double dx = std::max({x0 - x, 0.0, x - x1});
  const double dy = std::max({y0 - y, 0.0, y - y1});
  return std::hypot(dx, dy);
}

double UnitReliefRms(std::uint64_t relief_seed, double finest_m, double coarsest_m, double hurst) {
  double sum2 = 0.0;
  for (int i = 0; i < kReliefRmsSamplesPerSide; ++i) {
    for (int j = 0; j < kReliefRmsSamplesPerSide; ++j) {
      const double x = (i + 0.5) * 3.71 * coarsest_m;
      const double y = (j + 0.5) * 2.93 * coarsest_m;
      const double v = FractalNoise(relief_seed, x, y, finest_m, coarsest_m, hurst);
      sum2 += v * v;
    }
  }
  return std::sqrt(sum2 / (kReliefRmsSamplesPerSide * kReliefRmsSamplesPerSide));
}

// Which of the extent and grid options are usable, for the checks that use them.
struct ExtentChecks {
  bool extent_ok = false;
  bool spacing_ok = false;
};

// Extent and grid: finite, ordered bounds, a positive spacing, at most max_nodes nodes.
ExtentChecks ValidateExtent(const TerrainOptions& o, Checker& check) {
  bool extent_ok = Checker::All({check.Finite("min_x_m", o.min_x_m), check.Finite("max_x_m", o.max_x_m),
                                  check.Finite("min_y_m", o.min_y_m), check.Finite("max_y_m", o.max_y_m)});
  if (extent_ok) {
    extent_ok = Checker::All({check.Less("min_x_m", o.min_x_m, "max_x_m", o.max_x_m),
                              check.Less("min_y_m", o.min_y_m, "max_y_m", o.max_y_m)});
  }
  const bool spacing_ok = check.Positive("spacing_m", o.spacing_m);
  const bool max_nodes_ok = check.Check(o.max_nodes > 0, "max_nodes", static_cast<double>(o.max_nodes),
                                        "a value > 0");
  const bool grid_ok = extent_ok && spacing_ok;
  if (grid_ok && max_nodes_ok) {
    const double nx = NodesToCover(o.max_x_m - o.min_x_m, o.spacing_m);
    const double ny = NodesToCover(o.max_y_m - o.min_y_m, o.spacing_m);
    if (nx * ny > static_cast<double>(o.max_nodes) || nx > INT_MAX || ny > INT_MAX) {
      check.Fail("grid of " + util::ShortestText(nx) + " x " + util::ShortestText(ny) + " nodes (spacing_m = " +
                 util::ShortestText(o.spacing_m) + "): expected at most max_nodes = " +
                 std::to_string(o.max_nodes) + " nodes; enlarge spacing_m or shrink the extent");
    }
  }
  return {extent_ok, spacing_ok};
}

// Relief and regional slope.
void ValidateRelief(const TerrainOptions& o, bool spacing_ok, Checker& check) {
  if (check.NonNegative("relief_rms_m", o.relief_rms_m) && o.relief_rms_m > 0.0 && spacing_ok &&
      check.Finite("relief_largest_wavelength_m", o.relief_largest_wavelength_m)) {
    check.Check(o.relief_largest_wavelength_m >= 2.0 * o.spacing_m, "relief_largest_wavelength_m",
                o.relief_largest_wavelength_m,
                ">= 2 * spacing_m = " + util::ShortestText(2.0 * o.spacing_m) + " (the finest relief wavelength)");
  }
  check.InClosed("relief_hurst", o.relief_hurst, 0.0, 1.0);
  check.InClosed("regional_slope_deg", o.regional_slope_deg, 0.0, 80.0);
  check.Finite("regional_slope_downhill_azimuth_deg", o.regional_slope_downhill_azimuth_deg);
}

// Craters: the law, the shape ratios, the count cap over the placement area.
void ValidateCraterLaw(const TerrainOptions& o, bool extent_ok, Checker& check) {
  bool crater_law_ok = Checker::All({check.NonNegative("crater_k", o.crater_k),
                                     check.Negative("crater_exponent", o.crater_exponent)});
  const bool crater_d_ok =
      Checker::All({check.Positive("crater_d_min_m", o.crater_d_min_m),
                    check.Positive("crater_d_max_m", o.crater_d_max_m)});
  crater_law_ok = crater_law_ok && crater_d_ok &&
                  check.Less("crater_d_min_m", o.crater_d_min_m, "crater_d_max_m", o.crater_d_max_m);
  if (Checker::All({check.Positive("crater_depth_to_diameter", o.crater_depth_to_diameter),
                    check.NonNegative("crater_depth_to_diameter_spread", o.crater_depth_to_diameter_spread)})) {
    if (o.crater_depth_to_diameter_spread >= o.crater_depth_to_diameter ||
        o.crater_depth_to_diameter + o.crater_depth_to_diameter_spread > 0.5) {
      check.Fail("crater_depth_to_diameter = " + util::ShortestText(o.crater_depth_to_diameter) +
                 " and crater_depth_to_diameter_spread = " +
                 util::ShortestText(o.crater_depth_to_diameter_spread) +
                 ": expected the drawn range [value - spread, value + spread] inside (0, 0.5]");
    }
  }
  check.InClosed("crater_rim_height_to_diameter", o.crater_rim_height_to_diameter, 0.0, 0.5);
  const bool ejecta_ok = check.Check(
      std::isfinite(o.crater_ejecta_extent_radii) && o.crater_ejecta_extent_radii > 1.0,
      "crater_ejecta_extent_radii", o.crater_ejecta_extent_radii, "a finite value > 1");
  const bool max_craters_ok = check.Check(o.max_craters >= 0, "max_craters",
                                          static_cast<double>(o.max_craters), "a value >= 0");
  if (crater_law_ok && ejecta_ok && extent_ok && max_craters_ok) {
    const double expected = ExpectedCount(o.crater_k, o.crater_exponent, o.crater_d_min_m,
                                          o.crater_d_max_m, CraterAreaM2(o));
    if (std::ceil(expected) > static_cast<double>(o.max_craters)) {
      check.Fail("crater law gives " + util::ShortestText(expected) + " craters over " +
                 util::ShortestText(CraterAreaM2(o)) + " m^2 (crater_k = " + util::ShortestText(o.crater_k) +
                 ", crater_exponent = " + util::ShortestText(o.crater_exponent) + ", crater_d_min_m = " +
                 util::ShortestText(o.crater_d_min_m) + ", crater_d_max_m = " + util::ShortestText(o.crater_d_max_m) +
                 "): expected at most max_craters = " + std::to_string(o.max_craters) +
                 "; raise crater_d_min_m or max_craters, or lower crater_k");
    }
  }
}

// Each of extra_pads: a finite centre and azimuth, a positive side, a slope in [0, 80].
void ValidateExtraPads(const TerrainOptions& o, Checker& check) {
  for (size_t i = 0; i < o.extra_pads.size(); ++i) {
    const TerrainOptions::Pad& pad = o.extra_pads[i];
    const std::string name = "extra_pads[" + std::to_string(i) + "].";
    check.Finite(name + "center_in_local_m.x", pad.center_in_local_m.x());
    check.Finite(name + "center_in_local_m.y", pad.center_in_local_m.y());
    check.Positive(name + "side_m", pad.side_m);
    check.InClosed(name + "slope_deg", pad.slope_deg, 0.0, 80.0);
    check.Finite(name + "downhill_azimuth_deg", pad.downhill_azimuth_deg);
  }
}

// Each of extra_craters: a finite centre, a positive diameter, a depth up to half of it.
void ValidateExtraCraters(const TerrainOptions& o, Checker& check) {
  for (size_t i = 0; i < o.extra_craters.size(); ++i) {
    const Crater& crater = o.extra_craters[i];
    const std::string name = "extra_craters[" + std::to_string(i) + "].";
    check.Finite(name + "center_in_local_m.x", crater.center_in_local_m.x());
    check.Finite(name + "center_in_local_m.y", crater.center_in_local_m.y());
    if (check.Positive(name + "diameter_m", crater.diameter_m)) {
      check.InClosed(name + "depth_m", crater.depth_m, 0.0, 0.5 * crater.diameter_m);
    }
  }
}

// Rocks: the law, protrusion and albedo ranges, the count cap over the extent.
void ValidateRockLaw(const TerrainOptions& o, bool extent_ok, Checker& check) {
  bool rock_law_ok = true;
  if (o.rock_law_kind == TerrainOptions::RockLawKind::kPower) {
    rock_law_ok =
        Checker::All({check.NonNegative("rock_k", o.rock_k), check.Negative("rock_exponent", o.rock_exponent)});
  } else {
    rock_law_ok = Checker::All({check.InHalfOpen("rock_area_fraction", o.rock_area_fraction, 0.0, 1.0),
                                check.Positive("rock_q_per_m", o.rock_q_per_m)});
  }
  const bool rock_d_ok =
      Checker::All({check.Positive("rock_d_min_m", o.rock_d_min_m), check.Positive("rock_d_max_m", o.rock_d_max_m)});
  rock_law_ok = rock_law_ok && rock_d_ok &&
                check.Less("rock_d_min_m", o.rock_d_min_m, "rock_d_max_m", o.rock_d_max_m);
  if (Checker::All({check.InHalfOpen("rock_protrusion_min", o.rock_protrusion_min, 0.0, 1.0),
                    check.InHalfOpen("rock_protrusion_max", o.rock_protrusion_max, 0.0, 1.0)})) {
    if (o.rock_protrusion_min > o.rock_protrusion_max) {
      check.Fail("rock_protrusion_min = " + util::ShortestText(o.rock_protrusion_min) +
                 " and rock_protrusion_max = " + util::ShortestText(o.rock_protrusion_max) +
                 ": expected rock_protrusion_min <= rock_protrusion_max");
    }
  }
  if (Checker::All({check.InHalfOpen("rock_albedo", o.rock_albedo, 0.0, 1.0),
                    check.NonNegative("rock_albedo_spread", o.rock_albedo_spread)})) {
    if (o.rock_albedo - o.rock_albedo_spread <= 0.0 || o.rock_albedo + o.rock_albedo_spread > 1.0) {
      check.Fail("rock_albedo = " + util::ShortestText(o.rock_albedo) + " and rock_albedo_spread = " +
                 util::ShortestText(o.rock_albedo_spread) +
                 ": expected the drawn range [albedo - spread, albedo + spread] inside (0, 1]");
    }
  }
  const bool max_rocks_ok =
      check.Check(o.max_rocks >= 0, "max_rocks", static_cast<double>(o.max_rocks), "a value >= 0");
  if (rock_law_ok && extent_ok && max_rocks_ok) {
    const double expected = ExpectedRockCount(o, ExtentAreaM2(o));
    if (std::ceil(expected) > static_cast<double>(o.max_rocks)) {
      check.Fail("rock law gives " + util::ShortestText(expected) + " rocks over " + util::ShortestText(ExtentAreaM2(o)) +
                 " m^2 (" +
                 (o.rock_law_kind == TerrainOptions::RockLawKind::kPower
                      ? "rock_k = " + util::ShortestText(o.rock_k) + ", rock_exponent = " + util::ShortestText(o.rock_exponent)
                      : "rock_area_fraction = " + util::ShortestText(o.rock_area_fraction) +
                            ", rock_q_per_m = " + util::ShortestText(o.rock_q_per_m)) +
                 ", rock_d_min_m = " + util::ShortestText(o.rock_d_min_m) + ", rock_d_max_m = " +
                 util::ShortestText(o.rock_d_max_m) + "): expected at most max_rocks = " +
                 std::to_string(o.max_rocks) + "; raise rock_d_min_m or max_rocks, or lower rock_k");
    }
  }
}

// Each of extra_rocks: a finite centre inside the extent (when the extent is
// usable), a positive radius, a protrusion up to the diameter, an albedo in (0, 1].
void ValidateExtraRocks(const TerrainOptions& o, bool extent_ok, Checker& check) {
  for (size_t i = 0; i < o.extra_rocks.size(); ++i) {
    const Rock& rock = o.extra_rocks[i];
    const std::string name = "extra_rocks[" + std::to_string(i) + "].";
    const double x = rock.center_in_local_m.x();
    const double y = rock.center_in_local_m.y();
    if (Checker::All({check.Finite(name + "center_in_local_m.x", x), check.Finite(name + "center_in_local_m.y", y)})) {
      if (extent_ok && (x < o.min_x_m || x > o.max_x_m || y < o.min_y_m || y > o.max_y_m)) {
        check.Fail(name + "center_in_local_m = (" + util::ShortestText(x) + ", " + util::ShortestText(y) +
                   "): expected inside the extent [" + util::ShortestText(o.min_x_m) + ", " + util::ShortestText(o.max_x_m) +
                   "] x [" + util::ShortestText(o.min_y_m) + ", " + util::ShortestText(o.max_y_m) + "]");
      }
    }
    if (check.Positive(name + "radius_m", rock.radius_m)) {
      check.InHalfOpen(name + "height_above_ground_m", rock.height_above_ground_m, 0.0,
                       2.0 * rock.radius_m);
    }
    check.InHalfOpen(name + "albedo", static_cast<double>(rock.albedo), 0.0, 1.0);
  }
}

// Regolith albedo: mean, variation and an ordered pair of wavelengths.
void ValidateAlbedo(const TerrainOptions& o, Checker& check) {
  check.InHalfOpen("albedo_mean", o.albedo_mean, 0.0, 1.0);
  check.Check(std::isfinite(o.albedo_relative_variation) && o.albedo_relative_variation >= 0.0 &&
                  o.albedo_relative_variation < 1.0,
              "albedo_relative_variation", o.albedo_relative_variation, "a finite value in [0, 1)");
  if (Checker::All({check.Positive("albedo_finest_wavelength_m", o.albedo_finest_wavelength_m),
                    check.Positive("albedo_coarsest_wavelength_m", o.albedo_coarsest_wavelength_m)})) {
    if (o.albedo_finest_wavelength_m > o.albedo_coarsest_wavelength_m) {
      check.Fail("albedo_finest_wavelength_m = " + util::ShortestText(o.albedo_finest_wavelength_m) +
                 " and albedo_coarsest_wavelength_m = " + util::ShortestText(o.albedo_coarsest_wavelength_m) +
                 ": expected albedo_finest_wavelength_m <= albedo_coarsest_wavelength_m");
    }
  }
}

// Throws InputError joining every problem of the options and the thread count.
void ThrowIfInvalid(const TerrainOptions& options, int threads) {
  std::vector<std::string> errors = options.Validate();
  if (threads < 1) errors.push_back("threads = " + std::to_string(threads) + ": expected >= 1");
  hdabench::ThrowIfInvalid("invalid terrain options: ", errors);
}

// Sizes the DEM to cover the extent, all heights zero, and returns its grid.
Grid LayOutDem(const TerrainOptions& o, Heightfield* dem, TerrainSummary* stats) {
  dem->spacing_m = o.spacing_m;
  dem->origin_x_m = o.min_x_m;
  dem->origin_y_m = o.max_y_m;
  dem->width = static_cast<int>(NodesToCover(o.max_x_m - o.min_x_m, o.spacing_m));
  dem->height = static_cast<int>(NodesToCover(o.max_y_m - o.min_y_m, o.spacing_m));
  dem->height_m.assign(static_cast<size_t>(dem->width) * dem->height, 0.0f);
  stats->grid_width = dem->width;
  stats->grid_height = dem->height;
  return Grid{dem->width, dem->height, dem->origin_x_m, dem->origin_y_m, dem->spacing_m};
}

// Craters from the law, over the extent grown by the largest reach, then the
// extra ones; keeps those whose reach touches the grid, in that order, in
// scene->craters, and returns their shapes for carving.
std::vector<CraterShape> DrawCraters(const TerrainOptions& o, std::uint64_t seed, Scene* scene,
                                     TerrainSummary* stats) {
  const Heightfield& dem = scene->dem;
  std::vector<CraterShape> shapes;
  const std::uint64_t crater_seed = Stream(seed, kCraterStream);
  const double margin_m = CraterMarginM(o);
  const double x0 = o.min_x_m - margin_m;
  const double y0 = o.min_y_m - margin_m;
  const double span_x = o.max_x_m - o.min_x_m + 2.0 * margin_m;
  const double span_y = o.max_y_m - o.min_y_m + 2.0 * margin_m;
  stats->crater_placement_area_m2 = span_x * span_y;
  stats->expected_crater_count = ExpectedCount(o.crater_k, o.crater_exponent, o.crater_d_min_m,
                                               o.crater_d_max_m, stats->crater_placement_area_m2);
  stats->craters_drawn = StochasticCount(stats->expected_crater_count, crater_seed);
  const auto add = [&](const Crater& crater) {
    const double radius_m = 0.5 * crater.diameter_m;
    const double reach_m = o.crater_ejecta_extent_radii * radius_m;
    if (DistanceToRect(crater.center_in_local_m.x(), crater.center_in_local_m.y(), dem.MinXM(),
                       dem.MaxXM(), dem.MinYM(), dem.MaxYM()) >= reach_m) {
      return;
    }
    scene->craters.push_back(crater);
    shapes.push_back({crater.center_in_local_m.x(), crater.center_in_local_m.y(), radius_m,
                      crater.depth_m, o.crater_rim_height_to_diameter * crater.diameter_m,
                      reach_m});
  };
  for (std::int64_t i = 0; i < stats->craters_drawn; ++i) {
    const auto index = static_cast<std::uint64_t>(i);
    Crater crater;
    crater.diameter_m = SampleDiameter(HashUniform(crater_seed, index, 0), o.crater_exponent,
                                       o.crater_d_min_m, o.crater_d_max_m);
    crater.center_in_local_m = Eigen::Vector2d(x0 + span_x * HashUniform(crater_seed, index, 1),
                                               y0 + span_y * HashUniform(crater_seed, index, 2));
    const double ratio = o.crater_depth_to_diameter +
                         o.crater_depth_to_diameter_spread *
                             (2.0 * HashUniform(crater_seed, index, 3) - 1.0);
    crater.depth_m = ratio * crater.diameter_m;
    add(crater);
  }
  for (const Crater& crater : o.extra_craters) add(crater);
  stats->craters_in_scene = static_cast<std::int64_t>(scene->craters.size());
  return shapes;
}

// The smooth part of the surface: regional plane plus (when on) scaled fractal relief.
struct SurfaceModel {
  std::uint64_t relief_seed = 0;
  double finest_m = 0.0;
  double largest_wavelength_m = 0.0;
  double hurst = 0.0;
  bool relief_on = false;
  double relief_scale = 0.0;
  double gradient_x = 0.0;  // dz/dx
  double gradient_y = 0.0;  // dz/dy
  // TerrainOptions::extra_pads: their squares and planes (height at the
  // centre, gradient).
  struct PadPlane {
    double min_x, max_x, min_y, max_y;
    double centre_x, centre_y, centre_z;
    double gradient_x, gradient_y;
  };
  std::vector<PadPlane> pads;

  // The plane's height at (x, y): the last pad's that holds it, else the
  // regional plane's.
  double PlaneAt(double x, double y) const {
    for (auto pad = pads.rbegin(); pad != pads.rend(); ++pad) {
      if (x >= pad->min_x && x < pad->max_x && y >= pad->min_y && y < pad->max_y) {
        return pad->centre_z + pad->gradient_x * (x - pad->centre_x) + pad->gradient_y * (y - pad->centre_y);
      }
    }
    return gradient_x * x + gradient_y * y;
  }
};

// The plane and relief of the options, measuring the relief's unit RMS into stats.
SurfaceModel MakeSurfaceModel(const TerrainOptions& o, std::uint64_t seed, TerrainSummary* stats) {
  SurfaceModel surface;
  surface.relief_seed = Stream(seed, kReliefStream);
  surface.finest_m = 2.0 * o.spacing_m;
  surface.largest_wavelength_m = o.relief_largest_wavelength_m;
  surface.hurst = o.relief_hurst;
  surface.relief_on = o.relief_rms_m > 0.0;
  stats->relief_unit_rms =
      surface.relief_on ? UnitReliefRms(surface.relief_seed, surface.finest_m, o.relief_largest_wavelength_m,
                                        o.relief_hurst)
                        : 0.0;
  surface.relief_scale = surface.relief_on ? o.relief_rms_m / stats->relief_unit_rms : 0.0;
  const double tan_slope = std::tan(o.regional_slope_deg * kDegToRad);
  const double azimuth_rad = o.regional_slope_downhill_azimuth_deg * kDegToRad;
  surface.gradient_x = -tan_slope * std::sin(azimuth_rad);
  surface.gradient_y = -tan_slope * std::cos(azimuth_rad);
  for (const TerrainOptions::Pad& pad : o.extra_pads) {
    const double x = pad.center_in_local_m.x(), y = pad.center_in_local_m.y(), half = 0.5 * pad.side_m;
    const double tan_pad = std::tan(pad.slope_deg * kDegToRad);
    const double pad_azimuth_rad = pad.downhill_azimuth_deg * kDegToRad;
    surface.pads.push_back({x - half, x + half, y - half, y + half, x, y,
                            surface.gradient_x * x + surface.gradient_y * y, -tan_pad * std::sin(pad_azimuth_rad),
                            -tan_pad * std::cos(pad_azimuth_rad)});
  }
  return surface;
}

// Rows [row_begin, row_end) of plane + relief into `block` (row-major, full width).
void FillSurfaceBlock(const Grid& grid, const SurfaceModel& surface, int row_begin, int row_end,
                      std::vector<double>* block) {
  block->assign(static_cast<size_t>(row_end - row_begin) * grid.width, 0.0);
  for (int r = row_begin; r < row_end; ++r) {
    const double y = grid.origin_y_m - r * grid.spacing_m;
    double* row = block->data() + static_cast<size_t>(r - row_begin) * grid.width;
    for (int c = 0; c < grid.width; ++c) {
      const double x = grid.origin_x_m + c * grid.spacing_m;
      double z = surface.PlaneAt(x, y);
      if (surface.relief_on) {
        z += surface.relief_scale * FractalNoise(surface.relief_seed, x, y, surface.finest_m,
                                                 surface.largest_wavelength_m, surface.hurst);
      }
      row[c] = z;
    }
  }
}

// Heights, in blocks of rows on `threads` workers: plane + relief + craters,
// then rounded to float into dem->height_m.
void ComputeHeights(const TerrainOptions& o, const Grid& grid, const SurfaceModel& surface,
                    const std::vector<CraterShape>& shapes, int threads, Heightfield* dem) {
  const int block_count = (dem->height + kBlockRows - 1) / kBlockRows;
  util::ParallelFor("terrain blocks", block_count, threads, [&](int b) {
    std::vector<double> block;
    const int row_begin = b * kBlockRows;
    const int row_end = std::min(dem->height, row_begin + kBlockRows);
    FillSurfaceBlock(grid, surface, row_begin, row_end, &block);
    CarveBlock(grid, shapes, o.crater_ejecta_extent_radii, row_begin, row_end, &block);
    std::transform(block.begin(), block.end(),
                   dem->height_m.begin() + static_cast<std::ptrdiff_t>(row_begin) * dem->width,
                   [](double z) { return static_cast<float>(z); });
  });
}

// Rocks from the law over the extent, then the extra ones, each set on the
// finished terrain, into scene->rocks.
void PlaceRocks(const TerrainOptions& o, std::uint64_t seed, Scene* scene, TerrainSummary* stats) {
  const Heightfield& dem = scene->dem;
  const std::uint64_t rock_seed = Stream(seed, kRockStream);
  stats->expected_rock_count = ExpectedRockCount(o, ExtentAreaM2(o));
  stats->rocks_drawn = StochasticCount(stats->expected_rock_count, rock_seed);
  scene->rocks.reserve(static_cast<size_t>(stats->rocks_drawn) + o.extra_rocks.size());
  const auto place = [&](Rock rock) {
    double ground_m = 0.0;
    dem.HeightAt(rock.center_in_local_m.x(), rock.center_in_local_m.y(), &ground_m);
    rock.center_in_local_m.z() = ground_m + rock.height_above_ground_m - rock.radius_m;
    scene->rocks.push_back(rock);
  };
  for (std::int64_t i = 0; i < stats->rocks_drawn; ++i) {
    const auto index = static_cast<std::uint64_t>(i);
    Rock rock;
    const double diameter_m = SampleRockDiameter(HashUniform(rock_seed, index, 0), o);
    rock.radius_m = 0.5 * diameter_m;
    rock.center_in_local_m.x() =
        o.min_x_m + (o.max_x_m - o.min_x_m) * HashUniform(rock_seed, index, 1);
    rock.center_in_local_m.y() =
        o.min_y_m + (o.max_y_m - o.min_y_m) * HashUniform(rock_seed, index, 2);
    const double protrusion =
        o.rock_protrusion_min +
        (o.rock_protrusion_max - o.rock_protrusion_min) * HashUniform(rock_seed, index, 3);
    rock.height_above_ground_m = protrusion * diameter_m;
    rock.albedo = static_cast<float>(
        o.rock_albedo + o.rock_albedo_spread * (2.0 * HashUniform(rock_seed, index, 4) - 1.0));
    place(rock);
  }
  for (const Rock& rock : o.extra_rocks) place(rock);
  stats->rocks_in_scene = static_cast<std::int64_t>(scene->rocks.size());
}

// The regolith albedo field of the options, seeded from the scene seed.
AlbedoField MakeAlbedoField(const TerrainOptions& o, std::uint64_t seed) {
  AlbedoField albedo;
  albedo.mean = o.albedo_mean;
  albedo.relative_variation = o.albedo_relative_variation;
  albedo.finest_wavelength_m = o.albedo_finest_wavelength_m;
  albedo.coarsest_wavelength_m = o.albedo_coarsest_wavelength_m;
  albedo.seed = Stream(seed, kAlbedoStream);
  return albedo;
}

}  // namespace

// ---------------------------------------------------------------------------

std::vector<std::string> TerrainOptions::Validate() const {
  std::vector<std::string> errors;
  Checker check(&errors);
  const ExtentChecks extent = ValidateExtent(*this, check);
  ValidateRelief(*this, extent.spacing_ok, check);
  ValidateCraterLaw(*this, extent.extent_ok, check);
  ValidateExtraCraters(*this, check);
  ValidateExtraPads(*this, check);
  ValidateRockLaw(*this, extent.extent_ok, check);
  ValidateExtraRocks(*this, extent.extent_ok, check);
  ValidateAlbedo(*this, check);
  return errors;
}

std::vector<std::string> RockLawNames() {
  return {"surveyor-1", "viper", "intercrater", "haworth", "exponential-golombek", "exponential-pydem"};
}

void ApplyRockLaw(const std::string& name, TerrainOptions* options) {
  struct PowerLaw {
    const char* name;
    double k;
    double exponent;
  };
  static const PowerLaw kPowerLaws[] = {
      {"surveyor-1", 0.00234, -2.11}, {"viper", 3e-4, -2.482}, {"intercrater", 1e-4, -1.75457}, {"haworth", 2e-3, -2.6607}};
  for (const PowerLaw& law : kPowerLaws) {
    if (name != law.name) continue;
    options->rock_law_kind = TerrainOptions::RockLawKind::kPower;
    options->rock_law = name;
    options->rock_k = law.k;
    options->rock_exponent = law.exponent;
    return;
  }
  if (name == "exponential-golombek" || name == "exponential-pydem") {
    const double k = options->rock_area_fraction;
    if (!(k > 0.0 && k < 1.0)) {
      throw InputError("rock law " + name + " needs rock_area_fraction (the total fraction of area covered by "
                       "rocks) in (0, 1), got " + util::ShortestText(k) + "; set terrain.rock_area_fraction first");
    }
    options->rock_law_kind = TerrainOptions::RockLawKind::kExponentialArea;
    options->rock_law = name;
    options->rock_q_per_m = name == "exponential-golombek" ? 1.79 + 0.152 / k : 1.863 + 0.153 / k;
    return;
  }
  std::string valid;
  for (const std::string& law : RockLawNames()) valid += (valid.empty() ? "" : ", ") + law;
  throw InputError("unknown rock law \"" + name + "\": expected one of " + valid);
}

double CumulativeRocksPerM2(const TerrainOptions& o, double d_m) {
  if (o.rock_law_kind == TerrainOptions::RockLawKind::kPower) return o.rock_k * std::pow(d_m, o.rock_exponent);
  // dF = -(pi D^2 / 4) dN: N(>=D) = integral over x >= D of (4 k q / pi) exp(-q x) / x^2 dx,
  // and integral exp(-q x) / x^2 = exp(-q D) / D - q E1(q D), E1(z) = -Ei(-z).
  const double k = o.rock_area_fraction;
  const double q = o.rock_q_per_m;
  const double qd = q * d_m;
  const double e1 = -std::expint(-qd);
  return 4.0 * k * q / util::kPi * (std::exp(-qd) / d_m - q * e1);
}

std::vector<std::string> TerrainPresetNames() { return {"mare", "cratered", "rocky", "flank", "boulders"}; }

TerrainOptions TerrainPreset(const std::string& name) {
  TerrainOptions options;
  if (name == "mare") {
    // Smooth mature mare: low relief, a sparse crater population, few rocks.
    options.relief_rms_m = 0.2;
    options.crater_k = 0.01;
    ApplyRockLaw("intercrater", &options);  // the sparsest of the named laws
  } else if (name == "cratered") {
    // Craters at the empirical equilibrium density N(>=D) = 10^-1.1 D^-2 (after
    // Gault 1970; not verified here), many of them degraded (shallower).
    options.relief_rms_m = 0.3;
    options.crater_k = 0.08;
    options.crater_depth_to_diameter = 0.12;
    options.crater_depth_to_diameter_spread = 0.07;
    ApplyRockLaw("viper", &options);
  } else if (name == "flank") {
    // The flank of a massif or a large crater's wall, as at the south-pole
    // sites: a regional slope of 8 deg under relief of 0.8 m RMS up to
    // 128 m wavelengths, so that the sites' slopes spread over about
    // 5-20 deg, across the lander's 10 deg limit (docs/synthetic-scenes.md,
    // "Terrain"). It falls toward the east, where the default sun is: at a
    // 9 deg sun, ground falling away from the sun by more than 9 deg lies in
    // shadow, and the quadtree never offers it.
    options.relief_rms_m = 0.8;
    options.relief_largest_wavelength_m = 128.0;
    options.regional_slope_deg = 8.0;
    options.regional_slope_downhill_azimuth_deg = 90.0;
    options.crater_k = 0.03;
    ApplyRockLaw("viper", &options);
  } else if (name == "boulders") {
    // A boulder field such as the helicopter campaign's at KSC: rocks cover
    // 12 % of the ground, by the exponential law of pydem (q = 1.863 +
    // 0.153 / k), so that many are 0.2-1 m across, around the lander's
    // 0.30 m clearance (docs/synthetic-scenes.md, "Terrain"). The cover is
    // an assumption: no source gives KSC's.
    options.relief_rms_m = 0.3;
    options.crater_k = 0.03;
    options.rock_area_fraction = 0.12;
    ApplyRockLaw("exponential-pydem", &options);
  } else if (name == "rocky") {
    // A blocky surface such as the surroundings of a fresh crater.
    options.relief_rms_m = 0.3;
    options.crater_k = 0.03;
    ApplyRockLaw("surveyor-1", &options);  // the rockiest of the named laws at 0.2-10 m
  } else {
    std::string valid;
    for (const std::string& preset : TerrainPresetNames()) {
      valid += (valid.empty() ? "" : ", ") + preset;
    }
    throw InputError("unknown terrain preset \"" + name + "\": expected one of " + valid);
  }
  return options;
}

std::string TerrainSummary::Summary() const {
  std::ostringstream out;
  out.precision(6);
  out << "terrain " << grid_width << " x " << grid_height << " nodes, " << craters_drawn
      << " craters drawn (expected " << expected_crater_count << "), " << craters_in_scene
      << " in the scene, " << rocks_drawn << " rocks drawn (expected " << expected_rock_count
      << "), " << rocks_in_scene << " in the scene, " << threads << " thread"
      << (threads == 1 ? "" : "s") << ", " << wall_s << " s";
  return out.str();
}

double CraterHeightChange(double r_m, double radius_m, double depth_m, double rim_height_m,
                          double ejecta_extent_radii) {
  const double rho = r_m / radius_m;
  if (rho <= 1.0) return -depth_m + (depth_m + rim_height_m) * rho * rho;
  if (rho >= ejecta_extent_radii) return 0.0;
  const double tail = 1.0 / (ejecta_extent_radii * ejecta_extent_radii * ejecta_extent_radii);
  return rim_height_m * (1.0 / (rho * rho * rho) - tail) / (1.0 - tail);
}

Scene GenerateScene(const TerrainOptions& options, std::uint64_t seed, int threads,
                    TerrainSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  ThrowIfInvalid(options, threads);
  TerrainSummary stats;
  stats.threads = threads;

  Scene scene;
  const Grid grid = LayOutDem(options, &scene.dem, &stats);
  const std::vector<CraterShape> shapes = DrawCraters(options, seed, &scene, &stats);
  const SurfaceModel surface = MakeSurfaceModel(options, seed, &stats);
  ComputeHeights(options, grid, surface, shapes, threads, &scene.dem);
  PlaceRocks(options, seed, &scene, &stats);
  scene.albedo = MakeAlbedoField(options, seed);

  stats.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (summary != nullptr) *summary = stats;
  return scene;
}

double FitCumulativePowerLawExponent(const std::vector<double>& diameters_m, double d_min_m,
                                     double d_max_m) {
  if (!(std::isfinite(d_min_m) && std::isfinite(d_max_m) && d_min_m > 0.0 &&
        d_min_m < d_max_m)) {
    throw InputError("FitCumulativePowerLawExponent: d_min_m = " + util::ShortestText(d_min_m) +
                     " and d_max_m = " + util::ShortestText(d_max_m) +
                     ": expected finite values with 0 < d_min_m < d_max_m");
  }
  std::vector<double> sorted = diameters_m;
  for (size_t i = 0; i < sorted.size(); ++i) {
    if (!std::isfinite(sorted[i])) {
      throw InputError("FitCumulativePowerLawExponent: diameters_m[" + std::to_string(i) +
                       "] = " + util::ShortestText(sorted[i]) + ": expected a finite value");
    }
  }
  std::sort(sorted.begin(), sorted.end());
  // Weighted least squares: var(log N) ~ 1 / N for a counted N, so weight N.
  double sum_w = 0.0, sum_x = 0.0, sum_y = 0.0, sum_xx = 0.0, sum_xy = 0.0;
  int used = 0;
  for (int j = 0; j < kFitPoints; ++j) {
    const double d_m = j == kFitPoints - 1
                           ? d_max_m
                           : d_min_m * std::pow(d_max_m / d_min_m, j / (kFitPoints - 1.0));
    const auto count = sorted.end() - std::lower_bound(sorted.begin(), sorted.end(), d_m);
    if (count < kFitMinCount) continue;
    const double w = static_cast<double>(count);
    const double x = std::log(d_m);
    const double y = std::log(w);
    sum_w += w;
    sum_x += w * x;
    sum_y += w * y;
    sum_xx += w * x * x;
    sum_xy += w * x * y;
    ++used;
  }
  if (used < 2) {
    throw InputError("FitCumulativePowerLawExponent: " + std::to_string(used) + " of the " +
                     std::to_string(kFitPoints) + " log-spaced diameters in [" + util::ShortestText(d_min_m) +
                     ", " + util::ShortestText(d_max_m) + "] m have " + std::to_string(kFitMinCount) +
                     " or more of the " + std::to_string(diameters_m.size()) +
                     " diameters at or above them: expected at least 2");
  }
  return (sum_w * sum_xy - sum_x * sum_y) / (sum_w * sum_xx - sum_x * sum_x);
}

}  // namespace hdabench::datasets::synth
