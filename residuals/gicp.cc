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

bool GicpCost::Evaluate(double const* const* parameters, double* residuals,
                        double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q_a(parameters[0]);
  const Eigen::Map<const Vec3> t_a(parameters[0] + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(parameters[1]);
  const Eigen::Map<const Vec3> t_b(parameters[1] + 4);

  // r = L^T ((R_a p + t_a) - (R_b q + t_b))
  const Vec3 d = (q_a * point_a_ + t_a) - (q_b * point_b_ + t_b);
  Eigen::Map<Vec3> r(residuals);
  r = sqrt_information_ * d;
  if (jacobians == nullptr) return true;

  using Mat37 = Eigen::Matrix<double, 3, kPoseAmbientSize, Eigen::RowMajor>;
  if (jacobians[0] != nullptr) {
    // dr/dq_a = L^T J_R(q_a, p), dr/dt_a = L^T
    Eigen::Map<Mat37> J(jacobians[0]);
    J.leftCols<4>() = sqrt_information_ * RotatePointJacobian(q_a, point_a_);
    J.rightCols<3>() = sqrt_information_;
  }
  if (jacobians[1] != nullptr) {
    // dr/dq_b = -L^T J_R(q_b, q), dr/dt_b = -L^T
    Eigen::Map<Mat37> J(jacobians[1]);
    J.leftCols<4>() = -sqrt_information_ * RotatePointJacobian(q_b, point_b_);
    J.rightCols<3>() = -sqrt_information_;
  }
  return true;
}

}  // namespace rigfit
