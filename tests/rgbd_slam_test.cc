// Frame-to-model SLAM (rgbd/slam.h): the model rendering on hand-made maps, the coarser
// levels built from a given level 0, and SLAM on rendered sequences of the test room.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "core/pose.h"
#include "core/trajectory.h"
#include "rgbd/frame.h"
#include "rgbd/slam.h"
#include "rgbd/surfel_map.h"
#include "rgbd_test_util.h"
#include "sim/scene.h"

namespace rigfit {
namespace {

using namespace rgbd_test;  // NOLINT: TestRoom, Render, RenderedSequence, Walk, SinglePixelLevel

RenderOptions PixelOnly() {
  RenderOptions options;
  options.splat = false;
  return options;
}

TEST(RgbdRender, APointFillsThePixelItProjectsToAndTheNearestIsKept) {
  // Two points on the ray of the centre pixel, at 2 m and 1 m (too far apart to merge).
  SurfelMap map;
  map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, FusionOptions{});
  map.FuseFrame(SinglePixelLevel(1.0f), Pose::Identity(), 1, FusionOptions{});
  ASSERT_EQ(map.size(), 2);
  const PinholeIntrinsics K{10.0, 10.0, 2.0, 2.0};
  const FrameLevel same = RenderModel(map, {Pose::Identity(), 5, 5, K}, PixelOnly());
  ASSERT_EQ(same.valid_pixels, std::vector<int>{12});
  EXPECT_FLOAT_EQ(same.depth_m[12], 1.0f);  // the nearer one
  EXPECT_LT((same.vertices[12] - Vec3f(0, 0, 1)).norm(), 1e-6f);
  EXPECT_LT((same.normals[12] - Vec3f(0, 0, -1)).norm(), 1e-6f);

  // The camera 0.2 m to the left: the point at 2 m lands at u = 10 * 0.2 / 2 + 2 = 3, the one
  // at 1 m at u = 10 * 0.2 / 1 + 2 = 4, both in the middle row, in the camera's frame.
  Pose left = Pose::Identity();
  left.translation() = Vec3(-0.2, 0.0, 0.0);
  const FrameLevel moved = RenderModel(map, {left, 5, 5, K}, PixelOnly());
  ASSERT_EQ(moved.valid_pixels, (std::vector<int>{13, 14}));
  EXPECT_LT((moved.vertices[13] - Vec3f(0.2f, 0, 2)).norm(), 1e-6f);
  EXPECT_LT((moved.vertices[14] - Vec3f(0.2f, 0, 1)).norm(), 1e-6f);

  // Seen from behind (the camera turned round, 3 m ahead): nothing.
  Pose behind = Pose::Identity();
  behind.linear() = ExpSO3(Vec3(0.0, M_PI, 0.0));
  behind.translation() = Vec3(0.0, 0.0, 3.0);
  EXPECT_TRUE(RenderModel(map, {behind, 5, 5, K}, PixelOnly()).valid_pixels.empty());
}

TEST(RgbdRender, ConfidenceFilterDropsUnstableOldPointsOnly) {
  SurfelMap map;
  map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, FusionOptions{});  // weight 1
  const PinholeIntrinsics K{10.0, 10.0, 2.0, 2.0};
  RenderOptions options = PixelOnly();
  options.min_weight = 2.0f;
  options.recent_frames = 3;
  EXPECT_EQ(RenderModel(map, {Pose::Identity(), 5, 5, K, 3}, options).valid_pixels.size(), 1u);
  EXPECT_TRUE(RenderModel(map, {Pose::Identity(), 5, 5, K, 4}, options).valid_pixels.empty());
  map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 1, FusionOptions{});  // weight 2
  EXPECT_EQ(RenderModel(map, {Pose::Identity(), 5, 5, K, 100}, options).valid_pixels.size(), 1u);
}

