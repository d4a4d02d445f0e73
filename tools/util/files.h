// Files: reading one whole (or its start or end), writing one so that no reader ever sees it
// half-written, and a temporary folder that cleans up after itself.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace hdabench::util {

// Reads a whole file. On failure returns false and sets `error` to a message
// without the path: "file not found", "is a directory; expected a file",
// "cannot be read (Permission denied)".
bool ReadFileBytes(const std::filesystem::path& path, std::string* bytes, std::string* error);

// Reads at most the first `max_bytes` of a file, and its size into
// `file_size` (may be null). Failures as ReadFileBytes.
bool ReadFilePrefix(const std::filesystem::path& path, std::uint64_t max_bytes, std::string* bytes,
                    std::uint64_t* file_size, std::string* error);

// Reads the last `size` bytes of a regular file into `dest`, with no copy in
// between (a large array whose header was read with ReadFilePrefix goes
// straight into its own buffer). Failures as ReadFileBytes, and "holds N
// bytes; expected at least M" when the file is shorter.
bool ReadFileTail(const std::filesystem::path& path, std::uint64_t size, char* dest, std::string* error);

// Writes `bytes` to a temporary name next to `path` (TemporaryPathFor),
// flushes it to the disk (fsync), renames it into place and flushes the
// folder, so readers never see a partial file and a file that counts as
// written survives a crash of the machine. Creates the parent folders.
// Throws InputError naming the path on failure (a disk that fills up
// halfway included; the temporary is removed).
void WriteFileAtomically(const std::filesystem::path& path, const std::string& bytes);

// The temporary name WriteFileAtomically writes `path` under before the
// rename: ".<name>.<pid>.tmp" in the same folder. A process killed between
// the two leaves it behind: hidden, never the name of a result, and ignored
// by git (.gitignore: ".*.tmp"), so no later run or checkout takes it for one.
std::filesystem::path TemporaryPathFor(const std::filesystem::path& path);

// A fresh folder under the system's temporary folder (hdabench-<purpose>-XXXXXX),
// removed with everything in it when this goes out of scope. Throws InputError
// naming the temporary folder when it cannot be created.
class TempFolder {
 public:
  explicit TempFolder(const std::string& purpose);
  ~TempFolder();
  TempFolder(const TempFolder&) = delete;
  TempFolder& operator=(const TempFolder&) = delete;
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

}  // namespace hdabench::util
