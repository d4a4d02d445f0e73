// `hdabench report`: the HTML page and Markdown summary of a run or compare
// folder (reference/report/report.h, docs/report.md); also written at the end of
// `hdabench run` and `hdabench compare` unless --no-report.
#include <exception>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>

#include "tools/util/error.h"
#include "reference/report/report.h"
#include "tools/cli/command_line.h"
#include "tools/cli/commands.h"
#include "tools/cli/exit_codes.h"

namespace hdabench::tools {

namespace {

void PrintWritten(const reference::ReportResult& result, std::ostream& out) {
  out << "report: " << result.html_path << " (" << result.num_figures << " figures, "
      << result.num_table_rows << " ROIs), " << result.markdown_path << "\n";
}

}  // namespace

int RunReportCommand(const ReportCommandOptions& options, std::ostream& out, std::ostream& err) {
  reference::ReportOptions report;
  report.dataset_dir = options.dataset_dir;
  report.python = options.python;
  reference::ReportResult result;
  try {
    result = reference::WriteReport(options.run_dir, report);
  } catch (const InputError& e) {
    err << "hdabench report: " << e.what() << "\n";
    return kExitInput;
  }
  PrintWritten(result, out);
  if (!options.quiet) {
    for (const std::string& note : result.notes) err << "hdabench report: note: " << note << "\n";
  }
  if (!result.plots_ok) {
    err << "hdabench report: the report has no plots: " << result.plots_error << "\n";
    return kExitExternal;
  }
  return kExitOk;
}

bool WriteReportAfterCommand(const std::string& out_dir, const std::string& dataset_dir,
                             const std::string& command, bool quiet, std::ostream& out,
                             std::ostream& err) {
  if (!quiet) err << "hdabench " << command << ": writing the report\n";
  reference::ReportOptions report;
  report.dataset_dir = dataset_dir;
  reference::ReportResult result;
  try {
    result = reference::WriteReport(out_dir, report);
  } catch (const InputError& e) {
    err << "hdabench " << command << ": warning: report: " << e.what()
        << " (the other outputs are written; hdabench report " << out_dir << " retries)\n";
    return false;
  } catch (const std::exception& e) {
    // Not the folder's fault but the report's own: still not the command's,
    // whose results are written (docs/report.md).
    err << "hdabench " << command << ": warning: report: internal error: " << e.what()
        << " (the other outputs are written; hdabench report " << out_dir << " retries)\n";
    return false;
  }
  PrintWritten(result, out);
  if (!quiet) {
    for (const std::string& note : result.notes) {
      err << "hdabench " << command << ": report: note: " << note << "\n";
    }
  }
  if (!result.plots_ok) {
    err << "hdabench " << command << ": warning: report: no plots: " << result.plots_error << "\n";
    return false;
  }
  return true;
}

// report: RUN_DIR, --dataset, --python and --quiet.
Command AddReportCommand(CLI::App& app) {
  const auto options = std::make_shared<ReportCommandOptions>();
  CLI::App* report = app.add_subcommand(
      "report", "The HTML report (report.html, every figure embedded) and report.md of a run or\n"
                "compare folder (docs/report.md)");
  report->add_option("RUN_DIR", options->run_dir,
                     "Folder written by hdabench run or hdabench compare")
      ->required();
  report->add_option("--dataset", options->dataset_dir,
                     "The dataset folder, for its maps (default: looked for beside RUN_DIR)");
  report->add_option("--python", options->python,
                     "Python interpreter with matplotlib that draws the plots")
      ->capture_default_str();
  report->add_flag("--quiet", options->quiet, "No note lines");
  return {report, [options] { return RunReportCommand(*options, std::cout, std::cerr); }};
}

}  // namespace hdabench::tools
