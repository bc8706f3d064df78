// Point-based fusion (rgbd/surfel_map.h): merge, add and remove on hand-made 5x5 levels whose
// results are computed by hand, and maps fused from rendered frames of the test room.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <vector>

#include "core/pose.h"
#include "rgbd/frame.h"
#include "rgbd/slam.h"
#include "rgbd/surfel_map.h"
#include "rgbd_test_util.h"
#include "sim/scene.h"

namespace rigfit {
namespace {

using namespace rgbd_test;  // NOLINT: TestRoom, LookAt, Render, SinglePixelLevel

/// SinglePixelLevel's 5x5 image (f = 10 px, centre (2, 2)) without any valid pixel.
FrameLevel EmptyLevel() {
  FrameLevel level = SinglePixelLevel(1.0f);
  level.depth_m[12] = kNaN;
  level.vertices[12] = Vec3f::Constant(kNaN);
  level.normals[12] = Vec3f::Constant(kNaN);
  level.valid_pixels.clear();
  return level;
}

/// Makes pixel (u, v) of a 5x5 level valid at depth z with the given (unit) normal.
void SetPixel(FrameLevel* level, int u, int v, float z, const Vec3f& normal) {
  const int j = v * level->width + u;
  const PinholeIntrinsics& K = level->intrinsics;
  level->depth_m[j] = z;
  level->vertices[j] = Vec3f(static_cast<float>((u - K.cx) / K.fx) * z,
                             static_cast<float>((v - K.cy) / K.fy) * z, z);
  level->normals[j] = normal.normalized();
  level->valid_pixels.push_back(j);
  std::sort(level->valid_pixels.begin(), level->valid_pixels.end());
}

/// Colour of a 5x5 image, (r, g, b) at pixel (2, 2) and black elsewhere.
std::vector<std::uint8_t> CentreColor(std::uint8_t r, std::uint8_t g, std::uint8_t b) {
  std::vector<std::uint8_t> color(75, 0);
  color[36] = r;
  color[37] = g;
  color[38] = b;
  return color;
}

Pose SomePose() {
  Pose T = Pose::Identity();
  T.linear() = ExpSO3(Vec3(0.2, -0.4, 0.1));
  T.translation() = Vec3(0.5, -1.0, 2.0);
  return T;
}

TEST(RgbdFusion, RadiusGrowsWithDepthAndTheViewingAngle) {
  EXPECT_FLOAT_EQ(SurfelRadius(2.0f, -1.0f, 10.0), 0.2f);
  EXPECT_FLOAT_EQ(SurfelRadius(2.0f, -0.5f, 10.0), 0.4f);
  EXPECT_FLOAT_EQ(SurfelRadius(2.0f, 0.1f, 10.0), 0.2f / 0.26f);  // grazing: the floor
}

TEST(RgbdFusion, MergingAPointWithItselfKeepsItAndRaisesItsWeight) {
  SurfelMap map;
  const Pose T = SomePose();
  const FusionOptions options;
  const FusionStats first = map.FuseFrame(SinglePixelLevel(2.0f), T, 0, options);
  EXPECT_EQ(first.added, 1);
  EXPECT_EQ(first.merged, 0);
  const FusionStats second = map.FuseFrame(SinglePixelLevel(2.0f), T, 1, options);
  EXPECT_EQ(second.added, 0);
  EXPECT_EQ(second.merged, 1);
  ASSERT_EQ(map.size(), 1);
  EXPECT_FLOAT_EQ(map.weights()[0], 2.0f);
  EXPECT_EQ(map.last_seen()[0], 1);
  const Vec3 expected = T * Vec3(0, 0, 2);
  EXPECT_LT((map.positions()[0].cast<double>() - expected).norm(), 1e-6);
  EXPECT_LT((map.normals()[0].cast<double>() - T.linear() * Vec3(0, 0, -1)).norm(), 1e-6);
  EXPECT_EQ(map.input_points(), 2);
  EXPECT_DOUBLE_EQ(map.CompressionRatio(), 2.0);
}

TEST(RgbdFusion, WeightedAverageOfPositionsNormalsAndColours) {
  // A point of weight 2 at q1 = (0, 0, 2), n = (0, 0, -1), colour (100, 0, 0), merged with
  // q2 = (0, 0, 2.03) (same pixel, 3 cm farther), n2 = (0.3, 0, -1) / |.|, colour (130, 30, 0):
  //   p = (2 T q1 + T q2) / 3 = T (0, 0, 2.01)
  //   n = R normalise(2 (0, 0, -1) + n2) = R normalise(0.287348, 0, -2.957826)
  //     = R (0.0966931, 0, -0.9953142)
  //   c = (2 (100, 0, 0) + (130, 30, 0)) / 3 = (110, 10, 0)
  SurfelMap map;
  const Pose T = SomePose();
  const FusionOptions options;
  for (int k = 0; k < 2; ++k) {
    map.FuseFrame(SinglePixelLevel(2.0f), T, k, options, CentreColor(100, 0, 0));
  }
  FrameLevel level = EmptyLevel();
  SetPixel(&level, 2, 2, 2.03f, Vec3f(0.3f, 0.0f, -1.0f));
  const FusionStats stats = map.FuseFrame(level, T, 2, options, CentreColor(130, 30, 0));
  EXPECT_EQ(stats.merged, 1);
  ASSERT_EQ(map.size(), 1);
  EXPECT_FLOAT_EQ(map.weights()[0], 3.0f);
  EXPECT_LT((map.positions()[0].cast<double>() - T * Vec3(0, 0, 2.01)).norm(), 1e-6);
  const Vec3 n = T.linear() * Vec3(0.0966931, 0.0, -0.9953142);
  EXPECT_LT((map.normals()[0].cast<double>() - n).norm(), 1e-6);
  EXPECT_FLOAT_EQ(map.normals()[0].norm(), 1.0f);
  ASSERT_TRUE(map.has_color());
  EXPECT_LT((map.colors()[0] - Vec3f(110, 10, 0)).norm(), 1e-4f);
}

TEST(RgbdFusion, UnassociatedPointsAreAdded) {
  SurfelMap map;
  const FusionOptions options;  // gates 5 cm, 30 degrees
  FrameLevel first = EmptyLevel();
  SetPixel(&first, 2, 2, 2.0f, Vec3f(0, 0, -1));
  SetPixel(&first, 1, 2, 2.0f, Vec3f(0, 0, -1));
  SetPixel(&first, 3, 2, 2.0f, Vec3f(0, 0, -1));
  map.FuseFrame(first, Pose::Identity(), 0, options);
  ASSERT_EQ(map.size(), 3);
  FrameLevel second = EmptyLevel();
  SetPixel(&second, 2, 2, 2.01f, Vec3f(0, 0, -1));  // within both gates: merged
  SetPixel(&second, 1, 2, 2.10f, Vec3f(0, 0, -1));  // 10 cm behind the map point: added
  SetPixel(&second, 3, 2, 2.0f, Vec3f(1, 0, -1));   // normals 45 degrees apart: added
  SetPixel(&second, 2, 0, 2.0f, Vec3f(0, 0, -1));   // no map point there: added
  const FusionStats stats = map.FuseFrame(second, Pose::Identity(), 1, options);
  EXPECT_EQ(stats.input_points, 4);
  EXPECT_EQ(stats.merged, 1);
  EXPECT_EQ(stats.added, 3);
  EXPECT_EQ(map.size(), 6);
  EXPECT_EQ(map.input_points(), 7);
  EXPECT_DOUBLE_EQ(map.CompressionRatio(), 7.0 / 6.0);
  // A point behind the camera is never associated.
  SurfelMap behind;
  behind.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, options);
  Pose turned = Pose::Identity();
  turned.linear() = ExpSO3(Vec3(0, 3.14159265, 0));
  EXPECT_EQ(behind.FuseFrame(SinglePixelLevel(2.0f), turned, 1, options).added, 1);
}

TEST(RgbdFusion, DormantUnstablePointsAreRemoved) {
  FusionOptions options;
  options.dormant_frames = 2;
  options.min_stable_weight = 2.0;
  SurfelMap map;
  FrameLevel two = EmptyLevel();
  SetPixel(&two, 2, 2, 2.0f, Vec3f(0, 0, -1));
  SetPixel(&two, 1, 1, 2.0f, Vec3f(0, 0, -1));
  map.FuseFrame(two, Pose::Identity(), 0, options);
  map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 1, options);  // (2, 2): weight 2
  ASSERT_EQ(map.size(), 2);
  EXPECT_EQ(map.FuseFrame(EmptyLevel(), Pose::Identity(), 2, options).removed, 0);
  // Frame 3: (1, 1) was last seen 3 frames ago with weight 1 < 2; (2, 2) is stable.
  EXPECT_EQ(map.FuseFrame(EmptyLevel(), Pose::Identity(), 3, options).removed, 1);
  ASSERT_EQ(map.size(), 1);
  EXPECT_FLOAT_EQ(map.weights()[0], 2.0f);
  EXPECT_EQ(map.FuseFrame(EmptyLevel(), Pose::Identity(), 100, options).removed, 0);
  // dormant_frames = 0 never removes.
  options.dormant_frames = 0;
  SurfelMap kept;
  kept.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, options);
  kept.FuseFrame(EmptyLevel(), Pose::Identity(), 1000, options);
  EXPECT_EQ(kept.size(), 1);
}

