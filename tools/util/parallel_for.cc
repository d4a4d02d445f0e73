#include "tools/util/parallel_for.h"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <vector>

#include "tools/util/error.h"
#include "tools/util/text.h"

namespace hdabench::util {

namespace {

// True when HDABENCH_FAULT_IN_WORKER names this loop (read once per loop,
// before any thread starts).
bool FaultInjected(const std::string& name) {
  const char* value = std::getenv("HDABENCH_FAULT_IN_WORKER");
  return value != nullptr && name == value;
}

}  // namespace

bool NoThreadInjected(const std::string& name) {
  const char* value = std::getenv("HDABENCH_FAULT_NO_THREAD");
  return value != nullptr && name == value;
}

int AvailableCores() {
  // A set as large as the kernel's CPU mask: sched_getaffinity refuses a
  // smaller one (EINVAL), as cpu_set_t's 1024 CPUs are on larger hosts.
  for (int cpus = CPU_SETSIZE; cpus <= (1 << 20); cpus *= 2) {
    cpu_set_t* set = CPU_ALLOC(cpus);
    if (set == nullptr) break;
    const size_t size = CPU_ALLOC_SIZE(cpus);
    CPU_ZERO_S(size, set);
    const bool read = ::sched_getaffinity(0, size, set) == 0;
    const bool too_small = !read && errno == EINVAL;
    const int count = read ? CPU_COUNT_S(size, set) : 0;
    CPU_FREE(set);
    if (read) return std::max(1, count);
    if (!too_small) break;
  }
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int WorkerThreads(int requested) { return requested > 0 ? requested : AvailableCores(); }

void ParallelFor(const std::string& name, int count, int threads,
                 const std::function<void(int index)>& body,
                 const std::function<void(int items_done)>& done) {
  if (count <= 0) return;
  const int workers = std::max(1, std::min(threads, count));
  const bool inject = FaultInjected(name);
  std::atomic<int> next{0};
  std::atomic<bool> injected{false};          // the injected fault has been thrown
  bool caller_alone = workers == 1;  // no other thread runs: the fault is the caller's (read by the caller only)
  std::mutex mutex;  // guards items_done, failure and the done callback
  int items_done = 0;
  std::exception_ptr failure;

  const auto work = [&](bool caller) {
    // With a fault injected, the caller takes no item before another thread
    // has thrown, so the fault is on a worker thread whatever the timing.
    while (inject && caller && !caller_alone && !injected) std::this_thread::yield();
    try {
      for (int i = next.fetch_add(1); i < count; i = next.fetch_add(1)) {
        if (inject && (!caller || caller_alone) && !injected.exchange(true)) {
          throw std::runtime_error("a fault injected into a worker of " + name +
                                   " (HDABENCH_FAULT_IN_WORKER)");
        }
        body(i);
        if (done) {
          const std::lock_guard<std::mutex> lock(mutex);
          done(++items_done);
        }
      }
    } catch (...) {
      next.store(count);  // no more items for anyone
      const std::lock_guard<std::mutex> lock(mutex);
      if (!failure) failure = std::current_exception();
    }
  };

  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(workers - 1));
  const bool threadless = NoThreadInjected(name);
  for (int t = 1; t < workers && !threadless; ++t) {
    try {
      pool.emplace_back(work, false);
    } catch (...) {
      break;  // no more threads to be had: those running (and the caller) do every item
    }
  }
  if (pool.empty()) caller_alone = true;
  work(true);
  for (std::thread& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
}

Shard ParseShard(const std::string& text) {
  // Whole numbers that fit an int: "1/99999999999" is refused, not wrapped.
  const size_t slash = text.find('/');
  int k = 0, n = 0;
  if (slash == std::string::npos || ParseInt(std::string_view(text).substr(0, slash), &k) != ParseStatus::kOk ||
      ParseInt(std::string_view(text).substr(slash + 1), &n) != ParseStatus::kOk || n < 1 || k < 1 || k > n) {
    throw InputError("shard '" + text + "': expected K/N with 1 <= K <= N");
  }
  return {k, n};
}

}  // namespace hdabench::util