TEST(RgbdRender, ARenderedMapLiesOnTheSurfacesAndSplattingFillsItsHoles) {
  const Scene scene = TestRoom();
  const std::vector<Pose> poses = Walk(10);
  SurfelMap map;
  for (int i = 0; i < 10; i += 3) {
    map.FuseFrame(BuildFramePyramid(Render(scene, poses[i], 160, 120), FrameOptions{}).levels[0],
                  poses[i], i, FusionOptions{});
  }
  const RgbdFrame view = Render(scene, poses[5], 160, 120);
  const FramePyramid frame = BuildFramePyramid(view, FrameOptions{});
  const FrameLevel pixels = RenderModel(map, {poses[5], 160, 120, view.intrinsics}, PixelOnly());
  RenderOptions splat;
  splat.splat = true;
  const FrameLevel splats = RenderModel(map, {poses[5], 160, 120, view.intrinsics}, splat);
  EXPECT_GT(splats.valid_pixels.size(), pixels.valid_pixels.size());
  EXPECT_GT(splats.valid_pixels.size(), 0.9 * frame.levels[0].valid_pixels.size());
  // Where the frame has a depth the rendered one is within a millimetre of it (creases and
  // silhouettes aside).
  int close = 0;
  int compared = 0;
  for (const int j : splats.valid_pixels) {
    if (std::isnan(view.depth_m[j])) continue;
    ++compared;
    close += std::abs(splats.depth_m[j] - view.depth_m[j]) < 1e-3f ? 1 : 0;
  }
  EXPECT_GT(close, 0.8 * compared);
  // The model's pyramid: coarser levels from the rendered level 0.
  FramePyramid model;
  model.levels.push_back(splats);
  BuildCoarserLevels(&model, 3, FrameOptions{}.max_depth_jump_ratio);
  ASSERT_EQ(model.levels.size(), 3u);
  EXPECT_EQ(model.levels[2].width, 40);
  EXPECT_DOUBLE_EQ(model.levels[2].intrinsics.fx, frame.levels[2].intrinsics.fx);
  EXPECT_GT(model.levels[2].valid_pixels.size(), 0.9 * frame.levels[2].valid_pixels.size());
}

// Bit for bit: NaN-free values compared by their bits, the invalid pixels by the list.
void ExpectSameLevel(const FrameLevel& a, const FrameLevel& b) {
  ASSERT_EQ(a.valid_pixels, b.valid_pixels);
  for (const int j : a.valid_pixels) {
    EXPECT_EQ(a.depth_m[j], b.depth_m[j]);
    EXPECT_EQ(a.vertices[j], b.vertices[j]);
    EXPECT_EQ(a.normals[j], b.normals[j]);
  }
}

TEST(RgbdRender, ThreadsGiveTheSerialResultExactly) {
  // A noisy map (points overlap, ties and near-ties in the z-buffer), fused and rendered on 1
  // and on 3 threads: the same map and the same renderings, bit for bit.
  const Scene scene = TestRoom();
  const std::vector<Pose> poses = Walk(10);
  SurfelMap serial;
  SurfelMap parallel;
  for (int i = 0; i < 10; i += 2) {
    const FrameLevel level =
        BuildFramePyramid(Render(scene, poses[i], 160, 120, 0.01, i), FrameOptions{}).levels[0];
    const FusionStats one = serial.FuseFrame(level, poses[i], i, FusionOptions{}, {}, {1});
    const FusionStats three = parallel.FuseFrame(level, poses[i], i, FusionOptions{}, {}, {3});
    EXPECT_EQ(one.merged, three.merged);
    EXPECT_EQ(one.added, three.added);
    EXPECT_EQ(one.removed, three.removed);
  }
  ASSERT_EQ(serial.size(), parallel.size());
  EXPECT_GT(serial.size(), 20000);
  EXPECT_EQ(serial.positions(), parallel.positions());
  EXPECT_EQ(serial.normals(), parallel.normals());
  EXPECT_EQ(serial.weights(), parallel.weights());
  EXPECT_EQ(serial.radii(), parallel.radii());
  EXPECT_EQ(serial.last_seen(), parallel.last_seen());
  const PinholeIntrinsics K = Intrinsics(160, 120);
  RenderOptions splat;
  splat.splat = true;
  for (const RenderOptions& options : {PixelOnly(), splat}) {
    const FrameLevel one = RenderModel(serial, {poses[5], 160, 120, K, 9}, options, 1);
    EXPECT_GT(one.valid_pixels.size(), 10000u);
    ExpectSameLevel(one, RenderModel(serial, {poses[5], 160, 120, K, 9}, options, 2));
    ExpectSameLevel(one, RenderModel(serial, {poses[5], 160, 120, K, 9}, options, 3));
  }
}

