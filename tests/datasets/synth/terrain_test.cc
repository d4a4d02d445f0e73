// Tests of the terrain generator (datasets/synth/terrain.h): the rock
// size-frequency law, crater shape, regional slope, relief amplitude,
// determinism across seeds and thread counts, and the exact messages for bad
// options.
#include "datasets/synth/terrain.h"

#include <cmath>
#include <cstring>
#include <iostream>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Dense>
#include <gtest/gtest.h>

#include "tools/util/error.h"
#include "tests/support/test_support.h"
#include "tools/util/angles.h"

namespace hdabench::datasets::synth {
namespace {

using util::kPi;

using testing_support::CurrentTestSeed;


// Options with every feature off: a flat, level, empty terrain.
TerrainOptions FlatOptions(double half_width_m, double spacing_m) {
  TerrainOptions options;
  options.min_x_m = -half_width_m;
  options.max_x_m = half_width_m;
  options.min_y_m = -half_width_m;
  options.max_y_m = half_width_m;
  options.spacing_m = spacing_m;
  options.relief_rms_m = 0.0;
  options.crater_k = 0.0;
  options.rock_k = 0.0;
  return options;
}

double NodeX(const Heightfield& dem, int c) { return dem.origin_x_m + c * dem.spacing_m; }
double NodeY(const Heightfield& dem, int r) { return dem.origin_y_m - r * dem.spacing_m; }

double HeightAtOrDie(const Heightfield& dem, double x_m, double y_m) {
  double z_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(dem.HeightAt(x_m, y_m, &z_m)) << "(" << x_m << ", " << y_m << ") is off the grid";
  return z_m;
}

// ---------------------------------------------------------------------------
// Rocks

struct RockLawCase {
  double k;
  double exponent;
  double d_min_m;
  double d_max_m;
  double half_width_m;
};

TEST(RockLaw, NamedLawsHaveTheCitedValues) {
  TerrainOptions o;
  const struct {
    const char* name;
    double k;
    double exponent;
  } laws[] = {{"surveyor-1", 0.00234, -2.11}, {"viper", 3e-4, -2.482}, {"intercrater", 1e-4, -1.75457},
              {"haworth", 2e-3, -2.6607}};
  for (const auto& law : laws) {
    ApplyRockLaw(law.name, &o);
    EXPECT_EQ(o.rock_law, law.name);
    EXPECT_NEAR(CumulativeRocksPerM2(o, 1.0), law.k, 1e-15) << law.name;
    EXPECT_NEAR(CumulativeRocksPerM2(o, 0.5), law.k * std::pow(0.5, law.exponent), 1e-12) << law.name;
  }
  // The default terrain (cratered) is the VIPER specification's law.
  EXPECT_EQ(TerrainPreset("cratered").rock_law, "viper");
  // Exponential area laws: q(k) as cited.
  o.rock_area_fraction = 0.1;
  ApplyRockLaw("exponential-golombek", &o);
  EXPECT_NEAR(o.rock_q_per_m, 1.79 + 0.152 / 0.1, 1e-12);
  ApplyRockLaw("exponential-pydem", &o);
  EXPECT_NEAR(o.rock_q_per_m, 1.863 + 0.153 / 0.1, 1e-12);
  // N(>=D) of the exponential law against the numerical integral of
  // dN = (4 / (pi x^2)) k q exp(-q x) dx.
  for (const double d_m : {0.1, 0.5, 2.0}) {
    double sum = 0.0;
    const double step = 1e-4;
    for (double x = d_m + step / 2; x < d_m + 30.0; x += step) {
      sum += 4.0 / (kPi * x * x) * o.rock_area_fraction * o.rock_q_per_m * std::exp(-o.rock_q_per_m * x) * step;
    }
    EXPECT_NEAR(CumulativeRocksPerM2(o, d_m), sum, 1e-6 * sum) << d_m;
  }
  // An exponential law needs k; an unknown name lists the known ones.
  o.rock_area_fraction = 0.0;
  EXPECT_THROW(ApplyRockLaw("exponential-golombek", &o), InputError);
  try {
    ApplyRockLaw("surveyor", &o);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "unknown rock law \"surveyor\": expected one of surveyor-1, viper, intercrater, haworth, "
                           "exponential-golombek, exponential-pydem");
  }
}

TEST(GenerateScene, ExponentialAreaLawCoversTheFractionItStates) {
  TerrainOptions options = FlatOptions(150.0, 1.0);
  options.rock_area_fraction = 0.1;
  ApplyRockLaw("exponential-golombek", &options);
  options.rock_d_min_m = 0.1;
  options.rock_d_max_m = 10.0;
  TerrainSummary summary;
  const Scene scene = GenerateScene(options, CurrentTestSeed(), 1, &summary);
  const double area_m2 = 300.0 * 300.0;
  // The fraction of the area covered by rocks of D >= d (circles of D) against
  // F(d) = k exp(-q d), for d where thousands of rocks carry it.
  for (const double d_m : {0.1, 0.3, 0.6}) {
    double covered = 0.0;
    for (const Rock& rock : scene.rocks) {
      if (2.0 * rock.radius_m >= d_m) covered += kPi * rock.radius_m * rock.radius_m;
    }
    const double expected = 0.1 * std::exp(-options.rock_q_per_m * d_m);
    EXPECT_NEAR(covered / area_m2, expected, 0.05 * expected) << "d " << d_m;
  }
}

TEST(GenerateScene, RockPopulationFollowsConfiguredLaw) {
  // d_max is chosen where the law's tail above it, k * d_max^r * area, is
  // below one rock, so truncation does not bend the fitted range.
  const RockLawCase cases[] = {
      {0.002, -2.0, 0.2, 50.0, 500.0},   // ~50000 rocks over 1 km^2
      {0.0005, -2.5, 0.1, 10.0, 250.0},  // ~39500 rocks over 0.25 km^2
  };
  for (int i = 0; i < 2; ++i) {
    const RockLawCase& law = cases[i];
    const std::uint64_t seed = CurrentTestSeed() + static_cast<std::uint64_t>(i);
    SCOPED_TRACE("case " + std::to_string(i) + ", seed " + std::to_string(seed));
    TerrainOptions options = FlatOptions(law.half_width_m, 1.0);
    options.rock_k = law.k;
    options.rock_exponent = law.exponent;
    options.rock_d_min_m = law.d_min_m;
    options.rock_d_max_m = law.d_max_m;
    TerrainSummary summary;
    const Scene scene = GenerateScene(options, seed, 1, &summary);

    std::vector<double> diameters_m;
    for (const Rock& rock : scene.rocks) {
      const double d_m = 2.0 * rock.radius_m;
      diameters_m.push_back(d_m);
      ASSERT_GE(d_m, law.d_min_m);
      ASSERT_LE(d_m, law.d_max_m);
      ASSERT_GE(rock.center_in_local_m.x(), options.min_x_m);
      ASSERT_LE(rock.center_in_local_m.x(), options.max_x_m);
      ASSERT_GE(rock.center_in_local_m.y(), options.min_y_m);
      ASSERT_LE(rock.center_in_local_m.y(), options.max_y_m);
      // Burial: the cap protrudes 30-70% of D above the (flat, z = 0) ground.
      ASSERT_GE(rock.height_above_ground_m, 0.3 * d_m - 1e-12);
      ASSERT_LE(rock.height_above_ground_m, 0.7 * d_m + 1e-12);
      ASSERT_NEAR(rock.center_in_local_m.z() + rock.radius_m, rock.height_above_ground_m, 1e-9);
    }

    // Exponent of N(>=D) over the configured range. Over 30 other seeds the
    // fit scattered by 0.01-0.016 (1 sigma) at these sample sizes, worst 0.03;
    // 0.1 is the requirement.
    const double fitted = FitCumulativePowerLawExponent(diameters_m, law.d_min_m, law.d_max_m);
    std::cout << "[ fitted   ] case " << i << ": " << scene.rocks.size()
              << " rocks, fitted exponent " << fitted << " (configured " << law.exponent
              << ")\n";
    EXPECT_NEAR(fitted, law.exponent, 0.1);

    // Count of rocks >= d_min against k * d_min^r * area. The generator rounds
    // the truncated law's expectation stochastically (no Poisson scatter), so
    // the count differs from the untruncated law only by the tail above d_max
    // (k * d_max^r * area, < 1 here) and the rounding (< 1).
    const double area_m2 = (options.max_x_m - options.min_x_m) * (options.max_y_m - options.min_y_m);
    const double untruncated = law.k * std::pow(law.d_min_m, law.exponent) * area_m2;
    const double tail = law.k * std::pow(law.d_max_m, law.exponent) * area_m2;
    ASSERT_LT(tail, 1.0);
    EXPECT_LE(std::abs(static_cast<double>(scene.rocks.size()) - untruncated), tail + 1.0)
        << "expected " << untruncated;
    EXPECT_EQ(summary.rocks_drawn, static_cast<std::int64_t>(scene.rocks.size()));
    EXPECT_NEAR(summary.expected_rock_count, untruncated - tail, 1e-6 * untruncated);
  }
}

TEST(GenerateScene, RocksRestOnTheTerrainUnderTheirCentre) {
  TerrainOptions options = FlatOptions(20.0, 0.25);
  options.regional_slope_deg = 10.0;
  options.regional_slope_downhill_azimuth_deg = 30.0;
  options.relief_rms_m = 0.2;
  options.relief_largest_wavelength_m = 16.0;
  options.rock_k = 0.01;
  Rock extra;
  extra.center_in_local_m = Eigen::Vector3d(1.3, -2.7, 99.0);  // z is replaced
  extra.radius_m = 0.8;
  extra.height_above_ground_m = 0.5;
  extra.albedo = 0.2f;
  options.extra_rocks.push_back(extra);
  const Scene scene = GenerateScene(options, CurrentTestSeed());
  ASSERT_GT(scene.rocks.size(), 10u);
  for (size_t i = 0; i < scene.rocks.size(); ++i) {
    const Rock& rock = scene.rocks[i];
    const double ground_m =
        HeightAtOrDie(scene.dem, rock.center_in_local_m.x(), rock.center_in_local_m.y());
    EXPECT_NEAR(rock.center_in_local_m.z() + rock.radius_m - rock.height_above_ground_m, ground_m,
                1e-9);
    if (i + 1 < scene.rocks.size()) {  // the law's rocks: albedo 0.15 -/+ 0.03
      EXPECT_GE(rock.albedo, 0.12f);
      EXPECT_LE(rock.albedo, 0.18f);
    }
  }
  const Rock& last = scene.rocks.back();
  EXPECT_EQ(last.center_in_local_m.x(), 1.3);
  EXPECT_EQ(last.radius_m, 0.8);
  EXPECT_EQ(last.height_above_ground_m, 0.5);
  EXPECT_EQ(last.albedo, 0.2f);
}

// ---------------------------------------------------------------------------
// Pads

TEST(GenerateScene, APadHasItsOwnSlopeInsideTheRegionalPlane) {
  // A 20 m pad at (5, -5) sloping 3 deg down to the east, in a plane sloping
  // 10 deg down to the east; the pad's plane meets the regional one at its
  // centre.
  TerrainOptions options = FlatOptions(40.0, 0.25);
  options.regional_slope_deg = 10.0;
  options.regional_slope_downhill_azimuth_deg = 90.0;
  TerrainOptions::Pad pad;
  pad.center_in_local_m = Eigen::Vector2d(5.0, -5.0);
  pad.side_m = 20.0;
  pad.slope_deg = 3.0;
  pad.downhill_azimuth_deg = 90.0;
  options.extra_pads.push_back(pad);
  const Scene scene = GenerateScene(options, CurrentTestSeed());
  const double tan10 = std::tan(10.0 * kPi / 180.0), tan3 = std::tan(3.0 * kPi / 180.0);
  EXPECT_NEAR(HeightAtOrDie(scene.dem, 5.0, -5.0), -tan10 * 5.0, 1e-5);
  EXPECT_NEAR(HeightAtOrDie(scene.dem, 12.0, -5.0), -tan10 * 5.0 - tan3 * 7.0, 1e-5);  // inside
  EXPECT_NEAR(HeightAtOrDie(scene.dem, 0.0, 2.0), -tan10 * 5.0 + tan3 * 5.0, 1e-5);
  EXPECT_NEAR(HeightAtOrDie(scene.dem, 20.0, -5.0), -tan10 * 20.0, 1e-5);  // outside
  EXPECT_NEAR(HeightAtOrDie(scene.dem, 5.0, 10.0), -tan10 * 5.0, 1e-5);
  // Bad pads are named.
  options.extra_pads[0].side_m = 0.0;
  options.extra_pads[0].slope_deg = 95.0;
  const std::vector<std::string> errors = options.Validate();
  ASSERT_EQ(errors.size(), 2u);
  EXPECT_NE(errors[0].find("extra_pads[0].side_m"), std::string::npos) << errors[0];
  EXPECT_NE(errors[1].find("extra_pads[0].slope_deg"), std::string::npos) << errors[1];
}

// ---------------------------------------------------------------------------
// Craters

TEST(GenerateScene, SingleCraterOnFlatTerrainHasBowlRimAndEjecta) {
  // One 20 m crater at the origin, on a node; floor depth 0.15 D, rim 0.04 D.
  TerrainOptions options = FlatOptions(40.0, 0.25);
  const double diameter_m = 20.0;
  const double radius_m = 10.0;
  Crater crater;
  crater.center_in_local_m = Eigen::Vector2d(0.0, 0.0);
  crater.diameter_m = diameter_m;
  crater.depth_m = 0.15 * diameter_m;
  options.extra_craters.push_back(crater);
  const Scene scene = GenerateScene(options, CurrentTestSeed());
  ASSERT_EQ(scene.craters.size(), 1u);
  const Heightfield& dem = scene.dem;

  // Depth: the floor at the centre, measured from the flat surroundings (0).
  const double floor_m = HeightAtOrDie(dem, 0.0, 0.0);
  const double depth_to_diameter = -floor_m / diameter_m;
  EXPECT_GE(depth_to_diameter, 0.1);
  EXPECT_LE(depth_to_diameter, 0.2);
  EXPECT_NEAR(-floor_m, crater.depth_m, 1e-5);  // float heights

  // Along 8 radii: the highest point is the rim crest at r = R, 0.04 D above
  // the surroundings; the interior rises monotonically to it and the ejecta
  // falls monotonically beyond it, like (r/R)^-3, reaching 0 at 3 R.
  const double rim_m = 0.04 * diameter_m;
  for (int k = 0; k < 8; ++k) {
    const double angle = k * kPi / 4.0;
    const Eigen::Vector2d direction(std::cos(angle), std::sin(angle));
    SCOPED_TRACE("azimuth index " + std::to_string(k));
    double highest_m = -1e9;
    double highest_at_rho = 0.0;
    double previous_m = floor_m;
    for (int step = 1; step <= 70; ++step) {
      const double rho = 0.05 * step;
      const Eigen::Vector2d p = rho * radius_m * direction;
      const double z_m = HeightAtOrDie(dem, p.x(), p.y());
      if (z_m > highest_m) {
        highest_m = z_m;
        highest_at_rho = rho;
      }
      if (rho < 0.97) {
        EXPECT_GT(z_m, previous_m) << "interior at rho " << rho;
      } else if (rho > 1.03 && rho < 2.97) {
        EXPECT_LT(z_m, previous_m) << "ejecta at rho " << rho;
        EXPECT_GT(z_m, 0.0) << "ejecta at rho " << rho;
      } else if (rho > 3.04) {
        EXPECT_EQ(z_m, 0.0) << "beyond the ejecta at rho " << rho;
      }
      previous_m = z_m;
    }
    EXPECT_NEAR(highest_at_rho, 1.0, 0.051);
    // Off the grid axes the triangles cut the sharp crest: by up to
    // (inner + outer slope) * half a cell diagonal = (0.76 + 0.24) * 0.09 m.
    EXPECT_NEAR(highest_m, rim_m, 0.1);
  }
  // Over the nodes the crest is exact: the highest node is the rim height and
  // lies at r = R (on the grid axes).
  float highest_node_m = -1e9f;
  double highest_node_r_m = 0.0;
  for (int r = 0; r < dem.height; ++r) {
    for (int c = 0; c < dem.width; ++c) {
      if (dem.At(r, c) > highest_node_m) {
        highest_node_m = dem.At(r, c);
        highest_node_r_m = std::hypot(NodeX(dem, c), NodeY(dem, r));
      }
    }
  }
  EXPECT_NEAR(static_cast<double>(highest_node_m), rim_m, 1e-6);
  EXPECT_NEAR(highest_node_r_m, radius_m, 1e-9);

  // On nodes of the +x radius the heights are the profile itself.
  for (const double rho : {0.0, 0.5, 1.0, 1.25, 1.5, 2.0, 2.5}) {
    const double z_m = HeightAtOrDie(dem, rho * radius_m, 0.0);
    EXPECT_NEAR(z_m, CraterHeightChange(rho * radius_m, radius_m, crater.depth_m, rim_m, 3.0),
                1e-5)
        << "rho " << rho;
  }
  // Ejecta decays at least as fast as (r/R)^-3: from 1.25 R to 2.5 R it falls
  // by more than 2^3 (the taper to 0 at 3 R makes it fall faster: 17.6x).
  const double near_m = HeightAtOrDie(dem, 1.25 * radius_m, 0.0);
  const double far_m = HeightAtOrDie(dem, 2.5 * radius_m, 0.0);
  EXPECT_GT(near_m / far_m, 8.0);
  EXPECT_NEAR(near_m / far_m, (1.0 / (1.25 * 1.25 * 1.25) - 1.0 / 27.0) / (1.0 / 15.625 - 1.0 / 27.0),
              1e-3);
}

TEST(GenerateScene, LawCratersHaveDepthToDiameterInRange) {
  TerrainOptions options = FlatOptions(200.0, 0.25);
  options.crater_k = 0.03;  // ~50 craters of 8-12 m over the placement area
  options.crater_d_min_m = 8.0;
  options.crater_d_max_m = 12.0;
  TerrainSummary summary;
  const Scene scene = GenerateScene(options, CurrentTestSeed(), 2, &summary);
  ASSERT_GT(scene.craters.size(), 20u) << summary.Summary();
  int isolated = 0;
  for (size_t i = 0; i < scene.craters.size(); ++i) {
    const Crater& crater = scene.craters[i];
    const double ratio = crater.depth_m / crater.diameter_m;
    EXPECT_GE(ratio, 0.1);
    EXPECT_LE(ratio, 0.2);
    EXPECT_GE(crater.diameter_m, 8.0);
    EXPECT_LE(crater.diameter_m, 12.0);
    // Measure the depth of craters well inside the grid whose ejecta no other
    // crater's reaches: the lowest node within 1 m of the centre.
    const Eigen::Vector2d& c = crater.center_in_local_m;
    if (std::abs(c.x()) > 180.0 || std::abs(c.y()) > 180.0) continue;
    bool alone = true;
    for (size_t j = 0; j < scene.craters.size(); ++j) {
      if (j != i && (scene.craters[j].center_in_local_m - c).norm() <
                        1.5 * (crater.diameter_m + scene.craters[j].diameter_m)) {
        alone = false;
      }
    }
    if (!alone) continue;
    ++isolated;
    double lowest_m = 1e9;
    for (double dx = -1.0; dx <= 1.0; dx += 0.125) {
      for (double dy = -1.0; dy <= 1.0; dy += 0.125) {
        lowest_m = std::min(lowest_m, HeightAtOrDie(scene.dem, c.x() + dx, c.y() + dy));
      }
    }
    // Within 1 cm: the nearest node is < 0.18 m from the centre, where the
    // bowl is (d + h) * (0.18 / R)^2 < 1 cm above the floor.
    EXPECT_NEAR(-lowest_m, crater.depth_m, 0.01);
    EXPECT_GE(-lowest_m / crater.diameter_m, 0.1 - 0.01 / 8.0);
    EXPECT_LE(-lowest_m / crater.diameter_m, 0.2 + 0.01 / 8.0);
  }
  EXPECT_GT(isolated, 3);
}

// ---------------------------------------------------------------------------
// Regional slope and relief

TEST(GenerateScene, RegionalSlopeHasConfiguredSlopeAndDownhillAzimuth) {
  struct SlopeCase {
    double slope_deg;
    double azimuth_deg;
  };
  for (const SlopeCase& slope : {SlopeCase{7.5, 250.0}, SlopeCase{2.0, 30.0},
                                 SlopeCase{15.0, 90.0}}) {
    SCOPED_TRACE("slope " + std::to_string(slope.slope_deg) + " azimuth " +
                 std::to_string(slope.azimuth_deg));
    TerrainOptions options = FlatOptions(30.0, 0.5);
    options.min_x_m = -20.0;  // not centred on the origin
    options.rock_k = 0.01;    // rocks do not change the DEM
    options.regional_slope_deg = slope.slope_deg;
    options.regional_slope_downhill_azimuth_deg = slope.azimuth_deg;
    const Scene scene = GenerateScene(options, CurrentTestSeed());
    const Heightfield& dem = scene.dem;
    // Least-squares plane z = a x + b y + c through every node.
    Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
    Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
    for (int r = 0; r < dem.height; ++r) {
      for (int c = 0; c < dem.width; ++c) {
        const Eigen::Vector3d row(NodeX(dem, c), NodeY(dem, r), 1.0);
        normal_matrix += row * row.transpose();
        rhs += row * static_cast<double>(dem.At(r, c));
      }
    }
    const Eigen::Vector3d plane = normal_matrix.ldlt().solve(rhs);
    const double slope_deg = std::atan(std::hypot(plane.x(), plane.y())) * 180.0 / kPi;
    // Downhill = -gradient; azimuth from north (y) clockwise toward east (x).
    double azimuth_deg = std::atan2(-plane.x(), -plane.y()) * 180.0 / kPi;
    if (azimuth_deg < 0.0) azimuth_deg += 360.0;
    EXPECT_NEAR(slope_deg, slope.slope_deg, 0.01);
    EXPECT_NEAR(azimuth_deg, slope.azimuth_deg, 0.01);
    EXPECT_NEAR(plane.z(), 0.0, 1e-4);  // the plane passes through the local origin
  }
}

TEST(GenerateScene, ReliefHasConfiguredRms) {
  // Over 16 x 16 largest wavelengths the sample RMS scatters by a few percent.
  TerrainOptions options = FlatOptions(256.0, 1.0);
  options.relief_rms_m = 0.5;
  options.relief_largest_wavelength_m = 32.0;
  TerrainSummary summary;
  const Scene scene = GenerateScene(options, CurrentTestSeed(), 2, &summary);
  double sum = 0.0;
  double sum2 = 0.0;
  for (const float z : scene.dem.height_m) {
    sum += static_cast<double>(z);
    sum2 += static_cast<double>(z) * static_cast<double>(z);
  }
  const double n = static_cast<double>(scene.dem.height_m.size());
  const double rms_m = std::sqrt(sum2 / n);
  std::cout << "[ relief   ] rms " << rms_m << " m (configured 0.5), mean " << sum / n << " m\n";
  EXPECT_NEAR(rms_m, 0.5, 0.05);
  EXPECT_NEAR(sum / n, 0.0, 0.1);
  EXPECT_GT(summary.relief_unit_rms, 0.0);
}

// ---------------------------------------------------------------------------
// Determinism

TerrainOptions EverythingOn() {
  TerrainOptions options;
  options.min_x_m = -40.0;
  options.max_x_m = 35.0;
  options.min_y_m = -30.0;
  options.max_y_m = 33.0;
  options.regional_slope_deg = 3.0;
  options.regional_slope_downhill_azimuth_deg = 120.0;
  options.crater_k = 0.08;
  options.crater_d_max_m = 20.0;
  options.rock_k = 0.01;
  return options;
}

bool SameBytes(const Scene& a, const Scene& b) {
  if (a.dem.width != b.dem.width || a.dem.height != b.dem.height ||
      a.dem.origin_x_m != b.dem.origin_x_m || a.dem.origin_y_m != b.dem.origin_y_m ||
      a.rocks.size() != b.rocks.size() || a.craters.size() != b.craters.size() ||
      a.albedo.seed != b.albedo.seed) {
    return false;
  }
  if (std::memcmp(a.dem.height_m.data(), b.dem.height_m.data(),
                  a.dem.height_m.size() * sizeof(float)) != 0) {
    return false;
  }
  for (size_t i = 0; i < a.rocks.size(); ++i) {
    const Rock& p = a.rocks[i];
    const Rock& q = b.rocks[i];
    if (p.center_in_local_m != q.center_in_local_m || p.radius_m != q.radius_m ||
        p.height_above_ground_m != q.height_above_ground_m || p.albedo != q.albedo) {
      return false;
    }
  }
  for (size_t i = 0; i < a.craters.size(); ++i) {
    if (a.craters[i].center_in_local_m != b.craters[i].center_in_local_m ||
        a.craters[i].diameter_m != b.craters[i].diameter_m ||
        a.craters[i].depth_m != b.craters[i].depth_m) {
      return false;
    }
  }
  return true;
}

TEST(GenerateScene, SameSeedGivesIdenticalSceneForAnyThreadCount) {
  const std::uint64_t seed = CurrentTestSeed();
  SCOPED_TRACE("seed " + std::to_string(seed));
  const TerrainOptions options = EverythingOn();
  const Scene reference = GenerateScene(options, seed, 1);
  ASSERT_GT(reference.rocks.size(), 100u);
  ASSERT_GT(reference.craters.size(), 100u);
  EXPECT_TRUE(SameBytes(reference, GenerateScene(options, seed, 1)));
  EXPECT_TRUE(SameBytes(reference, GenerateScene(options, seed, 2)));
  EXPECT_TRUE(SameBytes(reference, GenerateScene(options, seed, 3)));
}

TEST(GenerateScene, DifferentSeedGivesDifferentScene) {
  const std::uint64_t seed = CurrentTestSeed();
  const TerrainOptions options = EverythingOn();
  const Scene a = GenerateScene(options, seed);
  const Scene b = GenerateScene(options, seed + 1);
  EXPECT_FALSE(SameBytes(a, b));
  size_t differing = 0;
  for (size_t i = 0; i < a.dem.height_m.size(); ++i) {
    if (a.dem.height_m[i] != b.dem.height_m[i]) ++differing;
  }
  EXPECT_GT(differing, a.dem.height_m.size() * 9 / 10);
  EXPECT_NE(a.rocks.front().center_in_local_m, b.rocks.front().center_in_local_m);
  EXPECT_NE(a.albedo.seed, b.albedo.seed);
}

// ---------------------------------------------------------------------------
// Presets

TEST(TerrainPreset, KnownNamesAreValid) {
  for (const std::string& name : TerrainPresetNames()) {
    TerrainOptions options = TerrainPreset(name);
    options.min_x_m = -350.0;
    options.max_x_m = 350.0;
    options.min_y_m = -300.0;
    options.max_y_m = 300.0;
    EXPECT_TRUE(options.Validate().empty()) << name;
  }
  EXPECT_LT(TerrainPreset("mare").crater_k, TerrainPreset("cratered").crater_k);
  for (const double d_m : {0.2, 0.5, 1.0, 3.0}) {
    EXPECT_LT(CumulativeRocksPerM2(TerrainPreset("mare"), d_m), CumulativeRocksPerM2(TerrainPreset("cratered"), d_m))
        << d_m;
    EXPECT_LT(CumulativeRocksPerM2(TerrainPreset("cratered"), d_m), CumulativeRocksPerM2(TerrainPreset("rocky"), d_m))
        << d_m;
  }
}

TEST(TerrainPreset, UnknownNameThrowsListingValidOnes) {
  try {
    TerrainPreset("highlands");
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "unknown terrain preset \"highlands\": expected one of mare, cratered, rocky, flank, boulders");
  }
}

