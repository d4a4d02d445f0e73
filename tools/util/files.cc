#include "tools/util/files.h"

#include <stdlib.h>  // mkdtemp
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>
#include <system_error>

#include "tools/util/error.h"

namespace hdabench::util {

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

void WriteFileAtomically(const fs::path& path, const std::string& bytes) {
  std::error_code ec;
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) {
      throw InputError(path.parent_path().string() + ": cannot create the folder (" + ec.message() +
                       ")");
    }
  }
  fs::path temporary = path;
  temporary += ".tmp-" + std::to_string(static_cast<long long>(::getpid()));
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) {
      throw InputError(path.string() + ": cannot be written (" + std::strerror(errno) + ")");
    }
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) {
      fs::remove(temporary, ec);
      throw InputError(path.string() + ": writing failed (disk full?)");
    }
  }
  fs::rename(temporary, path, ec);
  if (ec) {
    std::error_code ignored;
    fs::remove(temporary, ignored);
    throw InputError(path.string() + ": cannot move the written file into place (" + ec.message() +
                     ")");
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
