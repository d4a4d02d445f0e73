// The dataset's CSV tables (docs/dataset-format.md, "Tables"): a header line of
// column names, then one comma-separated row per line. No quoting; blanks around
// values are ignored; "\r\n" line ends are accepted.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "datasets/problem.h"

namespace hdabench::datasets::internal {

struct CsvSchema {
  std::vector<std::string> required;                     // must all be present
  std::vector<std::vector<std::string>> optional_groups;  // each: all present or all absent
  bool allow_other_columns = false;  // other columns are kept and not a problem (field logs)
};

struct CsvRow {
  int line = 0;                     // 1-based line number in the file
  std::vector<std::string> fields;  // one per header column, trimmed
};

struct CsvTable {
  std::map<std::string, int> column_index;  // header name -> field index
  std::vector<CsvRow> rows;                 // rows with one value per header column
  int num_data_lines = 0;                   // data lines seen, including rejected ones

  bool HasColumn(const std::string& name) const { return column_index.count(name) != 0; }
};

// Splits `text` (the contents of `file`, a path relative to the dataset used in
// problem locations) into a table. Checks the header against `schema`: a
// missing, unknown or duplicate column, or a partial optional group, is a
// problem and the rows are then not read (returns false). Rows with a wrong
// number of values and empty lines are problems and left out of `rows`.
bool ParseCsv(const std::string& file, const std::string& text, const CsvSchema& schema,
              CsvTable* table, std::vector<Problem>* problems);

// Reads typed values from one row; each failure adds a problem "file:line" that
// names the column, the text found and what was expected.
class CsvRowReader {
 public:
  CsvRowReader(const std::string& file, const CsvTable& table, const CsvRow& row,
               std::vector<Problem>* problems);

  // A finite double. Returns 0 on failure.
  double Double(const std::string& column);
  // A whole number. Returns 0 on failure.
  int Int(const std::string& column);
  // The trimmed text; a problem when empty.
  std::string Text(const std::string& column);
  // The trimmed text, which may be empty.
  std::string TextOrEmpty(const std::string& column);

  // Records a problem at this row.
  void Fail(const std::string& message);
  std::string Where() const;
  int Line() const { return row_.line; }
  // False once any read or Fail() at this row failed.
  bool ok() const { return ok_; }

 private:
  const std::string* Field(const std::string& column);

  const std::string& file_;
  const CsvTable& table_;
  const CsvRow& row_;
  std::vector<Problem>* problems_;
  bool ok_ = true;
};

// Writes a CSV line: the values joined by commas, then "\n".
std::string CsvLine(const std::vector<std::string>& values);

}  // namespace hdabench::datasets::internal
