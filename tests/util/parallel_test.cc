#include "mcvo/util/parallel.h"

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "mcvo/util/error.h"

namespace mcvo {
namespace {

TEST(Parallel, EveryIndexExactlyOnceIntoItsSlotAtAnyThreadCount) {
  for (int threads : {1, 2, 3, 8, 0}) {
    std::vector<int> calls(1000, 0);
    std::vector<double> out(1000, 0.0);
    ParallelFor(1000, threads, [&](int i) {
      ++calls[static_cast<size_t>(i)];
      out[static_cast<size_t>(i)] = 0.5 * i;
    });
    for (int i = 0; i < 1000; ++i) {
      ASSERT_EQ(calls[static_cast<size_t>(i)], 1) << "threads " << threads << " index " << i;
      ASSERT_EQ(out[static_cast<size_t>(i)], 0.5 * i);
    }
  }
}

TEST(Parallel, UsesSeveralThreadsWhenAsked) {
  // Two bodies that wait for each other finish only when two threads run.
  std::atomic<int> arrived{0};
  ParallelFor(2, 2, [&](int) {
    ++arrived;
    while (arrived.load() < 2) std::this_thread::yield();
  });
  EXPECT_EQ(arrived.load(), 2);
}

TEST(Parallel, NothingToDoAndOneItem) {
  int calls = 0;
  ParallelFor(0, 4, [&](int) { ++calls; });
  ParallelFor(-3, 4, [&](int) { ++calls; });
  EXPECT_EQ(calls, 0);
  ParallelFor(1, 4, [&](int i) { calls += 1 + i; });
  EXPECT_EQ(calls, 1);
}

TEST(Parallel, AnExceptionReachesTheCallerFromTheLowestFailingIndex) {
  for (int threads : {1, 2, 4}) {
    try {
      ParallelFor(200, threads, [](int i) {
        if (i == 37 || i == 150) throw std::runtime_error("item " + std::to_string(i));
      });
      ADD_FAILURE() << "no exception at threads " << threads;
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()), "item 37") << "threads " << threads;
    }
  }
}

// The system refuses threads after the first `n` (internal::LimitThreadStartsForTest).
struct ThreadLimit {
  explicit ThreadLimit(int n) { internal::LimitThreadStartsForTest(n); }
  ~ThreadLimit() { internal::LimitThreadStartsForTest(-1); }
};

TEST(Parallel, ARefusedThreadIsAResourceErrorAfterTheStartedOnesAreJoined) {
  for (int started : {0, 1, 5}) {
    std::atomic<int> calls{0};
    try {
      const ThreadLimit limit(started);
      ParallelFor(100, 8, [&](int) {
        ++calls;
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
      });
      ADD_FAILURE() << "no exception with " << started << " threads started";
    } catch (const ResourceError& e) {
      // Thread 1 is the caller's: the refused one is number started + 2.
      EXPECT_EQ(std::string(e.what()), "cannot start thread " + std::to_string(started + 2) +
                                           " of 8: Resource temporarily unavailable (the process or user "
                                           "thread limit, ulimit -u, or memory); try --threads 1");
    }
    // Had a started thread been left running, `calls` would still change (or
    // the std::thread destructor would have terminated the test).
    const int after = calls.load();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_EQ(calls.load(), after);
  }
  // Without the limit, the same call works.
  std::atomic<int> calls{0};
  ParallelFor(100, 8, [&](int) { ++calls; });
  EXPECT_EQ(calls.load(), 100);
}

TEST(Parallel, ARefusedThreadInsideABodyReachesTheCaller) {
  const ThreadLimit limit(3);
  EXPECT_THROW(ParallelFor(2, 2, [](int) { ParallelFor(8, 8, [](int) {}); }), ResourceError);
}

TEST(Parallel, ThreadCountsResolveToTheCoresThisProcessMayUse) {
  EXPECT_GE(AvailableCores(), 1);
  EXPECT_EQ(ResolveThreads(0), AvailableCores());
  EXPECT_EQ(ResolveThreads(-5), AvailableCores());
  EXPECT_EQ(ResolveThreads(3), 3);
}

}  // namespace
}  // namespace mcvo
