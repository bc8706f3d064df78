// Prior on one pose (derivation: docs/residuals.md, "Pose prior"): the surface bundle holds a
// camera at its start along the directions its planes know less well than the start does.
//
// With the pose T_world_camera = (R(q), t) as the parameter block [qx, qy, qz, qw, tx, ty, tz]
// (core/pose.h) and the prior's pose (q0, t0):
//
//   dq = q conj(q0),  sign-fixed so that dq_w >= 0
//   e  = [2 vec(dq);  t - t0]          6 errors, [rotation; translation]
//   r  = W e,   W^T W = information (6 x 6, in the PoseManifold tangent)
//
// e is the PoseManifold tangent of T relative to T0 (world rotation vector to first order, world
// translation): R = Exp(phi) R0 with 2 vec(dq) = 2 sin(|phi|/2) phi/|phi|.
//
// Ambient Jacobians (P_R the quaternion right-product matrix of pose_jacobians.h, s the sign):
//   de_rot/dq = 2 s [P_R(conj(q0))]_vec,   de_t/dt = I,   de_rot/dt = de_t/dq = 0
// In the PoseManifold tangent, with dq = (v, w): de_rot/dw = s (w I - [v]_x), de_t/dd = I.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

/// The prior as a templated functor: the automatic-differentiation reference for PosePriorCost
/// (same residuals, same parameter block).
struct PosePriorFunctor {
  Eigen::Quaterniond q0;  ///< unit quaternion of the prior's rotation
  Vec3 t0;                ///< the prior's translation
  Mat6 sqrt_information;  ///< W, W^T W = information

  template <typename T>
  bool operator()(const T* pose, T* residual) const {
    const Eigen::Quaternion<T> q(pose[3], pose[0], pose[1], pose[2]);
    const Eigen::Quaternion<T> dq = q * q0.conjugate().cast<T>();
    const T sign = dq.w() < T(0) ? T(-1) : T(1);
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = T(2) * sign * dq.vec();
    for (int k = 0; k < 3; ++k) e(3 + k) = pose[4 + k] - T(t0(k));
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_information.cast<T>() * e;
    return true;
  }

  static ceres::CostFunction* CreateAutoDiff(const Pose& T0, const Mat6& sqrt_information) {
    return new ceres::AutoDiffCostFunction<PosePriorFunctor, 6, kPoseAmbientSize>(
        new PosePriorFunctor{Eigen::Quaterniond(T0.linear()).normalized(), T0.translation(),
                             sqrt_information});
  }
};

/// Analytic pose prior: 6 whitened residuals, parameter block T_world_camera.
class PosePriorCost final : public ceres::SizedCostFunction<6, kPoseAmbientSize> {
 public:
  /// T0: the prior's pose; sqrt_information: W with W^T W the information (zero rows for the
  /// directions it does not hold).
  PosePriorCost(const Pose& T0, const Mat6& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Quaterniond q0_;
  Vec3 t0_;
  Mat6 sqrt_information_;
};

}  // namespace rigfit
