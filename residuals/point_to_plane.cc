#include "residuals/point_to_plane.h"

#include "residuals/pose_jacobians.h"

namespace rigfit {

void PointToPlaneTerm::Evaluate(const double* pose_a, const double* pose_b, double* residual,
                                double* jacobian_a, double* jacobian_b) const {
  const Eigen::Map<const Eigen::Quaterniond> q_a(pose_a);
  const Eigen::Map<const Vec3> t_a(pose_a + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(pose_b);
  const Eigen::Map<const Vec3> t_b(pose_b + 4);

  // d = (R_a p + t_a) - (R_b q + t_b), n_w = R_b n, r = n_w . d
  const Vec3 d = (q_a * point_a + t_a) - (q_b * point_b + t_b);
  const Vec3 n_w = q_b * normal_b;
  residual[0] = n_w.dot(d);

  using Row7 = Eigen::Matrix<double, 1, kPoseAmbientSize>;
  if (jacobian_a != nullptr) {
    // dr/dq_a = n_w^T J_R(q_a, p), dr/dt_a = n_w^T
    Eigen::Map<Row7> J(jacobian_a);
    J.head<4>() = ProjectedRotatePointJacobian(q_a, point_a, n_w);
    J.tail<3>() = n_w.transpose();
  }
  if (jacobian_b != nullptr) {
    // dr/dq_b = d^T J_R(q_b, n) - n_w^T J_R(q_b, q), dr/dt_b = -n_w^T
    Eigen::Map<Row7> J(jacobian_b);
    J.head<4>() = ProjectedRotatePointJacobian(q_b, normal_b, d) -
                  ProjectedRotatePointJacobian(q_b, point_b, n_w);
    J.tail<3>() = -n_w.transpose();
  }
}

}  // namespace rigfit
