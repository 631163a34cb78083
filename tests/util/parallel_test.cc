#include "mcvo/util/parallel.h"

#include <atomic>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

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

TEST(Parallel, ThreadCountsResolveToTheCoresThisProcessMayUse) {
  EXPECT_GE(AvailableCores(), 1);
  EXPECT_EQ(ResolveThreads(0), AvailableCores());
  EXPECT_EQ(ResolveThreads(-5), AvailableCores());
  EXPECT_EQ(ResolveThreads(3), 3);
}

}  // namespace
}  // namespace mcvo
