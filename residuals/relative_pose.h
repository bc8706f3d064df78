// Relative-pose edge of a pose graph (derivation: docs/residuals.md).
//
// The edge measures T_a_b = T_world_a^-1 T_world_b, the pose of camera b in camera a's
// frame (e.g. from pairwise ICP). With the poses T_world_a = (R_a, t_a), T_world_b =
// (R_b, t_b) as parameter blocks [qx, qy, qz, qw, tx, ty, tz] (core/pose.h), quaternions
// q_a, q_b, and the measurement (q_m, t_m):
//
//   R_ab = R_a^T R_b,  t_ab = R_a^T (t_b - t_a)          the estimated T_a_b
//   dq   = conj(q_a) q_b conj(q_m),  sign-fixed so that dq_w >= 0
//   e    = [2 vec(dq);  t_ab - t_m]                      6 errors, [rotation; translation]
//   r    = W e,   W^T W = information (6 x 6)
//
// e is rigfit's tangent difference (core/pose.h, PoseDifference) taken in camera a's
// frame: R_ab = Exp(phi) R_m with 2 vec(dq) = 2 sin(|phi|/2) phi/|phi| (= phi to first
// order), and t_ab = t_m + (t_ab - t_m). Both parts are expressed in the axes of camera a,
// and the information must be given in that frame and order
// (EdgeInformationFromTangentInformation converts an information in the PoseManifold
// tangent of camera b). e is invariant to a common change of world frame (gauge).
//
// Ambient Jacobians (P_L, P_R quaternion product matrices, J_RT from pose_jacobians.h,
// s = sign fix, C = diag(-1, -1, -1, 1) the conjugation):
//   de_rot/dq_a = 2 s [P_R(q_b conj(q_m)) C]_vec
//   de_rot/dq_b = 2 s [P_L(conj(q_a)) P_R(conj(q_m))]_vec
//   de_t/dq_a   = J_RT(q_a, t_b - t_a),   de_t/dt_a = -R_a^T,   de_t/dt_b = R_a^T
//   ([.]_vec: the three vector rows; r = W e, so dr/dx = W de/dx)
// In the PoseManifold tangent, with dq = (v, w):
//   de_rot/dw_b =  s (w I - [v]_x) R_a^T               de_t/dd_b =  R_a^T
//   de_rot/dw_a = -s (w I - [v]_x) R_a^T               de_t/dd_a = -R_a^T
//   de_t/dw_a   =  R_a^T [t_b - t_a]_x
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

/// The edge as a templated functor: the automatic-differentiation reference for
/// RelativePoseCost (same residuals, same parameter blocks).
struct RelativePoseFunctor {
  Eigen::Quaterniond q_a_b_measured;  ///< unit quaternion of the measured R_a_b
  Vec3 t_a_b_measured;                ///< measured translation of T_a_b (camera-a frame)
  Mat6 sqrt_information;              ///< W, W^T W = information

  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residuals) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(pose_a);
    const Eigen::Map<const Vec3T> t_a(pose_a + 4);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(pose_b);
    const Eigen::Map<const Vec3T> t_b(pose_b + 4);
    Eigen::Quaternion<T> dq = q_a.conjugate() * q_b * q_a_b_measured.conjugate().cast<T>();
    if (dq.w() < T(0)) dq.coeffs() = -dq.coeffs();
    Eigen::Matrix<T, 6, 1> e;
    e.template head<3>() = T(2) * dq.vec();
    e.template tail<3>() = q_a.conjugate() * (t_b - t_a) - t_a_b_measured.cast<T>();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residuals);
    r = sqrt_information.cast<T>() * e;
    return true;
  }

  /// Autodiff cost function over the blocks (T_world_a, T_world_b).
  static ceres::CostFunction* CreateAutoDiff(const Pose& T_a_b_measured,
                                             const Mat6& sqrt_information) {
    return new ceres::AutoDiffCostFunction<RelativePoseFunctor, 6, kPoseAmbientSize,
                                           kPoseAmbientSize>(
        new RelativePoseFunctor{Eigen::Quaterniond(T_a_b_measured.linear()).normalized(),
                                T_a_b_measured.translation(), sqrt_information});
  }
};

/// Analytic relative-pose edge: 6 whitened residuals, parameter blocks (T_world_a,
/// T_world_b), each [qx, qy, qz, qw, tx, ty, tz] with rigfit::PoseManifold.
class RelativePoseCost final
    : public ceres::SizedCostFunction<6, kPoseAmbientSize, kPoseAmbientSize> {
 public:
  /// T_a_b_measured = T_world_a^-1 T_world_b as measured; sqrt_information = W with
  /// W^T W = information, in the error order [rotation; translation], camera-a axes.
  RelativePoseCost(const Pose& T_a_b_measured, const Mat6& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// W with W^T W = information (symmetric positive semi-definite). Positive definite
  /// information gives the upper Cholesky factor L^T (information = L L^T, so
  /// |L^T e|^2 = e^T information e); a rank-deficient one (e.g. an edge that only sees a
  /// floor) gives Lambda^1/2 V^T from its eigen-decomposition, negative eigenvalues
  /// (rounding) clamped to zero.
  static Mat6 SqrtInformation(const Mat6& information);

  /// The cost function the solvers use (the caller, usually ceres::Problem, owns it).
  /// information: 6 x 6, order [rotation (1/rad^2 block); translation (1/m^2 block)], in
  /// camera a's axes (see EdgeInformationFromTangentInformation).
  static ceres::CostFunction* Create(const Pose& T_a_b_measured, const Mat6& information) {
    return new RelativePoseCost(T_a_b_measured, SqrtInformation(information));
  }

 private:
  Eigen::Quaterniond q_a_b_measured_;
  Vec3 t_a_b_measured_;
  Mat6 sqrt_information_;
};

/// Converts an information matrix of camera b's pose, expressed in the PoseManifold
/// tangent at T_world_b with camera a held fixed (e.g. sum of J^T J of point-to-plane
/// residuals, J the tangent Jacobian of block b), into the frame of RelativePoseCost's
/// error: with e = blockdiag(R_a^T, R_a^T) delta_b to first order,
///   information_edge = blockdiag(R_a^T, R_a^T) information_tangent_b blockdiag(R_a, R_a).
/// Only the rotation of T_world_a is used.
Mat6 EdgeInformationFromTangentInformation(const Mat6& information_tangent_b,
                                           const Pose& T_world_a);

}  // namespace rigfit
