#include "residuals/gicp.h"

#include <Eigen/Cholesky>

#include "residuals/pose_jacobians.h"

namespace rigfit {

Mat3 GicpCost::SqrtInformation(const Mat3& cov_a, const Mat3& cov_b, const Mat3& R_world_a,
                               const Mat3& R_world_b, double epsilon_m2) {
  // S = R_a C_p R_a^T + R_b C_q R_b^T + eps I, symmetrised against rounding; L L^T = S^-1.
  Mat3 S = R_world_a * cov_a * R_world_a.transpose() + R_world_b * cov_b * R_world_b.transpose();
  S = 0.5 * (S + S.transpose()) + epsilon_m2 * Mat3::Identity();
  const Mat3 information = S.llt().solve(Mat3::Identity());
  return information.llt().matrixU();
}

void GicpTerm::Evaluate(const double* pose_a, const double* pose_b, double* residuals,
                        double* jacobian_a, double* jacobian_b) const {
  const Eigen::Map<const Eigen::Quaterniond> q_a(pose_a);
  const Eigen::Map<const Vec3> t_a(pose_a + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(pose_b);
  const Eigen::Map<const Vec3> t_b(pose_b + 4);

  // r = L^T ((R_a p + t_a) - (R_b q + t_b))
  const Vec3 d = (q_a * point_a + t_a) - (q_b * point_b + t_b);
  Eigen::Map<Vec3> r(residuals);
  r = sqrt_information * d;

  using Mat37 = Eigen::Matrix<double, 3, kPoseAmbientSize, Eigen::RowMajor>;
  if (jacobian_a != nullptr) {
    // dr/dq_a = L^T J_R(q_a, p), dr/dt_a = L^T
    Eigen::Map<Mat37> J(jacobian_a);
    J.leftCols<4>() = sqrt_information * RotatePointJacobian(q_a, point_a);
    J.rightCols<3>() = sqrt_information;
  }
  if (jacobian_b != nullptr) {
    // dr/dq_b = -L^T J_R(q_b, q), dr/dt_b = -L^T
    Eigen::Map<Mat37> J(jacobian_b);
    J.leftCols<4>() = -sqrt_information * RotatePointJacobian(q_b, point_b);
    J.rightCols<3>() = -sqrt_information;
  }
}

void GicpTerm::AddNormal(double weight2, double* normal) const {
  const double z[8] = {point_a(0),  point_a(1),  point_a(2),  1.0,
                       -point_b(0), -point_b(1), -point_b(2), -1.0};
  const Mat3 W = weight2 * sqrt_information.transpose() * sqrt_information;
  // Block (a, b) of (z z^T) (x) W is z_a z_b W; the lower triangle is blocks b <= a.
  for (int b = 0; b < 8; ++b) {
    for (int a = b; a < 8; ++a) {
      const double zz = z[a] * z[b];
      for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) normal[(3 * b + j) * kFeatureSize + 3 * a + i] += zz * W(i, j);
      }
    }
  }
}

void GicpTerm::ResidualAt(const double* theta, double* residuals) const {
  // L^T (R_a p + t_a - R_b q - t_b), R x = sum_j x_j R e_j.
  const Eigen::Map<const Eigen::Matrix<double, kFeatureSize, 1>> f(theta);
  const Vec3 d = point_a(0) * f.segment<3>(0) + point_a(1) * f.segment<3>(3) +
                 point_a(2) * f.segment<3>(6) + f.segment<3>(9) - point_b(0) * f.segment<3>(12) -
                 point_b(1) * f.segment<3>(15) - point_b(2) * f.segment<3>(18) - f.segment<3>(21);
  Eigen::Map<Vec3> r(residuals);
  r = sqrt_information * d;
}

void GicpTerm::Features(const double* pose_a, const double* pose_b, double* theta, double* dtheta_a,
                        double* dtheta_b) {
  Eigen::Map<Eigen::Matrix<double, kFeatureSize, 1>> f(theta);
  using Mat = Eigen::Matrix<double, kFeatureSize, kPoseAmbientSize, Eigen::RowMajor>;
  // The features of one pose block x = [q; t] at `offset`: [vec(R(q)); t], and their
  // derivative d(R(q) e_j)/dq = J_R(q, e_j), dt/dt = I.
  const auto pose_features = [&](const double* pose, int offset, double* dtheta) {
    const Eigen::Map<const Eigen::Quaterniond> q(pose);
    for (int j = 0; j < 3; ++j) f.segment<3>(offset + 3 * j) = q * Vec3::Unit(j);
    f.segment<3>(offset + 9) = Eigen::Map<const Vec3>(pose + 4);
    if (dtheta == nullptr) return;
    Eigen::Map<Mat> J(dtheta);
    J.setZero();
    for (int j = 0; j < 3; ++j)
      J.block<3, 4>(offset + 3 * j, 0) = RotatePointJacobian(q, Vec3::Unit(j));
    J.block<3, 3>(offset + 9, 4) = Mat3::Identity();
  };
  pose_features(pose_a, 0, dtheta_a);
  pose_features(pose_b, 12, dtheta_b);
}

}  // namespace rigfit
