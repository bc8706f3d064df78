// Wall-clock timing of pipeline stages.
#pragma once

#include <chrono>

namespace rigfit {

/// Seconds elapsed since `start` on the steady clock.
inline double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace rigfit
