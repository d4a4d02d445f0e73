// `hdabench faults`: the flight method on one pair of a dataset, clean and
// under each sensor fault at a sweep of magnitudes (reference/faults/,
// docs/faults.md); writes faults.csv, faults.json and faults.md, prints the
// table, and draws faults.png.
#include <algorithm>
#include <iostream>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/core/utility.hpp>

#include "datasets/faults.h"
#include "reference/faults/fault_study.h"
#include "tools/cli/command_line.h"
#include "tools/cli/command_support.h"
#include "tools/cli/exit_codes.h"
#include "tools/util/error.h"
#include "tools/util/files.h"
#include "tools/util/options_check.h"
#include "tools/util/text.h"

namespace hdabench::tools {

namespace {

struct FaultsArgs {
  std::string dataset_dir;
  std::string out_dir;
  std::string frames_text;
  std::vector<std::string> fault_texts;
  std::uint64_t seed = 1;
  std::string params_file;
  std::vector<std::string> hda_sets;
  reference::FaultRequirements requirements;
  std::string python = "/usr/bin/python3";
  bool no_figures = false;
  bool list = false;
  bool quiet = false;
};

// --fault's text as datasets::ParseFaults reads it; a bad one is a
// CLI::ValidationError (exit 2) naming the flag.
std::vector<datasets::Fault> ParseFaultFlag(const std::string& text) {
  try {
    const std::vector<datasets::Fault> faults = datasets::ParseFaults(text);
    // A magnitude the fault never takes is the flag's (exit 2), found before
    // the clean run; one the dataset cannot take is listed as not applied.
    for (const datasets::Fault& fault : faults) datasets::CheckFaultMagnitude(fault);
    return faults;
  } catch (const InputError& e) {
    throw CLI::ValidationError("--fault", e.what());
  }
}

std::string CatalogueText() {
  std::vector<std::vector<std::string>> rows = {{"fault", "unit", "default sweep", "what it does"}};
  for (const datasets::FaultInfo& info : datasets::FaultCatalogue()) {
    std::string sweep;
    if (info.unit[0] != '\0') {
      for (const double m : info.sweep) sweep += (sweep.empty() ? "" : ",") + util::ShortestText(m);
    }
    rows.push_back({info.name, info.unit[0] == '\0' ? "-" : info.unit, sweep.empty() ? "-" : sweep,
                    info.description});
  }
  return util::FormatTextTable(rows, {true, true, true, true});
}

int RunFaults(const FaultsArgs& args, std::ostream& out, std::ostream& err) {
  if (args.list) {
    out << CatalogueText();
    return kExitOk;
  }
  if (args.dataset_dir.empty() || args.out_dir.empty()) {
    err << "hdabench faults: give DATASET and --out DIR (or --list for the faults)\n";
    return kExitUsage;
  }
  const auto progress = [&](const std::string& line) {
    if (!args.quiet) err << "hdabench faults: " << line << "\n";
  };
  const std::vector<std::string> bad_requirements = args.requirements.Validate();
  if (!bad_requirements.empty()) {
    err << "hdabench faults: " << JoinMessages(bad_requirements) << "\n";
    return kExitUsage;
  }
  std::vector<datasets::Fault> faults;
  for (const std::string& text : args.fault_texts) {
    const std::vector<datasets::Fault> some = ParseFaultFlag(text);
    faults.insert(faults.end(), some.begin(), some.end());
  }
  // One case per fault and magnitude: a repeat would only run again.
  std::set<std::string> labels;
  for (const datasets::Fault& fault : faults) {
    if (!labels.insert(datasets::FaultLabel(fault)).second) {
      err << "hdabench faults: --fault " << datasets::FaultLabel(fault) << " is given twice\n";
      return kExitUsage;
    }
  }
  if (faults.empty()) faults = reference::DefaultFaultSweep();
  reference::HdaSettings settings;
  const int settings_code = BuildHdaSettings(args.params_file, {}, args.hda_sets, "faults", err, &settings);
  if (settings_code != kExitOk) return settings_code;

  const bool drops_a_frame = std::any_of(faults.begin(), faults.end(), [](const datasets::Fault& f) {
    return f.kind == datasets::FaultKind::kFrameDropped;
  });
  const PairLoad pair = LoadDatasetPair(args.dataset_dir, ParseFramesFlag(args.frames_text), args.out_dir,
                                        "faults", err, progress, /*read_dem=*/true, "faults.json", drops_a_frame);
  if (pair.exit_code != kExitOk) return pair.exit_code;
  // One core, as on the flight computer (results do not depend on it).
  cv::setNumThreads(1);
  progress(std::to_string(faults.size()) + " fault case(s) on frames " + std::to_string(pair.frames.first) + "," +
           std::to_string(pair.frames.second) + ", and the clean run");
  return WithExitCodes("hdabench faults: ", err, [&] {
    const reference::FaultStudy study =
        reference::RunFaultStudy(*pair.dataset, pair.frames.first, pair.frames.second, settings, faults,
                                 args.requirements, args.seed, progress);
    const std::string table = reference::FaultStudyMarkdown(study);
    util::WriteFileAtomically(std::filesystem::path(args.out_dir) / "faults.csv", reference::FaultStudyCsv(study));
    util::WriteFileAtomically(std::filesystem::path(args.out_dir) / "faults.md", table);
    // faults.json last: it marks the folder as holding a whole study.
    util::WriteFileAtomically(std::filesystem::path(args.out_dir) / "faults.json", reference::FaultStudyJson(study));
    out << table;
    out << "wrote faults.csv, faults.md and faults.json to " << args.out_dir << "\n";
    if (args.no_figures) return;
    // The figure never changes the exit code: without it the study is whole.
    const std::string problem = reference::WriteFaultPlots(args.out_dir, args.python);
    if (problem.empty()) {
      out << "wrote faults.png\n";
    } else {
      err << "hdabench faults: warning: no faults.png: " << problem << "\n";
    }
  });
}

}  // namespace

Command AddFaultsCommand(CLI::App& app) {
  const auto args = std::make_shared<FaultsArgs>();
  CLI::App* faults = app.add_subcommand(
      "faults",
      "The flight method under sensor faults (LRF, navigation, clock, images) at a sweep of magnitudes,\n"
      "against the truth and the clean run (docs/faults.md)");
  faults->add_option("DATASET", args->dataset_dir, "Dataset folder (with truth for the slope errors)");
  faults->add_option("--out", args->out_dir, "Output folder (created if missing): faults.csv, faults.json, faults.md");
  faults->add_option("--frames", args->frames_text,
                     "Two different frame indices i,j (default: as hdabench run)");
  faults->add_option("--fault", args->fault_texts,
                     "A fault and its magnitudes, NAME or NAME=M1,M2,... (repeatable; default: every fault\n"
                     "at its default sweep; --list shows them)")
      ->allow_extra_args(false);
  AddSeedOption(faults, &args->seed, "Seed of the faults' random numbers (lrf-noise)");
  faults->add_option("--max-median-deg", args->requirements.max_median_deg,
                     "Requirement: slope error median at most this")
      ->capture_default_str();
  faults->add_option("--max-p90-deg", args->requirements.max_p90_deg,
                     "Requirement: slope error 90th percentile at most this")
      ->capture_default_str();
  faults->add_option("--min-within-two-sigma", args->requirements.min_within_two_sigma,
                     "Requirement: share of slopes within 2 predicted sigmas at least this")
      ->capture_default_str();
  faults->add_option("--min-share", args->requirements.min_evaluated_share,
                     "Requirement: share of ROIs with a slope at least this")
      ->capture_default_str();
  faults->add_option("--min-roi-fraction", args->requirements.min_rois_vs_clean,
                     "Requirement: ROIs found at least this fraction of the clean run's")
      ->capture_default_str();
  faults->add_option("--params", args->params_file, kParamsHelp);
  faults->add_option("--set", args->hda_sets, kSetHelp)->allow_extra_args(false);
  faults->add_option("--python", args->python, "Python 3 with matplotlib, for faults.png")->capture_default_str();
  faults->add_flag("--no-figures", args->no_figures, "Do not draw faults.png");
  faults->add_flag("--list", args->list, "Print the faults, their units and default sweeps, and exit");
  faults->add_flag("--quiet", args->quiet, "No progress lines");
  return {faults, [args] { return RunFaults(*args, std::cout, std::cerr); }};
}

}  // namespace hdabench::tools