TEST(RgbdFusion, RemovalKeepsTheOtherPointsInOrderAndComparesWeightsExactly) {
  // Row v = 2 at depths 2.00 .. 2.04 (u = 0 .. 4): points 0 .. 4; frame 1 sees u = 0, 1, 3
  // again (weight 2), so frame 2 removes points 2 and 4 (weight 1, unseen for 2 frames).
  FrameLevel row = EmptyLevel();
  FrameLevel again = EmptyLevel();
  for (int u = 0; u < 5; ++u) {
    SetPixel(&row, u, 2, 2.0f + 0.01f * u, Vec3f(0, 0, -1));
    if (u != 2 && u != 4) SetPixel(&again, u, 2, 2.0f + 0.01f * u, Vec3f(0, 0, -1));
  }
  // A stable weight of 2 keeps the weight-2 points; one just above 2 (not a float: the
  // nearest float is 2) removes them.
  for (const double stable : {2.0, 2.0000001}) {
    FusionOptions options;
    options.dormant_frames = 1;
    options.min_stable_weight = stable;
    SurfelMap map;
    map.FuseFrame(row, Pose::Identity(), 0, options);
    map.FuseFrame(again, Pose::Identity(), 1, options);
    ASSERT_EQ(map.size(), 5);
    EXPECT_EQ(map.FuseFrame(EmptyLevel(), Pose::Identity(), 2, options).removed, 2);
    ASSERT_EQ(map.size(), 3);
    const float z[3] = {2.0f, 2.01f, 2.03f};
    for (int i = 0; i < 3; ++i) {
      EXPECT_FLOAT_EQ(map.positions()[i].z(), z[i]) << i;
      EXPECT_FLOAT_EQ(map.weights()[i], 2.0f) << i;
      EXPECT_EQ(map.last_seen()[i], 1) << i;
    }
    EXPECT_EQ(map.FuseFrame(EmptyLevel(), Pose::Identity(), 3, options).removed,
              stable == 2.0 ? 0 : 3);
  }
}

