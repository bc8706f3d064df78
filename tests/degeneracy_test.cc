#include "uncertainty/degeneracy.h"

#include <gtest/gtest.h>

#include <random>

namespace rigfit {
namespace {

constexpr double kHoldSigma = 1e-3;
const Vec3 kCameraCenter(0.5, 2.0, -1.5);

/// Adds n points drawn uniformly on an axis-aligned rectangle with normal `normal`.
void AddPatch(const Vec3& lo, const Vec3& hi, const Vec3& normal, int n, double weight,
              std::mt19937_64* rng, StabilityAccumulator* rows) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const Vec3 t(u(*rng), u(*rng), u(*rng));
    rows->Add(lo + (hi - lo).cwiseProduct(t), normal, weight);
  }
}

/// delta^T H delta of a unit motion of the camera (PoseManifold tangent), in 1/sigma^2.
double Held(const Mat6& H, int axis) { return H(axis, axis) * kHoldSigma * kHoldSigma; }

enum Axis { kTiltX = 0, kYaw = 1, kX = 3, kY = 4, kZ = 5 };

/// delta^T H delta of a unit tilt about world axis `axis` through the world origin.
double HeldTiltAboutOrigin(const Mat6& H, const Vec3& axis) {
  Vec6 delta;
  // A rotation w about the camera centre t moves points by w x (p - t); about the origin
  // it is that plus the translation w x t.
  delta << axis, axis.cross(kCameraCenter);
  return delta.dot(H * delta) * kHoldSigma * kHoldSigma;
}

TEST(Degeneracy, AFloorAloneLeavesHorizontalTranslationAndYawFree) {
  StabilityAccumulator rows;
  for (int i = -20; i <= 20; ++i) {  // a grid centred on the origin
    for (int k = -20; k <= 20; ++k) rows.Add(Vec3(0.1 * i, 0.0, 0.1 * k), Vec3::UnitY(), 1.0);
  }
  const std::vector<WeakDirection> weak = rows.WeakDirections(kCameraCenter, 0.002);
  ASSERT_EQ(weak.size(), 3u);
  for (const WeakDirection& d : weak) EXPECT_LT(d.strength, 1e-9);
  // The hold acts on exactly the free directions: x, z and yaw, not on height or on tilt
  // about the floor (a tilt about the camera centre, 2 m up, also slides the floor).
  const Mat6 H = HoldInformation(weak, kHoldSigma);
  EXPECT_NEAR(Held(H, kX), 1.0, 1e-6);
  EXPECT_NEAR(Held(H, kZ), 1.0, 1e-6);
  EXPECT_GT(Held(H, kYaw), 1.0);
  EXPECT_NEAR(Held(H, kY), 0.0, 1e-9);
  EXPECT_NEAR(HeldTiltAboutOrigin(H, Vec3::UnitX()), 0.0, 1e-9);
  EXPECT_NEAR(HeldTiltAboutOrigin(H, Vec3::UnitZ()), 0.0, 1e-9);
  EXPECT_GT(Held(H, kTiltX), 1.0);
}

TEST(Degeneracy, AWallAlongZLeavesOnlyTranslationAlongZ) {
  std::mt19937_64 rng(2);
  StabilityAccumulator rows;
  AddPatch({-2, 0, -2}, {2, 0, 2}, Vec3::UnitY(), 4000, 1.0, &rng, &rows);
  AddPatch({2, 0, -2}, {2, 0.3, 2}, -Vec3::UnitX(), 1000, 1.0, &rng, &rows);
  const std::vector<WeakDirection> weak = rows.WeakDirections(kCameraCenter, 0.002);
  ASSERT_EQ(weak.size(), 1u);
  EXPECT_EQ(weak[0].name, "translation along world Z");
  EXPECT_NE(weak[0].reason.find("vertical structure"), std::string::npos);
  const Mat6 H = HoldInformation(weak, kHoldSigma);
  EXPECT_NEAR(Held(H, kZ), 1.0, 1e-6);
  EXPECT_NEAR(Held(H, kX), 0.0, 1e-9);
  EXPECT_NEAR(Held(H, kY), 0.0, 1e-9);
}

TEST(Degeneracy, TwoWallsConstrainEverything) {
  std::mt19937_64 rng(3);
  StabilityAccumulator rows;
  AddPatch({-2, 0, -2}, {2, 0, 2}, Vec3::UnitY(), 4000, 1.0, &rng, &rows);
  AddPatch({2, 0, -2}, {2, 0.3, 2}, -Vec3::UnitX(), 1000, 1.0, &rng, &rows);
  AddPatch({-2, 0, 2}, {2, 0.3, 2}, -Vec3::UnitZ(), 1000, 1.0, &rng, &rows);
  EXPECT_TRUE(rows.WeakDirections(kCameraCenter, 0.002).empty());
}

TEST(Degeneracy, WeightsDecideWhatCounts) {
  // The same two walls, but seen so noisily (weight 1e-4 of the floor's) that they carry
  // less than 0.2% of the information: x, z and yaw are weak again.
  std::mt19937_64 rng(4);
  StabilityAccumulator rows;
  AddPatch({-2, 0, -2}, {2, 0, 2}, Vec3::UnitY(), 4000, 1.0, &rng, &rows);
  AddPatch({2, 0, -2}, {2, 0.3, 2}, -Vec3::UnitX(), 1000, 1e-4, &rng, &rows);
  AddPatch({-2, 0, 2}, {2, 0.3, 2}, -Vec3::UnitZ(), 1000, 1e-4, &rng, &rows);
  EXPECT_EQ(rows.WeakDirections(kCameraCenter, 0.002).size(), 3u);
  EXPECT_TRUE(rows.WeakDirections(kCameraCenter, 0.0).empty());  // analysis off
}

}  // namespace
}  // namespace rigfit
