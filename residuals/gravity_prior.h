// Pitch/roll gravity prior on one camera (derivation and invariance proof:
// docs/residuals.md).
//
// Ground leveling puts camera c at T_world_c0 = (R0, t0) with the floor at y = 0. The up
// direction of the world, e_y = (0, 1, 0), seen in the camera frame is
//   u0 = R0^T e_y  (leveled, fixed)          u = R^T e_y  (current pose (R, t))
// Let {b1, b2} be an orthonormal basis of the plane perpendicular to u0 (fixed at
// creation). The two residuals are the components of u - u0 in that plane, weighted:
//   r = weight [b1 . u, b2 . u]^T      (b_i . u0 = 0)
// |r| = weight sin(alpha), alpha the angle between u and u0 (the tilt change); for small
// tilt |r| ~ weight alpha. weight = 1 / sigma_tilt in 1/rad whitens r.
//
// Invariance: a yaw R' = R_y R (rotation about world +Y, R_y^T e_y = e_y) gives
// R'^T e_y = R^T R_y^T e_y = R^T e_y, and t does not appear: r is exactly unchanged.
//
// Ambient Jacobian (J_RT(q, v) = d(R(q)^T v)/dq from residuals/pose_jacobians.h):
//   dr/dq = weight [b1 b2]^T J_RT(q, e_y),   dr/dt = 0
// In the PoseManifold tangent: dr/dw = weight [b1 b2]^T R^T [e_y]_x (its yaw column w_y
// is zero), dr/dd = 0.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

using Mat23 = Eigen::Matrix<double, 2, 3>;

/// weight [b1 b2]^T: the rows b1, b2 are an orthonormal basis of the plane perpendicular
/// to the leveled up direction u0 = R_world_camera_leveled^T e_y (camera frame), scaled by
/// weight (1/rad).
Mat23 GravityPriorBasis(const Mat3& R_world_camera_leveled, double weight);

/// The gravity prior as a templated functor: the automatic-differentiation reference for
/// GravityPriorCost (same residuals, same parameter block).
struct GravityPriorFunctor {
  Mat23 weighted_basis;  ///< GravityPriorBasis(R0, weight)

  template <typename T>
  bool operator()(const T* pose, T* residuals) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q(pose);
    const Vec3T up_in_camera = q.conjugate() * Vec3T(T(0), T(1), T(0));
    Eigen::Map<Eigen::Matrix<T, 2, 1>> r(residuals);
    r = weighted_basis.cast<T>() * up_in_camera;
    return true;
  }

  /// Autodiff cost function over the block T_world_camera.
  static ceres::CostFunction* CreateAutoDiff(const Mat3& R_world_camera_leveled, double weight) {
    return new ceres::AutoDiffCostFunction<GravityPriorFunctor, 2, kPoseAmbientSize>(
        new GravityPriorFunctor{GravityPriorBasis(R_world_camera_leveled, weight)});
  }
};

/// Analytic gravity prior: 2 residuals (weight x sine of the tilt change), one parameter
/// block T_world_camera = [qx, qy, qz, qw, tx, ty, tz] with rigfit::PoseManifold.
class GravityPriorCost final : public ceres::SizedCostFunction<2, kPoseAmbientSize> {
 public:
  /// weighted_basis = GravityPriorBasis(R_world_camera_leveled, weight).
  explicit GravityPriorCost(const Mat23& weighted_basis) : weighted_basis_(weighted_basis) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// The cost function the solvers use (the caller, usually ceres::Problem, owns it):
  /// anchors the camera's tilt at its leveled rotation R_world_camera_leveled, with
  /// weight = 1 / sigma_tilt in 1/rad.
  static ceres::CostFunction* Create(const Mat3& R_world_camera_leveled, double weight) {
    return new GravityPriorCost(GravityPriorBasis(R_world_camera_leveled, weight));
  }

 private:
  Mat23 weighted_basis_;
};

}  // namespace rigfit
