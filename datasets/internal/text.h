// Number formatting and parsing shared by the dataset reader and writer.
// Locale-independent (std::to_chars / std::from_chars).
#pragma once

#include <string>
#include <string_view>

#include <Eigen/Core>

namespace hdabench::datasets::internal {

// Shortest decimal that reads back as the same double ("0.02", "1e-07", "nan").
std::string FormatDouble(double value);

// "(1, 2, 3)" with FormatDouble for each element.
std::string FormatVector(const Eigen::VectorXd& values);

enum class ParseStatus {
  kOk,
  kEmpty,       // nothing but blanks
  kNotNumber,   // not a decimal number (or trailing characters)
  kOutOfRange,  // a number too large for the type
  kNotFinite,   // nan or inf (doubles only)
  kNotInteger,  // a number, but not a whole one (integers only)
};

// Parses the whole of `text` as a decimal double. Accepts an optional sign,
// digits, a fraction and an exponent; "nan" and "inf" parse but return
// kNotFinite (the value is still stored).
ParseStatus ParseDouble(std::string_view text, double* value);

// Parses the whole of `text` as a decimal int (optional leading '-' or '+').
ParseStatus ParseInt(std::string_view text, int* value);

// Removes leading and trailing spaces and tabs.
std::string_view Trim(std::string_view text);

}  // namespace hdabench::datasets::internal
