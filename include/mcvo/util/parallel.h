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
// Exceptions: an exception thrown by `body` does not reach std::terminate.
// The first failure stops the hand-out of further indices, the workers are
// joined, and the exception of the lowest index that threw is rethrown in
// the caller (the lowest, not the first in time, so that the error a user
// sees is the same at any thread count).
#pragma once

#include <functional>

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
void ParallelFor(int count, int threads, const std::function<void(int)>& body);

}  // namespace mcvo
