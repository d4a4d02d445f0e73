// Numbers and text, one helper per purpose, used by every module:
// - ShortestText: the shortest decimal that reads back as the same double, for
//   files other programs read (dataset tables, COLMAP models, camera models);
// - CsvNumber: a double as nlohmann's JSON writes it, for CSV tables that sit
//   beside a JSON file with the same numbers;
// - FixedCell: a fixed number of decimals for a table cell, "-" when there is
//   no number;
// - FixedText: a fixed number of decimals for messages and logs ("nan" as is);
// - parsing of whole decimal numbers, trimming, aligned text tables and HTML
//   escaping.
// Locale-independent (std::to_chars / std::from_chars / "%.*f" in the C locale).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

namespace hdabench::util {

// Shortest decimal that reads back as the same double ("0.02", "1e-07", "nan",
// "inf", "-inf").
std::string ShortestText(double value);

// "(1, 2, 3)" with ShortestText for each element.
std::string VectorText(const Eigen::VectorXd& values);

// A double as CSV text that reads back identical, in nlohmann's JSON form
// ("1.0", "0.25"), so a CSV and its JSON twin print the same numbers; empty
// when it is not finite.
std::string CsvNumber(double value);

// A table cell: fixed-point text with `digits` decimals ("%.*f"); "-" when
// not finite.
std::string FixedCell(double value, int digits);

// A table cell for a signed value: FixedCell with a "+" before a value that
// does not print as negative ("+0.87", "-0.12", "+0.00"); "-" when not finite.
std::string SignedCell(double value, int digits);

// Fixed-point text with `digits` decimals ("%.*f"), for messages: "nan",
// "inf" and "-inf" as they are, and from 1e15 on with an exponent ("%.*e":
// 1.00e+308, not 309 digits).
std::string FixedText(double value, int digits);

// Whole numbers separated by ", " ("0, 6"); "none" for an empty list.
std::string JoinInts(const std::vector<int>& values);

// Columns aligned to their widest cell; `left` columns are left-aligned, the
// others right-aligned; a rule of dashes under the header (the first row).
std::string FormatTextTable(const std::vector<std::vector<std::string>>& rows,
                            const std::vector<bool>& left);

// Text for HTML: & < > " ' replaced by their entities.
std::string HtmlEscape(const std::string& text);

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

// The items between the commas of `text`, the last included: "1,2," gives
// "1", "2" and "" (so a caller refuses an empty item as any other); "" gives
// none. The views point into `text`.
std::vector<std::string_view> SplitAtCommas(std::string_view text);

// A JSON library error's what() without its "[json.exception.parse_error.101] "
// tag: "parse error at line 1, column 1: ...", for a message about a file.
std::string JsonErrorText(const std::string& what);

}  // namespace hdabench::util
