// Speed of the rig-capture HDF5 writer and reader on a 4-camera 640x360 capture (the size of
// a ZED rig at its depth resolution), float32 and uint16 depth, with the compression WriteCapture
// uses, and the command line's guarded read. Run: build/bench/io_bench
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "io/capture_h5.h"

namespace rigfit {
namespace {

/// Four 640x360 cameras looking at a tilted plane with sensor-like noise and 5% holes.
RigCapture FourCameraCapture() {
  std::mt19937 rng(42);
  std::normal_distribution<float> noise(0.0f, 0.005f);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  RigCapture capture;
  for (int c = 0; c < 4; ++c) {
    CameraCapture cam;
    cam.serial = "3100" + std::to_string(1000 + c);
    cam.width = 640;
    cam.height = 360;
    cam.intrinsics = {360.0, 360.0, 319.5, 179.5};
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        const float z = 1.5f + 0.004f * v + noise(rng);
        cam.depth_m.push_back(unit(rng) < 0.05f ? std::nanf("") : z);
      }
    }
    capture.cameras.push_back(std::move(cam));
  }
  return capture;
}

std::string BenchPath(const char* name) {
  return (std::filesystem::temp_directory_path() /
          (std::string("rigfit_io_bench_") + std::to_string(::getpid()) + "_" + name))
      .string();
}

void BM_WriteCapture(benchmark::State& state) {
  const RigCapture capture = FourCameraCapture();
  CaptureWriteOptions options;
  options.depth_as_uint16 = state.range(0) != 0;
  const std::string path = BenchPath("write.h5");
  for (auto _ : state) WriteCapture(path, capture, options);
  state.counters["file_MB"] = std::filesystem::file_size(path) / 1e6;
  state.SetLabel(options.depth_as_uint16 ? "uint16" : "float32");
  std::filesystem::remove(path);
}
BENCHMARK(BM_WriteCapture)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_ReadCapture(benchmark::State& state) {
  CaptureWriteOptions options;
  options.depth_as_uint16 = state.range(0) != 0;
  const std::string path = BenchPath("read.h5");
  WriteCapture(path, FourCameraCapture(), options);
  for (auto _ : state) benchmark::DoNotOptimize(ReadCapture(path));
  state.SetLabel(options.depth_as_uint16 ? "uint16" : "float32");
  std::filesystem::remove(path);
}
BENCHMARK(BM_ReadCapture)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

/// The command line's read: in a forked child, the capture sent back through a pipe.
void BM_ReadCaptureGuarded(benchmark::State& state) {
  const std::string path = BenchPath("guarded.h5");
  WriteCapture(path, FourCameraCapture());
  for (auto _ : state) benchmark::DoNotOptimize(ReadCaptureGuarded(path));
  state.SetLabel("float32");
  std::filesystem::remove(path);
}
BENCHMARK(BM_ReadCaptureGuarded)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace rigfit

BENCHMARK_MAIN();
