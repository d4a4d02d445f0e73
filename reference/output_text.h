// Text helpers shared by the bench's output writers (flight run, comparison):
// numbers as JSON and CSV that read back identical, fixed-point table cells,
// aligned text tables, quantiles.
#pragma once

#include <string>
#include <vector>

namespace hdabench::reference {

// A double as CSV text that reads back identical (nlohmann's shortest
// round-trip form); empty when it is not finite.
std::string CsvNumber(double value);

// Fixed-point text with `digits` decimals; "-" when not finite.
std::string FixedText(double value, int digits);

// Columns aligned to their widest cell; `left` columns are left-aligned, the
// others right-aligned; a rule of dashes under the header (the first row).
std::string FormatTextTable(const std::vector<std::vector<std::string>>& rows,
                            const std::vector<bool>& left);

// p-quantile of sorted values, linear between order statistics; 0 when empty.
double Quantile(const std::vector<double>& sorted, double p);

// Text for HTML: & < > " ' replaced by their entities.
std::string HtmlEscape(const std::string& text);

}  // namespace hdabench::reference
