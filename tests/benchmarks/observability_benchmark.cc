// The observability study's throughput (reference/observability): one
// setting (lateral, 30 m, 0.1 px, 50 points per site) of `trials` trials on
// the synthetic scenes' default camera. Arguments: trials per setting,
// threads. Counters: trials per second in all, and per thread (times 60 for
// the study's per-minute figure).
#include <benchmark/benchmark.h>

#include "datasets/synth/synth.h"
#include "reference/observability/observability.h"

namespace {

void BM_ObservabilityTrials(benchmark::State& state) {
  hdabench::reference::StudyOptions options;
  options.geometries = {hdabench::reference::StudyGeometry::kLateral};
  options.baselines_m = {30.0};
  options.pixel_noises_px = {0.1};
  options.points = {50};
  options.trials = static_cast<int>(state.range(0));
  const int threads = static_cast<int>(state.range(1));
  const hdabench::calib::CameraModel camera = hdabench::datasets::synth::DefaultSynthCamera(1024, 30.0);
  const hdabench::reference::StudySetting setting = hdabench::reference::StudySettings(options).front();
  for (auto _ : state) {
    const hdabench::reference::SettingStats stats = hdabench::reference::RunSetting(options, camera, setting, threads);
    benchmark::DoNotOptimize(stats.p95_abs_error_deg);
  }
  const double trials = static_cast<double>(state.iterations()) * options.trials;
  state.counters["trials_per_s"] = benchmark::Counter(trials, benchmark::Counter::kIsRate);
  state.counters["trials_per_s_per_thread"] = benchmark::Counter(trials / threads, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_ObservabilityTrials)->Args({20000, 1})->Args({20000, 2})->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
