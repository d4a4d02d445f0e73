// The one check every XOptions::Validate() of the bench uses, and the one way
// its messages become an exception.
#pragma once

#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include "tools/util/error.h"

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

// The messages joined by `separator` ("a; b").
inline std::string JoinMessages(const std::vector<std::string>& messages,
                                const std::string& separator = "; ") {
  std::string text;
  for (size_t i = 0; i < messages.size(); ++i) text += (i > 0 ? separator : "") + messages[i];
  return text;
}

// Throws InputError(prefix + the errors joined by `separator`) unless there
// are none: ThrowIfInvalid("RunQuadtree: invalid QuadtreeOptions: ", options.Validate()).
inline void ThrowIfInvalid(const std::string& prefix, const std::vector<std::string>& errors,
                           const std::string& separator = "; ") {
  if (!errors.empty()) throw InputError(prefix + JoinMessages(errors, separator));
}

}  // namespace hdabench
