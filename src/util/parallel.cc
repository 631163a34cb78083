#include "mcvo/util/parallel.h"

#include <sched.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>
#include <vector>

#include "mcvo/util/stage.h"

namespace mcvo {
namespace {
std::atomic<int> thread_starts_left{-1};  // LimitThreadStartsForTest; < 0: no limit
}  // namespace

ResourceError ThreadStartError(const std::string& which, const std::system_error& error) {
  return ResourceError(StrCat("cannot start ", which, ": ", error.code().message(),
                              " (the process or user thread limit, ulimit -u, or memory); try --threads 1"));
}

namespace internal {
void LimitThreadStartsForTest(int n) { thread_starts_left = n; }

void CheckThreadStartForTest() {
  int left = thread_starts_left.load();
  while (left >= 0) {
    if (left == 0) throw std::system_error(std::make_error_code(std::errc::resource_unavailable_try_again));
    if (thread_starts_left.compare_exchange_weak(left, left - 1)) return;
  }
}
}  // namespace internal

int AvailableCores() {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (sched_getaffinity(0, sizeof(set), &set) == 0) {
    const int count = CPU_COUNT(&set);
    if (count > 0) return count;
  }
  return std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
}

int ResolveThreads(int requested) { return requested > 0 ? requested : AvailableCores(); }

void ParallelFor(int count, int threads, const std::function<void(int)>& body) {
  if (count <= 0) return;
  const int workers = std::min(ResolveThreads(threads), count);
  if (workers <= 1) {
    for (int i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<int> next{0};
  std::atomic<bool> failed{false};
  std::vector<StagedFailure> errors(static_cast<size_t>(count));
  const std::vector<std::string> stages = CurrentStageList();
  auto work = [&] {
    const InheritedStages outer(stages);
    for (int i = next++; i < count && !failed.load(); i = next++) {
      try {
        body(i);
      } catch (...) {
        errors[static_cast<size_t>(i)] = CaptureFailure();
        failed = true;
      }
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(static_cast<size_t>(workers - 1));
  try {
    for (int t = 1; t < workers; ++t) {
      pool.push_back(StartThread([&] { return StrCat("thread ", t + 1, " of ", workers); }, work));
    }
  } catch (...) {
    failed = true;  // the started workers stop at their next index
    for (std::thread& thread : pool) thread.join();
    throw;
  }
  work();
  for (std::thread& thread : pool) thread.join();
  for (const StagedFailure& error : errors) {
    if (error) RethrowFailure(error);
  }
}

}  // namespace mcvo
