// Error types shared by every module (util is the lowest layer), so the types
// that cross module boundaries live here.
#pragma once

#include <stdexcept>
#include <string>

namespace hdabench {

// Input from outside the program (a file, a dataset, a flag value) is unusable.
// what() names the file (and line or field where there is one), the value and
// what was expected. The CLI maps it to exit code 3 (README, "Exit codes").
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// A request the library cannot honour for this input by design, e.g. an OpenCV
// conversion of a lens model OpenCV has no equivalent for. CLI exit code 3.
class UnsupportedError : public std::runtime_error {
 public:
  explicit UnsupportedError(const std::string& message) : std::runtime_error(message) {}
};

// A program the bench runs (mrcal's tools, Debian's python3 with its modules)
// failed: not found, non-zero exit, timeout or unusable output. what() names
// the program, what it was doing and where its log is. CLI exit code 4.
class ExternalError : public std::runtime_error {
 public:
  explicit ExternalError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace hdabench
