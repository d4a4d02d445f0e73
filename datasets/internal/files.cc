#include "datasets/internal/files.h"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

#include <unistd.h>

#include "calib/error.h"

namespace hdabench::datasets::internal {

namespace fs = std::filesystem;

bool ReadFileBytes(const fs::path& path, std::string* bytes, std::string* error) {
  bytes->clear();
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) {
    *error = "file not found";
    return false;
  }
  if (fs::is_directory(status)) {
    *error = "is a directory; expected a file";
    return false;
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = std::string("cannot be opened (") + std::strerror(errno) + ")";
    return false;
  }
  bytes->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) {
    *error = "cannot be read (I/O error)";
    return false;
  }
  return true;
}

std::string CheckDatasetPath(const std::string& path) {
  if (path.empty()) return "is empty; expected a path relative to the dataset folder";
  if (path.find('\\') != std::string::npos) {
    return "'" + path + "' contains '\\'; use '/' as the separator";
  }
  if (path.find('\0') != std::string::npos) return "contains a NUL character";
  const fs::path p(path);
  if (p.is_absolute() || path.front() == '/') {
    return "'" + path + "' is absolute; expected a path relative to the dataset folder";
  }
  for (const fs::path& part : p) {
    if (part == "..") {
      return "'" + path + "' leaves the dataset folder ('..'); expected a path inside it";
    }
  }
  const fs::path normal = p.lexically_normal();
  if (normal.empty() || normal == "." || !p.has_filename()) {
    return "'" + path + "' names a folder; expected a file";
  }
  return std::string();
}

std::string NormalDatasetPath(const std::string& path) {
  return fs::path(path).lexically_normal().generic_string();
}


}  // namespace hdabench::datasets::internal
