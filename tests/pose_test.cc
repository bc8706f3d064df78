#include "core/pose.h"

#include <ceres/manifold_test_utils.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace rigfit {
namespace {

constexpr double kTolerance = 1e-9;

Pose RandomPose(std::mt19937& rng, double max_angle, double max_translation) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const Vec3 axis = Vec3(u(rng), u(rng), u(rng)).normalized();
  const double angle = max_angle * std::abs(u(rng));
  return PosePlus(
      Pose::Identity(),
      (Vec6() << angle * axis, max_translation * Vec3(u(rng), u(rng), u(rng))).finished());
}

TEST(Pose, ParametersRoundTrip) {
  std::mt19937 rng(1);
  for (int i = 0; i < 100; ++i) {
    const Pose T = RandomPose(rng, M_PI, 100.0);
    double x[kPoseAmbientSize];
    PoseToParameters(T, x);
    EXPECT_NEAR(Eigen::Map<Eigen::Vector4d>(x).norm(), 1.0, kTolerance);
    EXPECT_TRUE(PoseFromParameters(x).isApprox(T, kTolerance));
  }
}

TEST(Pose, TangentIsWorldRotationVectorAndTranslation) {
  std::mt19937 rng(2);
  const Pose T = RandomPose(rng, 1.0, 2.0).inverse();
  const double yaw = 0.3;
  Vec6 delta = Vec6::Zero();
  delta(1) = yaw;   // about world +Y
  delta(3) = 0.25;  // along world X
  const Pose T2 = PosePlus(T, delta);
  // The camera centre moves by exactly the translation part, the rotation is a yaw.
  EXPECT_TRUE(T2.translation().isApprox(T.translation() + Vec3(0.25, 0, 0), kTolerance));
  const Mat3 R_yaw = Eigen::AngleAxisd(yaw, Vec3::UnitY()).toRotationMatrix();
  EXPECT_TRUE(T2.linear().isApprox(R_yaw * T.linear(), kTolerance));
  EXPECT_TRUE(PoseDifference(T, T2).isApprox(delta, kTolerance));
}

TEST(Pose, LogExpRoundTripNearZeroAndNearPi) {
  for (double angle : {0.0, 1e-12, 1e-5, 0.5, 3.0, M_PI - 1e-7}) {
    const Vec3 w = angle * Vec3(1, -2, 0.5).normalized();
    EXPECT_TRUE(LogSO3(ExpSO3(w)).isApprox(w, 1e-9) || w.norm() < 1e-12)
        << "angle " << angle << " got " << LogSO3(ExpSO3(w)).transpose();
    EXPECT_TRUE(ExpSO3(w).isApprox(
        Eigen::AngleAxisd(angle, Vec3(1, -2, 0.5).normalized()).toRotationMatrix(), 1e-12));
  }
}

TEST(PoseManifold, InvariantsHold) {
  using namespace ceres;  // NOLINT: the invariants macro names ceres' matchers unqualified
  const PoseManifold manifold;
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    Eigen::Matrix<double, 7, 1> x, y;
    PoseToParameters(RandomPose(rng, M_PI, 100.0), x.data());
    PoseToParameters(RandomPose(rng, M_PI, 100.0), y.data());
    // Keep delta inside the injectivity radius (|w| < pi) of the rotation part.
    Eigen::Matrix<double, 6, 1> delta = PoseDifference(Pose::Identity(), RandomPose(rng, 3.0, 1.0));
    EXPECT_THAT_MANIFOLD_INVARIANTS_HOLD(manifold, x, delta, y, 1e-8);
  }
}

TEST(PoseManifold, PlusMatchesPosePlus) {
  const PoseManifold manifold;
  std::mt19937 rng(4);
  const Pose T = RandomPose(rng, 2.0, 5.0);
  const Vec6 delta = (Vec6() << 0.1, -0.2, 0.05, 1.0, 2.0, 3.0).finished();
  double x[7], x_plus[7];
  PoseToParameters(T, x);
  ASSERT_TRUE(manifold.Plus(x, delta.data(), x_plus));
  EXPECT_TRUE(PoseFromParameters(x_plus).isApprox(PosePlus(T, delta), kTolerance));
}

}  // namespace
}  // namespace rigfit
