// `hdabench gate`: run a suite of datasets through the comparison, compute the
// metrics per method, check them against the thresholds (and a baseline), and
// print the table (reference/gate/gate.h, docs/gate.md); with --shard, one
// slice of the suite; `hdabench gate merge`: the slices into the whole verdict.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
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
#include "tools/cli/command_support.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace fs = std::filesystem;

namespace {

// What the verdict is computed with.
struct VerdictInputs {
  std::string suite_file, thresholds_file, baseline_file, write_baseline_file, out_dir;
  reference::GateThresholds thresholds;
  std::optional<std::vector<reference::GateMetric>> baseline;
};

// The metrics of the complete entries, the checks, metrics.json, gate.md and
// gate.html, the table on `out` and every failure on `err`; the exit code.
int WriteVerdict(const VerdictInputs& v, const std::vector<reference::GateEntryOutcome>& outcomes,
                 const std::function<void(const std::string&)>& progress, std::ostream& out, std::ostream& err,
                 const std::string& command) {
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
  std::string metrics_json;
  try {
    metrics = reference::ComputeGateMetrics(dirs);
    checks = reference::CheckGate(metrics, v.thresholds, v.baseline ? &*v.baseline : nullptr);
    metrics_json = reference::GateMetricsJson(metrics);
    util::WriteFileAtomically(fs::path(v.out_dir) / "metrics.json", metrics_json);
    std::string markdown = "# Gate: " + v.suite_file + "\n\n" + std::to_string(dirs.size()) + " of " +
                           std::to_string(outcomes.size()) + " entries; thresholds " + v.thresholds_file +
                           (v.baseline ? ", baseline " + v.baseline_file : "") + "\n\n" +
                           reference::GateTable(checks);
    for (const std::string& f : failed_entries) markdown += "\nentry failed: " + f + "\n";
    util::WriteFileAtomically(fs::path(v.out_dir) / "gate.md", markdown);
    util::WriteFileAtomically(fs::path(v.out_dir) / "gate.html",
                              reference::GateHtml(v.suite_file, checks, outcomes));
    out << markdown;
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  // The baseline last: a baseline that cannot be written does not hide the
  // table or the verdict above it.
  bool baseline_written = true;
  if (!v.write_baseline_file.empty()) {
    try {
      util::WriteFileAtomically(v.write_baseline_file, metrics_json);
      progress("wrote the baseline " + v.write_baseline_file);
    } catch (const InputError& e) {
      err << command << "--write-baseline " << e.what() << "\n";
      baseline_written = false;
    }
  }

  int failures = static_cast<int>(failed_entries.size());
  for (const std::string& f : failed_entries) err << command << "FAILED entry " << f << "\n";
  for (const reference::GateCheck& c : checks) {
    if (c.has_value && c.passed && !c.regressed) continue;
    ++failures;
    err << command << "FAILED " << c.Summary() << "\n";
  }
  if (failures > 0) {
    err << command << failures << " failure(s)\n";
    return kExitCheckFailed;
  }
  progress("every metric within its threshold");
  return baseline_written ? kExitOk : kExitInput;
}

// Reads the suite, the thresholds and the baseline, and makes the output
// folder; `Options` is the gate's or the merge's.
template <typename Options>
int ReadInputs(const Options& options, reference::GateSuite* suite, VerdictInputs* v, std::ostream& err,
               const std::string& command) {
  v->suite_file = options.suite_file;
  v->thresholds_file = options.thresholds_file;
  v->baseline_file = options.baseline_file;
  v->write_baseline_file = options.write_baseline_file;
  v->out_dir = options.out_dir;
  // Not over a dataset or another command's results (a gate's own folder,
  // marked by metrics.json, is reused: its complete entries are kept).
  if (const int code = CheckOutputFolder(v->out_dir, "", "metrics.json", command, err); code != kExitOk) {
    return code;
  }
  try {
    *suite = reference::ReadGateSuite(v->suite_file);
    v->thresholds = reference::ReadGateThresholds(v->thresholds_file);
    if (!v->baseline_file.empty()) v->baseline = reference::ReadGateMetrics(v->baseline_file);
    fs::create_directories(v->out_dir);
    // The baseline's folder before anything runs, not after the whole suite.
    const fs::path baseline_folder = fs::path(v->write_baseline_file).parent_path();
    if (!v->write_baseline_file.empty() && !baseline_folder.empty()) {
      std::error_code ec;
      fs::create_directories(baseline_folder, ec);
      if (ec || !fs::is_directory(baseline_folder)) {
        err << command << "--write-baseline " << v->write_baseline_file << ": cannot create its folder ("
            << (ec ? ec.message() : std::string("exists and is not a folder")) << ")\n";
        return kExitInput;
      }
    }
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  } catch (const fs::filesystem_error& e) {
    err << command << "--out " << v->out_dir << ": " << e.code().message() << "\n";
    return kExitInput;
  }
  return kExitOk;
}

// --suite, --thresholds and --out, checked here: `gate merge` does not take
// the gate's own.
int RequireFlags(const std::vector<std::pair<const char*, const std::string*>>& flags, std::ostream& err,
                 const std::string& command) {
  for (const auto& [flag, value] : flags) {
    if (value->empty()) {
      err << command << flag << " is required\n";
      return kExitUsage;
    }
  }
  return kExitOk;
}

}  // namespace

int RunGateCommand(const GateCommandOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench gate: ";
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << command << line << "\n";
  };
  if (const int code = RequireFlags({{"--suite", &options.suite_file},
                                     {"--thresholds", &options.thresholds_file},
                                     {"--out", &options.out_dir}},
                                    err, command);
      code != kExitOk) {
    return code;
  }
  if (options.jobs < 1) {
    err << command << "--jobs " << options.jobs << ": expected >= 1\n";
    return kExitUsage;
  }
  if (!(std::isfinite(options.fault_match_noise_px) && options.fault_match_noise_px >= 0.0)) {
    err << command << "--fault-match-noise-px " << options.fault_match_noise_px << ": expected a finite number >= 0\n";
    return kExitUsage;
  }
  util::Shard shard;
  try {
    shard = util::ParseShard(options.shard);
  } catch (const InputError& e) {
    err << command << "--shard: " << e.what() << "\n";
    return kExitUsage;
  }
  for (const auto& [flag, names] : {std::pair<const char*, const std::vector<std::string>&>{"--entries", options.entries},
                                     {"--methods", options.methods}}) {
    if (names.empty()) continue;
    if (!shard.Whole()) {
      err << command << flag << " and --shard " << options.shard
          << " cannot be combined: `gate merge` gathers the shards of the whole suite\n";
      return kExitUsage;
    }
    if (!options.write_baseline_file.empty()) {
      err << command << flag << " and --write-baseline cannot be combined: a baseline holds the whole suite's metrics\n";
      return kExitUsage;
    }
  }
  VerdictInputs verdict;
  reference::GateSuite suite;
  if (const int code = ReadInputs(options, &suite, &verdict, err, command); code != kExitOk) return code;
  if (!options.entries.empty() || !options.methods.empty()) {
    const char* flag = "--entries";
    try {
      if (!options.entries.empty()) suite = reference::SelectGateEntries(suite, options.entries);
      flag = "--methods";
      if (!options.methods.empty()) suite = reference::SelectGateMethods(suite, options.methods);
    } catch (const InputError& e) {
      err << command << flag << ": " << e.what() << "\n";
      return kExitUsage;
    }
    std::vector<reference::GateThreshold>& thresholds = verdict.thresholds.thresholds;
    const size_t all = thresholds.size();
    thresholds.erase(std::remove_if(thresholds.begin(), thresholds.end(),
                                    [&](const reference::GateThreshold& t) {
                                      return !reference::SuiteGivesThresholdPool(suite, t);
                                    }),
                     thresholds.end());
    progress(std::to_string(suite.entries.size()) + " entries; " + std::to_string(thresholds.size()) + " of " +
             std::to_string(all) + " thresholds checked, the others' pools have no entry or method among them");
  }
  // --set over every entry's own parameters, checked before anything runs.
  for (reference::GateEntry& entry : suite.entries) {
    if (const int code = BuildHdaSettings("", {}, options.hda_sets, "gate", err, &entry.hda); code != kExitOk) {
      return code;
    }
  }
  for (const std::string& set : options.hda_sets) progress("every entry with --set " + set);

