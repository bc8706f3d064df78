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

/// The autodiff reference of a stack: the templated functors of its terms, each scaled by
/// its weight, residuals concatenated in order.
template <class Functor, int kResiduals>
struct StackedFunctor {
  std::vector<Functor> items;
  std::vector<double> weights;

  template <typename T>
  bool operator()(T const* const* parameters, T* residuals) const {
    for (size_t i = 0; i < items.size(); ++i) {
      items[i](parameters[0], parameters[1], residuals);
      for (int k = 0; k < kResiduals; ++k) residuals[k] *= T(weights[i]);
      residuals += kResiduals;
    }
    return true;
  }
};

/// A stack of terms with random geometry (from make(rng): the term and its functor) and
/// random weights, and its autodiff reference.
template <class Term, class Functor, class Make>
void ExpectStackMatchesItsTerms(Make make) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> weight(0.1, 3.0);
  for (const auto& [a, b] : TestPosePairs()) {
    constexpr int kTerms = 5;
    StackedCost<Term> analytic;
    auto* functor = new StackedFunctor<Functor, Term::kNumResiduals>;
    for (int i = 0; i < kTerms; ++i) {
      const auto [term, item] = make(rng, a.T, b.T);
      const double w = weight(rng);
      analytic.Add(term, w);
      functor->items.push_back(item);
      functor->weights.push_back(w);
    }
    ceres::DynamicAutoDiffCostFunction<StackedFunctor<Functor, Term::kNumResiduals>, 4> autodiff(
        functor);
    autodiff.AddParameterBlock(kPoseAmbientSize);
    autodiff.AddParameterBlock(kPoseAmbientSize);
    autodiff.SetNumResiduals(kTerms * Term::kNumResiduals);
    ASSERT_EQ(analytic.size(), static_cast<size_t>(kTerms));
    ASSERT_EQ(analytic.num_residuals(), kTerms * Term::kNumResiduals);
    ExpectProvenAt(analytic, autodiff, a, b);
  }
}

TEST(StackedCost, PointToPlaneEqualsTheWeightedTermsAndPassesTheGradientCheck) {
  ExpectStackMatchesItsTerms<PointToPlaneTerm, PointToPlaneFunctor>(
      [](std::mt19937& rng, const Pose&, const Pose&) {
        const Vec3 p = RandomVector(rng, 3.0), q = RandomVector(rng, 3.0);
        const Vec3 n = RandomVector(rng, 1.0).normalized();
        return std::make_pair(PointToPlaneTerm{p, q, n}, PointToPlaneFunctor{p, q, n});
      });
}

TEST(StackedCost, GicpEqualsTheWeightedTermsAndPassesTheGradientCheck) {
  ExpectStackMatchesItsTerms<GicpTerm, GicpFunctor>(
      [](std::mt19937& rng, const Pose& T_a, const Pose& T_b) {
        const Vec3 p = RandomVector(rng, 3.0), q = RandomVector(rng, 3.0);
        const Vec3 axis = RandomVector(rng, 1.0).normalized();
        const Mat3 C = Mat3::Identity() - 0.999 * axis * axis.transpose();
        const GicpTerm term = GicpCost::MakeTerm(p, q, C, C, T_a.linear(), T_b.linear());
        return std::make_pair(term, GicpFunctor{p, q, term.sqrt_information});
      });
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
