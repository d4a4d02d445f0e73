#include "tools/util/python_script.h"

#include <system_error>

#include "tools/util/error.h"
#include "tools/util/options_check.h"

namespace hdabench::util {

namespace fs = std::filesystem;

PythonScript::PythonScript(const std::string& purpose, const std::string& file_name,
                           const std::string& text)
    : folder_(purpose), script_(folder_.path() / file_name), config_(folder_.path() / "matplotlib") {
  std::error_code ec;
  fs::create_directories(config_, ec);
  if (ec || !fs::is_directory(config_)) {
    throw InputError(config_.string() + ": cannot create the matplotlib configuration folder" +
                     (ec ? ": " + ec.message() : ""));
  }
  WriteFileAtomically(script_, text);
}

std::vector<std::string> PythonScriptOptions::Validate() const {
  std::vector<std::string> errors;
  if (python.empty()) errors.push_back("python is empty: expected an interpreter such as /usr/bin/python3");
  RequireOption(true, "timeout_s", timeout_s, "a finite number of seconds (<= 0: none)", &errors);
  return errors;
}

ProcessResult PythonScript::Run(const std::vector<std::string>& arguments,
                                const PythonScriptOptions& options) const {
  ThrowIfInvalid("PythonScript: invalid PythonScriptOptions: ", options.Validate());
  if (!options.log_file.empty()) {
    // A fresh log per run, so that its last line is this run's.
    std::error_code ec;
    fs::remove(options.log_file, ec);
    if (ec) throw InputError(options.log_file + ": cannot remove the earlier log: " + ec.message());
  }
  ProcessOptions process;
  process.working_dir = options.working_dir;
  process.log_file = options.log_file;
  process.timeout_s = options.timeout_s;
  process.environment = {{"MPLBACKEND", "Agg"},
                         {"MPLCONFIGDIR", config_.string()},
                         {"MATPLOTLIBRC", config_.string()},
                         {"PYTHONDONTWRITEBYTECODE", "1"},
                         {"PYTHONHASHSEED", "0"},
                         {"SOURCE_DATE_EPOCH", "0"}};
  if (options.single_threaded_math) {
    process.environment.insert(process.environment.end(), {{"OPENBLAS_NUM_THREADS", "1"},
                                                           {"OMP_NUM_THREADS", "1"},
                                                           {"MKL_NUM_THREADS", "1"}});
  }
  std::vector<std::string> argv = {options.python, script_.string()};
  argv.insert(argv.end(), arguments.begin(), arguments.end());
  return RunProcess(argv, process);
}

std::string RunPlotScript(const std::string& python, const std::string& purpose, const std::string& file_name,
                          const std::string& text, const std::vector<std::string>& arguments, double timeout_s,
                          const std::string& figures_dir) {
  const std::string interpreter = FindExecutable(python);
  if (interpreter.empty()) {
    return "the Python interpreter '" + python + "' was not found; the plots need Python 3 with matplotlib";
  }
  if (!figures_dir.empty()) {
    std::error_code ec;
    fs::create_directories(figures_dir, ec);
    if (ec) return figures_dir + ": cannot create the folder: " + ec.message();
  }
  const PythonScript script(purpose, file_name, text);
  const fs::path log = script.folder() / "plots.log";
  PythonScriptOptions run;
  run.python = interpreter;
  run.log_file = log.string();
  run.working_dir = script.folder().string();
  run.timeout_s = timeout_s;
  run.single_threaded_math = true;
  const ProcessResult result = script.Run(arguments, run);
  if (!result.Ok()) {
    const std::string last_line = LastLineOfLog(log.string());
    return "the plotting script (" + file_name + " under " + interpreter + ") failed: " + result.error +
           (last_line.empty() ? "" : ": " + last_line);
  }
  return "";
}

}  // namespace hdabench::util
