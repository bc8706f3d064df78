// Point-to-plane residual between two cameras (derivation: docs/residuals.md).
//
// A point p of camera a (camera-a frame) corresponds to a point q with unit normal n of
// camera b (both camera-b frame). With the poses T_world_a = (R_a, t_a) and
// T_world_b = (R_b, t_b) as parameter blocks [qx, qy, qz, qw, tx, ty, tz] (core/pose.h):
//
//   d   = (R_a p + t_a) - (R_b q + t_b)       world-frame offset between the two points
//   n_w = R_b n                               the normal of b in the world frame
//   r   = n_w . d                             signed distance of T_a p to b's plane (m)
//
// Ambient Jacobians (J_R(q, v) = d(R(q) v)/dq from residuals/pose_jacobians.h):
//   dr/dq_a = n_w^T J_R(q_a, p)       dr/dt_a =  n_w^T
//   dr/dq_b = d^T J_R(q_b, n) - n_w^T J_R(q_b, q)
//   dr/dt_b = -n_w^T
// In the PoseManifold tangent (world rotation vector on the left, world translation):
//   dr/dw_a = (R_a p x n_w)^T         dr/dd_a =  n_w^T
//   dr/dw_b = (n_w x (t_a + R_a p - t_b))^T
//   dr/dd_b = -n_w^T
// Either block may be held constant (Ceres then passes a null Jacobian for it).
// r is linear in n: a normal scaled by 1 / sigma (sigma in metres) gives a whitened r.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

/// The point-to-plane residual as a templated functor: the automatic-differentiation
/// reference for PointToPlaneCost (same residual, same parameter blocks).
struct PointToPlaneFunctor {
  Vec3 point_a;   ///< p, camera-a frame
  Vec3 point_b;   ///< q, camera-b frame
  Vec3 normal_b;  ///< n, unit normal at q (or scaled by 1 / sigma), camera-b frame

  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residual) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(pose_a);
    const Eigen::Map<const Vec3T> t_a(pose_a + 4);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(pose_b);
    const Eigen::Map<const Vec3T> t_b(pose_b + 4);
    const Vec3T d = (q_a * point_a.cast<T>() + t_a) - (q_b * point_b.cast<T>() + t_b);
    residual[0] = (q_b * normal_b.cast<T>()).dot(d);
    return true;
  }

  /// Autodiff cost function over the blocks (T_world_a, T_world_b).
  static ceres::CostFunction* CreateAutoDiff(const Vec3& point_a, const Vec3& point_b,
                                             const Vec3& normal_b) {
    return new ceres::AutoDiffCostFunction<PointToPlaneFunctor, 1, kPoseAmbientSize,
                                           kPoseAmbientSize>(
        new PointToPlaneFunctor{point_a, point_b, normal_b});
  }
};

/// The analytic point-to-plane residual of one correspondence, as plain data: what
/// PointToPlaneCost evaluates, and what StackedCost<PointToPlaneTerm> evaluates for every
/// correspondence of a camera pair without one cost object each.
struct PointToPlaneTerm {
  static constexpr int kNumResiduals = 1;

  Vec3 point_a;   ///< p, camera-a frame
  Vec3 point_b;   ///< q, camera-b frame
  Vec3 normal_b;  ///< n, unit normal at q (or scaled by 1 / sigma), camera-b frame

  /// r and, where not null, the ambient Jacobians dr/dx_a and dr/dx_b (1 x 7 each) at the
  /// pose blocks x_a = pose_a, x_b = pose_b.
  void Evaluate(const double* pose_a, const double* pose_b, double* residual, double* jacobian_a,
                double* jacobian_b) const;

  /// r is linear in the features of the relative pose T_b^-1 T_a = (R, t) (CompressedCost):
  ///   theta = [vec(R); t; 1],  R = R_b^T R_a,  t = R_b^T (t_a - t_b),  vec column by column,
  ///   r = n^T (R p + t - q) = phi . theta,  phi = [p (x) n; n; -n.q]  (phi[i + 3j] = n_i p_j).
  static constexpr int kFeatureSize = 13;

  /// Adds weight2 phi^T phi to the lower triangle of `normal` (kFeatureSize^2, column-major).
  void AddNormal(double weight2, double* normal) const;

  /// r = phi . theta at features theta (Features): Evaluate's residual without the poses'
  /// rotations, for many terms of the same pair of poses.
  void ResidualAt(const double* theta, double* residual) const;

  /// theta at the pose blocks and, where not null, d theta/dx_a and d theta/dx_b
  /// (kFeatureSize x 7 each, row-major).
  static void Features(const double* pose_a, const double* pose_b, double* theta, double* dtheta_a,
                       double* dtheta_b);
};

/// Analytic point-to-plane cost: 1 residual (metres), parameter blocks
/// (T_world_a, T_world_b), each [qx, qy, qz, qw, tx, ty, tz] with rigfit::PoseManifold.
class PointToPlaneCost final
    : public ceres::SizedCostFunction<1, kPoseAmbientSize, kPoseAmbientSize> {
 public:
  /// point_a in camera a; point_b and its unit normal normal_b in camera b (a normal
  /// scaled by 1 / sigma, sigma in metres, whitens the residual: r is linear in n).
  PointToPlaneCost(const Vec3& point_a, const Vec3& point_b, const Vec3& normal_b)
      : term_{point_a, point_b, normal_b} {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    term_.Evaluate(parameters[0], parameters[1], residuals,
                   jacobians == nullptr ? nullptr : jacobians[0],
                   jacobians == nullptr ? nullptr : jacobians[1]);
    return true;
  }

  /// The cost function the solvers use (the caller, usually ceres::Problem, owns it).
  static ceres::CostFunction* Create(const Vec3& point_a, const Vec3& point_b,
                                     const Vec3& normal_b) {
    return new PointToPlaneCost(point_a, point_b, normal_b);
  }

 private:
  PointToPlaneTerm term_;
};

}  // namespace rigfit
