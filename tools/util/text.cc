#include "tools/util/text.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <system_error>

#include <nlohmann/json.hpp>

namespace hdabench::util {

std::string ShortestText(double value) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  char buffer[64];
  const std::to_chars_result result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  return std::string(buffer, result.ptr);
}

std::string VectorText(const Eigen::VectorXd& values) {
  std::string text = "(";
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    if (i > 0) text += ", ";
    text += ShortestText(values[i]);
  }
  return text + ")";
}

std::string CsvNumber(double value) { return std::isfinite(value) ? nlohmann::json(value).dump() : ""; }

std::string JoinInts(const std::vector<int>& values) {
  std::string text;
  for (const int value : values) text += (text.empty() ? "" : ", ") + std::to_string(value);
  return text.empty() ? "none" : text;
}

std::string FixedText(double value, int digits) {
  char buffer[512];
  // Beyond 1e15 fixed point would print every digit of the number (309 of
  // them for 1e308), none meaningful: an exponent instead.
  std::snprintf(buffer, sizeof(buffer), std::abs(value) >= 1e15 && std::isfinite(value) ? "%.*e" : "%.*f", digits,
                value);
  return buffer;
}

std::vector<std::string_view> SplitAtCommas(std::string_view text) {
  std::vector<std::string_view> items;
  for (size_t begin = 0; !text.empty();) {
    const size_t comma = text.find(',', begin);
    items.push_back(text.substr(begin, comma == std::string_view::npos ? std::string_view::npos : comma - begin));
    if (comma == std::string_view::npos) break;
    begin = comma + 1;
  }
  return items;
}

std::string FixedCell(double value, int digits) {
  return std::isfinite(value) ? FixedText(value, digits) : "-";
}

std::string SignedCell(double value, int digits) {
  const std::string text = FixedCell(value, digits);
  return std::isfinite(value) && text.front() != '-' ? "+" + text : text;
}

std::string FormatTextTable(const std::vector<std::vector<std::string>>& rows,
                            const std::vector<bool>& left) {
  std::vector<size_t> widths(left.size(), 0);
  for (const auto& row : rows) {
    for (size_t c = 0; c < row.size(); ++c) widths[c] = std::max(widths[c], row[c].size());
  }
  std::ostringstream out;
  const auto print_row = [&](const std::vector<std::string>& row) {
    std::string line;
    for (size_t c = 0; c < row.size(); ++c) {
      const std::string pad(widths[c] - row[c].size(), ' ');
      line += (c > 0 ? "  " : "") + (left[c] ? row[c] + pad : pad + row[c]);
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    out << line << "\n";
  };
  for (size_t r = 0; r < rows.size(); ++r) {
    print_row(rows[r]);
    if (r == 0) {
      std::vector<std::string> rule;
      for (const size_t w : widths) rule.emplace_back(w, '-');
      print_row(rule);
    }
  }
  return out.str();
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string_view Trim(std::string_view text) {
  size_t begin = 0;
  size_t end = text.size();
  while (begin < end && (text[begin] == ' ' || text[begin] == '\t')) ++begin;
  while (end > begin && (text[end - 1] == ' ' || text[end - 1] == '\t')) --end;
  return text.substr(begin, end - begin);
}

namespace {
// Trims `text` and drops one leading '+', which from_chars does not take.
// Returns kOk, kEmpty, or kNotNumber for a sign alone or "+-1".
ParseStatus PrepareNumber(std::string_view* text) {
  *text = Trim(*text);
  if (text->empty()) return ParseStatus::kEmpty;
  if (text->front() == '+') {
    text->remove_prefix(1);
    if (text->empty() || text->front() == '-' || text->front() == '+') return ParseStatus::kNotNumber;
  }
  return ParseStatus::kOk;
}
}  // namespace

ParseStatus ParseDouble(std::string_view text, double* value) {
  if (const ParseStatus status = PrepareNumber(&text); status != ParseStatus::kOk) return status;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  const std::from_chars_result result = std::from_chars(begin, end, *value);
  if (result.ec == std::errc::result_out_of_range) return ParseStatus::kOutOfRange;
  if (result.ec != std::errc() || result.ptr != end) return ParseStatus::kNotNumber;
  if (!std::isfinite(*value)) return ParseStatus::kNotFinite;
  return ParseStatus::kOk;
}

ParseStatus ParseInt(std::string_view text, int* value) {
  if (const ParseStatus status = PrepareNumber(&text); status != ParseStatus::kOk) return status;
  const char* begin = text.data();
  const char* end = text.data() + text.size();
  const std::from_chars_result result = std::from_chars(begin, end, *value);
  if (result.ec == std::errc::result_out_of_range) return ParseStatus::kOutOfRange;
  if (result.ec == std::errc() && result.ptr == end) return ParseStatus::kOk;
  // Tell "2.5" (a number, not whole) from "abc".
  double as_double = 0.0;
  const ParseStatus as_number = ParseDouble(text, &as_double);
  if (as_number == ParseStatus::kOk || as_number == ParseStatus::kNotFinite) {
    return ParseStatus::kNotInteger;
  }
  return ParseStatus::kNotNumber;
}

std::string JsonErrorText(const std::string& what) {
  if (!what.empty() && what.front() == '[') {
    const size_t close = what.find("] ");
    if (close != std::string::npos) return what.substr(close + 2);
  }
  return what;
}

}  // namespace hdabench::util
