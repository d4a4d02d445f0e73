// Entry points of the hdabench subcommands. tools/main.cc parses the command
// line (CLI11) and calls these; each returns an exit code from exit_codes.h and
// writes its report to `out` and problems to `err`. The work itself lives in the
// modules: these functions only load, call and print.
#pragma once

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

namespace hdabench::tools {

struct DatasetCheckOptions {
  std::string dataset_dir;                     // the dataset folder (holds manifest.json)
  std::optional<std::pair<int, int>> frames;   // frame indices for the baseline line; default: first and last
};
int RunDatasetCheck(const DatasetCheckOptions& options, std::ostream& out, std::ostream& err);

struct DatasetCreateOptions {
  std::string out_dir;     // folder to create; must not exist or be empty
  std::uint64_t seed = 1;  // same seed, same bytes
};
int RunDatasetCreate(const DatasetCreateOptions& options, std::ostream& out, std::ostream& err);

struct SynthCommandOptions {
  std::string out_dir;                  // folder to create; must not exist, or be empty
  std::string preset = "novac-lateral"; // novac-lateral, novac-boresight, truck, aircraft
  std::string terrain;                  // mare, cratered, rocky; empty: the preset's
  std::uint64_t seed = 1;               // same seed, same bytes
  int threads = 0;                      // 0: all cores; the output does not depend on it
  int image_size_px = 0;                // 0: the preset's (1024)
  std::string camera_model_file;        // a .cameramodel instead of the default camera
  std::vector<std::string> overrides;   // "key=value", docs/synthetic-scenes.md
  bool quiet = false;                   // no progress lines
};
int RunSynth(const SynthCommandOptions& options, std::ostream& out, std::ostream& err);

struct TruthCommandOptions {
  std::string dataset_dir;
  int frame = 0;
  int roi[4] = {0, 0, 0, 0};  // x, y, width, height in pixels
  bool json = false;          // print one JSON object instead of a table
};
int RunTruth(const TruthCommandOptions& options, std::ostream& out, std::ostream& err);

struct RunFlightOptions {
  std::string dataset_dir;
  std::optional<std::pair<int, int>> frames;  // default: reference::DefaultFramePair
  std::string out_dir;                        // created if missing; files of the same names replaced
  std::optional<double> processor_scale;      // HdaOptions::processor_scale; default: the options'
  std::optional<double> budget_s;             // HdaOptions::compute_budget_s; default: the options'
  bool figures = true;                        // write figures/ (PNG)
  bool quiet = false;                         // no progress lines on err
};
// hdabench run: the flight method on two frames of a dataset, its outputs
// written into out_dir (docs/flight-results.md) and the report with the
// per-ROI table printed to out.
int RunFlight(const RunFlightOptions& options, std::ostream& out, std::ostream& err);

struct CompareCommandOptions {
  std::string dataset_dir;
  std::optional<std::pair<int, int>> frames;  // default: reference::DefaultFramePair
  std::string methods = "all";                // comma-separated (reference::ParseMethodList) or "all"
  std::string out_dir;                        // created if missing; files of the same names replaced
  std::optional<double> site_size_m;          // hda QuadtreeOptions::site_size_m; default: the options'
  std::string colmap_executable = "colmap";   // a name looked up on PATH, or a path
  double colmap_timeout_s = 600.0;            // per COLMAP step
  bool colmap_all_frames = false;             // colmap-free on every frame of the collection window
  bool opengv_dense = false;                  // OpenGV on denser ORB matches than the flight's
  bool figures = true;                        // write flight/figures/ (PNG)
  bool quiet = false;                         // no progress lines on err
};
// hdabench compare: the flight method and the reference methods on two frames
// of a dataset, per ROI; outputs in out_dir (docs/compare-results.md), the
// Markdown table printed to out. Exit codes: 0 every method ran; 4 a method
// failed for the run (its column says why; every other output is written);
// 2 bad flags; 3 an unusable dataset or output folder.
int RunCompareCommand(const CompareCommandOptions& options, std::ostream& out, std::ostream& err);

struct DemoOptions {
  std::string out_dir = "hdabench-demo";  // replaced on each run; the dataset goes in out_dir/dataset
  std::uint64_t seed = 1;                 // same seed, same bytes
  int image_size_px = 0;                  // 0: the default camera's 1024
  int threads = 0;                        // 0: all cores
};
// The main job on the built-in default: generate the default synthetic
// dataset (hdabench synth, preset novac-lateral) into out_dir/dataset, then
// compare every method on it (hdabench compare) into out_dir/compare and print
// the table.
int RunDemo(const DemoOptions& options, std::ostream& out, std::ostream& err);

}  // namespace hdabench::tools
