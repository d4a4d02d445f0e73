// File helpers for the dataset reader and writer.
#pragma once

#include <filesystem>
#include <string>

#include "calib/files.h"

namespace hdabench::datasets::internal {

// Reads a whole file. On failure returns false and sets `error` to a message
// without the path: "file not found", "is a directory; expected a file",
// "cannot be read (Permission denied)".
bool ReadFileBytes(const std::filesystem::path& path, std::string* bytes, std::string* error);

// Checks a path written in a dataset (manifest or frames table): it must be
// non-empty, relative, use '/' separators and stay inside the dataset folder
// (no ".." component). Returns an empty string when it is acceptable, else
// what is wrong.
std::string CheckDatasetPath(const std::string& path);

// The lexically normal form used to compare dataset paths ("a/./b" == "a/b").
std::string NormalDatasetPath(const std::string& path);

// calib/files.h: temporary name, then rename.
using calib::WriteFileAtomically;

}  // namespace hdabench::datasets::internal
