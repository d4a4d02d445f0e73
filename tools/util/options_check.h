// The one check every XOptions::Validate() of the bench uses. calib is the
// lowest layer, so the helper lives here for all modules.
#pragma once

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

namespace hdabench {

// Appends "field = value: expected <expected>" to *errors unless `ok` holds
// and `value` is finite (so NaN and infinity are always reported).
inline void RequireOption(bool ok, const std::string& field, double value,
                          const std::string& expected, std::vector<std::string>* errors) {
  if (ok && std::isfinite(value)) return;
  std::ostringstream message;
  message << field << " = " << value << ": expected " << expected;
  errors->push_back(message.str());
}

}  // namespace hdabench
