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

}  // namespace rigfit
