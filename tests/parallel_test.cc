#include "core/parallel.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <set>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace rigfit {
namespace {

TEST(ParallelFor, CallsEveryIndexExactlyOnceWhateverTheSplit) {
  for (const int n : {0, 1, 7, 999, 1000, 1001, 8000, 12345}) {
    for (const int threads : {1, 2, 3, 8}) {
      for (const int min_per_thread : {1, 10, 1000}) {
        std::vector<std::atomic<int>> calls(n);
        ParallelFor(
            n, threads, [&](int i) { calls[i].fetch_add(1); }, min_per_thread);
        for (int i = 0; i < n; ++i) {
          ASSERT_EQ(calls[i].load(), 1)
              << "n " << n << " threads " << threads << " min " << min_per_thread << " index " << i;
        }
      }
    }
  }
}

/// The threads that called Arrive, each waiting (once per thread, at most until a deadline
/// 2 s after construction) until `expected` threads have arrived: counts every thread that
/// takes part, whatever the scheduling, without a timing assumption when all goes well.
class Rendezvous {
 public:
  explicit Rendezvous(size_t expected)
      : expected_(expected),
        deadline_(std::chrono::steady_clock::now() + std::chrono::seconds(2)) {}

  void Arrive() {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!ids_.insert(std::this_thread::get_id()).second) return;
    arrived_.notify_all();
    arrived_.wait_until(lock, deadline_, [&] { return ids_.size() >= expected_; });
  }

  size_t count() {
    const std::lock_guard<std::mutex> lock(mutex_);
    return ids_.size();
  }

 private:
  const size_t expected_;
  const std::chrono::steady_clock::time_point deadline_;
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::set<std::thread::id> ids_;
};

TEST(ParallelFor, UsesUpToTheThreadsGivenAndNoMoreThanTheWorkAllows) {
  const auto threads_used = [](int n, int threads, int min_per_thread, size_t expected) {
    Rendezvous rendezvous(expected);
    ParallelFor(
        n, threads, [&](int) { rendezvous.Arrive(); }, min_per_thread);
    return rendezvous.count();
  };
  EXPECT_EQ(threads_used(64, 4, 1, 4), 4u);
  EXPECT_EQ(threads_used(64, 4, 32, 2), 2u);  // 64 indices, at least 32 per thread
  EXPECT_EQ(threads_used(64, 4, 100, 1), 1u);
  EXPECT_EQ(threads_used(64, 1, 1, 1), 1u);
}

TEST(ParallelFor, UnevenWorkIsShared) {
  // Only the first half of the indices has work. A split into two contiguous halves would
  // give all of it to one thread; blocks taken as they come share it between both.
  Rendezvous heavy(2);
  ParallelFor(
      64, 2,
      [&](int i) {
        if (i < 32) heavy.Arrive();
      },
      /*min_per_thread=*/1);
  EXPECT_EQ(heavy.count(), 2u);
}

TEST(ParallelFor, AnExceptionOnAnyThreadReachesTheCaller) {
  for (const int threads : {1, 2, 4}) {
    for (const int thrower : {0, 63}) {  // the first index (the caller's) and the last
      std::atomic<int> calls{0};
      EXPECT_THROW(ParallelFor(
                       64, threads,
                       [&](int i) {
                         ++calls;
                         if (i == thrower) throw std::runtime_error("index " + std::to_string(i));
                       },
                       /*min_per_thread=*/1),
                   std::runtime_error)
          << threads << " threads, index " << thrower;
      EXPECT_GE(calls.load(), 1);
    }
  }
  // Several throwing: one of them arrives, and nothing terminates.
  EXPECT_THROW(ParallelFor(
                   1000, 2, [](int) { throw std::logic_error("every index"); }, 10),
               std::logic_error);
}

}  // namespace
}  // namespace rigfit