/// The map points (position, normal, weight, radius, last seen) from `first` on, sorted: what
/// a reordering must keep.
std::vector<std::vector<float>> PointsFrom(const SurfelMap& map, int first) {
  std::vector<std::vector<float>> points;
  for (int i = first; i < map.size(); ++i) {
    const Vec3f& p = map.positions()[i];
    const Vec3f& n = map.normals()[i];
    points.push_back({p.x(), p.y(), p.z(), n.x(), n.y(), n.z(), map.weights()[i], map.radii()[i],
                      static_cast<float>(map.last_seen()[i])});
  }
  std::sort(points.begin(), points.end());
  return points;
}

/// The mean diagonal of the bounding boxes of runs of 64 consecutive map points, metres.
double MeanRunExtent(const SurfelMap& map) {
  double sum = 0.0;
  int runs = 0;
  for (int begin = 0; begin + 64 <= map.size(); begin += 64, ++runs) {
    Vec3f low = map.positions()[begin];
    Vec3f high = low;
    for (int i = begin + 1; i < begin + 64; ++i) {
      low = low.cwiseMin(map.positions()[i]);
      high = high.cwiseMax(map.positions()[i]);
    }
    sum += (high - low).norm();
  }
  return sum / runs;
}

TEST(RgbdRender, SortingTheNewPointsKeepsThemAndTheRendering) {
  // A noisy map of four frames, its new points sorted by 0.2 m cell: the same points, now
  // near their neighbours in the arrays, and the same renderings (through runs of points the
  // rendering skips when they lie out of view). Fused again, only the new points move.
  const Scene scene = TestRoom();
  const std::vector<Pose> poses = Walk(12);
  const auto level = [&](int i) {
    return BuildFramePyramid(Render(scene, poses[i], 160, 120, 0.01, i), FrameOptions{}).levels[0];
  };
  SurfelMap map;
  for (int i = 0; i < 8; i += 2) map.FuseFrame(level(i), poses[i], i, FusionOptions{});
  const SurfelMap before = map;
  map.SortNewPoints(0.2);
  EXPECT_EQ(PointsFrom(map, 0), PointsFrom(before, 0));
  // Runs of 64 points span 3.42 m before (rows of a frame), 0.66 m after.
  EXPECT_LT(MeanRunExtent(map), 0.4 * MeanRunExtent(before));
  const PinholeIntrinsics K = Intrinsics(160, 120);
  RenderOptions splat;
  splat.splat = true;
  const Pose side = LookAt(Vec3(0.0, 1.4, 1.5), Vec3(-2.5, 0.8, 1.0));
  for (const Pose& pose : {poses[3], poses[11], side}) {
    for (const RenderOptions& options : {PixelOnly(), splat}) {
      ExpectSameLevel(RenderModel(before, {pose, 160, 120, K, 9}, options, 2),
                      RenderModel(map, {pose, 160, 120, K, 9}, options, 2));
    }
  }
  const SurfelMap sorted = map;
  map.SortNewPoints(0.2);  // nothing new
  EXPECT_EQ(map.positions(), sorted.positions());
  // Dormant points removed from the sorted ones, then new points sorted after them.
  FusionOptions removing;
  removing.dormant_frames = 2;
  const FusionStats stats = map.FuseFrame(level(10), poses[10], 10, removing);
  ASSERT_GT(stats.removed, 0);
  ASSERT_GT(stats.added, 100);
  const SurfelMap fused = map;
  map.SortNewPoints(0.2);
  const int old = map.size() - stats.added;
  EXPECT_TRUE(std::equal(fused.positions().begin(), fused.positions().begin() + old,
                         map.positions().begin()));
  EXPECT_EQ(PointsFrom(map, old), PointsFrom(fused, old));
  EXPECT_NE(map.positions(), fused.positions());
  EXPECT_THROW(map.SortNewPoints(0.0), std::invalid_argument);
}

