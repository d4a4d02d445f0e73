#include "tools/util/parallel_for.h"

#include <sched.h>

#include <atomic>
#include <chrono>
#include <cstdlib>
#include <future>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tools/util/error.h"

namespace hdabench::util {
namespace {

TEST(ParallelFor, EveryItemRunsOnceWhateverTheThreadCount) {
  for (const int threads : {1, 2, 3, 8}) {
    std::vector<int> runs(100, 0);
    ParallelFor("test items", 100, threads, [&](int i) { ++runs[static_cast<size_t>(i)]; });
    for (int i = 0; i < 100; ++i) EXPECT_EQ(runs[static_cast<size_t>(i)], 1) << "item " << i << ", " << threads << " threads";
  }
}

TEST(ParallelFor, DoneCountsRiseByOne) {
  std::vector<int> seen;
  ParallelFor("test items", 50, 4, [](int) {}, [&](int done) { seen.push_back(done); });
  ASSERT_EQ(seen.size(), 50u);
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], static_cast<int>(i) + 1);
}

TEST(ParallelFor, NoItemsNoCalls) {
  int calls = 0;
  ParallelFor("test items", 0, 2, [&](int) { ++calls; }, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

// A throw on a worker thread (not the caller) reaches the caller with its
// type and message, after every thread has stopped; the program goes on. The
// caller's own item waits until another thread has thrown, so the throw is
// on a thread other than the caller.
TEST(ParallelFor, AWorkerThreadThatThrowsReachesTheCaller) {
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<bool> thrown{false};
  std::atomic<int> items_run{0};
  try {
    ParallelFor("test items", 10000, 4, [&](int) {
      if (std::this_thread::get_id() == caller) {
        for (int wait_ms = 0; !thrown && wait_ms < 10000; ++wait_ms) {
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
        }
        return;
      }
      if (!thrown.exchange(true)) throw InputError("item went wrong");
      ++items_run;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    });
    ADD_FAILURE() << "the worker's exception was lost";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "item went wrong");
  }
  EXPECT_TRUE(thrown);
  // Handing out stops once an item throws: the other threads finish the few
  // items (200 us each) they had taken, not the 10000.
  EXPECT_LT(items_run.load(), 100);
}

TEST(ParallelFor, ACallbackThatThrowsReachesTheCaller) {
  EXPECT_THROW(ParallelFor("test items", 100, 3, [](int) {},
                           [](int done) {
                             if (done == 10) throw std::runtime_error("progress failed");
                           }),
               std::runtime_error);
}

// "All cores" means those the process may run on: one after taskset -c N
// (or a batch scheduler's allocation of one CPU), not every core of the host.
TEST(AvailableCores, FollowsTheCpuAffinity) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  ASSERT_EQ(sched_getaffinity(0, sizeof(allowed), &allowed), 0);
  EXPECT_EQ(AvailableCores(), CPU_COUNT(&allowed));
  int first = 0;
  while (!CPU_ISSET(first, &allowed)) ++first;
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(first, &one);
  ASSERT_EQ(sched_setaffinity(0, sizeof(one), &one), 0);
  EXPECT_EQ(AvailableCores(), 1);
  ASSERT_EQ(sched_setaffinity(0, sizeof(allowed), &allowed), 0);
  EXPECT_EQ(AvailableCores(), CPU_COUNT(&allowed));
}

TEST(ParallelFor, TheFaultPointThrowsInANamedLoopOnly) {
  ASSERT_EQ(setenv("HDABENCH_FAULT_IN_WORKER", "faulty loop", 1), 0);
  int runs = 0;
  EXPECT_NO_THROW(ParallelFor("another loop", 5, 1, [&](int) { ++runs; }));
  EXPECT_EQ(runs, 5);
  try {
    ParallelFor("faulty loop", 100, 2, [](int) {});
    ADD_FAILURE() << "no fault injected";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()),
              "a fault injected into a worker of faulty loop (HDABENCH_FAULT_IN_WORKER)");
  }
  unsetenv("HDABENCH_FAULT_IN_WORKER");
}

// K/N in whole numbers that fit an int, 1 <= K <= N; anything else, an
// overflow included (it had wrapped to another shard), is refused.
TEST(ParseShard, WholeNumbersInRangeOnly) {
  const Shard shard = ParseShard("2/3");
  EXPECT_EQ(shard.index, 2);
  EXPECT_EQ(shard.count, 3);
  EXPECT_TRUE(ParseShard("1/1").Whole());
  for (const char* bad : {"1/99999999999", "99999999999/1", "0/2", "3/2", "-1/2", "1/", "/2", "1/2/3", "1.5/2", "a/b",
                          "", "1x2"}) {
    EXPECT_THROW(ParseShard(bad), InputError) << bad;
  }
}

// Without a thread to be had (HDABENCH_FAULT_NO_THREAD stands for a process
// at its thread limit), the loop's caller does every item, and a task started
// beside runs on the thread that asks for its result, when it asks; other
// names start their threads.
TEST(ParallelFor, WithoutThreadsTheCallerDoesTheWork) {
  ASSERT_EQ(setenv("HDABENCH_FAULT_NO_THREAD", "threadless", 1), 0);
  const std::thread::id caller = std::this_thread::get_id();
  std::vector<std::thread::id> ran_on(40);
  ParallelFor("threadless", 40, 4, [&](int i) { ran_on[static_cast<size_t>(i)] = std::this_thread::get_id(); });
  for (const std::thread::id& id : ran_on) EXPECT_EQ(id, caller);

  std::atomic<bool> started{false};
  std::future<std::thread::id> beside = StartBeside("threadless", [&started] {
    started = true;
    return std::this_thread::get_id();
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_FALSE(started);  // not before it is asked for
  EXPECT_EQ(beside.get(), caller);

  std::future<std::thread::id> threaded = StartBeside("another task", [] { return std::this_thread::get_id(); });
  EXPECT_NE(threaded.get(), caller);
  std::future<int> failing = StartBeside("threadless", []() -> int { throw std::runtime_error("task failed"); });
  EXPECT_THROW(failing.get(), std::runtime_error);
  unsetenv("HDABENCH_FAULT_NO_THREAD");
}

}  // namespace
}  // namespace hdabench::util
