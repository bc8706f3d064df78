// Peak resident memory of a stretch of work in this process (Linux): the kernel's high-water
// mark of the resident set (VmHWM), lowered to the current resident size before the work by
// writing "5" to /proc/self/clear_refs.
#pragma once

namespace rigfit {

/// Measures the peak resident memory of this process from construction to Peak...Mb().
/// Not thread-safe against another PeakMemory in the same process (the mark is per process).
class PeakMemory {
 public:
  /// Returns the allocator's free memory to the system (malloc_trim), so that memory freed
  /// by earlier work does not count, then resets the high-water mark to the current resident
  /// size. When the reset is refused (no /proc, or a kernel without the feature), PeakMb()
  /// is the process-wide peak since it started and reset() is false.
  PeakMemory();

  /// True when the mark was reset: PeakMb() covers only the work since construction.
  bool reset() const { return reset_; }
  /// Resident size (VmRSS) at construction, MB; 0 if unknown.
  double start_mb() const { return start_mb_; }
  /// High-water mark of the resident set (VmHWM) now, MB; 0 if unknown.
  double PeakMb() const;

 private:
  bool reset_ = false;
  double start_mb_ = 0.0;
};

/// Resident size of this process now (VmRSS of /proc/self/status), MB; 0 if unknown.
double CurrentRssMb();

}  // namespace rigfit