TEST(RgbdRender, TheViewHoldsEveryPointThatLandsNearTheImage) {
  // A sorted map seen from views that see all or part of it, with a margin of 6 pixels: the view
  // collected while rendering holds exactly the points at least 5 cm in front of the camera
  // whose nearest pixel lies within the margin (as RenderModel projects them), whatever runs
  // of points it skipped.
  const Scene scene = TestRoom();
  const std::vector<Pose> poses = Walk(12);
  SurfelMap map;
  for (int i = 0; i < 12; i += 4) {
    map.FuseFrame(
        BuildFramePyramid(Render(scene, poses[i], 160, 120, 0.01, i), FrameOptions{}).levels[0],
        poses[i], i, FusionOptions{});
  }
  map.SortNewPoints(0.2);
  const PinholeIntrinsics K = Intrinsics(160, 120);
  Pose turned = poses[6];
  turned.linear() = turned.linear() * ExpSO3(Vec3(0.0, 0.3, 0.0));  // half the map out of view
  Pose close = poses[6];
  close.translation() += poses[6].linear() * Vec3(0.0, 0.0, 1.5);  // near the far wall
  // The map's points in view: all of them, 12,266 and 2,164 of 17,379.
  const std::vector<std::pair<Pose, double>> views = {{poses[6], 1.0}, {turned, 0.8}, {close, 0.3}};
  for (const auto& [pose, most] : views) {
    ZBuffer zbuffer;
    FrameLevel model;
    MapView view;
    view.margin_px = 6;
    RenderModel(map, {pose, 160, 120, K, 12}, PixelOnly(), 2, {&zbuffer, &model, &view});
    std::vector<int> found;
    for (const std::vector<int>& part : view.parts)
      found.insert(found.end(), part.begin(), part.end());
    const Eigen::Matrix3f R_cw = pose.linear().transpose().cast<float>();
    const Vec3f t = pose.translation().cast<float>();
    const float fx = static_cast<float>(K.fx);
    const float cx = static_cast<float>(K.cx);
    const float fy = static_cast<float>(K.fy);
    const float cy = static_cast<float>(K.cy);
    std::vector<int> expected;
    for (int i = 0; i < map.size(); ++i) {
      const Vec3f p = R_cw * (map.positions()[i] - t);
      if (!(p.z() >= MapView::kMinDepthM)) continue;
      const int u = NearestPixel(fx * p.x() / p.z() + cx);
      const int v = NearestPixel(fy * p.y() / p.z() + cy);
      if (u >= -6 && v >= -6 && u < 166 && v < 126) expected.push_back(i);
    }
    EXPECT_EQ(found, expected);
    EXPECT_GT(expected.size(), 1000u);
    EXPECT_LE(expected.size(), most * map.size());
  }
}