TEST(RgbdFusion, ColourMustBeGivenForEveryFrameOrNone) {
  SurfelMap map;
  EXPECT_THROW(map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, FusionOptions{},
                             std::vector<std::uint8_t>(10)),
               std::invalid_argument);
  map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 0, FusionOptions{}, CentreColor(1, 2, 3));
  EXPECT_THROW(map.FuseFrame(SinglePixelLevel(2.0f), Pose::Identity(), 1, FusionOptions{}),
               std::invalid_argument);
}

class RgbdFusionRoom : public ::testing::Test {
 protected:
  static FrameLevel Level(const Scene& scene, const Pose& T_world_camera) {
    FrameOptions options;
    options.levels = 1;
    return BuildFramePyramid(Render(scene, T_world_camera, 160, 120), options).levels[0];
  }
};

TEST_F(RgbdFusionRoom, FusingTheSameFrameAgainKeepsTheMapSize) {
  const Scene scene = TestRoom();
  const Pose T = LookAt(Vec3(0.4, 1.5, 1.6), Vec3(0.0, 0.5, -1.5));
  const FrameLevel level = Level(scene, T);
  SurfelMap map;
  for (int k = 0; k < 5; ++k) {
    const FusionStats stats = map.FuseFrame(level, T, k, FusionOptions{});
    EXPECT_EQ(stats.added, k == 0 ? stats.input_points : 0) << k;
    ASSERT_EQ(map.size(), static_cast<int>(level.valid_pixels.size())) << k;
  }
  EXPECT_GT(map.size(), 10000);
  EXPECT_DOUBLE_EQ(map.CompressionRatio(), 5.0);
  for (const float w : map.weights()) ASSERT_FLOAT_EQ(w, 5.0f);
}

