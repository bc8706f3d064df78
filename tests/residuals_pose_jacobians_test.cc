#include <ceres/jet.h>
#include <gtest/gtest.h>

#include <random>

#include "residuals/pose_jacobians.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using Jet4 = ceres::Jet<double, 4>;
using testing::RandomVector;

constexpr double kTolerance = 1e-12;

/// q as a Jet quaternion with derivative seeds in parameter order (qx, qy, qz, qw).
Eigen::Quaternion<Jet4> Seeded(const Eigen::Quaterniond& q) {
  return {Jet4(q.w(), 3), Jet4(q.x(), 0), Jet4(q.y(), 1), Jet4(q.z(), 2)};
}

Mat34 JacobianOf(const Eigen::Matrix<Jet4, 3, 1>& v) {
  Mat34 J;
  for (int i = 0; i < 3; ++i) J.row(i) = v(i).v.transpose();
  return J;
}

/// Unit quaternions from TestPoses, and the same scaled off the unit sphere (the formulas
/// differentiate the polynomial (R), which must hold for any q).
std::vector<Eigen::Quaterniond> TestQuaternions() {
  std::vector<Eigen::Quaterniond> quaternions;
  for (const auto& pose : testing::TestPoses(20)) {
    const Eigen::Quaterniond q(pose.T.linear());
    quaternions.push_back(q);
    quaternions.emplace_back(1.3 * q.coeffs());
  }
  return quaternions;
}

TEST(PoseJacobians, RotatePointJacobiansMatchAutodiffOfEigenRotation) {
  std::mt19937 rng(1);
  for (const Eigen::Quaterniond& q : TestQuaternions()) {
    const Vec3 v = RandomVector(rng, 5.0), a = RandomVector(rng, 1.0);
    const Eigen::Matrix<Jet4, 3, 1> v_jet = v.cast<Jet4>();
    const Mat34 J = RotatePointJacobian(q, v);
    EXPECT_TRUE(testing::ScaledNear(J, JacobianOf(Seeded(q) * v_jet), kTolerance));
    EXPECT_TRUE(testing::ScaledNear(InverseRotatePointJacobian(q, v),
                                    JacobianOf(Seeded(q).conjugate() * v_jet), kTolerance));
    EXPECT_TRUE(
        testing::ScaledNear(ProjectedRotatePointJacobian(q, v, a), a.transpose() * J, kTolerance));
    // Eigen's q * v and toRotationMatrix are one polynomial; R(q)^T = R(conj(q)) for any q.
    EXPECT_TRUE(testing::ScaledNear(q * v, q.toRotationMatrix() * v, kTolerance));
    EXPECT_TRUE(
        testing::ScaledNear(q.conjugate() * v, q.toRotationMatrix().transpose() * v, kTolerance));
  }
}

TEST(PoseJacobians, TangentJacobianIsMinusHatOfTheRotatedPoint) {
  // Through PoseManifold, d(R v)/dw = -[R v]_x (left perturbation Exp(w) R v).
  std::mt19937 rng(2);
  const PoseManifold manifold;
  for (const auto& pose : testing::TestPoses(20)) {
    const auto x = testing::ToBlock(pose.T);
    Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
    manifold.PlusJacobian(x.data(), P.data());
    const Eigen::Map<const Eigen::Quaterniond> q(x.data());
    const Vec3 v = RandomVector(rng, 5.0);
    EXPECT_TRUE(testing::ScaledNear(RotatePointJacobian(q, v) * P.topLeftCorner<4, 3>(),
                                    -Hat(pose.T.linear() * v), kTolerance));
    EXPECT_TRUE(testing::ScaledNear(InverseRotatePointJacobian(q, v) * P.topLeftCorner<4, 3>(),
                                    pose.T.linear().transpose() * Hat(v), kTolerance));
  }
}

TEST(PoseJacobians, ProductMatricesMatchEigenQuaternionProduct) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);  // not unit: products are bilinear
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond p(
        Eigen::Vector4d(uniform(rng), uniform(rng), uniform(rng), uniform(rng)));
    const Eigen::Quaterniond q(
        Eigen::Vector4d(uniform(rng), uniform(rng), uniform(rng), uniform(rng)));
    const Eigen::Vector4d pq = (p * q).coeffs();  // (x, y, z, w)
    EXPECT_TRUE(testing::ScaledNear(QuaternionLeftProduct(p) * q.coeffs(), pq, kTolerance));
    EXPECT_TRUE(testing::ScaledNear(QuaternionRightProduct(q) * p.coeffs(), pq, kTolerance));
  }
}

}  // namespace
}  // namespace rigfit
