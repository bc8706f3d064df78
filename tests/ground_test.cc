#include "prepare/ground.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/geometry.h"
#include "prepare/region.h"

namespace rigfit {
namespace {

/// A floor patch (y = 0) of side `size` around (cx, cz), a box on it and a wall, in the world.
PointCloud FloorScene(double noise, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, noise);
  PointCloud pts;
  for (double x = -1.5; x <= 1.5; x += 0.02) {
    for (double z = 1.0; z <= 4.0; z += 0.02) pts.emplace_back(x, n(rng), z);
  }
  for (double x = -0.3; x <= 0.3; x += 0.02) {  // box top at 0.4 m and a side face
    for (double z = 2.0; z <= 2.5; z += 0.02) pts.emplace_back(x, 0.4 + n(rng), z);
    for (double y = 0.0; y <= 0.4; y += 0.02) pts.emplace_back(x, y, 2.0 + n(rng));
  }
  for (double x = -1.5; x <= 1.5; x += 0.02) {  // wall
    for (double y = 0.0; y <= 2.0; y += 0.02) pts.emplace_back(x, y, 4.0 + n(rng));
  }
  return pts;
}

/// A camera 2 m above the floor at the world origin, looking toward +Z and 40 deg down.
Pose TrueCamera() {
  const double a = 40.0 * kDegToRad;
  Pose T = Pose::Identity();
  // Columns: camera x (right), y (down), z (forward) in world coordinates.
  T.linear().col(2) = Vec3(0.0, -std::sin(a), std::cos(a));
  T.linear().col(1) = Vec3(0.0, -std::cos(a), -std::sin(a));
  T.linear().col(0) = T.linear().col(1).cross(T.linear().col(2));
  T.translation() = Vec3(0.0, 2.0, 0.0);
  return T;
}

TEST(LevelCamera, RecoversKnownTiltAndFloorHeight) {
  const Pose T_true = TrueCamera();
  ASSERT_GT((T_true.linear() * Vec3::UnitZ()).z(), 0.5);  // looks toward +Z (the floor patch)
  const PointCloud camera_points = Transform(T_true.inverse(), FloorScene(0.0, 1));
  // Rough calibration: 2 deg tilt about a horizontal axis, 8 cm too high.
  Pose error = Pose::Identity();
  error.linear() = ExpSO3(2.0 * kDegToRad * Vec3(0.6, 0.0, 0.8));
  error.translation() = Vec3(0.0, 0.08, 0.0);
  const Pose T_init = error * T_true;

  const GroundResult r = LevelCamera(camera_points, T_init, GroundOptions{});
  ASSERT_TRUE(r.found) << r.message;
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(TiltErrorRad(r.T_world_camera, T_true), 1e-4 * kDegToRad);
  EXPECT_NEAR(r.T_world_camera.translation().y(), 2.0, 1e-6);
  EXPECT_NEAR(r.correction_rotation_deg, 2.0, 1e-6);
  // The floor is found in the camera frame: n_c . p + d_c = 0 for floor points.
  EXPECT_NEAR(r.plane_camera.SignedDistance(T_true.inverse() * Vec3(0.5, 0.0, 2.0)), 0.0, 1e-9);
  // Floor points of the leveled camera lie on y = 0.
  EXPECT_NEAR((r.T_world_camera * (T_true.inverse() * Vec3(1.0, 0.0, 3.0))).y(), 0.0, 1e-6);
}

TEST(LevelCamera, NoisyFloorLevelsToAFewHundredthsOfADegree) {
  const Pose T_true = TrueCamera();
  const PointCloud camera_points = Transform(T_true.inverse(), FloorScene(0.005, 2));
  Pose error = Pose::Identity();
  error.linear() = ExpSO3(1.0 * kDegToRad * Vec3(1.0, 0.0, 0.0));
  const GroundResult r = LevelCamera(camera_points, error * T_true, GroundOptions{});
  ASSERT_TRUE(r.accepted) << r.message;
  EXPECT_LT(TiltErrorRad(r.T_world_camera, T_true), 0.03 * kDegToRad);
  EXPECT_NEAR(r.T_world_camera.translation().y(), 2.0, 0.002);
  EXPECT_NEAR(r.inlier_rms_m, 0.005, 0.001);
}

TEST(LevelCamera, LevelingDoesNotChangeYawOrHorizontalPositionOfTheFloor) {
  const Pose T_true = TrueCamera();
  const PointCloud camera_points = Transform(T_true.inverse(), FloorScene(0.0, 3));
  Pose error = Pose::Identity();
  error.linear() = ExpSO3(3.0 * kDegToRad * Vec3(0.0, 0.0, 1.0));
  const GroundResult r = LevelCamera(camera_points, error * T_true, GroundOptions{});
  ASSERT_TRUE(r.accepted);
  // Forward direction projected on the floor keeps its heading.
  const Vec3 f_true = T_true.linear() * Vec3::UnitZ();
  const Vec3 f = r.T_world_camera.linear() * Vec3::UnitZ();
  EXPECT_NEAR(std::atan2(f.x(), f.z()), std::atan2(f_true.x(), f_true.z()), 0.05 * kDegToRad);
}

TEST(LevelCamera, RejectsCorrectionBeyondBoundsAndKeepsPose) {
  const Pose T_true = TrueCamera();
  const PointCloud camera_points = Transform(T_true.inverse(), FloorScene(0.0, 4));
  Pose error = Pose::Identity();
  error.translation() = Vec3(0.0, 0.3, 0.0);
  GroundOptions options;
  options.max_translation_m = 0.1;
  const GroundResult r = LevelCamera(camera_points, error * T_true, options);
  EXPECT_TRUE(r.found);
  EXPECT_FALSE(r.accepted);
  EXPECT_NE(r.message.find("translation"), std::string::npos) << r.message;
  EXPECT_TRUE(r.T_world_camera.isApprox(error * T_true));
  EXPECT_TRUE(r.correction.isApprox(Pose::Identity()));
}

TEST(LevelCamera, NoFloorWhenOnlyAWallIsSeen) {
  PointCloud wall;
  for (double x = -1.5; x <= 1.5; x += 0.02) {
    for (double y = 0.5; y <= 2.0; y += 0.02) wall.emplace_back(x, y, 3.0);
  }
  const Pose T_true = TrueCamera();
  const GroundResult r = LevelCamera(Transform(T_true.inverse(), wall), T_true, GroundOptions{});
  EXPECT_FALSE(r.found);
  EXPECT_FALSE(r.accepted);
  EXPECT_FALSE(r.message.empty());
  EXPECT_TRUE(r.T_world_camera.isApprox(T_true));
}

TEST(LevelCamera, EmptyInputIsReportedNotThrown) {
  const GroundResult r = LevelCamera({}, Pose::Identity(), GroundOptions{});
  EXPECT_FALSE(r.found);
  EXPECT_FALSE(r.message.empty());
}

TEST(NearFloorBand, KeepsPointsBetweenBelowAndHeight) {
  const PointCloud pts = {Vec3(0, -0.06, 1), Vec3(0, -0.04, 1), Vec3(0, 0.29, 1), Vec3(0, 0.31, 1)};
  const PointCloud band = NearFloorBand(pts, Pose::Identity(), RegionOptions{});
  ASSERT_EQ(band.size(), 2u);
  EXPECT_EQ(band[0], pts[1]);
  EXPECT_EQ(band[1], pts[2]);
  RegionOptions whole;
  whole.band_height = 0.0;
  EXPECT_EQ(NearFloorBand(pts, Pose::Identity(), whole).size(), 4u);
}

TEST(CandidatePairs, InflatedBoxesAndMinimumArea) {
  GroundBox a{0, 1, 0, 1, false}, b{1.5, 2.5, 0, 1, false}, c{10, 11, 10, 11, false};
  // Gap of 0.5 m closes with margin 0.5 (each side inflated): overlap 0.5 x 2.0 = 1.0 m^2.
  EXPECT_NEAR(InflatedOverlapArea(a, b, 0.5), 0.5 * 2.0, 1e-12);
  const auto pairs = FindCandidatePairs({a, b, c}, 0.5, 1.0);
  ASSERT_EQ(pairs.size(), 1u);
  EXPECT_EQ(pairs[0].a, 0);
  EXPECT_EQ(pairs[0].b, 1);
  EXPECT_TRUE(FindCandidatePairs({a, b, c}, 0.5, 1.01).empty());
}

TEST(RobustGroundBox, IgnoresAFewStrayPoints) {
  PointCloud pts;
  for (int i = 0; i <= 1000; ++i) pts.emplace_back(i * 0.001, 0.0, -i * 0.002);
  pts.emplace_back(50.0, 0.0, 50.0);
  const GroundBox box = RobustGroundBox(pts);
  EXPECT_LT(box.max_x, 1.01);
  EXPECT_GT(box.min_z, -2.01);
}

}  // namespace
}  // namespace rigfit
