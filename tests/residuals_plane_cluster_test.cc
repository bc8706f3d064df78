#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residuals/plane_cluster.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::ExpectAnalyticMatchesAutodiff;
using testing::ExpectGradientCheckPasses;
using testing::TestPoses;
using testing::ToBlock;

/// Cluster and per-pixel sums agree to this, relative.
constexpr double kClusterTolerance = 1e-9;

/// A world plane that camera T sees in front of it: through a point 2.5 m ahead, with a normal
/// tilted towards the camera by a random amount.
struct WorldPlane {
  Vec3 n;
  double d;
};
WorldPlane PlaneInFrontOf(const Pose& T, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  const Vec3 forward = T.linear().col(2);
  const Vec3 n = (-forward + Vec3(u(rng), u(rng), u(rng))).normalized();
  const Vec3 x = T.translation() + 2.5 * forward;
  return {n, -n.dot(x)};
}

/// Camera-frame points of plane P seen from T: pixels on a grid of rays, intersected.
std::vector<Vec3> PointsOnPlane(const Pose& T, const WorldPlane& P, int count, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  const Vec3 n_c = T.linear().transpose() * P.n;
  const double d_c = P.n.dot(T.translation()) + P.d;
  std::vector<Vec3> points;
  while (static_cast<int>(points.size()) < count) {
    const Vec3 a(u(rng), u(rng), 1.0);
    const double z = -d_c / n_c.dot(a);
    if (z > 0.1) points.push_back(z * a);
  }
  return points;
}

TEST(PlaneCluster, ClusterEqualsThePerPixelSum) {
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  const Pose T = testing::MakePose(Vec3(0.3, -0.2, 0.5), Vec3(1.0, 2.0, -0.5));
  const WorldPlane P = PlaneInFrontOf(T, rng);
  // Evaluate away from the plane the points were drawn on: nonzero residuals.
  const WorldPlane Q{(P.n + Vec3(0.02, -0.01, 0.03)).normalized(), P.d + 0.05};
  for (const bool ray_model : {true, false}) {
    SCOPED_TRACE(ray_model);
    PlaneCluster cluster;
    double per_pixel = 0.0;
    const Vec3 n_c = T.linear().transpose() * Q.n;
    const double d_c = Q.n.dot(T.translation()) + Q.d;
    std::uniform_real_distribution<double> sigma(0.001, 0.004);
    for (const Vec3& p : PointsOnPlane(T, P, 500, rng)) {
      const double s = sigma(rng);
      if (ray_model) {
        const double w = 1.0 / p.z() + noise(rng);
        cluster.AddRay(p, w, s);
        const double h = -n_c.dot(p / p.z()) / d_c;  // predicted inverse depth
        per_pixel += (w - h) * (w - h) / (s * s);
      } else {
        cluster.AddPoint(p, s);
        const double r = n_c.dot(p) + d_c;
        per_pixel += r * r / (s * s);
      }
    }
    EXPECT_EQ(cluster.Count(), 500);
    const std::unique_ptr<ceres::CostFunction> cost(PlaneClusterCost::Create(cluster, ray_model));
    const testing::PoseBlock x = ToBlock(T);
    const Vec4 plane(Q.n.x(), Q.n.y(), Q.n.z(), Q.d);
    const std::vector<const double*> parameters = {x.data(), plane.data()};
    Vec4 r;
    ASSERT_TRUE(cost->Evaluate(parameters.data(), r.data(), nullptr));
    EXPECT_GT(per_pixel, 1.0);
    EXPECT_NEAR(r.squaredNorm() / per_pixel, 1.0, kClusterTolerance);
  }
}

TEST(PlaneCluster, AnalyticJacobianEqualsAutodiffAndFiniteDifferences) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.003);
  const PoseManifold pose_manifold;
  const ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>
      plane_manifold;
  // The ray model divides by d_c, the plane's distance to the camera (2.5 m here): Ridders'
  // first step of 1% of a 100 m translation would reach past the pole.
  ceres::NumericDiffOptions numeric;
  numeric.ridders_relative_initial_step_size = 1e-5;
  for (const testing::NamedPose& pose : TestPoses(30)) {
    const WorldPlane P = PlaneInFrontOf(pose.T, rng);
    // The plane being estimated: near the true one.
    const WorldPlane Q{(P.n + Vec3(0.01, 0.02, -0.01)).normalized(), P.d - 0.02};
    for (const bool ray_model : {true, false}) {
      SCOPED_TRACE(pose.name + (ray_model ? " (ray model)" : " (points)"));
      PlaneCluster cluster;
      for (const Vec3& p : PointsOnPlane(pose.T, P, 50, rng)) {
        if (ray_model) {
          cluster.AddRay(p, 1.0 / p.z() + noise(rng), 0.0025);
        } else {
          cluster.AddPoint(p + noise(rng) * Vec3::UnitZ(), 0.002);
        }
      }
      const std::unique_ptr<ceres::CostFunction> analytic(
          PlaneClusterCost::Create(cluster, ray_model));
      const std::unique_ptr<ceres::CostFunction> autodiff(
          PlaneClusterFunctor::CreateAutoDiff(cluster.SquareRoot(), ray_model));
      const testing::PoseBlock x = ToBlock(pose.T);
      const double offset = Q.d;
      const std::vector<const double*> parameters = {x.data(), Q.n.data(), &offset};
      ExpectAnalyticMatchesAutodiff(*analytic, *autodiff, parameters);
      ExpectGradientCheckPasses(*analytic, parameters, {&pose_manifold, &plane_manifold}, numeric);
    }
  }
}

