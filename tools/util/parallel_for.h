// The bench's one parallel loop: items handed out one at a time to a fixed
// number of threads, the calling thread being one of them. What each item
// computes must depend only on its index, so results never depend on the
// thread count or on which thread ran what.
//
// A worker that throws does not end the program: the loop stops handing out
// items, waits for every thread, and rethrows the first exception on the
// calling thread (its type kept, so the CLI maps it to its exit code).
#pragma once

#include <functional>
#include <future>
#include <string>
#include <system_error>
#include <utility>

namespace hdabench::util {

// Calls body(i) for every i in [0, count) on min(threads, count) threads
// (threads < 1 counts as 1). After each item, done(items_done) runs on
// whichever thread finished it, under a lock and with items_done rising by
// one per call, so it may print progress. `name` says what the items are
// ("render rows"); it names the loop for HDABENCH_FAULT_IN_WORKER, a fault
// point for the bench's own tests: when that variable equals `name`, the
// loop's first item on a thread other than the caller (on the caller when
// there is no other) throws std::runtime_error instead of running. When no
// more threads can be had (a process or container at its thread limit), the
// threads that started, or the caller alone, do every item.
// HDABENCH_FAULT_NO_THREAD equal to `name` makes the loop start none.
void ParallelFor(const std::string& name, int count, int threads,
                 const std::function<void(int index)>& body,
                 const std::function<void(int items_done)>& done = {});

// Runs task() on a thread of its own, and returns its future. When no thread
// can be had, task() runs on the thread that asks the future for its result,
// when it asks (std::launch::deferred): the work is done either way, and a
// task's exception reaches that thread. `name` says what the task is ("report
// plots"); HDABENCH_FAULT_NO_THREAD equal to it makes it take the no-thread
// path, a fault point for the bench's own tests.
bool NoThreadInjected(const std::string& name);
template <typename Task>
auto StartBeside(const std::string& name, Task task) -> std::future<decltype(task())> {
  if (!NoThreadInjected(name)) {
    try {
      return std::async(std::launch::async, task);
    } catch (const std::system_error&) {
      // no thread to be had: run when asked
    }
  }
  return std::async(std::launch::deferred, std::move(task));
}

// The cores this process may run on (its CPU affinity: what taskset, a
// batch scheduler's allocation or a container's cpuset leaves it), at least
// 1: the thread count of a loop whose options say "all cores". Falls back
// to std::thread::hardware_concurrency when the affinity cannot be read.
int AvailableCores();

// A thread count as options give it: `requested` when it is > 0, else every
// core this process may use (AvailableCores).
int WorkerThreads(int requested);

// One slice of a piece of work split over processes or machines (the
// observability study's and the gate's --shard K/N): slice k of n holds the
// items whose 0-based index is congruent to k - 1 modulo n, so the slices
// cover the work once and each gets a share of every part of it.
struct Shard {
  int index = 1;  // k of k/n, 1-based
  int count = 1;  // n
  bool Whole() const { return count == 1; }
  bool Holds(int item) const { return item % count == index - 1; }
  std::string Text() const { return std::to_string(index) + "/" + std::to_string(count); }
};
// "K/N" with 1 <= K <= N; throws InputError ("shard 'TEXT': expected K/N
// with 1 <= K <= N") otherwise.
Shard ParseShard(const std::string& text);

}  // namespace hdabench::util