TEST(RgbdRender, FusingThroughTheRenderedViewEqualsFusingThroughTheWholeMap) {
  // Each frame rendered at a prediction 5 mm and 0.1 degrees off, then fused at the true pose
  // once through the points the rendering collected (MapView, a margin of 6 pixels) and once
  // through every point: the same maps, while the view held fewer points than the map.
  const Scene scene = TestRoom();
  const std::vector<Pose> poses = Walk(12);
  SurfelMap with_view;
  SurfelMap whole;
  // First a look at the side wall, out of the walk's view.
  const Pose side = LookAt(Vec3(0.0, 1.4, 1.5), Vec3(-2.5, 0.8, 1.0));
  const FrameLevel side_level =
      BuildFramePyramid(Render(scene, side, 160, 120), FrameOptions{}).levels[0];
  with_view.FuseFrame(side_level, side, 0, {});
  whole.FuseFrame(side_level, side, 0, {});
  int used = 0;
  for (int k = 1; k < 12; ++k) {
    const FrameLevel level =
        BuildFramePyramid(Render(scene, poses[k], 160, 120, 0.005, k), FrameOptions{}).levels[0];
    Pose predicted = poses[k];
    predicted.linear() = predicted.linear() * ExpSO3(Vec3(0.0, 0.0017, 0.0));
    predicted.translation() += Vec3(0.005, 0.0, 0.0);
    ZBuffer zbuffer;
    FrameLevel model;
    MapView view;
    view.margin_px = 6;
    RenderModel(with_view, {predicted, 160, 120, level.intrinsics, k}, {}, 2,
                {&zbuffer, &model, &view});
    const bool covers =
        view.Covers(level, poses[k], with_view.size(), FusionOptions{}.max_distance_m);
    const FusionStats a = with_view.FuseFrame(level, poses[k], k, {}, {}, {2, &view});
    const FusionStats b = whole.FuseFrame(level, poses[k], k, {}, {}, {2});
    if (covers) {
      ++used;
      EXPECT_LT(a.projected, b.projected);
    }
    EXPECT_EQ(a.merged, b.merged);
    EXPECT_EQ(a.added, b.added);
  }
  EXPECT_GE(used, 10);
  EXPECT_EQ(with_view.positions(), whole.positions());
  EXPECT_EQ(with_view.weights(), whole.weights());
  // A view does not cover a pose turned 10 degrees away, nor a map that changed.
  MapView view;
  ZBuffer zbuffer;
  FrameLevel model;
  RenderModel(whole, {poses[6], 160, 120, Intrinsics(160, 120), 12}, {}, 2,
              {&zbuffer, &model, &view});
  const FrameLevel level =
      BuildFramePyramid(Render(scene, poses[6], 160, 120), FrameOptions{}).levels[0];
  EXPECT_TRUE(view.Covers(level, poses[6], whole.size(), 0.05));
  Pose turned = poses[6];
  turned.linear() = turned.linear() * ExpSO3(Vec3(0.0, 10.0 * M_PI / 180.0, 0.0));
  EXPECT_FALSE(view.Covers(level, turned, whole.size(), 0.05));
  EXPECT_FALSE(view.Covers(level, poses[6], whole.size() + 1, 0.05));
}

TEST(RgbdSlam, NoiseFreeWalkStaysWellUnderAMillimetre) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(30), 320, 240, 0.0);
  SlamOptions options;
  options.icp.converged_rotation_rad = 1e-7;
  options.icp.converged_translation_m = 1e-7;
  int calls = 0;
  const SlamResult result =
      RunSlam(sequence, options, {}, [&](int done, int total, const SlamFrame& frame) {
        ++calls;
        EXPECT_EQ(done, calls);
        EXPECT_EQ(total, 30);
        EXPECT_EQ(frame.index, done - 1);
      });
  EXPECT_EQ(calls, 30);
  ASSERT_EQ(result.trajectory.poses.size(), 30u);
  EXPECT_EQ(result.failures, 0);
  EXPECT_EQ(result.restarts, 0);
  const TrajectoryErrors e = EvaluateTrajectory(result.trajectory, sequence.GroundTruth(), 0.02, 1);
  EXPECT_EQ(e.pairs, 30);
  EXPECT_LT(e.ate_rmse_m, 3e-4);
  // The map grows with what is newly seen, and far slower than the input.
  EXPECT_EQ(result.frames.back().map_size, result.map.size());
  EXPECT_GT(result.map.CompressionRatio(), 5.0);
  for (const SlamFrame& frame : result.frames) {
    if (frame.index > 0) {
      EXPECT_GT(frame.model_pixels, 0);
    }
  }
}

TEST(RgbdSlam, AHalvedSequenceIsTrackedAtHalfTheResolution) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(10), 320, 240, 0.0);
  SlamOptions options;
  options.halvings = 1;
  const SlamResult result = RunSlam(sequence, options);
  EXPECT_EQ(result.failures, 0);
  const TrajectoryErrors e = EvaluateTrajectory(result.trajectory, sequence.GroundTruth(), 0.02, 1);
  EXPECT_LT(e.ate_rmse_m, 1e-3);
  // At most one point per 160x120 pixel and frame.
  EXPECT_LE(result.map.input_points(), 10 * 160 * 120);
  EXPECT_GT(result.map.input_points(), 5 * 160 * 120);
}

