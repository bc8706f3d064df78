#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residuals/gicp.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::RandomVector;
using testing::TestPosePairs;
using testing::ToBlock;

constexpr double kTolerance = 1e-12;

/// A random surface-like covariance in m^2: a flat ellipsoid (5 cm x 3 cm x 2 mm) with a
/// random orientation.
Mat3 RandomCovariance(std::mt19937& rng) {
  const Mat3 V = testing::RandomPose(rng, 0.0).linear();
  return V * Vec3(25e-4, 9e-4, 4e-6).asDiagonal() * V.transpose();
}

struct Correspondence {
  Vec3 point_a, point_b;
  Mat3 cov_a, cov_b;
};

Correspondence RandomCorrespondence(std::mt19937& rng, const Pose& T_world_a,
                                    const Pose& T_world_b) {
  const Vec3 X = T_world_a.translation() + RandomVector(rng, 3.0);
  return {T_world_a.inverse() * X, T_world_b.inverse() * (X + RandomVector(rng, 0.05)),
          RandomCovariance(rng), RandomCovariance(rng)};
}

/// Analytic cost and autodiff reference with the weight fixed at (T_world_a, T_world_b).
struct Costs {
  std::unique_ptr<ceres::CostFunction> analytic, autodiff;
};

Costs MakeCosts(const Correspondence& c, const Pose& T_a, const Pose& T_b) {
  const Mat3 W = GicpCost::SqrtInformation(c.cov_a, c.cov_b, T_a.linear(), T_b.linear());
  return {
      std::unique_ptr<ceres::CostFunction>(
          GicpCost::Create(c.point_a, c.point_b, c.cov_a, c.cov_b, T_a.linear(), T_b.linear())),
      std::unique_ptr<ceres::CostFunction>(GicpFunctor::CreateAutoDiff(c.point_a, c.point_b, W))};
}

TEST(Gicp, ProvenAgainstAutodiffAndGradientChecker) {
  std::mt19937 rng(1);
  for (const auto& [a, b] : TestPosePairs()) {
    for (int k = 0; k < 2; ++k) {
      const Costs costs = MakeCosts(RandomCorrespondence(rng, a.T, b.T), a.T, b.T);
      testing::ExpectProvenAt(*costs.analytic, *costs.autodiff, a, b);
    }
  }
}

TEST(Gicp, SquaredResidualIsTheMahalanobisDistance) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Pose T_a = testing::RandomPose(rng, 5.0), T_b = testing::RandomPose(rng, 5.0);
    const Correspondence c = RandomCorrespondence(rng, T_a, T_b);
    const Mat3 W = GicpCost::SqrtInformation(c.cov_a, c.cov_b, T_a.linear(), T_b.linear());
    // W is upper triangular and W^T W = (R_a C_p R_a^T + R_b C_q R_b^T + eps I)^-1.
    EXPECT_TRUE(W.isUpperTriangular(0.0));
    const Mat3 S = T_a.linear() * c.cov_a * T_a.linear().transpose() +
                   T_b.linear() * c.cov_b * T_b.linear().transpose() +
                   kGicpCovarianceEpsilon * Mat3::Identity();
    EXPECT_TRUE(testing::ScaledNear(W.transpose() * W * S, Mat3::Identity(), 1e-9));

    const GicpCost cost(c.point_a, c.point_b, W);
    const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const double* parameters[] = {x_a.data(), x_b.data()};
    Vec3 r;
    ASSERT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
    const Vec3 d = T_a * c.point_a - T_b * c.point_b;
    EXPECT_NEAR(r.squaredNorm(), d.dot(S.inverse() * d), 1e-9 * r.squaredNorm());
  }
}

TEST(Gicp, ZeroAtGroundTruth) {
  std::mt19937 rng(4);
  for (int i = 0; i < 50; ++i) {
    const Pose T_a = testing::RandomPose(rng, 5.0), T_b = testing::RandomPose(rng, 5.0);
    const Vec3 X = RandomVector(rng, 3.0);
    const std::unique_ptr<ceres::CostFunction> cost(
        GicpCost::Create(T_a.inverse() * X, T_b.inverse() * X, RandomCovariance(rng),
                         RandomCovariance(rng), T_a.linear(), T_b.linear()));
    const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const double* parameters[] = {x_a.data(), x_b.data()};
    Vec3 r;
    ASSERT_TRUE(cost->Evaluate(parameters, r.data(), nullptr));
    // Whitened by at most 1/sqrt(eps) = 1000 per metre: 1e-9 here is 1e-12 m.
    EXPECT_LT(r.cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(Gicp, EpsilonKeepsCoplanarCovariancesInvertible) {
  // Both points on planes with the same normal (world +Y) and no thickness: the summed
  // covariance is singular along y, and eps alone sets the weight there.
  const Mat3 flat = Vec3(1e-2, 0.0, 1e-2).asDiagonal();
  const Mat3 W = GicpCost::SqrtInformation(flat, flat, Mat3::Identity(), Mat3::Identity());
  ASSERT_TRUE(W.allFinite());
  const GicpCost cost(Vec3(0.0, 1e-3, 0.0), Vec3::Zero(), W);
  const auto x = ToBlock(Pose::Identity());
  const double* parameters[] = {x.data(), x.data()};
  Vec3 r;
  ASSERT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
  // 1 mm along the normal, whitened by 1 / sqrt(eps) = 1 / (1 mm).
  EXPECT_NEAR(r.norm(), 1e-3 / std::sqrt(kGicpCovarianceEpsilon), kTolerance * 1e3);
  // Along the plane the offset is weighted by the covariances: 1 cm against sqrt(2e-2 + eps).
  const GicpCost along(Vec3(1e-2, 0.0, 0.0), Vec3::Zero(), W);
  ASSERT_TRUE(along.Evaluate(parameters, r.data(), nullptr));
  EXPECT_NEAR(r.norm(), 1e-2 / std::sqrt(2e-2 + kGicpCovarianceEpsilon), kTolerance);
}

}  // namespace
}  // namespace rigfit
