// Procedural lunar terrain: a heightfield with fractal relief, a regional
// slope and craters, partly buried rocks on it, and the regolith albedo field.
// Frames follow docs/conventions.md: local = ENU at the ILS, z up, metres.
//
// Everything is a pure function of (options, seed): the same inputs give a
// bit-identical Scene for any thread count and on any machine (noise.h hashes,
// no std:: distributions, which differ between standard libraries).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "datasets/synth/scene.h"

namespace hdabench::datasets::synth {

// Parameters of GenerateScene. Size-frequency laws are cumulative power laws
//   N(>=D) = k * D^exponent   [count per square metre, D in metres],
// truncated to [d_min, d_max]: only bodies with d_min <= D <= d_max are made,
// so the generated population has N(>=D) = k * (D^exponent - d_max^exponent)
// per m^2 for D in [d_min, d_max] (the part of the law above d_max is left
// out; choose d_max where k * d_max^exponent * area is below one body to make
// that negligible).
//
// Counts: the expected count lambda = k * (d_min^exponent - d_max^exponent) *
// area is rounded stochastically (floor(lambda), plus one with probability
// frac(lambda)). That keeps the expectation exact and the code portable; the
// count does not have the sqrt(lambda) scatter of a Poisson field.
// Diameters: inverse-CDF sampling of the truncated law; positions uniform.
struct TerrainOptions {
  // ---- Extent, local frame. The grid starts at node (min_x_m, max_y_m) (the
  // north-west corner) and covers the extent: its last column / row may lie up
  // to one spacing_m beyond max_x_m / below min_y_m.
  double min_x_m = -50.0;  // western edge, metres
  double max_x_m = 50.0;   // eastern edge, metres
  double min_y_m = -50.0;  // southern edge, metres
  double max_y_m = 50.0;   // northern edge, metres
  double spacing_m = 0.25;  // distance between grid nodes, metres

  // ---- Fractal relief: FractalNoise (noise.h) from
  // relief_largest_wavelength_m down to 2 * spacing_m, octave amplitudes
  // proportional to wavelength^relief_hurst (fractional Brownian surface).
  // Lunar topography is self-affine with a Hurst exponent of about 0.7-0.95
  // at metre baselines (after Rosenburg et al. 2011, LOLA; not verified here).
  double relief_rms_m = 0.3;  // standard deviation of the relief, metres, over areas much larger
                              // than the largest wavelength (a smaller patch shows less); 0 = off
  double relief_hurst = 0.8;  // Hurst exponent H in [0, 1]: amplitude ~ wavelength^H
  double relief_largest_wavelength_m = 64.0;  // coarsest octave, metres

  // ---- Regional slope: a plane through the local origin,
  //   z = -tan(slope) * (x * sin(azimuth) + y * cos(azimuth)).
  double regional_slope_deg = 0.0;  // slope of the plane, degrees in [0, 80]
  double regional_slope_downhill_azimuth_deg = 0.0;  // downhill direction, degrees from north
                                                     // clockwise toward east (90 = east)

  // ---- Craters. Default law: exponent -2, the steady-state population of
  // small lunar craters (after Moore, Boyce & Hahn 1980; not verified here);
  // k = 0.03 is about 40% of the empirical equilibrium density
  // N(>=D) = 10^-1.1 D^-2 (after Gault 1970; not verified here): a moderately
  // cratered mare.
  // Shape (CraterHeightChange): parabolic bowl, raised rim, ejecta blanket
  // decaying as (r/R)^-3 out to crater_ejecta_extent_radii * R.
  // Craters are placed over the extent grown on every side by the reach of the
  // largest one (crater_ejecta_extent_radii * crater_d_max_m / 2), so the
  // density is the same at the edges; the law's count is over that area.
  double crater_k = 0.03;          // k of N(>=D) = k D^exponent, craters per m^2 (D in m); 0 = off
  double crater_exponent = -2.0;   // exponent of the cumulative law, < 0
  double crater_d_min_m = 1.0;     // smallest crater diameter, metres (about 4 spacings or more)
  double crater_d_max_m = 50.0;    // largest crater diameter, metres
  // Depth of the floor below the pre-impact surface over the diameter
  // (Crater::depth_m / diameter_m). Each crater draws its ratio uniformly in
  // [value - spread, value + spread]: [0.10, 0.20] by default, i.e. a
  // rim-to-floor depth of 0.14-0.24 D with the rim, bracketing ~0.2 D of fresh
  // simple craters and shallower degraded ones (after Pike 1977; not verified here).
  double crater_depth_to_diameter = 0.15;         // mean floor depth / D
  double crater_depth_to_diameter_spread = 0.05;  // half-width of the uniform draw, >= 0
  double crater_rim_height_to_diameter = 0.04;    // rim crest above the pre-impact surface / D
                                                  // (~0.036 D for fresh craters, after Pike 1977;
                                                  // not verified here)
  double crater_ejecta_extent_radii = 3.0;  // ejecta reach in crater radii (> 1); the (r/R)^-3
                                            // thickness law is after McGetchin et al. 1973
                                            // (not verified here)
  // Craters added after the law's, in this order (e.g. a known hazard near the
  // ILS). Their depth_m is used as given; the rim follows the ratio above.
  std::vector<Crater> extra_craters;

