// Files: reading one whole (or its start or end), writing one so that no reader ever sees it
// half-written, and a temporary folder that cleans up after itself.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>

namespace hdabench::util {

// False with `error` set to "file not found", "is a directory; expected a
// file", "is a device or socket; expected a file" or "cannot be read (why)"
// when `path` is missing, a folder, a device or socket, or cannot be looked
// at; true for a regular file or a pipe (or a link to one).
bool IsReadableFile(const std::filesystem::path& path, std::string* error);

// Reads a whole file. On failure returns false and sets `error` to a message
// without the path: IsReadableFile's, or "cannot be opened (Permission
// denied)".
bool ReadFileBytes(const std::filesystem::path& path, std::string* bytes, std::string* error);

// Reads at most the first `max_bytes` of a file, and its size into
// `file_size` (may be null). Failures as ReadFileBytes.
bool ReadFilePrefix(const std::filesystem::path& path, std::uint64_t max_bytes, std::string* bytes,
                    std::uint64_t* file_size, std::string* error);

// A file opened for reading, and read at offsets through that one
// descriptor: a header and the data it describes come from the same file
// even when the path is replaced meanwhile (a dataset regenerated while it
// is read), and a large array goes straight into its own buffer. Closed when
// it goes out of scope.
class OpenedFile {
 public:
  OpenedFile() = default;
  ~OpenedFile();
  OpenedFile(const OpenedFile&) = delete;
  OpenedFile& operator=(const OpenedFile&) = delete;

  // Opens `path` (closing what was open). False with `error` as ReadFileBytes
  // sets it when it is missing, a folder, or cannot be opened.
  bool Open(const std::filesystem::path& path, std::string* error);
  // The file's size when it was opened.
  std::uint64_t Size() const { return size_; }
  // Reads `size` bytes at `offset` into `dest`. False with "holds N bytes;
  // expected at least M" when the file is shorter, or "cannot be read
  // (...)" when a read fails.
  bool ReadAt(std::uint64_t offset, std::uint64_t size, char* dest, std::string* error) const;

 private:
  int fd_ = -1;
  std::uint64_t size_ = 0;
};

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
