#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residuals/point_to_plane.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::RandomVector;
using testing::TestPosePairs;
using testing::ToBlock;

constexpr double kTolerance = 1e-12;

/// A correspondence near camera a: a world point within 3 m of a, seen by b 5 cm away,
/// with a random normal, so that residual and every Jacobian term are non-zero.
struct Correspondence {
  Vec3 point_a, point_b, normal_b;
};

Correspondence RandomCorrespondence(std::mt19937& rng, const Pose& T_world_a,
                                    const Pose& T_world_b) {
  const Vec3 X = T_world_a.translation() + RandomVector(rng, 3.0);
  return {T_world_a.inverse() * X, T_world_b.inverse() * (X + RandomVector(rng, 0.05)),
          RandomVector(rng, 1.0).normalized()};
}

TEST(PointToPlane, ProvenAgainstAutodiffAndGradientChecker) {
  std::mt19937 rng(1);
  for (const auto& [a, b] : TestPosePairs()) {
    for (int k = 0; k < 2; ++k) {
      const Correspondence c = RandomCorrespondence(rng, a.T, b.T);
      const std::unique_ptr<ceres::CostFunction> analytic(
          PointToPlaneCost::Create(c.point_a, c.point_b, c.normal_b));
      const std::unique_ptr<ceres::CostFunction> autodiff(
          PointToPlaneFunctor::CreateAutoDiff(c.point_a, c.point_b, c.normal_b));
      testing::ExpectProvenAt(*analytic, *autodiff, a, b);
    }
  }
}

TEST(PointToPlane, TangentJacobiansMatchDocumentedFormulas) {
  std::mt19937 rng(3);
  const PoseManifold manifold;
  for (int i = 0; i < 20; ++i) {
    const Pose T_a = testing::RandomPose(rng, 5.0), T_b = testing::RandomPose(rng, 5.0);
    const Correspondence c = RandomCorrespondence(rng, T_a, T_b);
    const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const PointToPlaneCost cost(c.point_a, c.point_b, c.normal_b);
    const auto eval = testing::Evaluate(cost, {x_a.data(), x_b.data()}, {true, true});
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P_a, P_b;
    manifold.PlusJacobian(x_a.data(), P_a.data());
    manifold.PlusJacobian(x_b.data(), P_b.data());
    // dr/dw_a = (R_a p x n_w)^T, dr/dw_b = (n_w x (t_a + R_a p - t_b))^T, dr/dd = +-n_w^T
    const Vec3 n_w = T_b.linear() * c.normal_b;
    const Vec3 Rp = T_a.linear() * c.point_a;
    Eigen::Matrix<double, 1, 6> expected_a, expected_b;
    expected_a << Rp.cross(n_w).transpose(), n_w.transpose();
    expected_b << n_w.cross(T_a.translation() + Rp - T_b.translation()).transpose(),
        -n_w.transpose();
    EXPECT_TRUE(testing::ScaledNear(eval.jacobians[0] * P_a, expected_a, 1e-12));
    EXPECT_TRUE(testing::ScaledNear(eval.jacobians[1] * P_b, expected_b, 1e-12));
  }
}

TEST(PointToPlane, ZeroAtGroundTruthAndAlongThePlane) {
  std::mt19937 rng(4);
  for (int i = 0; i < 50; ++i) {
    const Pose T_a = testing::RandomPose(rng, 5.0), T_b = testing::RandomPose(rng, 5.0);
    const Vec3 X = RandomVector(rng, 3.0);
    const Vec3 n_w = RandomVector(rng, 1.0).normalized();
    // q lies on the plane through X with normal n_w, anywhere on it.
    const Vec3 slide = n_w.cross(RandomVector(rng, 1.0));
    const PointToPlaneCost cost(T_a.inverse() * X, T_b.inverse() * (X + slide),
                                T_b.linear().transpose() * n_w);
    const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const double* parameters[] = {x_a.data(), x_b.data()};
    double r = 1.0;
    ASSERT_TRUE(cost.Evaluate(parameters, &r, nullptr));
    EXPECT_NEAR(r, 0.0, kTolerance);
  }
}

TEST(PointToPlane, IsTheSignedDistanceToThePlaneOfB) {
  std::mt19937 rng(5);
  const Pose T_a = testing::RandomPose(rng, 5.0), T_b = testing::RandomPose(rng, 5.0);
  const Vec3 X = RandomVector(rng, 3.0);
  const Vec3 n_w = RandomVector(rng, 1.0).normalized();
  for (const double h : {-0.3, -0.01, 0.0, 0.02, 1.5}) {
    // p sits h above b's plane along its normal.
    const PointToPlaneCost cost(T_a.inverse() * (X + h * n_w), T_b.inverse() * X,
                                T_b.linear().transpose() * n_w);
    const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const double* parameters[] = {x_a.data(), x_b.data()};
    double r = 0.0;
    ASSERT_TRUE(cost.Evaluate(parameters, &r, nullptr));
    EXPECT_NEAR(r, h, kTolerance);
  }
}

}  // namespace
}  // namespace rigfit
