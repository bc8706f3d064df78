#include "residuals/point_to_plane.h"

#include "residuals/pose_jacobians.h"

namespace rigfit {

bool PointToPlaneCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q_a(parameters[0]);
  const Eigen::Map<const Vec3> t_a(parameters[0] + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(parameters[1]);
  const Eigen::Map<const Vec3> t_b(parameters[1] + 4);

  // d = (R_a p + t_a) - (R_b q + t_b), n_w = R_b n, r = n_w . d
  const Vec3 d = (q_a * point_a_ + t_a) - (q_b * point_b_ + t_b);
  const Vec3 n_w = q_b * normal_b_;
  residuals[0] = n_w.dot(d);
  if (jacobians == nullptr) return true;

  using Row7 = Eigen::Matrix<double, 1, kPoseAmbientSize>;
  if (jacobians[0] != nullptr) {
    // dr/dq_a = n_w^T J_R(q_a, p), dr/dt_a = n_w^T
    Eigen::Map<Row7> J(jacobians[0]);
    J.head<4>() = ProjectedRotatePointJacobian(q_a, point_a_, n_w);
    J.tail<3>() = n_w.transpose();
  }
  if (jacobians[1] != nullptr) {
    // dr/dq_b = d^T J_R(q_b, n) - n_w^T J_R(q_b, q), dr/dt_b = -n_w^T
    Eigen::Map<Row7> J(jacobians[1]);
    J.head<4>() = ProjectedRotatePointJacobian(q_b, normal_b_, d) -
                  ProjectedRotatePointJacobian(q_b, point_b_, n_w);
    J.tail<3>() = -n_w.transpose();
  }
  return true;
}

}  // namespace rigfit