  // Square pads of their own slope set into the regional plane (a landing
  // site of one slope inside surroundings of another): inside a pad (its
  // sides along x and y), the regional plane is replaced by the pad's, which
  // passes through the regional plane's height at the pad's centre; the
  // relief and the craters are kept. The edges are steps where the planes
  // part. Applied in this order (a later pad wins where two overlap).
  struct Pad {
    Eigen::Vector2d center_in_local_m = Eigen::Vector2d::Zero();
    double side_m = 10.0;                 // > 0
    double slope_deg = 0.0;               // in [0, 80]
    double downhill_azimuth_deg = 0.0;    // degrees from north, as regional_slope_downhill_azimuth_deg
  };
  std::vector<Pad> extra_pads;

  // ---- Rocks: spheres partly buried, uniform over the extent (they may
  // overlap each other), with diameters from a size-frequency law
  // (docs/synthetic-scenes.md "Rocks"; the named laws: RockLawNames()).
  //  kPower: the cumulative number per m^2 with diameter >= D (m) is
  //   N(>=D) = rock_k D^rock_exponent.
  //  kExponentialArea: the cumulative fractional area covered by rocks of
  //   diameter >= D is F(D) = rock_area_fraction exp(-rock_q_per_m D)
  //   (Golombek-type), so N(>=D) = (4 k q / pi) (exp(-q D) / D - q E1(q D)).
  // Default: the VIPER specification's power law (rock_law "viper").
  enum class RockLawKind { kPower, kExponentialArea };
  RockLawKind rock_law_kind = RockLawKind::kPower;
  std::string rock_law = "viper";  // the named law ApplyRockLaw last set (for the record); `--set`
                                   // of a rock law number makes it "custom"
  double rock_k = 3e-4;           // kPower: k of N(>=D) = k D^exponent, rocks per m^2 (D in m); 0 = off
  double rock_exponent = -2.482;  // kPower: exponent of the cumulative law, < 0
  double rock_area_fraction = 0.0;  // kExponentialArea: k, the total fraction of area covered, [0, 1)
  double rock_q_per_m = 0.0;        // kExponentialArea: q, per metre, > 0
  double rock_d_min_m = 0.2;      // smallest rock diameter, metres
  double rock_d_max_m = 10.0;     // largest rock diameter, metres
  // Each rock's cap protrudes a fraction of its diameter drawn uniformly in
  // [min, max]: height_above_ground_m = fraction * D, measured from the
  // terrain (the triangulated surface) under the centre.
  double rock_protrusion_min = 0.3;  // fraction of D, in (0, 1]
  double rock_protrusion_max = 0.7;  // fraction of D, in [rock_protrusion_min, 1]
  double rock_albedo = 0.15;         // mean normal albedo of rocks (fresh blocks are brighter than
                                     // mature mare regolith)
  double rock_albedo_spread = 0.03;  // each rock's albedo is uniform in rock_albedo -/+ this
  // Rocks added after the law's. center_in_local_m x and y, radius_m,
  // height_above_ground_m (in (0, 2 * radius_m]) and albedo are used; z is set
  // from the terrain. Each must lie inside the extent.
  std::vector<Rock> extra_rocks;

  // ---- Regolith albedo (Scene::albedo; its seed derives from the scene seed).
  double albedo_mean = 0.12;                 // mean normal albedo (mare ~0.07-0.12, highlands ~0.2)
  double albedo_relative_variation = 0.25;   // peak-to-mean fraction of the fractal variation,
                                             // in [0, 1)
  double albedo_finest_wavelength_m = 0.5;   // smallest texture feature, metres
  double albedo_coarsest_wavelength_m = 64.0;  // largest texture feature, metres

  // ---- Caps: Validate() refuses options that exceed them (never a truncated law).
  std::int64_t max_nodes = 100'000'000;  // grid nodes (4 bytes each, plus 8 while generating)
  std::int64_t max_craters = 1'000'000;  // craters drawn from the law over the placement area
  std::int64_t max_rocks = 2'000'000;    // rocks drawn from the law over the extent

