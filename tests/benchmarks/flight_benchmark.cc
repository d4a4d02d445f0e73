// Speed and memory of the flight method (hda::RunHda) on a novac-lateral pair,
// 1024 x 1024 and 2048 x 2048, on one core (OpenCV's threads set to 1), with
// the time of each stage. The pairs are generated once with `hdabench synth`
// (frames 0 to 6: the pair 0-6 is the paper's 30 m baseline) into the build
// tree and reused. Only the two images and the navigation are kept, and the
// process's peak resident size is reset before the runs, so its high-water
// mark is the method's plus the program's and the images'.
//
// Run: build/tests/benchmarks/hdabench_benchmarks --benchmark_filter=Flight
// (BM_FlightMethodWithoutNavAidedRefinement: the same with matching.warp_refine
// off, to show what the nav-aided refinement costs. BM_FlightMethodScaling:
// 512 to 4096 px with the options of `hdabench run`, the cost against size.)
// Counters: stage times in ms per run (quadtree, prediction, matching,
// rejection, plane), rois, evaluated, and rss_before_mb / peak_rss_mb: the
// process's resident size before the runs (program, libraries, the two images
// and what loading the dataset left) and its high-water mark during them (the
// mark is reset before the runs).
#include <malloc.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>

#include "datasets/dataset.h"
#include "hda/pipeline.h"
#include "reference/flight/flight_run.h"
#include "reference/flight/hda_params.h"
#include "tools/images/codecs.h"

