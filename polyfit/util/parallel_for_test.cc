#include "polyfit/util/parallel_for.h"

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

namespace polyfit {
namespace {

// Every index exactly once, each on a thread index below the count asked
// for, call after call (the pool's threads are reused).
TEST(ParallelForTest, EveryIndexOnceOnTheThreadsAskedFor) {
  for (int call = 0; call < 200; ++call) {
    const int n = 1 + call * 7, threads = 1 + call % 4;
    std::vector<std::atomic<int>> hits(n);
    std::atomic<int> bad_thread{0};
    ParallelFor(
        n, threads,
        [&](int t, int i) {
          if (t < 0 || t >= threads) ++bad_thread;
          ++hits[i];
        },
        3);
    for (int i = 0; i < n; ++i) ASSERT_EQ(hits[i].load(), 1) << "call " << call << " index " << i;
    EXPECT_EQ(bad_thread.load(), 0);
  }
}

// A call inside a call (the pool busy) and calls from several threads at
// once still visit every index once.
TEST(ParallelForTest, NestedAndConcurrentCalls) {
  std::atomic<long> sum{0};
  ParallelFor(
      8, 2,
      [&](int, int i) {
        ParallelFor(
            100, 2, [&](int, int j) { sum += i * 100 + j; }, 10);
      },
      1);
  EXPECT_EQ(sum.load(), 799L * 800 / 2);

  std::atomic<long> total{0};
  std::vector<std::thread> callers;
  for (int c = 0; c < 4; ++c) {
    callers.emplace_back([&] {
      for (int k = 0; k < 50; ++k)
        ParallelFor(
            1000, 3, [&](int, int i) { total += i; }, 16);
    });
  }
  for (std::thread& t : callers) t.join();
  EXPECT_EQ(total.load(), 4L * 50 * (999L * 1000 / 2));
}

// An exception in any chunk reaches the caller, and the pool serves the
// next call.
TEST(ParallelForTest, AnExceptionReachesTheCaller) {
  EXPECT_THROW(ParallelFor(
                   1000, 2,
                   [](int, int i) {
                     if (i == 777) throw std::runtime_error("index 777");
                   },
                   8),
               std::runtime_error);
  std::atomic<int> count{0};
  ParallelFor(
      1000, 2, [&](int, int) { ++count; }, 8);
  EXPECT_EQ(count.load(), 1000);
}

}  // namespace
}  // namespace polyfit
