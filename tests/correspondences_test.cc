#include "prepare/correspondences.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "core/pose.h"

namespace rigfit {
namespace {

/// A one-point level at depth z (camera frame, on the optical axis) whose normal is turned
/// by angle_deg about the camera's x axis from facing the camera.
ScaleLevel OnePointLevel(double z, double angle_deg) {
  ScaleLevel level;
  level.voxel_size = 0.02;
  level.normal_support = 0.05;
  level.points = {Vec3(0.0, 0.0, z)};
  level.tree = std::make_unique<KdTree>(level.points);
  const double a = angle_deg * kDegToRad;
  level.geometry.normals = {Vec3(0.0, std::sin(a), -std::cos(a))};
  level.geometry.covariances = {Mat3::Identity()};
  level.geometry.planarity = {1.0};
  return level;
}

/// Whether a source point and a target point at the same place (same pose, depth z), their
/// normals angle_deg apart, pair up under the 30-degree check with depth noise k.
bool Pairs(double z, double angle_deg, double k) {
  const ScaleLevel source = OnePointLevel(z, 0.0);
  const ScaleLevel target = OnePointLevel(z, angle_deg);
  const CameraView s{&source, Pose::Identity(), nullptr, k};
  const CameraView t{&target, Pose::Identity(), nullptr, k};
  return FindCorrespondences(s, t, 0.1, 30.0, 1).size() == 1;
}

TEST(FindCorrespondences, NoiseFreeNormalsMustAgreeWithinTheGivenAngle) {
  EXPECT_TRUE(Pairs(3.0, 28.0, 0.0));
  EXPECT_FALSE(Pairs(3.0, 32.0, 0.0));
}

TEST(FindCorrespondences, TheNormalCheckWidensWithTheDepthNoiseOfBothPoints) {
  // k z^2 = 0.0045 m over a 0.05 m support: atan(0.09) = 5.14 deg per point, 40.3 in all.
  EXPECT_TRUE(Pairs(3.0, 39.0, 0.0005));
  EXPECT_FALSE(Pairs(3.0, 42.0, 0.0005));
  // Nearer, less noise: 1.5 m gives 1.29 deg per point, 32.6 in all.
  EXPECT_TRUE(Pairs(1.5, 32.0, 0.0005));
  EXPECT_FALSE(Pairs(1.5, 34.0, 0.0005));
}

TEST(FindCorrespondences, NoNoiseWidensTheCheckBeyondSixtyDegrees) {
  // 2.3 cm of depth noise per point would add 48 deg; the check stops at 60 degrees, far
  // from the 90 degrees between the faces of a box corner.
  EXPECT_TRUE(Pairs(3.0, 58.0, 0.0025));
  EXPECT_FALSE(Pairs(3.0, 62.0, 0.0025));
  EXPECT_FALSE(Pairs(3.0, 90.0, 1.0));
}

TEST(StepConverged, CoarseScalesStopAtAFifthOfTheFinestScalesPrecision) {
  // At a 2 cm voxel the finest scale stops below 0.2 mm (and 0.2 mrad), a coarser one
  // below 1 mm (and 1 mrad).
  const auto step = [](double rotation_rad, double translation_m) {
    return (Vec6() << 0.0, rotation_rad, 0.0, translation_m, 0.0, 0.0).finished();
  };
  EXPECT_TRUE(StepConverged(step(0.0, 0.00015), 0.02, /*finest=*/true));
  EXPECT_FALSE(StepConverged(step(0.0, 0.00025), 0.02, /*finest=*/true));
  EXPECT_FALSE(StepConverged(step(0.00025, 0.0), 0.02, /*finest=*/true));
  EXPECT_TRUE(StepConverged(step(0.0009, 0.0009), 0.02, /*finest=*/false));
  EXPECT_FALSE(StepConverged(step(0.0, 0.0011), 0.02, /*finest=*/false));
  EXPECT_FALSE(StepConverged(step(0.0011, 0.0), 0.02, /*finest=*/false));
}

/// A level of the given points at the finest voxel (2 cm), every normal facing the camera.
ScaleLevel FacingLevel(const PointCloud& points) {
  ScaleLevel level;
  level.voxel_size = 0.02;
  level.normal_support = 0.05;
  level.points = points;
  level.tree = std::make_unique<KdTree>(level.points);
  level.geometry.normals.assign(points.size(), Vec3(0.0, 0.0, -1.0));
  level.geometry.covariances.assign(points.size(), Mat3::Identity());
  level.geometry.planarity.assign(points.size(), 1.0);
  return level;
}

TEST(MeasureOverlap, FitnessWithinTheCoarsestScalesDistanceRmseWithinTheViewsOwn) {
  // The target: a 2 cm grid on the wall z = 2. The source: points in front of grid points
  // at distances inside the finest scale's correspondence distance (1.4 x 2 cm), inside
  // only the coarsest one's (1.4 x 8 cm) and beyond both.
  PointCloud grid;
  for (int i = -10; i <= 10; ++i) {
    for (int j = -10; j <= 10; ++j) grid.emplace_back(0.02 * i, 0.02 * j, 2.0);
  }
  const std::vector<double> gaps = {0.01, 0.02, 0.05, 0.1, 0.2};
  PointCloud in_front;
  for (size_t i = 0; i < gaps.size(); ++i) in_front.emplace_back(0.04 * i, 0.0, 2.0 - gaps[i]);
  const ScaleLevel target = FacingLevel(grid);
  const ScaleLevel source = FacingLevel(in_front);
  const CameraView s{&source, Pose::Identity(), nullptr, 0.0};
  const CameraView t{&target, Pose::Identity(), nullptr, 0.0};
  const OverlapStats stats = MeasureOverlap(s, t, 0.08, IcpOptions(), 2);
  EXPECT_DOUBLE_EQ(stats.fitness, 4.0 / 5.0);
  EXPECT_NEAR(stats.rmse_m, std::sqrt((0.01 * 0.01 + 0.02 * 0.02) / 2.0), 1e-12);
  // The RMSE alone, from the narrower search, is the same.
  EXPECT_EQ(FitRmse(s, t, IcpOptions(), 2), stats.rmse_m);
  // No source point near the target: no fitness, no RMSE.
  const ScaleLevel far = FacingLevel({Vec3(0.0, 0.0, 1.0)});
  const CameraView f{&far, Pose::Identity(), nullptr, 0.0};
  EXPECT_EQ(MeasureOverlap(f, t, 0.08, IcpOptions(), 1).fitness, 0.0);
  EXPECT_EQ(MeasureOverlap(f, t, 0.08, IcpOptions(), 1).rmse_m, 0.0);
  EXPECT_EQ(FitRmse(f, t, IcpOptions(), 1), 0.0);
}

}  // namespace
}  // namespace rigfit
