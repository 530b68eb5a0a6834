// ParallelFor(n, num_threads, fn): calls fn(thread_index, i) for i in [0, n)
// on up to num_threads threads (0: all hardware threads), in dynamic chunks.
#ifndef POLYFIT_UTIL_PARALLEL_FOR_H_
#define POLYFIT_UTIL_PARALLEL_FOR_H_

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace polyfit {

inline int ResolveNumThreads(int num_threads) {
  if (num_threads > 0) return num_threads;
  return std::max(1u, std::thread::hardware_concurrency());
}

template <typename Fn>
void ParallelFor(int n, int num_threads, Fn&& fn, int chunk = 64) {
  num_threads = std::min(ResolveNumThreads(num_threads), std::max(1, (n + chunk - 1) / chunk));
  if (num_threads <= 1) {
    for (int i = 0; i < n; ++i) fn(0, i);
    return;
  }
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto worker = [&](int thread_index) {
    try {
      for (;;) {
        const int begin = next.fetch_add(chunk);
        if (begin >= n) break;
        const int end = std::min(n, begin + chunk);
        for (int i = begin; i < end; ++i) fn(thread_index, i);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next.store(n);
    }
  };
  std::vector<std::thread> threads;
  threads.reserve(num_threads - 1);
  for (int t = 1; t < num_threads; ++t) threads.emplace_back(worker, t);
  worker(0);
  for (std::thread& t : threads) t.join();
  if (error) std::rethrow_exception(error);
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_PARALLEL_FOR_H_
