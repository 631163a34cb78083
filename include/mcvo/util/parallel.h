// The one way mcvo runs independent work in parallel (cameras, images, rows
// of an image, clusters, runs of a batch), and the one meaning of a thread
// count of 0.
//
// Determinism: ParallelFor hands indices out through an atomic counter (load
// balance), so which thread runs which index varies; `body` must write only
// what belongs to its index (a pre-sized slot), and the caller combines the
// slots in index order after it returns. Then the result does not depend on
// the thread count.
//
// Threads: every thread mcvo starts is started by StartThread, which turns
// the system's refusal (std::system_error, EAGAIN: the process or user
// thread limit, ulimit -u) into a ResourceError with one line saying so.
// ParallelFor joins the threads it had started before it throws it.
//
// Exceptions: an exception thrown by `body` does not reach std::terminate.
// The first failure stops the hand-out of further indices, the workers are
// joined, and the exception of the lowest index that threw is rethrown in
// the caller (the lowest, not the first in time, so that the error a user
// sees is the same at any thread count).
#pragma once

#include <functional>
#include <string>
#include <system_error>
#include <thread>
#include <utility>

#include "mcvo/util/error.h"

namespace mcvo {

// Cores this process may run on (its CPU affinity, as taskset or a batch
// scheduler's cgroup cpuset set it), at least 1; std::thread's
// hardware_concurrency when the affinity cannot be read.
int AvailableCores();

// A thread count as options and command lines give it: positive as given,
// 0 (or negative) as AvailableCores().
int ResolveThreads(int requested);

// Calls body(i) for every i in [0, count), each exactly once, on
// min(ResolveThreads(threads), count) threads (the caller's included).
// Body exceptions carry the stage (mcvo/util/stage.h) they failed in to the
// caller, and the workers run inside the caller's stages.
void ParallelFor(int count, int threads, const std::function<void(int)>& body);

// "cannot start <which>: <reason> (the process or user thread limit, ulimit
// -u, or memory); try --threads 1".
ResourceError ThreadStartError(const std::string& which, const std::system_error& error);

namespace internal {
// Tests: the next `n` thread starts succeed, the ones after fail as the
// thread limit makes them fail (EAGAIN); n < 0 (the default): no limit.
void LimitThreadStartsForTest(int n);
// Throws the std::system_error of a refused start when the test limit says so.
void CheckThreadStartForTest();
}  // namespace internal

// std::thread(fn), started or a ResourceError naming `which` ("thread 3 of
// 8", "the frame decoder"). `which` is a callable returning the name, so
// that no string is built unless the start fails.
template <typename Which, typename F>
std::thread StartThread(Which&& which, F&& fn) {
  try {
    internal::CheckThreadStartForTest();
    return std::thread(std::forward<F>(fn));
  } catch (const std::system_error& e) {
    throw ThreadStartError(which(), e);
  }
}

}  // namespace mcvo
