// Deterministic procedural noise for synthetic scenes: the same seed and
// coordinates give the same value on every machine and thread.
#pragma once

#include <cstdint>

namespace hdabench::datasets::synth {

// splitmix64 finaliser: a well-distributed 64-bit hash.
std::uint64_t Mix64(std::uint64_t z);

// Uniform double in [0, 1) from a hash of (seed, a, b, c).
double HashUniform(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0, std::uint64_t c = 0);

// Value noise in [-1, 1] on the integer lattice, smoothly interpolated
// (quintic fade, C2). `layer` selects an independent field for the same seed.
double ValueNoise(std::uint64_t seed, int layer, double x, double y);

// Fractal sum of ValueNoise octaves from coarsest_wavelength down to
// finest_wavelength (halving each octave), each weighted by
// (wavelength / coarsest_wavelength)^hurst and normalised so the result is in
// [-1, 1]. hurst = 0.5 gives the 1/f texture used for regolith albedo.
// filter_sigma > 0 (same units as x, y): the noise as seen through a Gaussian
// low-pass of that standard deviation, each octave's amplitude multiplied by
// the Gaussian's transfer at the octave's frequency, exp(-2 pi^2 sigma^2 /
// wavelength^2); octaves attenuated below 1e-4 are skipped. The normalisation
// stays the unfiltered one, so the mean is unchanged and the contrast falls
// as the filter widens. filter_sigma = 0 gives exactly the unfiltered value.
double FractalNoise(std::uint64_t seed, double x, double y, double finest_wavelength,
                    double coarsest_wavelength, double hurst, double filter_sigma = 0.0);

}  // namespace hdabench::datasets::synth
