// A blocking parallel loop over [0, n) on plain threads. Chosen over OpenMP because a
// join blocks where libgomp's default barrier spins, which on shared cores costs CPU time
// (docs/benchmarks.md, preprocessing).
#pragma once

#include <algorithm>
#include <thread>
#include <vector>

namespace rigfit {

/// Calls body(i) for every i in [0, n), in contiguous chunks on up to num_threads threads
/// (the calling thread takes the first chunk), with at least min_per_thread indices per
/// thread. body must be safe to call concurrently for different i.
template <typename Body>
void ParallelFor(int n, int num_threads, const Body& body, int min_per_thread = 1000) {
  const int chunks = std::max(1, std::min(num_threads, n / std::max(1, min_per_thread)));
  const auto run = [&](int c) {
    const int begin = static_cast<int>(static_cast<long>(n) * c / chunks);
    const int end = static_cast<int>(static_cast<long>(n) * (c + 1) / chunks);
    for (int i = begin; i < end; ++i) body(i);
  };
  std::vector<std::thread> workers;
  for (int c = 1; c < chunks; ++c) workers.emplace_back(run, c);
  run(0);
  for (std::thread& worker : workers) worker.join();
}

}  // namespace rigfit