  // Every violated constraint, one message each: "<field> = <value>: expected
  // <what>". Empty when the options are usable.
  std::vector<std::string> Validate() const;
};

// The named rock laws, ApplyRockLaw's names.
std::vector<std::string> RockLawNames();
// Sets the rock law fields of `options` to a named law (RockLawNames()):
//  "surveyor-1"   N(>=D) = 0.00234 D^-2.11 (Surveyor I site, Flamsteed, mare)
//  "viper"        N(>=D) = 3e-4 D^-2.482 (VIPER-MSE-SPEC-001)
//  "intercrater"  N(>=D) = 1e-4 D^-1.75457
//  "haworth"      N(>=D) = 2e-3 D^-2.6607
//  "exponential-golombek"  F(D) = k exp(-(1.79 + 0.152 / k) D)
//  "exponential-pydem"     F(D) = k exp(-(1.863 + 0.153 / k) D)
// For the exponential laws k is options->rock_area_fraction (set it first;
// 0 is refused). Throws InputError for an unknown name (listing the names)
// or an exponential law without k in (0, 1).
void ApplyRockLaw(const std::string& name, TerrainOptions* options);
// The law's cumulative number of rocks per m^2 with diameter >= d_m.
double CumulativeRocksPerM2(const TerrainOptions& options, double d_m);

// Named presets; the caller sets the extent afterwards. "mare": smooth, few
// craters and rocks; "cratered": craters at the empirical equilibrium density;
// "rocky": a blocky surface (rocks ~7 times the default density).
// Throws InputError for an unknown name, listing the valid ones.
TerrainOptions TerrainPreset(const std::string& name);
std::vector<std::string> TerrainPresetNames();

// What GenerateScene did.
struct TerrainSummary {
  int grid_width = 0;                 // nodes along x
  int grid_height = 0;                // nodes along y
  double crater_placement_area_m2 = 0.0;  // extent grown by the largest crater's reach
  double expected_crater_count = 0.0;     // the law's expectation over that area
  std::int64_t craters_drawn = 0;         // from the law, over that area
  std::int64_t craters_in_scene = 0;      // drawn + extra craters that reach the grid
  double expected_rock_count = 0.0;       // the law's expectation over the extent
  std::int64_t rocks_drawn = 0;           // from the law
  std::int64_t rocks_in_scene = 0;        // drawn + extra rocks
  double relief_unit_rms = 0.0;  // RMS of the unit FractalNoise the relief is scaled by (0 if off)
  int threads = 1;
  double wall_s = 0.0;          // wall time of GenerateScene
  std::string Summary() const;   // one line
};

// Generates the scene: heights = regional plane + fractal relief + craters
// (law's, then extra_craters, each added to the surface in that fixed order),
// then rocks placed on the finished terrain, and the albedo field.
// Rows are computed in blocks on `threads` threads (util::ParallelFor, the
// caller being one of them); each node's value is a
// pure function of the seed and its coordinates, so the result is bit-identical
// for any thread count. Throws InputError listing every Validate() message
// (joined by "; ") when the options are invalid, or when threads < 1.
Scene GenerateScene(const TerrainOptions& options, std::uint64_t seed, int threads = 1,
                    TerrainSummary* summary = nullptr);

// Height change of a crater of radius R, floor depth d (below the pre-impact
// surface) and rim height h at distance r from its centre, rho = r / R:
//   rho <= 1:             -d + (d + h) * rho^2                      (bowl up to the rim crest)
//   1 < rho < e:          h * (rho^-3 - e^-3) / (1 - e^-3)          (ejecta, zero at rho = e)
//   rho >= e:             0
// with e = ejecta_extent_radii (> 1). Continuous; metres.
double CraterHeightChange(double r_m, double radius_m, double depth_m, double rim_height_m,
                          double ejecta_extent_radii);

// Exponent of a cumulative power law fitted to a sample of diameters:
// N(>=D) is counted at 20 log-spaced diameters D_j from d_min_m to d_max_m
// (inclusive), and the slope of log N(>=D_j) against log D_j is fitted by
// least squares over the D_j with N(>=D_j) >= 10, each point weighted by
// N(>=D_j) (the Poisson variance of log N is ~1/N; unweighted, the few-body
// tail points scatter the slope 3-4 times more). A sample truncated at d_max
// bends down near d_max; see TerrainOptions. Throws InputError when
// d_min_m, d_max_m are not finite with 0 < d_min_m < d_max_m, or when fewer
// than 2 of the D_j have 10 or more diameters at or above them.
double FitCumulativePowerLawExponent(const std::vector<double>& diameters_m, double d_min_m,
                                     double d_max_m);

}  // namespace hdabench::datasets::synth
