#include "tools/util/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <stdlib.h>  // mkdtemp
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <limits>
#include <fstream>
#include <iterator>
#include <system_error>

#include "tools/util/error.h"

namespace hdabench::util {

namespace fs = std::filesystem;

bool IsReadableFile(const fs::path& path, std::string* error) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (!fs::exists(status)) {
    *error = !ec || ec == std::errc::no_such_file_or_directory ? std::string("file not found")
                                                               : "cannot be read (" + ec.message() + ")";
    return false;
  }
  if (fs::is_directory(status)) {
    *error = "is a directory; expected a file";
    return false;
  }
  // A device or socket would block, or never end; a pipe (a FIFO, or the
  // shell's <(...)) is read to its end.
  if (!fs::is_regular_file(status) && !fs::is_fifo(status)) {
    *error = "is a device or socket; expected a file";
    return false;
  }
  return true;
}

bool ReadFileBytes(const fs::path& path, std::string* bytes, std::string* error) {
  return ReadFilePrefix(path, std::numeric_limits<std::uint64_t>::max(), bytes, nullptr, error);
}

bool ReadFilePrefix(const fs::path& path, std::uint64_t max_bytes, std::string* bytes, std::uint64_t* file_size,
                    std::string* error) {
  bytes->clear();
  if (!IsReadableFile(path, error)) return false;
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = std::string("cannot be opened (") + std::strerror(errno) + ")";
    return false;
  }
  // One read of the size the open file has; what a file that is not seekable
  // (a pipe) or grew meanwhile holds beyond it is read to its end.
  in.seekg(0, std::ios::end);
  const std::streamoff end = in.tellg();
  in.clear();
  in.seekg(0, std::ios::beg);
  const std::uint64_t size = end > 0 ? static_cast<std::uint64_t>(end) : 0;
  bytes->resize(static_cast<size_t>(std::min(size, max_bytes)));
  in.read(bytes->data(), static_cast<std::streamsize>(bytes->size()));
  bytes->resize(static_cast<size_t>(in.gcount()));
  if (bytes->size() < max_bytes && !in.eof()) {
    std::string rest(std::istreambuf_iterator<char>(in), {});
    bytes->append(rest, 0, static_cast<size_t>(std::min<std::uint64_t>(rest.size(), max_bytes - bytes->size())));
  }
  if (in.bad()) {
    *error = "cannot be read (I/O error)";
    return false;
  }
  if (file_size != nullptr) *file_size = std::max<std::uint64_t>(size, bytes->size());
  return true;
}

OpenedFile::~OpenedFile() {
  if (fd_ >= 0) ::close(fd_);
}

bool OpenedFile::Open(const fs::path& path, std::string* error) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  size_ = 0;
  if (!IsReadableFile(path, error)) return false;
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) {
    *error = std::string("cannot be opened (") + std::strerror(errno) + ")";
    return false;
  }
  struct stat status {};
  if (::fstat(fd_, &status) != 0) {
    *error = std::string("cannot be read (") + std::strerror(errno) + ")";
    ::close(fd_);
    fd_ = -1;
    return false;
  }
  size_ = static_cast<std::uint64_t>(status.st_size);
  return true;
}

bool OpenedFile::ReadAt(std::uint64_t offset, std::uint64_t size, char* dest, std::string* error) const {
  if (fd_ < 0) {
    *error = "cannot be read (not open)";
    return false;
  }
  if (offset > size_ || size > size_ - offset) {
    *error = "holds " + std::to_string(size_) + " bytes; expected at least " + std::to_string(offset + size);
    return false;
  }
  std::uint64_t done = 0;
  while (done < size) {
    const size_t chunk = static_cast<size_t>(std::min<std::uint64_t>(size - done, std::uint64_t{1} << 30));
    const ssize_t got = ::pread(fd_, dest + done, chunk, static_cast<off_t>(offset + done));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) {
      *error = got < 0 ? std::string("cannot be read (") + std::strerror(errno) + ")"
                       : "ended after " + std::to_string(offset + done) + " bytes while being read";
      return false;
    }
    done += static_cast<std::uint64_t>(got);
  }
  return true;
}

fs::path TemporaryPathFor(const fs::path& path) {
  fs::path temporary = path.parent_path();
  temporary /= "." + path.filename().string() + "." + std::to_string(static_cast<long long>(::getpid())) + ".tmp";
  return temporary;
}

namespace {

// Writes every byte to `fd`, retrying after signals and short writes. False
// with errno set when a write fails.
bool WriteAll(int fd, const std::string& bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  return true;
}

// Flushes the folder's entries (the rename) to the disk. A file system that
// cannot sync a folder (EINVAL) is taken as having nothing to flush.
bool SyncFolder(const fs::path& folder) {
  const int fd = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool synced = ::fsync(fd) == 0 || errno == EINVAL;
  const int saved = errno;
  ::close(fd);
  errno = saved;
  return synced;
}

}  // namespace

void WriteFileAtomically(const fs::path& path, const std::string& bytes) {
  std::error_code ec;
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) {
      throw InputError(path.parent_path().string() + ": cannot create the folder (" + ec.message() +
                       ")");
    }
  }
  const fs::path temporary = TemporaryPathFor(path);
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) {
    throw InputError(path.string() + ": cannot be written (" + std::strerror(errno) + ")");
  }
  // On failure: the file closed (errno kept for the message: close may set
  // its own), the temporary removed, an InputError naming the path.
  const auto fail = [&](const std::string& what, bool close_file) {
    const std::string reason = std::strerror(errno);
    if (close_file) ::close(fd);
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw InputError(path.string() + ": " + what + " (" + reason + ")");
  };
  if (!WriteAll(fd, bytes)) fail("writing failed", true);
  // Durable before it counts as written: the bytes, then the rename.
  if (::fsync(fd) != 0) fail("could not be flushed to the disk", true);
  if (::close(fd) != 0) fail("writing failed", false);
  fs::rename(temporary, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw InputError(path.string() + ": cannot move the written file into place (" + ec.message() +
                     ")");
  }
  if (!SyncFolder(path.parent_path())) {
    throw InputError(path.string() + ": written, but its folder could not be flushed to the disk (" +
                     std::strerror(errno) + ")");
  }
}

TempFolder::TempFolder(const std::string& purpose) {
  std::error_code ec;
  fs::path base = fs::temp_directory_path(ec);
  if (ec) base = "/tmp";
  std::string pattern = (base / ("hdabench-" + purpose + "-XXXXXX")).string();
  if (::mkdtemp(pattern.data()) == nullptr) {
    throw InputError(base.string() + ": cannot create a temporary folder (" +
                     std::strerror(errno) + ")");
  }
  path_ = pattern;
}

TempFolder::~TempFolder() {
  std::error_code ignored;
  fs::remove_all(path_, ignored);
}

}  // namespace hdabench::util
