#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "residuals/gravity_prior.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::RandomVector;
using testing::ToBlock;

constexpr double kTolerance = 1e-12;
constexpr double kWeight = 50.0;  // 1 / sigma_tilt, sigma_tilt = 0.02 rad

Eigen::Vector2d Residual(const ceres::CostFunction& cost, const Pose& T_world_camera) {
  const auto x = ToBlock(T_world_camera);
  const double* parameters[] = {x.data()};
  Eigen::Vector2d r;
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
  return r;
}

Mat3 Yaw(double angle) { return ExpSO3(angle * Vec3::UnitY()); }

TEST(GravityPrior, AnalyticMatchesAutodiff) {
  std::mt19937 rng(1);
  for (const auto& pose : testing::TestPoses()) {
    SCOPED_TRACE(pose.name);
    // Anchored at a random rotation, so that the residual is not zero.
    const Mat3 R_leveled = testing::RandomPose(rng, 0.0).linear();
    const std::unique_ptr<ceres::CostFunction> analytic(
        GravityPriorCost::Create(R_leveled, kWeight));
    const std::unique_ptr<ceres::CostFunction> autodiff(
        GravityPriorFunctor::CreateAutoDiff(R_leveled, kWeight));
    const auto x = ToBlock(pose.T);
    testing::ExpectAnalyticMatchesAutodiff(*analytic, *autodiff, {x.data()});
  }
}

TEST(GravityPrior, GradientCheckerPasses) {
  std::mt19937 rng(2);
  for (const auto& pose : testing::TestPoses()) {
    SCOPED_TRACE(pose.name);
    // Anchored at the test pose itself (zero residual) and at a random rotation.
    const Mat3 anchors[] = {pose.T.linear(), testing::RandomPose(rng, 0.0).linear()};
    for (const Mat3& R_leveled : anchors) {
      const std::unique_ptr<ceres::CostFunction> cost(GravityPriorCost::Create(R_leveled, kWeight));
      const auto x = ToBlock(pose.T);
      testing::ExpectGradientCheckPasses(*cost, {x.data()});
    }
  }
}

TEST(GravityPrior, ZeroForAnyYawAndTranslation) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Pose T_leveled = testing::RandomPose(rng, 5.0);
    const std::unique_ptr<ceres::CostFunction> cost(
        GravityPriorCost::Create(T_leveled.linear(), kWeight));
    for (const double yaw : {0.0, 1e-6, 0.3, -1.2, 2.5, M_PI}) {
      Pose T = T_leveled;
      T.linear() = Yaw(yaw) * T_leveled.linear();
      T.translation() = RandomVector(rng, 100.0);
      EXPECT_LT(Residual(*cost, T).norm(), kTolerance * kWeight) << "yaw " << yaw;
    }
  }
}

TEST(GravityPrior, InvariantToYawAndTranslationAtAnyTilt) {
  std::mt19937 rng(4);
  for (int i = 0; i < 50; ++i) {
    const Pose T_leveled = testing::RandomPose(rng, 5.0);
    const std::unique_ptr<ceres::CostFunction> cost(
        GravityPriorCost::Create(T_leveled.linear(), kWeight));
    // A tilted camera: its residual is not zero, and neither yaw nor translation change it.
    const Pose T_tilted = testing::MakePose(Vec3(0.05, 0.0, -0.03), Vec3::Zero()) * T_leveled;
    const Eigen::Vector2d r = Residual(*cost, T_tilted);
    ASSERT_GT(r.norm(), 1.0);
    for (const double yaw : {1e-6, 0.3, -1.2, 2.5, M_PI}) {
      Pose T = T_tilted;
      T.linear() = Yaw(yaw) * T_tilted.linear();
      T.translation() = RandomVector(rng, 100.0);
      EXPECT_TRUE(testing::ScaledNear(Residual(*cost, T), r, kTolerance)) << "yaw " << yaw;
    }
    // Translation alone leaves the residual bit-for-bit unchanged.
    Pose T_moved = T_tilted;
    T_moved.translation() += Vec3(100.0, -100.0, 100.0);
    EXPECT_EQ(Residual(*cost, T_moved), r);
  }
}

TEST(GravityPrior, GrowsWithTiltAsWeightTimesSine) {
  std::mt19937 rng(5);
  for (int i = 0; i < 20; ++i) {
    const Pose T_leveled = testing::RandomPose(rng, 5.0);
    const std::unique_ptr<ceres::CostFunction> cost(
        GravityPriorCost::Create(T_leveled.linear(), kWeight));
    // Tilt about a random horizontal world axis (pitch/roll mix).
    const Vec3 axis =
        Vec3(RandomVector(rng, 1.0).x(), 0.0, RandomVector(rng, 1.0).z()).normalized();
    double previous = 0.0;
    for (const double tilt : {1e-6, 1e-4, 0.01, 0.1, 0.5, 1.0, 1.5}) {
      Pose T = T_leveled;
      T.linear() = ExpSO3(tilt * axis) * T_leveled.linear();
      const double magnitude = Residual(*cost, T).norm();
      EXPECT_NEAR(magnitude, kWeight * std::sin(tilt), kTolerance * kWeight) << "tilt " << tilt;
      EXPECT_GT(magnitude, previous);
      previous = magnitude;
    }
  }
}

TEST(GravityPrior, TangentJacobianIsBlindToYawAndTranslation) {
  std::mt19937 rng(6);
  const PoseManifold manifold;
  for (int i = 0; i < 20; ++i) {
    const Pose T_leveled = testing::RandomPose(rng, 5.0);
    const GravityPriorCost cost(GravityPriorBasis(T_leveled.linear(), kWeight));
    const Pose T = testing::RandomPose(rng, 5.0);
    const auto x = ToBlock(T);
    const auto eval = testing::Evaluate(cost, {x.data()}, {true});
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
    manifold.PlusJacobian(x.data(), P.data());
    const Eigen::Matrix<double, 2, 6> J = eval.jacobians[0] * P;
    // dr/dw = weight [b1 b2]^T R^T [e_y]_x: zero yaw column (w_y) and zero dr/dd.
    Eigen::Matrix<double, 2, 6> expected = Eigen::Matrix<double, 2, 6>::Zero();
    expected.leftCols<3>() = GravityPriorBasis(T_leveled.linear(), kWeight) *
                             T.linear().transpose() * Hat(Vec3::UnitY());
    EXPECT_TRUE(testing::ScaledNear(J, expected, kTolerance));
    EXPECT_LT(J.col(1).norm(), kTolerance * kWeight);
  }
}

TEST(GravityPrior, BasisIsOrthonormalAndPerpendicularToUp) {
  std::mt19937 rng(7);
  for (int i = 0; i < 50; ++i) {
    const Mat3 R = testing::RandomPose(rng, 0.0).linear();
    const Mat23 B = GravityPriorBasis(R, 2.0);
    EXPECT_TRUE(
        testing::ScaledNear(B * B.transpose(), 4.0 * Eigen::Matrix2d::Identity(), kTolerance));
    EXPECT_LT((B * R.transpose() * Vec3::UnitY()).norm(), kTolerance);
  }
}

}  // namespace
}  // namespace rigfit