TEST(RgbdSlam, TheDefaultHalvesFramesWiderThan480Pixels) {
  EXPECT_EQ(SlamHalvings(std::nullopt, 320), 0);
  EXPECT_EQ(SlamHalvings(std::nullopt, 480), 0);
  EXPECT_EQ(SlamHalvings(std::nullopt, 640), 1);
  EXPECT_EQ(SlamHalvings(std::nullopt, 848), 1);
  EXPECT_EQ(SlamHalvings(std::nullopt, 1280), 2);
  EXPECT_EQ(SlamHalvings(0, 1280), 0);
  EXPECT_EQ(SlamHalvings(2, 320), 2);
  // The run halves as the first frame's width says, and says so.
  const Scene scene = TestRoom();
  const RenderedSequence wide(scene, Walk(2), 640, 480, 0.0);
  const SlamResult halved = RunSlam(wide, SlamOptions{});
  EXPECT_EQ(halved.halvings, 1);
  EXPECT_LE(halved.map.input_points(), 2 * 320 * 240);
  const RenderedSequence narrow(scene, Walk(2), 320, 240, 0.0);
  EXPECT_EQ(RunSlam(narrow, SlamOptions{}).halvings, 0);
}

TEST(RgbdSlam, AFrameWithoutColourInAColouredMapIsTrackedNotFused) {
  const Scene scene = TestRoom();
  const RenderedSequence rendered(scene, Walk(8), 160, 120, 0.0);
  // Grey colour on every frame but 4 (as TUM, whose depth images sometimes have no colour image
  // close enough in time).
  const EditedSequence sequence(
      rendered,
      [](int index, RgbdFrame* frame) {
        if (index != 4) frame->color.assign(3 * frame->depth_m.size(), 128);
      },
      "coloured");
  const SlamResult result = RunSlam(sequence, SlamOptions{});
  EXPECT_EQ(result.failures, 0);
  EXPECT_EQ(result.without_color, 1);
  ASSERT_EQ(result.frames.size(), 8u);
  EXPECT_TRUE(result.frames[4].track.success);
  EXPECT_EQ(result.frames[4].map_size, result.frames[3].map_size);
  EXPECT_TRUE(result.map.has_color());
  const TrajectoryErrors e = EvaluateTrajectory(result.trajectory, sequence.GroundTruth(), 0.02, 1);
  EXPECT_LT(e.ate_rmse_m, 1e-3);
}

// The next frame is read and its pyramid built on the loader's thread while the current one
// is tracked: a frame that cannot be preprocessed stops the run when its turn comes, after
// every frame before it, with its own error; the loop's wall time holds its stages.
TEST(RgbdSlam, APreprocessingErrorArrivesInFrameOrderAndTheLoopHoldsItsStages) {
  const Scene scene = TestRoom();
  const RenderedSequence rendered(scene, Walk(6), 80, 60, 0.0);
  // Frame 4 with one depth sample too few: no pyramid can be built of it.
  const EditedSequence broken(
      rendered,
      [](int index, RgbdFrame* frame) {
        if (index != 4) return;
        frame->depth_m.pop_back();
        frame->source = "broken frame";
      },
      "broken");
  int done = 0;
  try {
    RunSlam(broken, SlamOptions{}, {}, [&](int d, int, const SlamFrame&) { done = d; });
    ADD_FAILURE() << "frame 4 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("broken frame"), std::string::npos) << e.what();
  }
  EXPECT_EQ(done, 4);

  const SlamResult result = RunSlam(rendered, SlamOptions{});
  EXPECT_GT(result.preprocess_s, 0.0);
  EXPECT_GE(result.loop_s, result.load_s + result.render_s + result.track_s + result.fuse_s);
}

TEST(RgbdSlam, RefusesBadOptions) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(2), 80, 60, 0.0);
  SlamOptions bad;
  bad.stride = 0;
  EXPECT_THROW(RunSlam(sequence, bad), InputError);
  bad = SlamOptions{};
  bad.first_frame = 5;
  EXPECT_THROW(RunSlam(sequence, bad), InputError);
  bad = SlamOptions{};
  bad.halvings = -1;
  EXPECT_THROW(RunSlam(sequence, bad), InputError);
}

}  // namespace
}  // namespace rigfit
