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
#include <string>

namespace hdabench::util {

// Calls body(i) for every i in [0, count) on min(threads, count) threads
// (threads < 1 counts as 1). After each item, done(items_done) runs on
// whichever thread finished it, under a lock and with items_done rising by
// one per call, so it may print progress. `name` says what the items are
// ("render rows"); it names the loop for HDABENCH_FAULT_IN_WORKER, a fault
// point for the bench's own tests: when that variable equals `name`, the
// loop's first item on a thread other than the caller (on the caller when
// there is no other) throws std::runtime_error instead of running.
void ParallelFor(const std::string& name, int count, int threads,
                 const std::function<void(int index)>& body,
                 const std::function<void(int items_done)>& done = {});

}  // namespace hdabench::util
