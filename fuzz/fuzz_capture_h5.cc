// Fuzz target: the HDF5 rig-capture loader (io/capture_h5.h ReadCaptureFromMemory) on
// arbitrary bytes, read through HDF5's in-memory (core) driver. Rejecting the bytes with
// InputError is correct behaviour; anything else (another exception, a crash, a sanitizer
// report, a leak, a hang) is a finding. libhdf5 itself is not instrumented: memory errors
// inside it show only as crashes or through ASan's interceptors (memcpy, malloc, ...).
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/errors.h"
#include "io/capture_h5.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const rigfit::RigCapture capture = rigfit::ReadCaptureFromMemory(data, size, "fuzz.h5");
    // What the reader accepts keeps its promises: a camera is depth + intrinsics sized to the
    // image, or points; depth is NaN or in (0, 1000] m.
    for (const rigfit::CameraCapture& camera : capture.cameras) {
      if (camera.HasDepth() == camera.HasPoints()) __builtin_trap();
      if (!camera.HasDepth()) continue;
      if (camera.depth_m.size() != static_cast<std::size_t>(camera.width) * camera.height) {
        __builtin_trap();
      }
      for (const float z : camera.depth_m) {
        if (!std::isnan(z) && !(z > 0.0f && z <= 1000.0f)) __builtin_trap();
      }
    }
  } catch (const rigfit::InputError&) {
  }
  return 0;
}
