// The exact SIFT matcher of the COLMAP references (reference/colmap/
// sift_matching.h) on descriptor sets of the sizes COLMAP extracts from a
// 1024 x 1024 regolith frame: about 23000 at the first octave -1, 50000 at
// -2. Arguments: descriptors per image, threads.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <benchmark/benchmark.h>

#include "reference/colmap/sift_matching.h"

namespace {

using hdabench::reference::SiftDescriptors;

// Sparse non-negative vectors scaled to length 512 as COLMAP stores them;
// image 2 holds noisy copies of image 1's descriptors, shuffled.
std::pair<SiftDescriptors, SiftDescriptors> Descriptors(int n) {
  std::mt19937_64 rng(7);
  const auto uniform = [&rng]() { return static_cast<double>(rng() >> 11) * 0x1.0p-53; };
  std::vector<std::vector<double>> base(static_cast<size_t>(n), std::vector<double>(128));
  for (auto& v : base) {
    for (double& x : v) x = uniform() * uniform() * uniform();
  }
  const auto quantise = [](const std::vector<double>& v, std::vector<std::uint8_t>* out) {
    double norm = 0.0;
    for (const double x : v) norm += x * x;
    norm = std::sqrt(norm);
    for (const double x : v) out->push_back(static_cast<std::uint8_t>(std::min(255.0, 512.0 * x / norm)));
  };
  SiftDescriptors one, two;
  one.rows = two.rows = n;
  for (const auto& v : base) quantise(v, &one.data);
  std::vector<size_t> order(static_cast<size_t>(n));
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  for (const size_t i : order) {
    std::vector<double> v = base[i];
    for (double& x : v) x = std::max(0.0, x + 0.05 * (uniform() - 0.5));
    quantise(v, &two.data);
  }
  return {one, two};
}

void BM_MatchSiftExact(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto [one, two] = Descriptors(n);
  hdabench::reference::SiftMatchOptions options;
  options.threads = static_cast<int>(state.range(1));
  options.max_num_matches = n;
  size_t matches = 0;
  for (auto _ : state) {
    matches = hdabench::reference::MatchSiftExact(one, two, options).size();
    benchmark::DoNotOptimize(matches);
  }
  state.counters["matches"] = static_cast<double>(matches);
  state.counters["pairs_per_s"] =
      benchmark::Counter(static_cast<double>(n) * n, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_MatchSiftExact)
    ->Args({23000, 1})
    ->Args({23000, 2})
    ->Args({50000, 1})
    ->Args({50000, 2})
    ->Unit(benchmark::kSecond)
    ->UseRealTime()
    ->Iterations(1);

}  // namespace
