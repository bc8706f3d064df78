#include <gtest/gtest.h>

#include <memory>
#include <random>
#include <vector>

#include "residuals/point_to_plane.h"
#include "residuals/relative_pose.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using testing::RandomVector;
using testing::TestPosePairs;
using testing::ToBlock;

constexpr double kTolerance = 1e-12;

Mat6 RandomInformation(std::mt19937& rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Mat6 A;
  for (int i = 0; i < 36; ++i) A(i) = uniform(rng);
  return 100.0 * (A * A.transpose() + 0.1 * Mat6::Identity());
}

/// A measurement 0.1 rad / 0.1 m away from T_a^-1 T_b, so that the error is not zero.
Pose NoisyMeasurement(std::mt19937& rng, const Pose& T_a, const Pose& T_b) {
  Vec6 noise;
  noise << RandomVector(rng, 0.1), RandomVector(rng, 0.1);
  return PosePlus(T_a.inverse() * T_b, noise);
}

Vec6 Residual(const ceres::CostFunction& cost, const Pose& T_a, const Pose& T_b) {
  const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
  const double* parameters[] = {x_a.data(), x_b.data()};
  Vec6 r;
  EXPECT_TRUE(cost.Evaluate(parameters, r.data(), nullptr));
  return r;
}

/// Tangent Jacobian [dr/ddelta_a, dr/ddelta_b] (rows x 12) through PoseManifold.
Eigen::MatrixXd TangentJacobian(const ceres::CostFunction& cost, const Pose& T_a, const Pose& T_b) {
  const PoseManifold manifold;
  const auto x_a = ToBlock(T_a), x_b = ToBlock(T_b);
  const auto eval = testing::Evaluate(cost, {x_a.data(), x_b.data()}, {true, true});
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P_a, P_b;
  manifold.PlusJacobian(x_a.data(), P_a.data());
  manifold.PlusJacobian(x_b.data(), P_b.data());
  Eigen::MatrixXd J(cost.num_residuals(), 12);
  J << eval.jacobians[0] * P_a, eval.jacobians[1] * P_b;
  return J;
}

TEST(RelativePose, ProvenAgainstAutodiffAndGradientChecker) {
  std::mt19937 rng(1);
  for (const auto& [a, b] : TestPosePairs()) {
    for (int k = 0; k < 2; ++k) {
      const Pose T_ab = NoisyMeasurement(rng, a.T, b.T);
      const Mat6 information = RandomInformation(rng);
      const std::unique_ptr<ceres::CostFunction> analytic(
          RelativePoseCost::Create(T_ab, information));
      const std::unique_ptr<ceres::CostFunction> autodiff(RelativePoseFunctor::CreateAutoDiff(
          T_ab, RelativePoseCost::SqrtInformation(information)));
      testing::ExpectProvenAt(*analytic, *autodiff, a, b);
      // The same rotations with the other quaternion sign (the error's sign fix flips).
      auto x_a = ToBlock(a.T), x_b = ToBlock(b.T);
      x_b.head<4>() *= -1.0;
      testing::ExpectAnalyticMatchesAutodiff(*analytic, *autodiff, {x_a.data(), x_b.data()});
    }
  }
}

TEST(RelativePose, ZeroAtTheMeasurementAndGaugeInvariant) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Pose T_a = testing::RandomPose(rng, 10.0), T_b = testing::RandomPose(rng, 10.0);
    const Mat6 information = RandomInformation(rng);
    const std::unique_ptr<ceres::CostFunction> exact(
        RelativePoseCost::Create(T_a.inverse() * T_b, information));
    const double scale = RelativePoseCost::SqrtInformation(information).cwiseAbs().maxCoeff();
    EXPECT_LT(Residual(*exact, T_a, T_b).cwiseAbs().maxCoeff(), kTolerance * 10.0 * scale);

    // A common change of world frame G leaves the (non-zero) residual unchanged.
    const std::unique_ptr<ceres::CostFunction> noisy(
        RelativePoseCost::Create(NoisyMeasurement(rng, T_a, T_b), information));
    const Pose G = testing::RandomPose(rng, 100.0);
    const Vec6 r = Residual(*noisy, T_a, T_b);
    ASSERT_GT(r.norm(), 0.1);
    EXPECT_TRUE(testing::ScaledNear(Residual(*noisy, G * T_a, G * T_b), r, 1e-9));
  }
}

