#include "tools/util/stderr_capture.h"

#include <unistd.h>

#include <cstdio>
#include <memory>
#include <mutex>

namespace hdabench::util {

namespace {
std::mutex g_stderr_mutex;

// Restores fd 2 on every exit path.
class Redirection {
 public:
  explicit Redirection(std::FILE* target) {
    std::fflush(stderr);
    saved_fd_ = dup(2);
    if (saved_fd_ >= 0 && dup2(fileno(target), 2) < 0) {
      close(saved_fd_);
      saved_fd_ = -1;
    }
  }
  ~Redirection() {
    if (saved_fd_ < 0) return;
    std::fflush(stderr);
    dup2(saved_fd_, 2);
    close(saved_fd_);
  }
  Redirection(const Redirection&) = delete;
  Redirection& operator=(const Redirection&) = delete;
  bool active() const { return saved_fd_ >= 0; }

 private:
  int saved_fd_ = -1;
};
}  // namespace

std::string CaptureStderr(const std::function<void()>& fn, size_t max_bytes) {
  std::lock_guard<std::mutex> lock(g_stderr_mutex);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::tmpfile(), &std::fclose);
  if (!file) {
    fn();
    return "";
  }
  {
    Redirection redirection(file.get());
    fn();
    if (!redirection.active()) return "";
  }
  std::string captured;
  std::rewind(file.get());
  char buffer[512];
  size_t n = 0;
  while (captured.size() < max_bytes && (n = std::fread(buffer, 1, sizeof(buffer), file.get())) > 0) {
    captured.append(buffer, n);
  }
  if (captured.size() > max_bytes) captured.resize(max_bytes);
  return captured;
}

}  // namespace hdabench::util