namespace hdabench {
namespace {

namespace fs = std::filesystem;

// A field of /proc/self/status in MB ("VmRSS", "VmHWM"), or -1.
double StatusMb(const std::string& field) {
  std::ifstream status("/proc/self/status");
  std::string key;
  while (status >> key) {
    if (key == field + ":") {
      double kb = 0.0;
      status >> kb;
      return kb / 1024.0;
    }
  }
  return -1.0;
}

// Returns freed heap to the system and resets the process's peak resident
// size (Linux: "5" into /proc/self/clear_refs), so that VmHWM afterwards is the
// peak of what runs next.
void ResetPeakRss() {
  malloc_trim(0);
  std::ofstream("/proc/self/clear_refs") << "5";
}

struct Pair {
  std::unique_ptr<datasets::Dataset> dataset;
  int frame1 = 0, frame2 = 1;
  hda::HdaInput input;
};

// The dataset folder for an image size, generated when missing.
std::string PairDir(int size_px) {
  const fs::path dir = fs::path(HDABENCH_BENCH_DATA) / ("novac-lateral-" + std::to_string(size_px));
  if (!fs::exists(dir / "manifest.json")) {
    fs::remove_all(dir);
    fs::create_directories(dir.parent_path());
    const std::string command = std::string(HDABENCH_EXE) + " synth --out " + dir.string() +
                                " --seed 1 --quiet --frames pair --image-size " + std::to_string(size_px) +
                                " --set collection_s=2.4" +
                                // Above 2048 px the DEM keeps the 2048 px scene's spacing: the
                                // pixel footprint's would exceed the generator's 60 M nodes.
                                (size_px > 2048 ? " --set dem_spacing_m=0.07401" : "");
    std::cerr << "generating " << dir << " (once): " << command << "\n";
    if (std::system(command.c_str()) != 0) {
      std::cerr << "hdabench synth failed\n";
      std::exit(1);
    }
  }
  return dir.string();
}

const Pair& GetPair(int size_px) {
  static std::map<int, Pair> pairs;
  auto found = pairs.find(size_px);
  if (found != pairs.end()) return found->second;
  const std::string dir = PairDir(size_px);
  datasets::LoadOptions load;
  load.decode_images = false;
  load.check_truth_values = false;
  datasets::DatasetLoadResult loaded = datasets::LoadDataset(dir, load);
  if (!loaded.Ok()) {
    std::cerr << dir << ": " << loaded.Summary() << "\n";
    std::exit(1);
  }
  Pair& pair = pairs[size_px];
  pair.dataset = std::make_unique<datasets::Dataset>(std::move(*loaded.dataset));
  pair.dataset->truth = datasets::Truth();
  const auto frames = reference::DefaultFramePair(*pair.dataset);
  pair.frame1 = frames.first;
  pair.frame2 = frames.second;
  for (const int frame : {frames.first, frames.second}) {
    datasets::FrameRecord& record = pair.dataset->frames[static_cast<size_t>(frame)];
    record.image = hdabench::images::Read((fs::path(dir) / record.image_path).string(), cv::IMREAD_UNCHANGED);
  }
  pair.input = reference::MakeHdaInput(*pair.dataset, frames.first, frames.second);
  return pair;
}

// The options `hdabench run` takes for the pair: the defaults, with the
// lengths and the site size following its geometry (docs/flight-parameters.md).
hda::HdaOptions RunOptions(const Pair& pair) {
  const reference::HdaSettings settings;
  reference::PairGeometry geometry;
  geometry.lrf_range_m = pair.input.lrf_range_m;
  geometry.baseline_m = pair.dataset->BaselineM(pair.frame1, pair.frame2);
  geometry.keypoints_per_px =
      reference::OrbKeypointDensity(pair.dataset->frames[static_cast<size_t>(pair.frame1)].image,
                                    settings.options.matching, settings.options.quadtree.min_block_mean);
  std::vector<reference::DerivedParam> derived;
  return reference::ResolveHdaOptions(settings, pair.dataset->camera, geometry, &derived);
}

void RunFlightMethod(benchmark::State& state, const hda::HdaOptions& given_options, bool as_run = false) {
  cv::setNumThreads(1);
  const Pair& pair = GetPair(static_cast<int>(state.range(0)));
  const hda::HdaOptions options = as_run ? RunOptions(pair) : given_options;
  ResetPeakRss();
  const double rss_before_mb = StatusMb("VmRSS");
  hda::StageTimes sum;
  hda::HdaResult result;
  for (auto _ : state) {
    result = hda::RunHda(pair.input, pair.dataset->camera, options);
    sum.quadtree_s += result.times.quadtree_s;
    sum.prediction_s += result.times.prediction_s;
    sum.matching_s += result.times.matching_s;
    sum.rejection_s += result.times.rejection_s;
    sum.plane_s += result.times.plane_s;
    benchmark::DoNotOptimize(result.rois.data());
  }
  const double runs = static_cast<double>(state.iterations());
  state.counters["quadtree_ms"] = 1e3 * sum.quadtree_s / runs;
  state.counters["prediction_ms"] = 1e3 * sum.prediction_s / runs;
  state.counters["matching_ms"] = 1e3 * sum.matching_s / runs;
  state.counters["rejection_ms"] = 1e3 * sum.rejection_s / runs;
  state.counters["plane_ms"] = 1e3 * sum.plane_s / runs;
  state.counters["rois"] = static_cast<double>(result.rois.size());
  state.counters["evaluated"] = static_cast<double>(result.ranking.size());
  state.counters["rss_before_mb"] = rss_before_mb;
  state.counters["peak_rss_mb"] = StatusMb("VmHWM");
  const double seconds = (sum.quadtree_s + sum.prediction_s + sum.matching_s + sum.rejection_s + sum.plane_s) / runs;
  const double pixels = static_cast<double>(pair.dataset->camera.WidthPx()) * pair.dataset->camera.HeightPx();
  state.counters["ns_per_px"] = 1e9 * seconds / pixels;
  if (!result.rois.empty()) state.counters["ms_per_roi"] = 1e3 * seconds / static_cast<double>(result.rois.size());
}
void BM_FlightMethod(benchmark::State& state) { RunFlightMethod(state, hda::HdaOptions()); }
BENCHMARK(BM_FlightMethod)->Arg(1024)->Arg(2048)->Unit(benchmark::kMillisecond)->UseRealTime();

// Cost against size: the same scene at 512 to 4096 px, with the options
// `hdabench run` takes (the site size in pixels follows the geometry, so the
// ROIs cover the same ground at every size). Counters ns_per_px and
// ms_per_roi show how the time grows.
void BM_FlightMethodScaling(benchmark::State& state) { RunFlightMethod(state, hda::HdaOptions(), true); }
BENCHMARK(BM_FlightMethodScaling)
    ->Arg(512)
    ->Arg(1024)
    ->Arg(2048)
    ->Arg(4096)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The same without the nav-aided refinement (matching.warp_refine off): its
// cost is the difference of the matching times.
void BM_FlightMethodWithoutNavAidedRefinement(benchmark::State& state) {
  hda::HdaOptions options;
  options.matching.warp_refine = false;
  RunFlightMethod(state, options);
}
BENCHMARK(BM_FlightMethodWithoutNavAidedRefinement)
    ->Arg(1024)
    ->Arg(2048)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace hdabench
