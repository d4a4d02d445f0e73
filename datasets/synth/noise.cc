#include "datasets/synth/noise.h"

#include <cmath>

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
}  // namespace

double ValueNoise(std::uint64_t seed, int layer, double x, double y) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const auto i = static_cast<std::int64_t>(fx);
  const auto j = static_cast<std::int64_t>(fy);
  const auto fade = [](double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); };
  const double sx = fade(x - fx);
  const double sy = fade(y - fy);
  const double a = LatticeValue(seed, layer, i, j);
  const double b = LatticeValue(seed, layer, i + 1, j);
  const double c = LatticeValue(seed, layer, i, j + 1);
  const double d = LatticeValue(seed, layer, i + 1, j + 1);
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
