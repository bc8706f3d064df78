// A deterministic random source for the simulator: the same numbers for a given seed with
// every standard library. std::mt19937_64 is fully specified by the C++ standard, but
// std::uniform_real_distribution and std::normal_distribution are not, so the uniform and
// normal variates are computed here.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace rigfit {

/// Mersenne Twister with portable uniform and normal variates.
class SimRng {
 public:
  /// Stream `stream` of seed `seed`: distinct streams are statistically independent.
  SimRng(std::uint64_t seed, std::uint64_t stream)
      : engine_(SplitMix64(SplitMix64(seed) ^ SplitMix64(stream + 0x632BE59BD9B4E019ull))) {}

  /// Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }

  /// Uniform in [lo, hi).
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }

  /// Uniform integer in [lo, hi] (hi - lo much smaller than 2^53).
  int UniformInt(int lo, int hi) {
    return lo + static_cast<int>(std::floor(Uniform() * (hi - lo + 1)));
  }

  /// Standard normal variate by the Box-Muller transform: for u1 in (0, 1], u2 in [0, 1),
  /// sqrt(-2 ln u1) (cos 2 pi u2, sin 2 pi u2) are two independent N(0, 1) samples; the
  /// second one is kept for the next call.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    const double radius = std::sqrt(-2.0 * std::log(1.0 - Uniform()));
    const double angle = 2.0 * M_PI * Uniform();
    spare_ = radius * std::sin(angle);
    has_spare_ = true;
    return radius * std::cos(angle);
  }

 private:
  /// SplitMix64 finaliser: a well-mixed 64-bit hash, used to derive the stream seeds.
  static std::uint64_t SplitMix64(std::uint64_t x) {
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
  }

  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

}  // namespace rigfit
