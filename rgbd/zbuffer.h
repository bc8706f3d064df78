// The z-buffer shared by the model rendering (rgbd/slam.h) and fusion's association
// (rgbd/surfel_map.h), filled by several threads without locks and with the result of a
// single thread: every pixel keeps the smallest key (depth, point index), the nearest point,
// ties to the lowest index. Each thread writes into its own buffer (no cache line shared
// while points are projected); the buffers are then merged by taking the smaller key per
// pixel. The minimum does not depend on which thread saw which point, so any thread count
// gives the bits of one.
#pragma once

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "core/parallel.h"

namespace rigfit {

/// The nearest pixel of an image coordinate: floor(x + 0.5) (lround without the library call,
/// which is not inlined and took 6% of SLAM's time); far outside every image for coordinates
/// beyond +-1e6 and NaN.
inline int NearestPixel(float x) {
  const float y = x + 0.5f;
  if (!(y > -1e6f && y < 1e6f)) return -1000000;
  const int i = static_cast<int>(y);
  return i - (y < static_cast<float>(i) ? 1 : 0);
}

class ZBuffer {
 public:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t{0};

  /// The key of a point at depth z > 0 (the float's bits order positive floats) and index i.
  static std::uint64_t Key(float z, int i) {
    std::uint32_t bits;
    std::memcpy(&bits, &z, sizeof bits);
    return (static_cast<std::uint64_t>(bits) << 32) | static_cast<std::uint32_t>(i);
  }
  static int Index(std::uint64_t key) { return static_cast<int>(key & 0xffffffffu); }
  static float Depth(std::uint64_t key) {
    const auto bits = static_cast<std::uint32_t>(key >> 32);
    float z;
    std::memcpy(&z, &bits, sizeof z);
    return z;
  }

  /// Empties `pixels` pixels for `threads` writers (the buffers are kept between calls).
  void Reset(int pixels, int threads) {
    pixels_ = pixels;
    threads_ = std::max(1, threads);
    keys_.resize(threads_);
    for (auto& keys : keys_) keys.assign(pixels_, kEmpty);
  }
  int threads() const { return threads_; }

  /// Thread t's buffer: keys[j] = min(keys[j], key).
  std::uint64_t* Thread(int t) { return keys_[t].data(); }
  static void Write(std::uint64_t* keys, int j, std::uint64_t key) {
    if (key < keys[j]) keys[j] = key;
  }

  /// Merges every thread's buffer into the first (split over the threads by pixels) and
  /// returns it.
  const std::vector<std::uint64_t>& Merge() {
    if (threads_ > 1) {
      ParallelForChunks(pixels_, threads_, [&](int, int begin, int end) {
        std::uint64_t* out = keys_[0].data();
        for (int t = 1; t < threads_; ++t) {
          const std::uint64_t* in = keys_[t].data();
          for (int j = begin; j < end; ++j) out[j] = std::min(out[j], in[j]);
        }
      });
    }
    return keys_[0];
  }

 private:
  int pixels_ = 0;
  int threads_ = 1;
  std::vector<std::vector<std::uint64_t>> keys_;
};

}  // namespace rigfit
