#include "residuals/pose_prior.h"

#include "residuals/pose_jacobians.h"

namespace rigfit {

PosePriorCost::PosePriorCost(const Pose& T0, const Mat6& sqrt_information)
    : q0_(Eigen::Quaterniond(T0.linear()).normalized()),
      t0_(T0.translation()),
      sqrt_information_(sqrt_information) {}

bool PosePriorCost::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0]);
  const Eigen::Map<const Vec3> t(parameters[0] + 4);
  const Eigen::Quaterniond q0_conj = q0_.conjugate();
  const Eigen::Quaterniond dq = q * q0_conj;
  const double s = dq.w() < 0.0 ? -1.0 : 1.0;
  Vec6 e;
  e.head<3>() = 2.0 * s * dq.vec();
  e.tail<3>() = t - t0_;
  Eigen::Map<Vec6> r(residuals);
  r = sqrt_information_ * e;
  if (jacobians == nullptr || jacobians[0] == nullptr) return true;
  // dr/dx = W_rot de_rot/dq (quaternion columns) and W_t (translation columns).
  using Mat67 = Eigen::Matrix<double, 6, kPoseAmbientSize, Eigen::RowMajor>;
  Eigen::Map<Mat67> J(jacobians[0]);
  const Mat34 de_rot = 2.0 * s * QuaternionRightProduct(q0_conj).topRows<3>();
  J.leftCols<4>() = sqrt_information_.leftCols<3>() * de_rot;
  J.rightCols<3>() = sqrt_information_.rightCols<3>();
  return true;
}

}  // namespace rigfit
