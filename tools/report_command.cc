// `hdabench report`: the HTML page and Markdown summary of a run or compare
// folder (reference/report.h, docs/report.md); also written at the end of
// `hdabench run` and `hdabench compare` unless --no-report.
#include <string>

#include "calib/error.h"
#include "reference/report.h"
#include "tools/commands.h"
#include "tools/exit_codes.h"

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

}  // namespace hdabench::tools
