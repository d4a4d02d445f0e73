// hdabench: the bench's single binary. This file sets up the command line
// (CLI11), has each command file register its subcommands (command_line.h), and
// maps errors to exit codes; the subcommands live in commands.h and the work in
// the modules.
#include <exception>
#include <iostream>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "tools/util/process.h"
#include "tools/cli/command_line.h"
#include "tools/cli/exit_codes.h"
#include "tools/cli/version.h"

namespace hdabench::tools {
namespace {

// version: prints the version and the libraries in use.
Command AddVersionCommand(CLI::App& app) {
  CLI::App* version = app.add_subcommand("version", "Print the version and the libraries in use");
  return {version, [] {
            std::cout << VersionReport();
            return kExitOk;
          }};
}

// Appends `added` to `commands`.
void Append(std::vector<Command>& commands, std::vector<Command> added) {
  for (Command& command : added) commands.push_back(std::move(command));
}

// Every subcommand, registered in the order of `hdabench --help`.
std::vector<Command> AddCommands(CLI::App& app) {
  std::vector<Command> commands;
  commands.push_back(AddVersionCommand(app));
  Append(commands, AddDatasetCommands(app));
  Append(commands, AddSynthCommands(app));
  Append(commands, AddImageryCommands(app));
  commands.push_back(AddRunCommand(app));
  commands.push_back(AddCompareCommand(app));
  commands.push_back(AddReportCommand(app));
  Append(commands, AddGateCommands(app));
  Append(commands, AddIngestCommands(app));
  Append(commands, AddCalibrateCommands(app));
  Append(commands, AddObservabilityCommands(app));
  commands.push_back(AddFaultsCommand(app));
  commands.push_back(AddDemoCommand(app));
  return commands;
}

// The message for the first word of the command line that names no command
// where one is expected ("hdabench dataset: unknown command 'chek' (the
// commands: check, create)"), or empty: CLI11 alone answers "A subcommand is
// required" without naming the word.
std::string UnknownCommand(CLI::App& app, int argc, char** argv) {
  CLI::App* current = &app;
  std::string path = "hdabench";
  for (int i = 1; i < argc; ++i) {
    const std::string word = argv[i];
    if (word.empty() || word[0] == '-') return "";
    const std::vector<CLI::App*> subcommands = current->get_subcommands({});
    if (subcommands.empty()) return "";  // a command's own arguments
    CLI::App* found = nullptr;
    std::string names;
    for (CLI::App* subcommand : subcommands) {
      if (subcommand->get_name() == word) found = subcommand;
      names += (names.empty() ? "" : ", ") + subcommand->get_name();
    }
    if (found == nullptr) return path + ": unknown command '" + word + "' (the commands: " + names + ")";
    current = found;
    path += " " + word;
  }
  return "";
}

// "hdabench ingest field: --out: an empty value" for the first option of the
// command given as an empty string (an unset shell variable, say): an empty
// path would mean the current folder, or no file at all. "" when none is.
std::string EmptyValue(const CLI::App& command) {
  for (const CLI::Option* option : command.get_options()) {
    if (option->get_expected_max() == 0) continue;  // a flag
    for (const std::string& value : option->results()) {
      if (!value.empty()) continue;
      std::string path = command.get_name();
      for (const CLI::App* parent = command.get_parent(); parent != nullptr && parent->get_parent() != nullptr;
           parent = parent->get_parent()) {
        path = parent->get_name() + " " + path;
      }
      return "hdabench " + path + ": " + option->get_name() + ": an empty value";
    }
  }
  return "";
}

// Parses the command line and runs the chosen command; returns the exit code.
int Main(int argc, char** argv) {
  CLI::App app{"hdabench: test bench for the NOVA-C hazard detection and avoidance method.\n"
               "Exit codes: 0 ok, 1 checks failed, 2 bad command line, 3 unusable input,\n"
               "4 an external program failed, 70 internal error, 130/143 interrupted (SIGINT/SIGTERM).",
               "hdabench"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kVersionString);
  const std::vector<Command> commands = AddCommands(app);
  if (const std::string unknown = UnknownCommand(app, argc, argv); !unknown.empty()) {
    std::cerr << unknown << "; see hdabench --help\n";
    return kExitUsage;
  }

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

  for (const Command& command : commands) {
    if (!command.app->parsed()) continue;
    if (const std::string empty = EmptyValue(*command.app); !empty.empty()) {
      std::cerr << empty << "\n";
      return kExitUsage;
    }
    return command.run();
  }
  std::cerr << "hdabench: no command given; see hdabench --help\n";
  return kExitUsage;
}

}  // namespace
}  // namespace hdabench::tools

// The binary: Main, with escaped exceptions mapped to exit codes.
int main(int argc, char** argv) {
  using namespace hdabench::tools;
  // SIGINT and SIGTERM end the programs the command started too, then the
  // command (exit codes 130 and 143).
  const std::string command = argc > 1 && argv[1][0] != '-' ? std::string(" ") + argv[1] : std::string();
  hdabench::util::InstallInterruptHandlers("hdabench" + command);
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
  } catch (const hdabench::ExternalError& e) {
    std::cerr << "hdabench: error: " << e.what() << "\n";
    return kExitExternal;
  } catch (const std::exception& e) {
    std::cerr << "hdabench: internal error: " << e.what() << "\n";
    return kExitInternal;
  } catch (...) {
    std::cerr << "hdabench: internal error: unknown exception\n";
    return kExitInternal;
  }
}
