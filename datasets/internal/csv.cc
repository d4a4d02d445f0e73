#include "datasets/internal/csv.h"

#include <set>
#include <string_view>

#include "tools/util/text.h"

namespace hdabench::datasets::internal {

using util::ParseDouble;
using util::ParseInt;
using util::ParseStatus;
using util::Trim;

namespace {

std::vector<std::string> SplitFields(std::string_view line) {
  std::vector<std::string> fields;
  size_t begin = 0;
  while (true) {
    const size_t comma = line.find(',', begin);
    const std::string_view field =
        line.substr(begin, comma == std::string_view::npos ? std::string_view::npos : comma - begin);
    fields.emplace_back(Trim(field));
    if (comma == std::string_view::npos) break;
    begin = comma + 1;
  }
  return fields;
}

std::string JoinNames(const std::vector<std::string>& names) {
  std::string text;
  for (const std::string& name : names) text += (text.empty() ? "" : ", ") + name;
  return text;
}

std::string ExpectedColumns(const CsvSchema& schema) {
  std::string text = "expected columns " + JoinNames(schema.required);
  if (!schema.optional_groups.empty()) {
    text += " (optional:";
    for (const std::vector<std::string>& group : schema.optional_groups) {
      text += " " + JoinNames(group) + ";";
    }
    text.back() = ')';
  }
  return text;
}

}  // namespace

bool ParseCsv(const std::string& file, const std::string& text, const CsvSchema& schema,
              CsvTable* table, std::vector<Problem>* problems) {
  *table = CsvTable();
  // Lines; a final "\n" ends the last line rather than starting an empty one.
  std::vector<std::string_view> lines;
  std::string_view all(text);
  // The byte-order mark spreadsheet programs put before UTF-8 text is not
  // part of the first column's name.
  if (all.substr(0, 3) == "\xEF\xBB\xBF") all.remove_prefix(3);
  size_t begin = 0;
  while (begin < all.size()) {
    size_t end = all.find('\n', begin);
    if (end == std::string_view::npos) end = all.size();
    std::string_view line = all.substr(begin, end - begin);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    lines.push_back(line);
    begin = end + 1;
  }
  if (lines.empty()) {
    problems->push_back({file, "file is empty; expected a header line: " + JoinNames(schema.required)});
    return false;
  }

  const std::string header_where = file + ":1";
  const std::vector<std::string> header = SplitFields(lines[0]);
  std::set<std::string> known(schema.required.begin(), schema.required.end());
  for (const std::vector<std::string>& group : schema.optional_groups) {
    known.insert(group.begin(), group.end());
  }
  bool header_ok = true;
  for (size_t i = 0; i < header.size(); ++i) {
    const std::string& name = header[i];
    if (name.empty()) {
      problems->push_back({header_where, "header column " + std::to_string(i + 1) +
                                             " has no name; " + ExpectedColumns(schema)});
      header_ok = false;
    } else if (known.count(name) == 0 && !schema.allow_other_columns) {
      problems->push_back({header_where, "unknown column '" + name + "'; " + ExpectedColumns(schema)});
      header_ok = false;
    } else if (table->column_index.count(name) != 0) {
      problems->push_back({header_where, "column '" + name + "' appears twice"});
      header_ok = false;
    } else {
      table->column_index[name] = static_cast<int>(i);
    }
  }
  for (const std::string& name : schema.required) {
    if (table->column_index.count(name) == 0) {
      problems->push_back({header_where, "missing column '" + name + "'; " + ExpectedColumns(schema)});
      header_ok = false;
    }
  }
  for (const std::vector<std::string>& group : schema.optional_groups) {
    std::vector<std::string> present;
    std::vector<std::string> absent;
    for (const std::string& name : group) {
      (table->column_index.count(name) != 0 ? present : absent).push_back(name);
    }
    if (!present.empty() && !absent.empty()) {
      problems->push_back({header_where, "optional columns " + JoinNames(group) +
                                             " must all be present or all absent; missing " +
                                             JoinNames(absent)});
      header_ok = false;
    }
  }
  if (!header_ok) {
    table->rows.clear();
    return false;
  }

  for (size_t i = 1; i < lines.size(); ++i) {
    const int line_number = static_cast<int>(i + 1);
    const std::string where = file + ":" + std::to_string(line_number);
    ++table->num_data_lines;
    if (Trim(lines[i]).empty()) {
      problems->push_back({where, "empty line; expected " + std::to_string(header.size()) +
                                      " comma-separated values"});
      continue;
    }
    CsvRow row;
    row.line = line_number;
    row.fields = SplitFields(lines[i]);
    if (row.fields.size() != header.size()) {
      problems->push_back({where, "row has " + std::to_string(row.fields.size()) +
                                      " values; the header has " + std::to_string(header.size()) +
                                      " columns"});
      continue;
    }
    table->rows.push_back(std::move(row));
  }
  return true;
}

CsvRowReader::CsvRowReader(const std::string& file, const CsvTable& table, const CsvRow& row,
                           std::vector<Problem>* problems)
    : file_(file), table_(table), row_(row), problems_(problems) {}

std::string CsvRowReader::Where() const { return file_ + ":" + std::to_string(row_.line); }

void CsvRowReader::Fail(const std::string& message) {
  problems_->push_back({Where(), message});
  ok_ = false;
}

const std::string* CsvRowReader::Field(const std::string& column) {
  const auto it = table_.column_index.find(column);
  if (it == table_.column_index.end()) {
    Fail("column '" + column + "' is not in the header");
    return nullptr;
  }
  return &row_.fields[static_cast<size_t>(it->second)];
}

double CsvRowReader::Double(const std::string& column) {
  const std::string* field = Field(column);
  if (field == nullptr) return 0.0;
  double value = 0.0;
  switch (ParseDouble(*field, &value)) {
    case ParseStatus::kOk:
      return value;
    case ParseStatus::kEmpty:
      Fail("column '" + column + "' is empty; expected a number");
      break;
    case ParseStatus::kNotFinite:
      Fail("column '" + column + "': value '" + *field + "' is not finite; expected a finite number");
      break;
    case ParseStatus::kOutOfRange:
      Fail("column '" + column + "': value '" + *field + "' is out of the range of a double");
      break;
    case ParseStatus::kNotNumber:
    case ParseStatus::kNotInteger:
      Fail("column '" + column + "': '" + *field + "' is not a number");
      break;
  }
  return 0.0;
}

int CsvRowReader::Int(const std::string& column) {
  const std::string* field = Field(column);
  if (field == nullptr) return 0;
  int value = 0;
  switch (ParseInt(*field, &value)) {
    case ParseStatus::kOk:
      return value;
    case ParseStatus::kEmpty:
      Fail("column '" + column + "' is empty; expected a whole number");
      break;
    case ParseStatus::kNotInteger:
    case ParseStatus::kNotFinite:
      Fail("column '" + column + "': '" + *field + "' is not a whole number");
      break;
    case ParseStatus::kOutOfRange:
      Fail("column '" + column + "': value '" + *field + "' is out of the range of an int");
      break;
    case ParseStatus::kNotNumber:
      Fail("column '" + column + "': '" + *field + "' is not a number");
      break;
  }
  return 0;
}

std::string CsvRowReader::TextOrEmpty(const std::string& column) {
  const std::string* field = Field(column);
  return field == nullptr ? std::string() : *field;
}

std::string CsvRowReader::Text(const std::string& column) {
  const std::string* field = Field(column);
  if (field == nullptr) return std::string();
  if (field->empty()) Fail("column '" + column + "' is empty");
  return *field;
}

std::string CsvLine(const std::vector<std::string>& values) {
  std::string line;
  for (size_t i = 0; i < values.size(); ++i) {
    if (i > 0) line += ',';
    line += values[i];
  }
  return line + "\n";
}

}  // namespace hdabench::datasets::internal
