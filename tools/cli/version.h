// Version of hdabench and of the libraries it was built against.
#pragma once

#include <string>

namespace hdabench::tools {

extern const char* const kVersionString;
// Several lines: hdabench's version, then one line per library.
std::string VersionReport();

}  // namespace hdabench::tools
