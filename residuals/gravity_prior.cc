#include "residuals/gravity_prior.h"

#include "residuals/pose_jacobians.h"

namespace rigfit {

Mat23 GravityPriorBasis(const Mat3& R_world_camera_leveled, double weight) {
  const Vec3 u0 = (R_world_camera_leveled.transpose() * Vec3::UnitY()).normalized();
  // b1 = u0 x e_k with e_k the axis least aligned with u0 (|u0 x e_k| >= sqrt(2/3)),
  // b2 = u0 x b1: {b1, b2, u0} is orthonormal.
  Eigen::Index k = 0;
  u0.cwiseAbs().minCoeff(&k);
  const Vec3 b1 = u0.cross(Vec3::Unit(k)).normalized();
  const Vec3 b2 = u0.cross(b1);
  Mat23 basis;
  basis.row(0) = weight * b1.transpose();
  basis.row(1) = weight * b2.transpose();
  return basis;
}

bool GravityPriorCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0]);

  // r = weight [b1 b2]^T R^T e_y
  Eigen::Map<Eigen::Vector2d> r(residuals);
  r = weighted_basis_ * (q.conjugate() * Vec3::UnitY());
  if (jacobians == nullptr || jacobians[0] == nullptr) return true;

  // dr/dq = weight [b1 b2]^T J_RT(q, e_y), dr/dt = 0
  Eigen::Map<Eigen::Matrix<double, 2, kPoseAmbientSize, Eigen::RowMajor>> J(jacobians[0]);
  J.leftCols<4>() = weighted_basis_ * InverseRotatePointJacobian(q, Vec3::UnitY());
  J.rightCols<3>().setZero();
  return true;
}

}  // namespace rigfit
