#include "datasets/synth/noise.h"

#include <array>
#include <cmath>
#include <cstddef>

namespace hdabench::datasets::synth {

std::uint64_t Mix64(std::uint64_t z) {
  z += 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

double HashUniform(std::uint64_t seed, std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  const std::uint64_t h = Mix64(seed ^ Mix64(a ^ Mix64(b ^ Mix64(c + 0x51ed27ULL))));
  return static_cast<double>(h >> 11) * (1.0 / 9007199254740992.0);
}

namespace {
constexpr double kPiSquared = 9.869604401089358;  // pi^2
// One mix of a linear key per lattice point: value noise evaluates four of
// these per octave, so this is the hot path of albedo and relief. The odd
// multipliers keep distinct (layer, i, j) within any realistic range apart.
double LatticeValue(std::uint64_t seed, int layer, std::int64_t i, std::int64_t j) {
  const std::uint64_t key = seed + static_cast<std::uint64_t>(layer) * 0x9e3779b97f4a7c15ULL +
                            static_cast<std::uint64_t>(i) * 0xc2b2ae3d27d4eb4fULL +
                            static_cast<std::uint64_t>(j) * 0x165667b19e3779f9ULL;
  return static_cast<double>(Mix64(key) >> 11) * (2.0 / 9007199254740992.0) - 1.0;
}

// The lattice values at the corners of the cell that ValueNoise last used,
// per layer and thread. Neighbouring calls (the nodes of a grid's row, the
// hits of neighbouring rays) mostly fall in the same cell of all but the
// finest layers, and the values depend on (seed, layer, i, j) only, so reusing
// them changes no bit.
struct LatticeCell {
  bool valid = false;
  std::uint64_t seed = 0;
  std::int64_t i = 0;
  std::int64_t j = 0;
  double a = 0.0, b = 0.0, c = 0.0, d = 0.0;  // at (i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)
};
constexpr int kCachedLayers = 32;
thread_local std::array<LatticeCell, kCachedLayers> last_cell;

void FillCell(std::uint64_t seed, int layer, std::int64_t i, std::int64_t j, LatticeCell* cell) {
  cell->valid = true;
  cell->seed = seed;
  cell->i = i;
  cell->j = j;
  cell->a = LatticeValue(seed, layer, i, j);
  cell->b = LatticeValue(seed, layer, i + 1, j);
  cell->c = LatticeValue(seed, layer, i, j + 1);
  cell->d = LatticeValue(seed, layer, i + 1, j + 1);
}
}  // namespace

double ValueNoise(std::uint64_t seed, int layer, double x, double y) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto i = static_cast<std::int64_t>(fx);
  const auto j = static_cast<std::int64_t>(fy);
  const auto fade = [](double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); };
  const double sx = fade(x - fx);
  const double sy = fade(y - fy);
  LatticeCell uncached;
  LatticeCell& cell = layer >= 0 && layer < kCachedLayers ? last_cell[static_cast<size_t>(layer)] : uncached;
  if (!cell.valid || cell.seed != seed || cell.i != i || cell.j != j) FillCell(seed, layer, i, j, &cell);
  const double a = cell.a;
  const double b = cell.b;
  const double c = cell.c;
  const double d = cell.d;
  const double top = a + (b - a) * sx;
  const double bottom = c + (d - c) * sx;
  return top + (bottom - top) * sy;
}

double FractalNoise(std::uint64_t seed, double x, double y, double finest_wavelength,
                    double coarsest_wavelength, double hurst, double filter_sigma) {
  double sum = 0.0;
  double norm = 0.0;
  int layer = 0;
  // (wavelength / coarsest)^hurst, kept as a running product: one pow per call.
  const double amplitude_step = std::pow(0.5, hurst);
  double amplitude = 1.0;
  // The Gaussian's transfer at the octave's frequency, exp(-2 pi^2 (sigma /
  // wavelength)^2): each halving of the wavelength raises it to the 4th power.
  double transfer = filter_sigma > 0.0 ? std::exp(-2.0 * kPiSquared * (filter_sigma / coarsest_wavelength) *
                                                  (filter_sigma / coarsest_wavelength))
                                       : 1.0;
  for (double wavelength = coarsest_wavelength; wavelength >= finest_wavelength * 0.999;
       wavelength *= 0.5, ++layer, amplitude *= amplitude_step) {
    norm += amplitude;
    if (filter_sigma > 0.0) {
      if (transfer < 1e-4) continue;  // and so is every finer octave
      sum += amplitude * transfer * ValueNoise(seed, layer, x / wavelength, y / wavelength);
      transfer *= transfer;
      transfer *= transfer;
      continue;
    }
    sum += amplitude * ValueNoise(seed, layer, x / wavelength, y / wavelength);
  }
  return norm > 0.0 ? sum / norm : 0.0;
}

}  // namespace hdabench::datasets::synth