  // Every method runs on one core, as the flight computer does; entries run
  // in parallel instead.
  cv::setNumThreads(1);
  reference::GateRunOptions run;
  run.out_dir = options.out_dir;
  run.jobs = options.jobs;
  run.fault_match_noise_px = options.fault_match_noise_px;
  run.colmap_executable = options.colmap_executable;
  run.shard = shard;
  progress("suite " + options.suite_file + ": " + std::to_string(suite.entries.size()) + " entries" +
           (shard.Whole() ? "" : " (shard " + shard.Text() + " runs every " + std::to_string(shard.count) +
                                     "th from the " + std::to_string(shard.index) + "th)") +
           ", methods " + [&] {
             std::string text;
             for (const std::string& m : suite.methods) text += (text.empty() ? "" : ",") + m;
             return text;
           }() + ", " + std::to_string(options.jobs) + " at a time, into " + options.out_dir);
  std::vector<reference::GateEntryOutcome> outcomes;
  try {
    outcomes = reference::RunGateSuite(suite, run, progress);
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  if (shard.Whole()) return WriteVerdict(verdict, outcomes, progress, out, err, command);

  try {
    util::WriteFileAtomically(fs::path(options.out_dir) / reference::kGateShardFileName,
                              reference::GateShardJson(suite, shard, outcomes));
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  }
  int failed = 0;
  for (const reference::GateEntryOutcome& o : outcomes) {
    if (!o.ok) ++failed;
  }
  out << "shard " << shard.Text() << ": " << outcomes.size() - static_cast<size_t>(failed) << " of "
      << outcomes.size() << " entries complete in " << options.out_dir
      << "; the verdict comes from `hdabench gate merge` over every shard's folder\n";
  if (failed > 0) {
    err << command << failed << " entr" << (failed == 1 ? "y" : "ies") << " of shard " << shard.Text()
        << " failed (recorded for the merge)\n";
    return kExitCheckFailed;
  }
  return kExitOk;
}

int RunGateMerge(const GateMergeOptions& options, std::ostream& out, std::ostream& err) {
  const std::string command = "hdabench gate merge: ";
  const auto progress = [&](const std::string& line) {
    if (!options.quiet) err << command << line << "\n";
  };
  VerdictInputs verdict;
  reference::GateSuite suite;
  if (const int code = ReadInputs(options, &suite, &verdict, err, command); code != kExitOk) return code;
  std::vector<reference::GateEntryOutcome> outcomes;
  try {
    outcomes = reference::MergeGateShards(suite, options.shard_dirs, options.out_dir);
  } catch (const InputError& e) {
    err << command << e.what() << "\n";
    return kExitInput;
  } catch (const fs::filesystem_error& e) {
    err << command << e.path1().string() << ": " << e.code().message() << "\n";
    return kExitInput;
  }
  progress("merged " + std::to_string(options.shard_dirs.size()) + " shards: " +
           std::to_string(outcomes.size()) + " entries into " + options.out_dir);
  return WriteVerdict(verdict, outcomes, progress, out, err, command);
}

namespace {

// What is wrong when one of gate's own flags was given before 'merge' (`gate
// --jobs 2 merge ...` would otherwise drop --jobs without a word); "" when none was.
std::string GateFlagBeforeMerge(const CLI::App& gate, const CLI::App& merge) {
  for (const CLI::Option* option : gate.get_options()) {
    if (option->count() == 0) continue;
    std::string own;
    bool merge_has_it = false;
    for (const CLI::Option* merge_option : merge.get_options()) {
      if (merge_option->get_name() == "--help") continue;
      own += " " + merge_option->get_name();
      merge_has_it = merge_has_it || merge_option->get_name() == option->get_name();
    }
    return option->get_name() + " was given before 'merge'" +
           (merge_has_it ? ": give it after 'merge'"
                         : " and is a flag of gate, not of gate merge (whose arguments, after 'merge', are" + own +
                               ")");
  }
  return "";
}

}  // namespace

// gate: the suite, thresholds, baseline, --out and the comparison's options.
std::vector<Command> AddGateCommands(CLI::App& app) {
  const auto options = std::make_shared<GateCommandOptions>();
  CLI::App* gate = app.add_subcommand(
      "gate", "Merge gate: a suite of datasets through the comparison, metrics against thresholds");
  gate->add_option("--suite", options->suite_file, "Suite file (docs/gate.md); required");
  gate->add_option("--thresholds", options->thresholds_file, "Thresholds file (docs/gate.md); required");
  gate->add_option("--baseline", options->baseline_file,
                   "Metrics of main (metrics.json of an earlier gate): fail on a regression");
  gate->add_option("--write-baseline", options->write_baseline_file,
                   "Write this run's metrics to this file, as a new baseline");
  gate->add_option("--out", options->out_dir,
                   "Output folder; a rerun into it resumes, reusing complete entries; required");
  gate->add_option("--jobs", options->jobs, "Suite entries run at once")->capture_default_str();
  gate->add_option("--colmap", options->colmap_executable,
                   "The colmap program: a name on PATH or a path")
      ->capture_default_str();
  gate->add_option("--fault-match-noise-px", options->fault_match_noise_px,
                   "Fault injection for testing the gate: noise on the flight method's matches, px")
      ->capture_default_str();
  gate->add_option("--set", options->hda_sets,
                   "A flight-method parameter over every entry's own: hda.KEY=VALUE (repeatable); a\n"
                   "what-if run, e.g. hda.max_slope_deg=90 declares every site safe")
      ->allow_extra_args(false);
  gate->add_option("--shard", options->shard,
                   "Run shard K of N (K/N): entry i when i mod N = K - 1, into its own --out; no verdict\n"
                   "until `gate merge` over every shard's folder (tools/slurm/ submits them)")
      ->capture_default_str();
  gate->add_option("--entries", options->entries,
                   "Run only these entries of the suite (comma-separated names) and check only the thresholds "
                   "of the pools they give")
      ->delimiter(',');
  gate->add_option("--methods", options->methods,
                   "Compare only these of each entry's methods (comma-separated; the flight method always runs) and "
                   "check only their thresholds")
      ->delimiter(',');
  gate->add_flag("--quiet", options->quiet, "No progress lines");

  const auto merge = std::make_shared<GateMergeOptions>();
  CLI::App* merge_app = gate->add_subcommand(
      "merge", "The shards' entries gathered into one folder, then the whole suite's metrics, table and verdict");
  merge_app->add_option("DIRS", merge->shard_dirs, "The shards' --out folders")->required();
  merge_app->add_option("--suite", merge->suite_file, "The suite the shards ran")->required();
  merge_app->add_option("--thresholds", merge->thresholds_file, "Thresholds file (docs/gate.md)")->required();
  merge_app->add_option("--baseline", merge->baseline_file,
                        "Metrics of main (metrics.json of an earlier gate): fail on a regression");
  merge_app->add_option("--write-baseline", merge->write_baseline_file,
                        "Write the merged metrics to this file, as a new baseline");
  merge_app->add_option("--out", merge->out_dir, "Output folder (entries gathered, metrics.json, gate.md, gate.html)")
      ->required();
  merge_app->add_flag("--quiet", merge->quiet, "No progress lines");
  // The gate's own flags are checked when it runs: a parsed merge has its
  // parent parsed too, so merge comes first.
  gate->require_subcommand(0, 1);
  return {{merge_app,
           [merge, gate, merge_app] {
             if (const std::string given = GateFlagBeforeMerge(*gate, *merge_app); !given.empty()) {
               std::cerr << "hdabench gate merge: " << given << "\n";
               return kExitUsage;
             }
             return RunGateMerge(*merge, std::cout, std::cerr);
           }},
          {gate, [options] { return RunGateCommand(*options, std::cout, std::cerr); }}};
}

}  // namespace hdabench::tools
