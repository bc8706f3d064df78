#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residuals/camera_planes.h"
#include "residuals/plane_cluster.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::ExpectAnalyticMatchesAutodiff;
using testing::ExpectGradientCheckPasses;
using testing::TestPoses;
using testing::ToBlock;

constexpr int kPlanes = 3;

/// Planes [n; d] that camera T sees 2-3 m ahead, tilted at random.
std::vector<Vec4> PlanesInFrontOf(const Pose& T, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-0.5, 0.5);
  std::vector<Vec4> planes;
  for (int j = 0; j < kPlanes; ++j) {
    const Vec3 forward = T.linear().col(2);
    const Vec3 n = (-forward + Vec3(u(rng), u(rng), u(rng))).normalized();
    const Vec3 x = T.translation() + (2.0 + 0.5 * j) * forward;
    planes.push_back(Vec4(n.x(), n.y(), n.z(), -n.dot(x)));
  }
  return planes;
}

/// A random symmetric positive semi-definite (4 P) x (4 P) moment with coupled planes.
Eigen::MatrixXd RandomMoment(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Eigen::MatrixXd B(6 * kPlanes, 4 * kPlanes);
  for (int i = 0; i < B.size(); ++i) B.data()[i] = normal(rng);
  return B.transpose() * B;
}

TEST(CameraPlanes, SquareRootReproducesTheMoment) {
  std::mt19937 rng(1);
  const Eigen::MatrixXd M = RandomMoment(rng);
  const Eigen::MatrixXd L = CameraPlanesCost::SquareRoot(M);
  EXPECT_TRUE(testing::ScaledNear(L * L.transpose(), M, 1e-12));
}

TEST(CameraPlanes, AnalyticJacobianEqualsAutodiffAndFiniteDifferences) {
  std::mt19937 rng(4);
  const PoseManifold pose_manifold;
  const ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>>
      plane_manifold;
  ceres::NumericDiffOptions numeric;  // the pole at d_c = 0 (residuals_plane_cluster_test.cc)
  numeric.ridders_relative_initial_step_size = 1e-5;
  for (const testing::NamedPose& pose : TestPoses(20)) {
    const std::vector<Vec4> planes = PlanesInFrontOf(pose.T, rng);
    const Eigen::MatrixXd L = CameraPlanesCost::SquareRoot(RandomMoment(rng));
    for (const bool ray_model : {true, false}) {
      SCOPED_TRACE(pose.name + (ray_model ? " (ray model)" : " (points)"));
      const CameraPlanesCost analytic(L, ray_model);
      const std::unique_ptr<ceres::CostFunction> autodiff(
          CameraPlanesFunctor::CreateAutoDiff(L, ray_model));
      const testing::PoseBlock x = ToBlock(pose.T);
      std::vector<const double*> parameters = {x.data()};
      std::vector<const ceres::Manifold*> manifolds = {&pose_manifold};
      for (const Vec4& plane : planes) {
        parameters.push_back(plane.data());
        manifolds.push_back(&plane_manifold);
      }
      ExpectAnalyticMatchesAutodiff(analytic, *autodiff, parameters);
      ExpectGradientCheckPasses(analytic, parameters, manifolds, numeric);
    }
  }
}

TEST(CameraPlanes, UncoupledPlanesEqualTheirClusters) {
  // A block-diagonal moment (independent pixels) gives the plane clusters' cost.
  std::mt19937 rng(6);
  std::normal_distribution<double> noise(0.0, 0.002);
  const Pose T = testing::MakePose(Vec3(0.2, -0.3, 0.1), Vec3(0.5, 1.4, -0.8));
  const std::vector<Vec4> planes = PlanesInFrontOf(T, rng);
  Eigen::MatrixXd M = Eigen::MatrixXd::Zero(4 * kPlanes, 4 * kPlanes);
  const testing::PoseBlock x = ToBlock(T);
  std::vector<const double*> parameters = {x.data()};
  double clusters = 0.0;
  std::uniform_real_distribution<double> u(-0.4, 0.4);
  for (int j = 0; j < kPlanes; ++j) {
    PlaneCluster cluster;
    const Vec3 n_c = T.linear().transpose() * planes[j].head<3>();
    const double d_c = planes[j].head<3>().dot(T.translation()) + planes[j](3);
    for (int i = 0; i < 200; ++i) {
      const Vec3 a(u(rng), u(rng), 1.0);
      const double z = -d_c / n_c.dot(a);
      cluster.AddRay(z * a, 1.0 / z + noise(rng), 0.0025);
    }
    M.block<4, 4>(4 * j, 4 * j) = cluster.Moment();
    const std::unique_ptr<ceres::CostFunction> cost(PlaneClusterCost::Create(cluster, true));
    const Vec4 moved = planes[j] + Vec4(0.0, 0.0, 0.0, 0.02);  // off the points: a cost
    const std::vector<const double*> blocks = {x.data(), moved.data()};
    Vec4 r;
    ASSERT_TRUE(cost->Evaluate(blocks.data(), r.data(), nullptr));
    clusters += r.squaredNorm();
  }
  std::vector<Vec4> moved = planes;
  for (Vec4& plane : moved) {
    plane(3) += 0.02;
    parameters.push_back(plane.data());
  }
  const CameraPlanesCost cost(CameraPlanesCost::SquareRoot(M), true);
  Eigen::VectorXd r(4 * kPlanes);
  ASSERT_TRUE(cost.Evaluate(parameters.data(), r.data(), nullptr));
  EXPECT_GT(clusters, 1.0);
  EXPECT_NEAR(r.squaredNorm() / clusters, 1.0, 1e-9);
}

}  // namespace
}  // namespace rigfit
