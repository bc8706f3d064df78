// Dense RGB-D tracking on two consecutive real frames (7-Scenes RedKitchen frames 300 and 301,
// Kinect v1, 640x480) and on their half-resolution versions (320x240): the frame pyramid, one
// Gauss-Newton system by the fused projective pass, the two solve paths on one fixed set of
// pairs (closed-form Gauss-Newton against Ceres), and a whole coarse-to-fine track; and SLAM's
// model rendered from a map (frames 0..299 fused at 320x240 at their ground-truth poses, as
// `rigfit slam` fuses them) at frame 300's pose. Results:
// docs/benchmarks.md, "Dense RGB-D tracking".
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "io/rgbd_sequence.h"
#include "rgbd/frame.h"
#include "rgbd/projective_icp.h"
#include "rgbd/slam.h"

namespace rigfit {
namespace {

constexpr int kThreads = 2;
constexpr int kFirstFrame = 100;  // frame-000300 of the 400 shared frames
constexpr int kMapFrames = 300;   // BM_RenderModel's map: frames 0..299, rendered at 300

struct FramePair {
  RgbdFrame source;
  RgbdFrame target;
};

/// The frame at half resolution: the pyramid's level 1 (block means, scaled intrinsics).
RgbdFrame Half(const RgbdFrame& frame) {
  FrameOptions options;
  options.levels = 2;
  options.max_depth_m = 1e3;
  const FrameLevel level = BuildFramePyramid(frame, options, kThreads).levels[1];
  RgbdFrame half = frame;
  half.width = level.width;
  half.height = level.height;
  half.intrinsics = level.intrinsics;
  half.depth_m = level.depth_m;
  return half;
}

/// `load` run on the shared 7-Scenes frames; exits with a message when they cannot be read.
template <typename Load>
auto FromKitchen(const Load& load) {
  const std::string path = std::string(RIGFIT_SHARED_DATA_DIR) + "/sevenscenes_kitchen";
  try {
    return load(*OpenRgbdSequence(path));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rgbd_bench: needs %s (%s)\n", path.c_str(), e.what());
    std::exit(2);
  }
}

const FramePair& Frames(int width) {
  static const FramePair* full = nullptr;
  static const FramePair* half = nullptr;
  if (full == nullptr) {
    full = FromKitchen([](const RgbdSequence& sequence) {
      return new FramePair{sequence.Frame(kFirstFrame + 1), sequence.Frame(kFirstFrame)};
    });
    half = new FramePair{Half(full->source), Half(full->target)};
  }
  return width == 640 ? *full : *half;
}

FramePyramid Pyramid(const RgbdFrame& frame, int levels, bool bilateral = false) {
  FrameOptions options;
  options.levels = levels;
  options.bilateral = bilateral;
  return BuildFramePyramid(frame, options, kThreads);
}

/// Arguments: width, bilateral filter (0 or 1).
void BM_FramePyramid(benchmark::State& state) {
  const RgbdFrame& frame = Frames(static_cast<int>(state.range(0))).source;
  for (auto _ : state) benchmark::DoNotOptimize(Pyramid(frame, 3, state.range(1) == 1));
}
BENCHMARK(BM_FramePyramid)
    ->Args({640, 0})
    ->Args({640, 1})
    ->Args({320, 0})
    ->Args({320, 1})
    ->Unit(benchmark::kMillisecond);

void BM_NormalEquationsFused(benchmark::State& state) {
  const FramePair& pair = Frames(static_cast<int>(state.range(0)));
  const FrameLevel source = Pyramid(pair.source, 1).levels[0];
  const FrameLevel target = Pyramid(pair.target, 1).levels[0];
  int count = 0;
  for (auto _ : state) {
    const NormalEquations eq =
        AccumulateProjective(source, target, Pose::Identity(), {}, {}, kThreads);
    count = eq.count;
    benchmark::DoNotOptimize(eq.H);
  }
  state.counters["pairs"] = count;
}
BENCHMARK(BM_NormalEquationsFused)->Arg(640)->Arg(320)->Unit(benchmark::kMillisecond);

/// Both solve paths to convergence on one fixed set of pairs (640x480, identity start).
void BM_SolvePairs(benchmark::State& state) {
  const bool ceres = state.range(0) == 1;
  const FramePair& pair = Frames(640);
  const FrameLevel source = Pyramid(pair.source, 1).levels[0];
  const FrameLevel target = Pyramid(pair.target, 1).levels[0];
  const std::vector<ProjectiveCorrespondence> pairs =
      FindCorrespondences(source, target, Pose::Identity(), {}, kThreads);
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        ceres ? SolvePairsCeres(pairs, Pose::Identity(), {}, kThreads)
              : SolvePairsGaussNewton(pairs, Pose::Identity(), {}, 100, kThreads));
  }
  state.SetLabel(ceres ? "Ceres, one PointToPlaneCost per pair" : "closed-form Gauss-Newton");
  state.counters["pairs"] = static_cast<double>(pairs.size());
}
BENCHMARK(BM_SolvePairs)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

