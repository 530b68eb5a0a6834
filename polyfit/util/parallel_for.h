// ParallelFor(n, num_threads, fn): calls fn(thread_index, i) for i in [0, n)
// on up to num_threads threads (0: all hardware threads), in dynamic chunks.
// The calling thread is thread 0; the others come from a pool kept for the
// process (a solver calls this thousands of times a second: starting and
// joining threads each time cost about 45 us a call and a page-faulting
// stack). A call made while the pool serves another (nested, or from
// another thread) starts its own threads as before.
#ifndef POLYFIT_UTIL_PARALLEL_FOR_H_
#define POLYFIT_UTIL_PARALLEL_FOR_H_

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace polyfit {

inline int ResolveNumThreads(int num_threads) {
  if (num_threads > 0) return num_threads;
  return std::max(1u, std::thread::hardware_concurrency());
}

namespace internal {

// Threads 1..k of a ParallelFor call. Grown to the most a call asked for;
// never joined (a pool thread waits for work until the process ends).
class WorkerPool {
 public:
  static WorkerPool& Get() {
    static WorkerPool* pool = new WorkerPool;  // leaked: outlives every static user
    return *pool;
  }

  // Runs call(context, 1), ..., call(context, workers) on pool threads and
  // call(context, 0) on the caller's, and returns once all have. False,
  // running nothing, when the pool is serving another call. `call` must
  // not throw. (A function pointer and its context, not a std::function:
  // no allocation per call.)
  bool TryRun(int workers, void (*call)(void* context, int thread_index), void* context) {
    bool idle = false;
    if (!busy_.compare_exchange_strong(idle, true)) return false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      for (; started_ < workers; ++started_) {
        const int index = started_ + 1;
        std::thread([this, index] { Loop(index); }).detach();
      }
      call_ = call;
      context_ = context;
      wanted_ = workers;
      pending_ = workers;
      ++generation_;
    }
    wake_.notify_all();
    call(context, 0);
    {
      std::unique_lock<std::mutex> lock(mutex_);
      done_.wait(lock, [this] { return pending_ == 0; });
    }
    busy_.store(false);
    return true;
  }

 private:
  WorkerPool() = default;

  void Loop(int index) {
    std::uint64_t seen = 0;
    for (;;) {
      void (*call)(void*, int) = nullptr;
      void* context = nullptr;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return generation_ != seen; });
        seen = generation_;
        if (index > wanted_) continue;
        call = call_;
        context = context_;
      }
      call(context, index);
      std::lock_guard<std::mutex> lock(mutex_);
      if (--pending_ == 0) done_.notify_one();
    }
  }

  std::atomic<bool> busy_{false};
  std::mutex mutex_;
  std::condition_variable wake_, done_;
  int started_ = 0;                     // pool threads, detached
  void (*call_)(void*, int) = nullptr;  // the current call's
  void* context_ = nullptr;
  int wanted_ = 0;   // threads 1..wanted_ run the current call
  int pending_ = 0;  // of those, how many have not finished
  std::uint64_t generation_ = 0;
};

}  // namespace internal

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
  const auto call = [](void* context, int thread_index) { (*static_cast<decltype(worker)*>(context))(thread_index); };
  if (!internal::WorkerPool::Get().TryRun(num_threads - 1, call, &worker)) {
    std::vector<std::thread> threads;
    threads.reserve(num_threads - 1);
    for (int t = 1; t < num_threads; ++t) threads.emplace_back(worker, t);
    worker(0);
    for (std::thread& t : threads) t.join();
  }
  if (error) std::rethrow_exception(error);
}

}  // namespace polyfit

#endif  // POLYFIT_UTIL_PARALLEL_FOR_H_
