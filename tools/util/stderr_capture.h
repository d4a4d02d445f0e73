// Captures what third-party C code (libmrcal's parser, libpng) writes straight
// to the process's stderr, so the bench can fold it into its own messages
// instead of letting it reach the terminal without context.
#pragma once

#include <functional>
#include <string>

namespace hdabench::util {

// Runs fn() with file descriptor 2 redirected into a temporary file, then
// restores it and returns what was written (at most max_bytes). Redirections
// are serialised by one process-wide lock, since fd 2 is shared by all
// threads: output another thread writes meanwhile is captured too. When the
// redirection cannot be set up, fn() still runs and "" is returned. fn's
// exceptions propagate after fd 2 is restored.
std::string CaptureStderr(const std::function<void()>& fn, size_t max_bytes = 4096);

}  // namespace hdabench::util