TEST(RelativePose, ErrorIsTheTangentDifferenceInCameraAAxes) {
  std::mt19937 rng(4);
  for (int i = 0; i < 20; ++i) {
    const Pose T_a = testing::RandomPose(rng, 10.0), T_b = testing::RandomPose(rng, 10.0);
    const Mat3& R_a = T_a.linear();
    const std::unique_ptr<ceres::CostFunction> cost(
        RelativePoseCost::Create(T_a.inverse() * T_b, Mat6::Identity()));
    // Moving b by d (world) gives e = [0; R_a^T d].
    const Vec3 d = RandomVector(rng, 1.0);
    Vec6 expected;
    expected << Vec3::Zero(), R_a.transpose() * d;
    EXPECT_TRUE(testing::ScaledNear(
        Residual(*cost, T_a, PosePlus(T_b, (Vec6() << Vec3::Zero(), d).finished())), expected,
        kTolerance));
    // Rotating b about its centre by w (world) gives e = [2 sin(|w|/2) R_a^T w/|w|; 0].
    const Vec3 w = RandomVector(rng, 1.0);
    expected << 2.0 * std::sin(0.5 * w.norm()) * R_a.transpose() * w.normalized(), Vec3::Zero();
    EXPECT_TRUE(testing::ScaledNear(
        Residual(*cost, T_a, PosePlus(T_b, (Vec6() << w, Vec3::Zero()).finished())), expected,
        kTolerance));
  }
}

TEST(RelativePose, SqrtInformationOfFullAndRankDeficientInformation) {
  std::mt19937 rng(5);
  const Mat6 full = RandomInformation(rng);
  const Mat6 W = RelativePoseCost::SqrtInformation(full);
  EXPECT_TRUE(W.isUpperTriangular(0.0));
  EXPECT_TRUE(testing::ScaledNear(W.transpose() * W, full, kTolerance));

  // Rank 3 (an edge that only sees a floor constrains tilt and height), and a matrix
  // whose zero eigenvalues come out slightly negative after rounding.
  Eigen::Matrix<double, 6, 3> B;
  for (int i = 0; i < 18; ++i) B(i) = RandomVector(rng, 1.0).x();
  const Mat6 deficient = B * B.transpose();
  const Mat6 W_deficient = RelativePoseCost::SqrtInformation(deficient);
  ASSERT_TRUE(W_deficient.allFinite());
  EXPECT_TRUE(testing::ScaledNear(W_deficient.transpose() * W_deficient, deficient, kTolerance));
  EXPECT_TRUE(RelativePoseCost::SqrtInformation(Mat6::Zero()).isZero(0.0));
}

/// A plane n . X = offset of the world.
struct Plane {
  Vec3 normal;
  double offset = 0.0;
};

/// Point-to-plane correspondences between a and b with zero residual: 30 points on each
/// plane, near the origin.
std::vector<std::unique_ptr<ceres::CostFunction>> PlaneCorrespondences(
    std::mt19937& rng, const Pose& T_a, const Pose& T_b, const std::vector<Plane>& planes) {
  std::vector<std::unique_ptr<ceres::CostFunction>> costs;
  for (const Plane& plane : planes) {
    for (int i = 0; i < 30; ++i) {
      Vec3 X = RandomVector(rng, 3.0);
      X -= (plane.normal.dot(X) - plane.offset) * plane.normal;
      costs.emplace_back(PointToPlaneCost::Create(T_a.inverse() * X, T_b.inverse() * X,
                                                  T_b.linear().transpose() * plane.normal));
    }
  }
  return costs;
}

TEST(RelativePose, EdgeInformationReproducesThePointToPlaneHessian) {
  std::mt19937 rng(6);
  // Floor y = 0 with walls x = 3 and z = -3 (full rank), and the floor alone (rank 3).
  const std::vector<std::vector<Plane>> scenes = {
      {{Vec3::UnitY(), 0.0}, {Vec3::UnitX(), 3.0}, {Vec3::UnitZ(), -3.0}},
      {{Vec3::UnitY(), 0.0}},
  };
  for (const auto& planes : scenes) {
    for (int i = 0; i < 10; ++i) {
      const Pose T_a = testing::RandomPose(rng, 3.0), T_b = testing::RandomPose(rng, 3.0);
      // Gauss-Newton Hessian of the point-to-plane terms over both tangents (12 x 12),
      // and its block of pose b alone (a fixed).
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(12, 12);
      for (const auto& cost : PlaneCorrespondences(rng, T_a, T_b, planes)) {
        const Eigen::MatrixXd J = TangentJacobian(*cost, T_a, T_b);
        H += J.transpose() * J;
      }
      const Mat6 information =
          EdgeInformationFromTangentInformation(H.bottomRightCorner<6, 6>(), T_a);
      const std::unique_ptr<ceres::CostFunction> edge(
          RelativePoseCost::Create(T_a.inverse() * T_b, information));
      const Eigen::MatrixXd J_edge = TangentJacobian(*edge, T_a, T_b);
      // Both costs depend on T_a^-1 T_b only, so matching b's block matches all of it.
      EXPECT_TRUE(testing::ScaledNear(J_edge.transpose() * J_edge, H, 1e-9))
          << planes.size() << " planes";
    }
  }
}

}  // namespace
}  // namespace rigfit