TEST_F(RgbdFusionRoom, CoveredPixelsAreNotAddedSoAJitteringViewStaysBounded) {
  // A camera shaking by a few millimetres and a tenth of a degree: a map point lands on a
  // neighbour of the pixel it came from, and without the coverage rule the pixel left
  // without a point is added again and again.
  const Scene scene = TestRoom();
  const Pose T = LookAt(Vec3(0.4, 1.5, 1.6), Vec3(0.0, 0.5, -1.5));
  std::vector<Pose> poses;
  std::vector<FrameLevel> levels;
  for (int k = 0; k < 12; ++k) {
    Pose jittered = T;
    jittered.linear() = T.linear() * ExpSO3(Vec3(0.002 * std::sin(k), 0.002 * std::cos(k), 0.0));
    jittered.translation() += Vec3(0.003 * std::cos(2.0 * k), 0.003 * std::sin(3.0 * k), 0.0);
    poses.push_back(jittered);
    levels.push_back(Level(scene, jittered));
  }
  FusionOptions cover;
  FusionOptions add_all;
  add_all.cover_radius_scale = 0.0;
  SurfelMap covered_map;
  SurfelMap full_map;
  int covered = 0;
  for (int k = 0; k < 12; ++k) {
    covered += covered_map.FuseFrame(levels[k], poses[k], k, cover).covered;
    EXPECT_EQ(full_map.FuseFrame(levels[k], poses[k], k, add_all).covered, 0);
  }
  const double one_view = static_cast<double>(levels[0].valid_pixels.size());
  EXPECT_GT(covered, 0);
  EXPECT_EQ(covered_map.input_points(), full_map.input_points());
  // Growth beyond one view (measured: 88 points against 683).
  EXPECT_GT(full_map.size(), 1.03 * one_view);
  EXPECT_LT(covered_map.size() - one_view, 0.25 * (full_map.size() - one_view));
  // The points left out were on surfaces already in the map: rendered, the two maps cover the
  // view alike.
  const FrameLevel a = RenderModel(covered_map, {T, 160, 120, levels[0].intrinsics}, {});
  const FrameLevel b = RenderModel(full_map, {T, 160, 120, levels[0].intrinsics}, {});
  EXPECT_GT(a.valid_pixels.size(), 0.9 * b.valid_pixels.size());
}

TEST_F(RgbdFusionRoom, AMapFusedAtTheTruePosesLiesOnTheSurfaces) {
  const Scene scene = TestRoom();
  SurfelMap map;
  std::int64_t input = 0;
  for (int k = 0; k < 8; ++k) {
    // A slow pan across the room, 4 cm and a few degrees per frame.
    const Pose T = LookAt(Vec3(0.04 * k - 0.2, 1.5, 1.6), Vec3(0.15 * k - 0.6, 0.5, -1.5));
    const FrameLevel level = Level(scene, T);
    input += static_cast<std::int64_t>(level.valid_pixels.size());
    map.FuseFrame(level, T, k, FusionOptions{});
  }
  EXPECT_EQ(map.input_points(), input);
  EXPECT_GT(map.CompressionRatio(), 2.0);  // overlapping views merge
  int far = 0;
  double worst = 0.0;
  for (const Vec3f& p : map.positions()) {
    const double d = scene.DistanceToSurface(p.cast<double>());
    worst = std::max(worst, d);
    if (d > 1e-3) ++far;
  }
  // Noise-free depth lies on the faces, and so do averages of points of one face. The few
  // exceptions are at creases (a box on the floor), where a pixel's normal, from its
  // neighbours on both faces, lets a point of one face merge with one of the other: 62 of
  // 21681 points, at most 3.8 mm off.
  EXPECT_LT(far, map.size() / 200) << "worst " << worst << " m of " << map.size() << " points";
  EXPECT_LT(worst, 5e-3);
  for (const Vec3f& n : map.normals()) ASSERT_NEAR(n.norm(), 1.0f, 1e-5f);
}

}  // namespace
}  // namespace rigfit
