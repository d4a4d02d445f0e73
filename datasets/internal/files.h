// File helpers for the dataset reader and writer.
#pragma once

#include <filesystem>
#include <string>

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

// Writes `bytes` to a temporary name next to `path`, then renames it into
// place, so readers never see a partial file. Creates the parent folders.
// Throws InputError naming the path on failure (the temporary is removed).
void WriteFileAtomically(const std::filesystem::path& path, const std::string& bytes);

}  // namespace hdabench::datasets::internal
