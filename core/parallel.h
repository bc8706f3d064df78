// Blocking parallel loops over [0, n) on plain threads. Chosen over OpenMP because a join
// blocks where libgomp's default barrier spins, which on shared cores costs CPU time
// (docs/benchmarks.md, preprocessing).
#pragma once

#include <algorithm>
#include <thread>
#include <vector>

namespace rigfit {

/// Splits [0, n) into `chunks` contiguous ranges and calls body(chunk, begin, end) for
/// each, one thread per chunk (the calling thread takes chunk 0), and waits for all.
template <typename Body>
void ParallelForChunks(int n, int chunks, const Body& body) {
  const auto run = [&](int c) {
    body(c, static_cast<int>(static_cast<long>(n) * c / chunks),
         static_cast<int>(static_cast<long>(n) * (c + 1) / chunks));
  };
  std::vector<std::thread> workers;
  for (int c = 1; c < chunks; ++c) workers.emplace_back(run, c);
  run(0);
  for (std::thread& worker : workers) worker.join();
}

/// Calls body(i) for every i in [0, n) on up to num_threads threads, with at least
/// min_per_thread indices per thread. body must be safe to call concurrently for
/// different i.
template <typename Body>
void ParallelFor(int n, int num_threads, const Body& body, int min_per_thread = 1000) {
  const int chunks = std::max(1, std::min(num_threads, n / std::max(1, min_per_thread)));
  ParallelForChunks(n, chunks, [&](int, int begin, int end) {
    for (int i = begin; i < end; ++i) body(i);
  });
}

}  // namespace rigfit
