#include "core/peak_memory.h"

#include <malloc.h>

#include <fstream>
#include <string>

namespace rigfit {
namespace {

/// The value of a "Key:   123 kB" line of /proc/self/status, MB; 0 if absent.
double StatusMb(const std::string& key) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(key, 0) == 0) return std::stod(line.substr(key.size())) / 1024.0;
  }
  return 0.0;
}

}  // namespace

PeakMemory::PeakMemory() {
  ::malloc_trim(0);
  std::ofstream clear_refs("/proc/self/clear_refs");
  clear_refs << "5";
  clear_refs.flush();
  reset_ = static_cast<bool>(clear_refs);
  start_mb_ = CurrentRssMb();
}

double PeakMemory::PeakMb() const { return StatusMb("VmHWM:"); }

double CurrentRssMb() { return StatusMb("VmRSS:"); }

}  // namespace rigfit
