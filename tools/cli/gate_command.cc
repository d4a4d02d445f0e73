// `hdabench gate`: run a suite of datasets through the comparison, compute the
// metrics per method, check them against the thresholds (and a baseline), and
// print the table (reference/gate/gate.h, docs/gate.md).
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>

#include "tools/util/error.h"
#include "tools/util/files.h"
#include "reference/gate/gate.h"
#include "tools/cli/command_line.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace fs = std::filesystem;

int RunGateCommand(const GateCommandOptions& options, std::ostream& out, std::ostream& err) {
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << "hdabench gate: " << line << "\n";
  };
  if (options.jobs < 1) {
    err << "hdabench gate: --jobs " << options.jobs << ": expected >= 1\n";
    return kExitUsage;
  }
  if (!(options.fault_match_noise_px >= 0.0)) {
    err << "hdabench gate: --fault-match-noise-px " << options.fault_match_noise_px << ": expected >= 0\n";
    return kExitUsage;
  }
  reference::GateSuite suite;
  reference::GateThresholds thresholds;
  std::optional<std::vector<reference::GateMetric>> baseline;
  try {
    suite = reference::ReadGateSuite(options.suite_file);
    thresholds = reference::ReadGateThresholds(options.thresholds_file);
    if (!options.baseline_file.empty()) baseline = reference::ReadGateMetrics(options.baseline_file);
    fs::create_directories(options.out_dir);
  } catch (const InputError& e) {
    err << "hdabench gate: " << e.what() << "\n";
    return kExitInput;
  } catch (const fs::filesystem_error& e) {
    err << "hdabench gate: --out " << options.out_dir << ": " << e.code().message() << "\n";
    return kExitInput;
  }

  // Every method runs on one core, as the flight computer does; entries run
  // in parallel instead.
  cv::setNumThreads(1);
  reference::GateRunOptions run;
  run.out_dir = options.out_dir;
  run.jobs = options.jobs;
  run.fault_match_noise_px = options.fault_match_noise_px;
  run.colmap_executable = options.colmap_executable;
  progress("suite " + options.suite_file + ": " + std::to_string(suite.entries.size()) +
           " entries, methods " + [&] {
             std::string text;
             for (const std::string& m : suite.methods) text += (text.empty() ? "" : ",") + m;
             return text;
           }() + ", " + std::to_string(options.jobs) + " at a time, into " + options.out_dir);
  const std::vector<reference::GateEntryOutcome> outcomes =
      reference::RunGateSuite(suite, run, progress);
  std::vector<std::string> dirs;
  std::vector<std::string> failed_entries;
  for (const reference::GateEntryOutcome& o : outcomes) {
    if (o.ok) {
      dirs.push_back(o.dir);
    } else {
      failed_entries.push_back(o.name + ": " + o.error);
    }
  }

  std::vector<reference::GateMetric> metrics;
  std::vector<reference::GateCheck> checks;
  try {
    metrics = reference::ComputeGateMetrics(dirs, run.processor_scale);
    checks = reference::CheckGate(metrics, thresholds, baseline ? &*baseline : nullptr);
    const std::string metrics_json = reference::GateMetricsJson(metrics);
    util::WriteFileAtomically(fs::path(options.out_dir) / "metrics.json", metrics_json);
    std::string markdown = "# Gate: " + options.suite_file + "\n\n" +
                           std::to_string(dirs.size()) + " of " + std::to_string(outcomes.size()) +
                           " entries; thresholds " + options.thresholds_file +
                           (baseline ? ", baseline " + options.baseline_file : "") + "\n\n" +
                           reference::GateTable(checks);
    for (const std::string& f : failed_entries) markdown += "\nentry failed: " + f + "\n";
    util::WriteFileAtomically(fs::path(options.out_dir) / "gate.md", markdown);
    util::WriteFileAtomically(
        fs::path(options.out_dir) / "gate.html",
        reference::GateHtml(options.suite_file, checks, outcomes));
    if (!options.write_baseline_file.empty()) {
      util::WriteFileAtomically(options.write_baseline_file, metrics_json);
      progress("wrote the baseline " + options.write_baseline_file);
    }
    out << markdown;
  } catch (const InputError& e) {
    err << "hdabench gate: " << e.what() << "\n";
    return kExitInput;
  }

  int failures = static_cast<int>(failed_entries.size());
  for (const std::string& f : failed_entries) err << "hdabench gate: FAILED entry " << f << "\n";
  for (const reference::GateCheck& c : checks) {
    if (c.has_value && c.passed && !c.regressed) continue;
    ++failures;
    err << "hdabench gate: FAILED " << c.Summary() << "\n";
  }
  if (failures > 0) {
    err << "hdabench gate: " << failures << " failure(s)\n";
    return kExitCheckFailed;
  }
  progress("every metric within its threshold");
  return kExitOk;
}

// gate: the suite, thresholds, baseline, --out and the comparison's options.
Command AddGateCommand(CLI::App& app) {
  const auto options = std::make_shared<GateCommandOptions>();
  CLI::App* gate = app.add_subcommand(
      "gate", "Merge gate: a suite of datasets through the comparison, metrics against thresholds");
  gate->add_option("--suite", options->suite_file, "Suite file (docs/gate.md)")->required();
  gate->add_option("--thresholds", options->thresholds_file, "Thresholds file (docs/gate.md)")
      ->required();
  gate->add_option("--baseline", options->baseline_file,
                   "Metrics of main (metrics.json of an earlier gate): fail on a regression");
  gate->add_option("--write-baseline", options->write_baseline_file,
                   "Write this run's metrics to this file, as a new baseline");
  gate->add_option("--out", options->out_dir,
                   "Output folder; a rerun into it resumes, reusing complete entries")
      ->required();
  gate->add_option("--jobs", options->jobs, "Suite entries run at once")->capture_default_str();
  gate->add_option("--colmap", options->colmap_executable,
                   "The colmap program: a name on PATH or a path")
      ->capture_default_str();
  gate->add_option("--fault-match-noise-px", options->fault_match_noise_px,
                   "Fault injection for testing the gate: noise on the flight method's matches, px")
      ->capture_default_str();
  gate->add_flag("--quiet", options->quiet, "No progress lines");
  return {gate, [options] { return RunGateCommand(*options, std::cout, std::cerr); }};
}

}  // namespace hdabench::tools