// ---------------------------------------------------------------------------
// Bad options

TEST(TerrainOptions, DefaultsAreValid) { EXPECT_TRUE(TerrainOptions().Validate().empty()); }

TEST(TerrainOptions, BadParametersGiveExactMessages) {
  struct BadCase {
    std::string what;
    void (*edit)(TerrainOptions*);
    std::vector<std::string> messages;
  };
  const BadCase cases[] = {
      {"zero spacing", [](TerrainOptions* o) { o->spacing_m = 0.0; },
       {"spacing_m = 0: expected a finite value > 0"}},
      {"empty extent", [](TerrainOptions* o) { o->max_x_m = o->min_x_m; },
       {"min_x_m = -50 and max_x_m = -50: expected min_x_m < max_x_m"}},
      {"rock d_min >= d_max",
       [](TerrainOptions* o) {
         o->rock_d_min_m = 2.0;
         o->rock_d_max_m = 1.0;
       },
       {"rock_d_min_m = 2 and rock_d_max_m = 1: expected rock_d_min_m < rock_d_max_m"}},
      {"positive exponent", [](TerrainOptions* o) { o->rock_exponent = 0.5; },
       {"rock_exponent = 0.5: expected a finite value < 0"}},
      {"negative k", [](TerrainOptions* o) { o->crater_k = -1.0; },
       {"crater_k = -1: expected a finite value >= 0"}},
      {"NaN hurst",
       [](TerrainOptions* o) { o->relief_hurst = std::numeric_limits<double>::quiet_NaN(); },
       {"relief_hurst = nan: expected a finite value in [0, 1]"}},
      {"negative crater size",
       [](TerrainOptions* o) { o->crater_d_min_m = -1.0; },
       {"crater_d_min_m = -1: expected a finite value > 0"}},
      {"two at once",
       [](TerrainOptions* o) {
         o->spacing_m = -1.0;
         o->rock_k = std::numeric_limits<double>::infinity();
       },
       {"spacing_m = -1: expected a finite value > 0",
        "rock_k = inf: expected a finite value >= 0"}},
      {"relief wavelength below the grid's",
       [](TerrainOptions* o) { o->relief_largest_wavelength_m = 0.3; },
       {"relief_largest_wavelength_m = 0.3: expected >= 2 * spacing_m = 0.5 (the finest relief "
        "wavelength)"}},
      {"too many nodes", [](TerrainOptions* o) { o->max_nodes = 1000; },
       {"grid of 401 x 401 nodes (spacing_m = 0.25): expected at most max_nodes = 1000 nodes; "
        "enlarge spacing_m or shrink the extent"}},
      {"rock law over the cap",
       [](TerrainOptions* o) {
         o->rock_k = 0.01;
         o->rock_exponent = -2.0;
         o->rock_d_min_m = 0.5;
         o->rock_d_max_m = 1.0;
         o->max_rocks = 299;
       },
       {"rock law gives 300 rocks over 10000 m^2 (rock_k = 0.01, rock_exponent = -2, "
        "rock_d_min_m = 0.5, rock_d_max_m = 1): expected at most max_rocks = 299; raise "
        "rock_d_min_m or max_rocks, or lower rock_k"}},
      {"protrusion range reversed",
       [](TerrainOptions* o) {
         o->rock_protrusion_min = 0.8;
         o->rock_protrusion_max = 0.4;
       },
       {"rock_protrusion_min = 0.8 and rock_protrusion_max = 0.4: expected rock_protrusion_min "
        "<= rock_protrusion_max"}},
      {"extra rock outside the extent",
       [](TerrainOptions* o) {
         Rock rock;
         rock.center_in_local_m = Eigen::Vector3d(60.0, 0.0, 0.0);
         rock.radius_m = 1.0;
         rock.height_above_ground_m = 1.0;
         o->extra_rocks.push_back(rock);
       },
       {"extra_rocks[0].center_in_local_m = (60, 0): expected inside the extent [-50, 50] x "
        "[-50, 50]"}},
  };
  for (const BadCase& bad : cases) {
    SCOPED_TRACE(bad.what);
    TerrainOptions options;
    bad.edit(&options);
    EXPECT_EQ(options.Validate(), bad.messages);
    std::string expected_what = "invalid terrain options: ";
    for (size_t i = 0; i < bad.messages.size(); ++i) {
      expected_what += (i > 0 ? "; " : "") + bad.messages[i];
    }
    try {
      GenerateScene(options, 1);
      ADD_FAILURE() << "expected InputError";
    } catch (const InputError& error) {
      EXPECT_EQ(std::string(error.what()), expected_what);
    }
  }
}

