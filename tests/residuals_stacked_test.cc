#include <ceres/dynamic_autodiff_cost_function.h>
#include <gtest/gtest.h>

#include <random>

#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"
#include "residuals/stacked_cost.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using namespace testing;  // NOLINT: the residual test helpers

/// The autodiff reference of a stack: the templated functors of its items, each scaled by
/// its weight, residuals concatenated in order.
struct StackedFunctor {
  std::vector<PointToPlaneFunctor> point_to_plane;
  std::vector<GicpFunctor> gicp;
  std::vector<double> weights;  ///< point-to-plane items first, then GICP ones

  template <typename T>
  bool operator()(T const* const* parameters, T* residuals) const {
    size_t item = 0;
    for (const PointToPlaneFunctor& f : point_to_plane) {
      f(parameters[0], parameters[1], residuals);
      residuals[0] *= T(weights[item++]);
      residuals += 1;
    }
    for (const GicpFunctor& f : gicp) {
      f(parameters[0], parameters[1], residuals);
      for (int i = 0; i < 3; ++i) residuals[i] *= T(weights[item]);
      ++item;
      residuals += 3;
    }
    return true;
  }
};

/// A stack of point-to-plane and GICP items with random geometry and weights, and its
/// autodiff reference.
struct Stack {
  std::unique_ptr<StackedCost> analytic;
  std::unique_ptr<ceres::CostFunction> autodiff;
};

Stack MakeStack(std::mt19937& rng, const Pose& T_a, const Pose& T_b) {
  std::uniform_real_distribution<double> weight(0.1, 3.0);
  auto* functor = new StackedFunctor;
  Stack stack;
  stack.analytic = std::make_unique<StackedCost>(std::vector<int32_t>{7, 7});
  for (int i = 0; i < 5; ++i) {
    const Vec3 p = RandomVector(rng, 3.0), q = RandomVector(rng, 3.0);
    const Vec3 n = RandomVector(rng, 1.0).normalized();
    const double w = weight(rng);
    stack.analytic->Add(PointToPlaneCost::Create(p, q, n), w);
    functor->point_to_plane.push_back({p, q, n});
    functor->weights.push_back(w);
  }
  for (int i = 0; i < 3; ++i) {
    const Vec3 p = RandomVector(rng, 3.0), q = RandomVector(rng, 3.0);
    const Vec3 axis = RandomVector(rng, 1.0).normalized();
    const Mat3 C = Mat3::Identity() - 0.999 * axis * axis.transpose();
    const double w = weight(rng);
    stack.analytic->Add(GicpCost::Create(p, q, C, C, T_a.linear(), T_b.linear()), w);
    functor->gicp.push_back({p, q, GicpCost::SqrtInformation(C, C, T_a.linear(), T_b.linear())});
    functor->weights.push_back(w);
  }
  // The weights were pushed in item order: point-to-plane first, GICP next, as evaluated.
  auto* autodiff = new ceres::DynamicAutoDiffCostFunction<StackedFunctor, 4>(functor);
  autodiff->AddParameterBlock(kPoseAmbientSize);
  autodiff->AddParameterBlock(kPoseAmbientSize);
  autodiff->SetNumResiduals(5 + 3 * 3);
  stack.autodiff.reset(autodiff);
  return stack;
}

TEST(StackedCost, EqualsTheWeightedItemsAndPassesTheGradientCheck) {
  std::mt19937 rng(3);
  for (const auto& [a, b] : TestPosePairs()) {
    const Stack stack = MakeStack(rng, a.T, b.T);
    ASSERT_EQ(stack.analytic->num_residuals(), 5 + 3 * 3);
    const PoseBlock x_a = ToBlock(a.T), x_b = ToBlock(b.T);
    const std::vector<const double*> parameters = {x_a.data(), x_b.data()};
    SCOPED_TRACE(a.name + " | " + b.name);
    ExpectAnalyticMatchesAutodiff(*stack.analytic, *stack.autodiff, parameters);
    ExpectGradientCheckPasses(*stack.analytic, parameters);
  }
}

TEST(StackedCost, RejectsAnItemWithOtherParameterBlocks) {
  StackedCost stack({7, 7});
  EXPECT_THROW(
      stack.Add(new ceres::DynamicAutoDiffCostFunction<StackedFunctor, 4>(new StackedFunctor), 1.0),
      std::invalid_argument);
  EXPECT_EQ(stack.size(), 0u);
}

TEST(RobustWeight, IsTheSquareRootOfTheLossDerivative) {
  const double r_inlier[3] = {0.5, 0.0, 0.0};
  const double r_outlier[3] = {3.0, 4.0, 0.0};  // |r| = 5
  ceres::HuberLoss huber(2.0);
  EXPECT_DOUBLE_EQ(RobustWeight(&huber, r_inlier, 3), 1.0);
  // Huber: rho'(s) = a / sqrt(s) beyond a^2, so the weight is sqrt(2 / 5).
  EXPECT_NEAR(RobustWeight(&huber, r_outlier, 3), std::sqrt(2.0 / 5.0), 1e-15);
  EXPECT_DOUBLE_EQ(RobustWeight(nullptr, r_outlier, 3), 1.0);
}

}  // namespace
}  // namespace rigfit
