// The report a person reads of a folder written by `hdabench run` or
// `hdabench compare`: one self-contained HTML page (report.html: CSS inline,
// every figure a base64 PNG data URI, no other file needed) and a Markdown
// summary (report.md), both written into the folder. Specified in
// docs/report.md.
//
// The plots (slope estimated against true, slope error histograms, error
// against number of points and against predicted sigma, stage times against
// the budget, time per method) are drawn by matplotlib: the script
// reference/report/report_plots.py is compiled into the library
// (ReportPlotsScript) and run with Debian's python3 through util::PythonScript,
// on a copy written to a temporary folder. The figures `hdabench run` already wrote (quadtree, ROI
// pairs, matches) and the dataset's maps (elevation, slope, hazards) are
// embedded as they are.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace hdabench::reference {

struct ReportOptions {
  // The dataset folder the run was made on, for its maps/*.png. Empty: looked
  // for beside the run folder (docs/report.md, "Finding the dataset"); not
  // found is a note in the report, not an error.
  std::string dataset_dir;
  // The Python interpreter that runs the plotting script: a path, or a name
  // looked up on PATH. It needs matplotlib and numpy (Debian:
  // python3-matplotlib, python3-numpy).
  std::string python = "/usr/bin/python3";
  // Wall-time limit of the plotting script, seconds (> 0).
  double plot_timeout_s = 120.0;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

struct ReportResult {
  std::string kind;           // "run" (result.json) or "compare" (compare.json)
  std::string html_path;      // <run_dir>/report.html
  std::string markdown_path;  // <run_dir>/report.md
  int num_figures = 0;        // <img> elements embedded in report.html
  int num_table_rows = 0;     // rows of the per-ROI table (one per ROI)
  // True when the plotting script ran and every plot it drew is embedded.
  // False: report.html is written without the plots, and plots_error (also
  // shown in the page) says why, naming the interpreter or matplotlib.
  bool plots_ok = false;
  std::string plots_error;
  std::string dataset_dir;    // the dataset folder whose maps are embedded; empty: none
  // Everything the page says is missing (plots, dataset maps, a figure file
  // that is not a PNG), one line each; also written into the page.
  std::vector<std::string> notes;
};

// Writes report.html and report.md into `run_dir`, each to a temporary name
// renamed into place. The same folder and options give the same bytes (the
// page holds no date, and the plots are drawn deterministically).
// Throws InputError naming the path when run_dir is not a folder, holds
// neither result.json nor compare.json, one of the files the report reads is
// unreadable or malformed, options.dataset_dir is given but is not a folder,
// or a report file cannot be written. A plotting failure (no interpreter,
// no matplotlib, the script failing or timing out) does not throw: see
// ReportResult::plots_ok.
ReportResult WriteReport(const std::string& run_dir, const ReportOptions& options);

// Reads and checks what WriteReport reads of run_dir (its result.json or
// compare.json, the timing files, the flight figures) and builds the page's
// tables, without drawing the plots, looking for the dataset or writing
// anything; returns the number of rows of the per-ROI table. Throws as
// WriteReport does for the folder and its files (the fuzzing harness
// report_records drives it).
int CheckReportFolder(const std::string& run_dir);

// The slopes the plots draw, decided by the bench (report_plots.py applies no
// rule of its own): every fitted slope of every method of a folder's
// result.json (kind "run") or compare.json ("compare"), as read by
// WriteReport, each with its truth, sigma, points and whether the statistics
// count it (SlopeSample::Counts). JSON: {"min_points", "series": [{"method",
// "samples": [{"roi", "slope_deg", "truth_deg", "sigma_deg", "num_points",
// "counts"}]}]}.
std::string PlotSeriesJson(const nlohmann::json& result, const std::string& kind);

// The text of reference/report/report_plots.py as built into the library.
const std::string& ReportPlotsScript();

// Standard base64 (RFC 4648, with '=' padding, no line breaks).
std::string Base64Encode(const std::string& bytes);

}  // namespace hdabench::reference
