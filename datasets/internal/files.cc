#include "datasets/internal/files.h"

#include <system_error>

namespace hdabench::datasets::internal {

namespace fs = std::filesystem;

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