TEST(PlaneCluster, ResidualVanishesOnThePlane) {
  std::mt19937 rng(9);
  const Pose T = testing::MakePose(Vec3(-0.4, 1.0, 0.2), Vec3(0.0, 1.5, 3.0));
  const WorldPlane P = PlaneInFrontOf(T, rng);
  PlaneCluster cluster;
  for (const Vec3& p : PointsOnPlane(T, P, 100, rng)) cluster.AddRay(p, 1.0 / p.z(), 0.0025);
  const std::unique_ptr<ceres::CostFunction> cost(PlaneClusterCost::Create(cluster, true));
  const testing::PoseBlock x = ToBlock(T);
  const Vec4 plane(P.n.x(), P.n.y(), P.n.z(), P.d);
  const std::vector<const double*> parameters = {x.data(), plane.data()};
  Vec4 r;
  ASSERT_TRUE(cost->Evaluate(parameters.data(), r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-6);
}

TEST(PlaneClusterDepth, AnalyticJacobianEqualsAutodiffAndFiniteDifferences) {
  std::mt19937 rng(6);
  std::normal_distribution<double> noise(0.0, 0.003);
  const PoseManifold pose_manifold;
  const ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>
      plane_manifold;
  ceres::NumericDiffOptions numeric;  // the pole at d_c = 0, as above
  numeric.ridders_relative_initial_step_size = 1e-5;
  // The model at rest, a 2 % scale with an offset of 0.3 px at f = 500 px and 0.12 m, and a
  // far one.
  const std::vector<Eigen::Vector2d> models = {{1.0, 0.0}, {1.02, -0.005}, {0.9, 0.05}};
  for (const testing::NamedPose& pose : TestPoses(30)) {
    const WorldPlane P = PlaneInFrontOf(pose.T, rng);
    // The plane being estimated: tilted from the true one, through a point 2.4 m ahead (a tilt
    // about the world origin would move it by metres at 100 m, up to the pole).
    const Vec3 n = (P.n + Vec3(0.01, 0.02, -0.01)).normalized();
    const Vec3 ahead = pose.T.translation() + 2.4 * pose.T.linear().col(2);
    const WorldPlane Q{n, -n.dot(ahead)};
    PlaneCluster cluster;
    for (const Vec3& p : PointsOnPlane(pose.T, P, 50, rng)) {
      cluster.AddRay(p, 1.0 / p.z() + noise(rng), 0.0025);
    }
    const std::unique_ptr<ceres::CostFunction> analytic(PlaneClusterDepthCost::Create(cluster));
    const std::unique_ptr<ceres::CostFunction> autodiff(
        PlaneClusterDepthFunctor::CreateAutoDiff(cluster.SquareRoot()));
    const testing::PoseBlock x = ToBlock(pose.T);
    const Vec4 plane(Q.n.x(), Q.n.y(), Q.n.z(), Q.d);
    for (const Eigen::Vector2d& model : models) {
      SCOPED_TRACE(pose.name + ", model " + std::to_string(model(0)) + " " +
                   std::to_string(model(1)));
      const std::vector<const double*> parameters = {x.data(), plane.data(), model.data()};
      ExpectAnalyticMatchesAutodiff(*analytic, *autodiff, parameters);
      ExpectGradientCheckPasses(*analytic, parameters, {&pose_manifold, &plane_manifold, nullptr},
                                numeric);
    }
  }
}

TEST(PlaneClusterDepth, EqualsTheClusterOfTheCorrectedInverseDepths) {
  // The model read into the residual equals the plain cluster of w' = alpha w + beta with
  // sigma alpha sigma_w, per pixel.
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0.0, 0.002);
  const Pose T = testing::MakePose(Vec3(0.2, 0.4, -0.1), Vec3(0.5, 1.2, -1.0));
  const WorldPlane P = PlaneInFrontOf(T, rng);
  const Eigen::Vector2d model(1.015, -0.004);
  PlaneCluster measured, corrected;
  for (const Vec3& p : PointsOnPlane(T, P, 200, rng)) {
    const double w = 1.0 / p.z() + noise(rng);
    measured.AddRay(p, w, 0.0025);
    corrected.AddRay(p, model(0) * w + model(1), model(0) * 0.0025);
  }
  const std::unique_ptr<ceres::CostFunction> with_model(PlaneClusterDepthCost::Create(measured));
  const std::unique_ptr<ceres::CostFunction> plain(PlaneClusterCost::Create(corrected, true));
  const testing::PoseBlock x = ToBlock(T);
  const Vec4 plane(P.n.x(), P.n.y(), P.n.z(), P.d + 0.03);
  const std::vector<const double*> with_parameters = {x.data(), plane.data(), model.data()};
  const std::vector<const double*> parameters = {x.data(), plane.data()};
  Vec4 r_model, r_plain;
  ASSERT_TRUE(with_model->Evaluate(with_parameters.data(), r_model.data(), nullptr));
  ASSERT_TRUE(plain->Evaluate(parameters.data(), r_plain.data(), nullptr));
  // The square roots differ by a rotation; the cost does not.
  EXPECT_NEAR(r_model.squaredNorm() / r_plain.squaredNorm(), 1.0, kClusterTolerance);
}

}  // namespace
}  // namespace rigfit