/// The kitchen's map after frames 0..299 (of the 400 shared), each halved to 320x240 and fused
/// at its ground-truth pose with `rigfit slam`'s settings, and frame 300 as slam sees it.
struct KitchenMap {
  SurfelMap map;
  FramePyramid frame;
  Pose T_world_camera;
};

const KitchenMap& MapOfKitchen() {
  static const KitchenMap* kitchen = FromKitchen([](const RgbdSequence& sequence) {
    const SlamOptions options;
    const auto halved = [&](int index) {
      return HalveFrame(sequence.Frame(index), options.frame.max_depth_jump_ratio);
    };
    auto* built = new KitchenMap;
    for (int index = 0; index < kMapFrames; ++index) {
      const RgbdFrame frame = halved(index);
      built->map.FuseFrame(BuildFramePyramid(frame, options.frame, kThreads).levels[0],
                           frame.T_world_camera_gt.value(), index, options.fusion, {}, {kThreads});
    }
    const RgbdFrame frame = halved(kMapFrames);
    built->frame = BuildFramePyramid(frame, options.frame, kThreads);
    built->T_world_camera = frame.T_world_camera_gt.value();
    return built;
  });
  return *kitchen;
}

/// The model rendered at a frame's pose (with the view of the map fusion then projects).
void BM_RenderModel(benchmark::State& state) {
  const KitchenMap& kitchen = MapOfKitchen();
  const FrameLevel& base = kitchen.frame.levels[0];
  const ModelViewpoint viewpoint{kitchen.T_world_camera, base.width, base.height, base.intrinsics,
                                 kMapFrames};
  ZBuffer zbuffer;
  FrameLevel level;
  MapView view;
  for (auto _ : state) {
    RenderModel(kitchen.map, viewpoint, RenderOptions{}, kThreads, {&zbuffer, &level, &view});
    benchmark::DoNotOptimize(level.valid_pixels.data());
  }
  state.counters["map_points"] = kitchen.map.size();
  state.counters["pixels"] = static_cast<double>(level.valid_pixels.size());
}
BENCHMARK(BM_RenderModel)->Unit(benchmark::kMillisecond);

/// Tracking alone (pyramids built beforehand): 3 levels, 10 / 5 / 4 iterations at most.
void BM_Track(benchmark::State& state) {
  const FramePair& pair = Frames(static_cast<int>(state.range(0)));
  const FramePyramid source = Pyramid(pair.source, 3);
  const FramePyramid target = Pyramid(pair.target, 3);
  int iterations = 0;
  for (auto _ : state) {
    const TrackResult result =
        TrackProjective(source, target, Pose::Identity(), ProjectiveIcpOptions{}, kThreads);
    iterations = result.iterations;
    benchmark::DoNotOptimize(result.T_target_source);
  }
  state.counters["gn_steps"] = iterations;
  state.counters["frames_per_s"] =
      benchmark::Counter(1, benchmark::Counter::kIsIterationInvariantRate);
}
BENCHMARK(BM_Track)->Arg(640)->Arg(320)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace rigfit

BENCHMARK_MAIN();
