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

void PointToPlaneTerm::AddNormal(double weight2, double* normal) const {
  double phi[kFeatureSize];
  for (int j = 0; j < 3; ++j) {
    for (int i = 0; i < 3; ++i) phi[3 * j + i] = normal_b(i) * point_a(j);
  }
  for (int i = 0; i < 3; ++i) phi[9 + i] = normal_b(i);
  phi[12] = -normal_b.dot(point_b);
  for (int col = 0; col < kFeatureSize; ++col) {
    const double w = weight2 * phi[col];
    for (int row = col; row < kFeatureSize; ++row) normal[col * kFeatureSize + row] += w * phi[row];
  }
}

void PointToPlaneTerm::ResidualAt(const double* theta, double* residual) const {
  // n^T (R p + t - q), R p = sum_j p_j R e_j.
  const Eigen::Map<const Eigen::Matrix<double, kFeatureSize, 1>> f(theta);
  const Vec3 moved = point_a(0) * f.segment<3>(0) + point_a(1) * f.segment<3>(3) +
                     point_a(2) * f.segment<3>(6) + f.segment<3>(9) - point_b;
  residual[0] = normal_b.dot(moved);
}

void PointToPlaneTerm::Features(const double* pose_a, const double* pose_b, double* theta,
                                double* dtheta_a, double* dtheta_b) {
  const Eigen::Map<const Eigen::Quaterniond> q_a(pose_a);
  const Eigen::Map<const Vec3> t_a(pose_a + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(pose_b);
  const Eigen::Map<const Vec3> t_b(pose_b + 4);
  // R_b^T v = R(conj(q_b)) v for every q_b (pose_jacobians.h).
  const Eigen::Quaterniond q_b_inverse = q_b.conjugate();
  const Vec3 dt = t_a - t_b;
  Eigen::Map<Eigen::Matrix<double, kFeatureSize, 1>> f(theta);
  for (int j = 0; j < 3; ++j) f.segment<3>(3 * j) = q_b_inverse * (q_a * Vec3::Unit(j));
  f.segment<3>(9) = q_b_inverse * dt;
  f(12) = 1.0;

  using Mat = Eigen::Matrix<double, kFeatureSize, kPoseAmbientSize, Eigen::RowMajor>;
  const Mat3 R_b_transpose = q_b_inverse.toRotationMatrix();
  if (dtheta_a != nullptr) {
    // d(R_b^T R_a e_j)/dq_a = R_b^T J_R(q_a, e_j), dt/dt_a = R_b^T
    Eigen::Map<Mat> J(dtheta_a);
    J.setZero();
    for (int j = 0; j < 3; ++j) {
      J.block<3, 4>(3 * j, 0) = R_b_transpose * RotatePointJacobian(q_a, Vec3::Unit(j));
    }
    J.block<3, 3>(9, 4) = R_b_transpose;
  }
  if (dtheta_b != nullptr) {
    // d(R_b^T c)/dq_b = J_R^T(q_b, c) for c = R_a e_j and c = t_a - t_b, dt/dt_b = -R_b^T
    Eigen::Map<Mat> J(dtheta_b);
    J.setZero();
    for (int j = 0; j < 3; ++j) {
      J.block<3, 4>(3 * j, 0) = InverseRotatePointJacobian(q_b, q_a * Vec3::Unit(j));
    }
    J.block<3, 4>(9, 0) = InverseRotatePointJacobian(q_b, dt);
    J.block<3, 3>(9, 4) = -R_b_transpose;
  }
}

}  // namespace rigfit
