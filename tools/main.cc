// hdabench: the bench's single binary. This file only parses the command line
// (CLI11 is included here and nowhere else) and maps errors to exit codes; the
// subcommands live in commands.h and the work in the modules.
#include <exception>
#include <iostream>
#include <optional>
#include <string>

#include <CLI/CLI.hpp>

#include "calib/error.h"
#include "tools/commands.h"
#include "tools/exit_codes.h"
#include "tools/version.h"

namespace hdabench::tools {
namespace {

std::optional<std::pair<int, int>> ParseFramePair(const std::string& text) {
  const size_t comma = text.find(',');
  if (comma == std::string::npos) throw CLI::ValidationError("--frames", "expected i,j, got '" + text + "'");
  try {
    size_t used_i = 0;
    size_t used_j = 0;
    const int i = std::stoi(text.substr(0, comma), &used_i);
    const int j = std::stoi(text.substr(comma + 1), &used_j);
    if (used_i != comma || used_j != text.size() - comma - 1) throw std::invalid_argument(text);
    return std::make_pair(i, j);
  } catch (const std::logic_error&) {
    throw CLI::ValidationError("--frames", "expected two frame indices i,j, got '" + text + "'");
  }
}

int Main(int argc, char** argv) {
  CLI::App app{"hdabench: test bench for the NOVA-C hazard detection and avoidance method.\n"
               "Exit codes: 0 ok, 1 checks failed, 2 bad command line, 3 unusable input,\n"
               "4 an external program failed, 70 internal error.",
               "hdabench"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kVersionString);

  CLI::App* version = app.add_subcommand("version", "Print the version and the libraries in use");

  CLI::App* dataset = app.add_subcommand("dataset", "Create and check datasets (docs/dataset-format.md)");
  dataset->require_subcommand(1);
  DatasetCheckOptions check_options;
  std::string frames_text;
  CLI::App* check = dataset->add_subcommand(
      "check", "Validate a dataset: print a summary, or every problem (exit 1)");
  check->add_option("DIR", check_options.dataset_dir, "Dataset folder (holds manifest.json)")->required();
  check->add_option("--frames", frames_text, "Two frame indices i,j for the baseline line (default: first,last)");

  DatasetCreateOptions create_options;
  CLI::App* create = dataset->add_subcommand(
      "create", "Write the built-in small example dataset (deterministic for a seed)");
  create->add_option("DIR", create_options.out_dir, "Folder to create (must not exist, or be empty)")->required();
  create->add_option("--seed", create_options.seed, "Random seed")->capture_default_str();

  DemoOptions demo_options;
  CLI::App* demo = app.add_subcommand(
      "demo", "The main job on the built-in default: create the example dataset and check it");
  demo->add_option("--out", demo_options.out_dir, "Output folder (replaced on each run)")->capture_default_str();
  demo->add_option("--seed", demo_options.seed, "Random seed")->capture_default_str();

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kExitUsage;
  }

  if (version->parsed()) {
    std::cout << VersionReport();
    return kExitOk;
  }
  if (check->parsed()) {
    if (!frames_text.empty()) check_options.frames = ParseFramePair(frames_text);
    return RunDatasetCheck(check_options, std::cout, std::cerr);
  }
  if (create->parsed()) return RunDatasetCreate(create_options, std::cout, std::cerr);
  if (demo->parsed()) return RunDemo(demo_options, std::cout, std::cerr);
  std::cerr << "hdabench: no command given; see hdabench --help\n";
  return kExitUsage;
}

}  // namespace
}  // namespace hdabench::tools

int main(int argc, char** argv) {
  using namespace hdabench::tools;
  try {
    return Main(argc, argv);
  } catch (const CLI::ValidationError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitUsage;
  } catch (const hdabench::InputError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const hdabench::UnsupportedError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitInput;
  } catch (const std::exception& e) {
    std::cerr << "hdabench: internal error: " << e.what() << "\n";
    return kExitInternal;
  } catch (...) {
    std::cerr << "hdabench: internal error: unknown exception\n";
    return kExitInternal;
  }
}
