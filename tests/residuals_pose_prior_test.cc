#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "residuals/pose_prior.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::RandomVector;
using testing::ToBlock;

constexpr double kTolerance = 1e-12;

/// A square root of an information, full rank or (as the surface bundle's weak-direction
/// prior) with zero rows for the directions it does not hold.
Mat6 RandomSqrtInformation(std::mt19937& rng, int zero_rows) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Mat6 W;
  for (int i = 0; i < 36; ++i) W(i) = 30.0 * uniform(rng);
  W.topRows(zero_rows).setZero();
  return W;
}

Vec6 Residual(const ceres::CostFunction& cost, const Pose& T) {
  const auto x = ToBlock(T);
  const double* parameters[] = {x.data()};
  Vec6 r;
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
  return r;
}

TEST(PosePrior, ProvenAgainstAutodiffAndGradientChecker) {
  std::mt19937 rng(1);
  for (const auto& pose : testing::TestPoses()) {
    SCOPED_TRACE(pose.name);
    for (const int zero_rows : {0, 4}) {
      // The prior 0.1 rad / 0.1 m away, so that the residual is not zero.
      Vec6 offset;
      offset << RandomVector(rng, 0.1), RandomVector(rng, 0.1);
      const Pose T0 = PosePlus(pose.T, offset);
      const Mat6 W = RandomSqrtInformation(rng, zero_rows);
      const PosePriorCost analytic(T0, W);
      const std::unique_ptr<ceres::CostFunction> autodiff(PosePriorFunctor::CreateAutoDiff(T0, W));
      auto x = ToBlock(pose.T);
      testing::ExpectAnalyticMatchesAutodiff(analytic, *autodiff, {x.data()});
      testing::ExpectGradientCheckPasses(analytic, {x.data()});
      // The same rotation with the other quaternion sign: the error's sign fix flips.
      x.head<4>() *= -1.0;
      testing::ExpectAnalyticMatchesAutodiff(analytic, *autodiff, {x.data()});
    }
  }
}

TEST(PosePrior, ErrorIsTheTangentDifferenceInWorldAxes) {
  std::mt19937 rng(2);
  for (int i = 0; i < 20; ++i) {
    const Pose T0 = testing::RandomPose(rng, 10.0);
    const PosePriorCost cost(T0, Mat6::Identity());
    EXPECT_LT(Residual(cost, T0).cwiseAbs().maxCoeff(), kTolerance);
    // Moving by d (world) gives e = [0; d]; rotating about the centre by w (world) gives
    // e = [2 sin(|w| / 2) w / |w|; 0].
    const Vec3 d = RandomVector(rng, 1.0);
    const Vec3 w = RandomVector(rng, 1.0);
    Vec6 expected;
    expected << Vec3::Zero(), d;
    EXPECT_TRUE(
        testing::ScaledNear(Residual(cost, PosePlus(T0, (Vec6() << Vec3::Zero(), d).finished())),
                            expected, kTolerance));
    expected << 2.0 * std::sin(0.5 * w.norm()) * w.normalized(), Vec3::Zero();
    EXPECT_TRUE(
        testing::ScaledNear(Residual(cost, PosePlus(T0, (Vec6() << w, Vec3::Zero()).finished())),
                            expected, kTolerance));
  }
}

}  // namespace
}  // namespace rigfit
