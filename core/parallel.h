// Blocking parallel loops over [0, n) on plain threads. Chosen over OpenMP because a join
// blocks where libgomp's default barrier spins, which on shared cores costs CPU time
// (docs/benchmarks.md, preprocessing).
#pragma once

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rigfit {

/// Splits [0, n) into `chunks` contiguous ranges and calls body(chunk, begin, end) for
/// each, one thread per chunk (the calling thread takes chunk 0), and waits for all. An
/// exception thrown by body on any thread reaches the caller once every thread has ended
/// (the first one caught, if several throw).
template <typename Body>
void ParallelForChunks(int n, int chunks, const Body& body) {
  std::mutex mutex;
  std::exception_ptr error;
  const auto run = [&](int c) {
    try {
      body(c, static_cast<int>(static_cast<long>(n) * c / chunks),
           static_cast<int>(static_cast<long>(n) * (c + 1) / chunks));
    } catch (...) {
      const std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
    }
  };
  std::vector<std::thread> workers;
  for (int c = 1; c < chunks; ++c) workers.emplace_back(run, c);
  run(0);
  for (std::thread& worker : workers) worker.join();
  if (error) std::rethrow_exception(error);
}

/// Calls body(i) for every i in [0, n) on up to num_threads threads, at most one per
/// min_per_thread indices. The threads take the indices in blocks of at most
/// min_per_thread, each the next block left, so that uneven work (queries that miss
/// against queries that match) evens out. body must be safe to call concurrently for
/// different i. An exception from body reaches the caller, as in ParallelForChunks; the
/// other threads finish the blocks they hold and take no more.
template <typename Body>
void ParallelFor(int n, int num_threads, const Body& body, int min_per_thread = 1000) {
  const int threads = std::max(1, std::min(num_threads, n / std::max(1, min_per_thread)));
  // At least 8 blocks per thread, as long as they hold min_per_thread indices or fewer.
  const int block = std::max(1, std::min(min_per_thread, n / (8 * threads)));
  std::atomic<int> next{0};
  ParallelForChunks(threads, threads, [&](int, int, int) {
    try {
      for (int begin = next.fetch_add(block); begin < n; begin = next.fetch_add(block)) {
        const int end = std::min(n, begin + block);
        for (int i = begin; i < end; ++i) body(i);
      }
    } catch (...) {
      next.store(n);  // no thread takes another block
      throw;
    }
  });
}

}  // namespace rigfit
