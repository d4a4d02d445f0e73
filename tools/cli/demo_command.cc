// `hdabench demo`: the default synthetic dataset, then every method compared on it.
#include <filesystem>
#include <iostream>
#include <memory>
#include <system_error>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "datasets/synth/synth.h"
#include "tools/util/files.h"

#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace fs = std::filesystem;

namespace {

// True when `dir` holds a dataset hdabench synth made (its manifest's
// description says so): one the demo may replace, as it can make it again.
bool IsSyntheticScene(const fs::path& dir) {
  std::string bytes, error;
  if (!util::ReadFileBytes(dir / "manifest.json", &bytes, &error)) return false;
  const nlohmann::json manifest = nlohmann::json::parse(bytes, nullptr, /*allow_exceptions=*/false);
  if (!manifest.is_object() || !manifest.contains("description") || !manifest["description"].is_string()) {
    return false;
  }
  return manifest["description"].get<std::string>().rfind(datasets::synth::kSyntheticSceneDescription, 0) == 0;
}

}  // namespace

int RunDemo(const DemoOptions& options, std::ostream& out, std::ostream& err) {
  const fs::path dataset_dir = fs::path(options.out_dir) / "dataset";
  // The demo's dataset is replaced on every run, but only when it is one
  // synth made: anything else there is the user's, and is left alone. synth
  // renames a complete folder into place, so a failed run leaves no
  // half-written dataset behind.
  std::error_code ec;
  if (fs::symlink_status(dataset_dir, ec).type() != fs::file_type::not_found && !IsSyntheticScene(dataset_dir)) {
    err << "hdabench demo: " << dataset_dir.string()
        << " exists and is not a synthetic scene hdabench made; the demo replaces only its own dataset "
           "(choose another --out, or move it away)\n";
    return kExitInput;
  }
  fs::remove_all(dataset_dir, ec);
  if (ec) {
    err << "hdabench demo: cannot replace " << dataset_dir.string() << ": " << ec.message() << "\n";
    return kExitInput;
  }
  fs::create_directories(options.out_dir, ec);
  if (ec) {
    err << "hdabench demo: cannot create " << options.out_dir << ": " << ec.message() << "\n";
    return kExitInput;
  }
  SynthCommandOptions synth;
  synth.out_dir = dataset_dir.string();
  synth.seed = options.seed;
  synth.image_size_px = options.image_size_px;
  synth.threads = options.threads;
  synth.frames = "pair";  // compare takes the default pair only
  out << "== Generating the default synthetic dataset (preset novac-lateral, seed " << options.seed
      << ")\n";
  const int created = RunSynth(synth, out, err);
  if (created != kExitOk) return created;
  out << "== Comparing every method on " << dataset_dir.string() << "\n";
  CompareCommandOptions compare;
  compare.dataset_dir = dataset_dir.string();
  compare.out_dir = (fs::path(options.out_dir) / "compare").string();
  return RunCompareCommand(compare, out, err);
}

// demo: --out, --seed, --image-size and --threads.
Command AddDemoCommand(CLI::App& app) {
  const auto options = std::make_shared<DemoOptions>();
  CLI::App* demo = app.add_subcommand(
      "demo",
      "The main job on the built-in default: generate the default synthetic dataset and compare\n"
      "every method on it");
  demo->add_option("--out", options->out_dir,
                   "Output folder; its dataset/ and compare/ are replaced on each run (a dataset/ that "
                   "synth did not make is refused)")
      ->capture_default_str();
  AddSeedOption(demo, &options->seed, "Random seed");
  demo->add_option("--image-size", options->image_size_px, "Square imager side in pixels (default 1024)")
      ->check(NonNegativeWhole());
  demo->add_option("--threads", options->threads,
                   "Worker threads of the scene's generation (0: every core this process may use)")
      ->check(NonNegativeWhole())
      ->capture_default_str();
  return {demo, [options] { return RunDemo(*options, std::cout, std::cerr); }};
}

}  // namespace hdabench::tools