TEST(GenerateScene, ZeroThreadsIsRefused) {
  try {
    GenerateScene(FlatOptions(5.0, 0.5), 1, 0);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(), "invalid terrain options: threads = 0: expected >= 1");
  }
}

// ---------------------------------------------------------------------------
// FitCumulativePowerLawExponent

TEST(FitCumulativePowerLawExponent, RecoversExponentOfExactQuantiles) {
  // D_i at the quantiles of the untruncated law: N(>=D) = n (D / d_min)^r.
  for (const double exponent : {-1.5, -2.0, -3.0}) {
    const int n = 20000;
    std::vector<double> diameters_m;
    for (int i = 0; i < n; ++i) {
      diameters_m.push_back(0.5 * std::pow((i + 0.5) / n, 1.0 / exponent));
    }
    EXPECT_NEAR(FitCumulativePowerLawExponent(diameters_m, 0.5, 5.0), exponent, 0.01);
  }
}

TEST(FitCumulativePowerLawExponent, BadRangeOrTooFewDiameters) {
  try {
    FitCumulativePowerLawExponent({1.0, 2.0}, 1.0, 1.0);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "FitCumulativePowerLawExponent: d_min_m = 1 and d_max_m = 1: expected finite "
                 "values with 0 < d_min_m < d_max_m");
  }
  try {
    FitCumulativePowerLawExponent({1.0, 2.0, 3.0}, 1.0, 3.0);
    FAIL() << "expected InputError";
  } catch (const InputError& error) {
    EXPECT_STREQ(error.what(),
                 "FitCumulativePowerLawExponent: 0 of the 20 log-spaced diameters in [1, 3] m "
                 "have 10 or more of the 3 diameters at or above them: expected at least 2");
  }
}

}  // namespace
}  // namespace hdabench::datasets::synth
