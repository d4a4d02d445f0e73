// `hdabench ingest stereolunar`: convert a StereoLunar nadir pair
// (datasets/stereolunar.h, docs/stereolunar.md) and write it as a dataset.
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <system_error>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "datasets/dataset.h"
#include "datasets/stereolunar.h"
#include "tools/cli/command_line.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

int RunIngestStereoLunar(const IngestStereoLunarOptions& options, std::ostream& out,
                         std::ostream& err) {
  namespace fs = std::filesystem;
  const std::string command = "hdabench ingest stereolunar: ";
  const std::string& dir = options.out_dir;
  std::error_code ec;
  if (fs::exists(dir, ec) && (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec))) {
    err << command << dir << ": exists and is not an empty folder; choose a new folder\n";
    return kExitUsage;
  }
  if (options.sun < 0) {
    err << command << "--sun " << options.sun << ": expected 0, 1 or 2\n";
    return kExitUsage;
  }
  const std::string cameras = options.cameras_file.empty()
                                  ? datasets::DefaultStereoLunarCamerasFile(options.pair_dir)
                                  : options.cameras_file;
  try {
    const datasets::Dataset dataset =
        datasets::ConvertStereoLunarPair(options.pair_dir, cameras, options.sun);
    datasets::WriteDataset(dataset, dir);
    // What was written must load cleanly; anything else is a bug in the bench.
    const datasets::DatasetLoadResult check = datasets::LoadDataset(dir);
    if (!check.Ok()) {
      err << command << "internal error: the written dataset has " << check.problems.size()
          << " problem(s):\n";
      for (const datasets::Problem& problem : check.problems) err << problem.ToString() << "\n";
      return kExitInternal;
    }
    out << "wrote dataset '" << dataset.name << "' to " << dir << ": 2 frames ("
        << dataset.camera.WidthPx() << " x " << dataset.camera.HeightPx() << " px), baseline "
        << dataset.BaselineM(0, 1) << " m, LRF range " << dataset.lrf.front().range_m
        << " m, truth points and navigation\n";
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  return kExitOk;
}

// ingest, with its one subcommand stereolunar: PAIR_DIR, --out, --sun and --cameras.
Command AddIngestCommand(CLI::App& app) {
  CLI::App* ingest = app.add_subcommand("ingest", "Convert outside data into a dataset");
  ingest->require_subcommand(1);
  const auto options = std::make_shared<IngestStereoLunarOptions>();
  CLI::App* stereolunar = ingest->add_subcommand(
      "stereolunar",
      "Convert one sun position of a StereoLunar nadir pair (docs/stereolunar.md) into a dataset");
  stereolunar->add_option("PAIR_DIR", options->pair_dir, "Pair folder (im_NNNNN.jpg and .exr)")
      ->required();
  stereolunar->add_option("--out", options->out_dir,
                          "Folder to create (must not exist, or be empty)")
      ->required();
  stereolunar->add_option("--sun", options->sun, "Sun position, 0-based (0, 1 or 2)")
      ->check(CLI::Range(0, 2))
      ->capture_default_str();
  stereolunar->add_option(
      "--cameras", options->cameras_file,
      "cameras.txt (default: PAIR_DIR/cameras.txt, else PAIR_DIR/../cameras.txt)");
  return {stereolunar,
          [options] { return RunIngestStereoLunar(*options, std::cout, std::cerr); }};
}

}  // namespace hdabench::tools
