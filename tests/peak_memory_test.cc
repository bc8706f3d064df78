// PeakMemory (core/peak_memory.h): the high-water mark of a stretch of work in this process.
#include "core/peak_memory.h"

#include <gtest/gtest.h>

#include <cstring>
#include <memory>

namespace rigfit {
namespace {

constexpr size_t kMb = 1024 * 1024;

TEST(PeakMemoryTest, PositiveAndAtLeastWhatTheWorkTouched) {
  const PeakMemory memory;
  if (!memory.reset()) GTEST_SKIP() << "/proc/self/clear_refs refused the reset";
  EXPECT_GT(memory.start_mb(), 0.0);
  EXPECT_GE(memory.PeakMb(), memory.start_mb() * 0.9);
  {
    // 200 MB written page by page: resident while it lives, freed before the measurement.
    constexpr size_t kSize = 200 * kMb;
    std::unique_ptr<char[]> buffer(new char[kSize]);
    std::memset(buffer.get(), 1, kSize);
    EXPECT_EQ(buffer[kSize - 1], 1);
  }
  EXPECT_GE(memory.PeakMb(), memory.start_mb() + 200.0 * 0.98);
}

TEST(PeakMemoryTest, ResetForgetsAnEarlierPeak) {
  {
    constexpr size_t kSize = 300 * kMb;
    std::unique_ptr<char[]> buffer(new char[kSize]);
    std::memset(buffer.get(), 1, kSize);
    EXPECT_EQ(buffer[kSize / 2], 1);
  }
  const PeakMemory memory;  // after the 300 MB were freed
  if (!memory.reset()) GTEST_SKIP() << "/proc/self/clear_refs refused the reset";
  EXPECT_GT(memory.PeakMb(), 0.0);
  EXPECT_LT(memory.PeakMb(), memory.start_mb() + 100.0);
}

}  // namespace
}  // namespace rigfit
