// One defect found while checking a dataset (docs/dataset-format.md, "What the
// loader checks").
#pragma once

#include <string>

namespace hdabench::datasets {

struct Problem {
  // Where the defect is: "file:line" for a table row, "manifest.json: field 'x'"
  // for a manifest field, or a file path relative to the dataset folder.
  std::string where;
  // What is wrong: the value found and what was expected.
  std::string message;

  // "where: message", the line `hdabench dataset check` prints.
  std::string ToString() const { return where + ": " + message; }
};

inline bool operator==(const Problem& a, const Problem& b) {
  return a.where == b.where && a.message == b.message;
}

}  // namespace hdabench::datasets
