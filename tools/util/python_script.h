// Running a Python script that is compiled into the bench (the calibration
// analysis, the report's plots) in a clean, repeatable environment.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "tools/util/files.h"
#include "tools/util/process.h"

namespace hdabench::util {

struct PythonScriptOptions {
  std::string python = "/usr/bin/python3";  // the interpreter (a name is looked up in PATH)
  std::string log_file;                     // receives the script's stdout and stderr, started afresh
  std::string working_dir;                  // empty: the caller's
  double timeout_s = 0.0;                   // wall-time limit, seconds; <= 0: none
  // One thread for NumPy's linear algebra (OpenBLAS, OpenMP, MKL), so sums
  // are done in the same order on every run.
  bool single_threaded_math = false;

  // Every violated constraint, one message each ("field = value: expected ...").
  std::vector<std::string> Validate() const;
};

// A script's text written as `file_name` into a fresh scratch folder (removed
// with this object), run as `python script arguments...` with: matplotlib's
// Agg backend and a fresh configuration (no user style changes a figure), no
// byte-code files, a fixed hash seed and SOURCE_DATE_EPOCH 0. The scratch
// folder is the place for the script's own outputs.
class PythonScript {
 public:
  // Throws InputError when the scratch folder or the script cannot be written.
  PythonScript(const std::string& purpose, const std::string& file_name, const std::string& text);

  const std::filesystem::path& folder() const { return folder_.path(); }
  const std::filesystem::path& script() const { return script_; }

  // Runs the script; what goes wrong with Python is in the result (RunProcess).
  // Throws InputError when the earlier log cannot be removed or the options
  // are invalid.
  ProcessResult Run(const std::vector<std::string>& arguments, const PythonScriptOptions& options) const;

 private:
  TempFolder folder_;
  std::filesystem::path script_;
  std::filesystem::path config_;
};

// Runs a compiled-in plotting script: `text` saved as `file_name` in a
// scratch folder (PythonScript, `purpose` names it), run with `python` (a
// path, or a name looked up in PATH) as `python script arguments...`, NumPy
// on one thread, at most `timeout_s` seconds. `figures_dir`, when not empty,
// is created (with its parents) once the interpreter is found, so that no
// folder is left behind without Python. Returns "" when it ran, else what
// went wrong in one line: the interpreter not found, the folder not made, or
// the script failed with its last line of output.
std::string RunPlotScript(const std::string& python, const std::string& purpose, const std::string& file_name,
                          const std::string& text, const std::vector<std::string>& arguments, double timeout_s,
                          const std::string& figures_dir = "");

}  // namespace hdabench::util
