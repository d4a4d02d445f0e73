// The hdabench subcommands on the command line: each command file registers its
// subcommands' options on the CLI11 app (main.cc calls these in the order of
// `hdabench --help`) and returns what runs once the command line is parsed.
#pragma once

#include <functional>
#include <vector>

namespace CLI {
class App;
}  // namespace CLI

namespace hdabench::tools {

// One subcommand that does work (a leaf: `dataset check`, not `dataset`).
struct Command {
  CLI::App* app = nullptr;   // owned by the top-level CLI::App
  std::function<int()> run;  // after a successful parse, when app->parsed(): the exit code
};

// dataset check, dataset create (dataset_commands.cc).
std::vector<Command> AddDatasetCommands(CLI::App& app);
// synth, truth (synth_commands.cc).
std::vector<Command> AddSynthCommands(CLI::App& app);
// imagery pair, imagery edge (imagery_command.cc).
std::vector<Command> AddImageryCommands(CLI::App& app);
// run (run_command.cc).
Command AddRunCommand(CLI::App& app);
// compare (compare_command.cc).
Command AddCompareCommand(CLI::App& app);
// report (report_command.cc).
Command AddReportCommand(CLI::App& app);
// gate, gate merge (gate_command.cc).
std::vector<Command> AddGateCommands(CLI::App& app);
// ingest stereolunar, ingest field (ingest_command.cc).
std::vector<Command> AddIngestCommands(CLI::App& app);
// calibrate, calib-diff (calibrate_command.cc).
std::vector<Command> AddCalibrateCommands(CLI::App& app);
// observability, observability merge (observability_command.cc).
std::vector<Command> AddObservabilityCommands(CLI::App& app);
// faults (faults_command.cc).
Command AddFaultsCommand(CLI::App& app);
// demo (demo_command.cc).
Command AddDemoCommand(CLI::App& app);

}  // namespace hdabench::tools
