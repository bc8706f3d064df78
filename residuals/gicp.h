// Generalised-ICP (plane-to-plane, Mahalanobis) residual between two cameras
// (derivation: docs/residuals.md).
//
// A point p of camera a with covariance C_p (camera-a frame) corresponds to a point q of
// camera b with covariance C_q (camera-b frame). With the poses T_world_a = (R_a, t_a) and
// T_world_b = (R_b, t_b) as parameter blocks [qx, qy, qz, qw, tx, ty, tz] (core/pose.h):
//
//   d = (R_a p + t_a) - (R_b q + t_b)                          world frame, metres
//   S = R_a0 C_p R_a0^T + R_b0 C_q R_b0^T + eps I              world-frame covariance of d
//   L L^T = S^-1 (Cholesky),   r = L^T d                       3 whitened residuals
//
// so that |r|^2 = d^T S^-1 d. As in the usual GICP practice, S uses the rotations R_a0,
// R_b0 of the poses when the correspondences were made and stays fixed until they are
// remade: r is then linear in the point positions and its Jacobian does not differentiate
// the weight. eps (SqrtInformation) keeps S invertible when both covariances are flat
// in the same direction (two planes with equal normals).
//
// Ambient Jacobians (J_R(q, v) = d(R(q) v)/dq from residuals/pose_jacobians.h):
//   dr/dq_a =  L^T J_R(q_a, p)      dr/dt_a =  L^T
//   dr/dq_b = -L^T J_R(q_b, q)      dr/dt_b = -L^T
// In the PoseManifold tangent: dr/dw_a = -L^T [R_a p]_x, dr/dw_b = L^T [R_b q]_x,
// dr/dd_a = L^T, dr/dd_b = -L^T.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

/// Default eps added to the summed GICP covariance: (1 mm)^2, in m^2.
inline constexpr double kGicpCovarianceEpsilon = 1e-6;

/// The GICP residual as a templated functor: the automatic-differentiation reference for
/// GicpCost (same residuals, same parameter blocks).
struct GicpFunctor {
  Vec3 point_a;           ///< p, camera-a frame
  Vec3 point_b;           ///< q, camera-b frame
  Mat3 sqrt_information;  ///< L^T, world frame (GicpCost::SqrtInformation)

  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residuals) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(pose_a);
    const Eigen::Map<const Vec3T> t_a(pose_a + 4);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(pose_b);
    const Eigen::Map<const Vec3T> t_b(pose_b + 4);
    const Vec3T d = (q_a * point_a.cast<T>() + t_a) - (q_b * point_b.cast<T>() + t_b);
    Eigen::Map<Vec3T> r(residuals);
    r = sqrt_information.cast<T>() * d;
    return true;
  }

  /// Autodiff cost function over the blocks (T_world_a, T_world_b).
  static ceres::CostFunction* CreateAutoDiff(const Vec3& point_a, const Vec3& point_b,
                                             const Mat3& sqrt_information) {
    return new ceres::AutoDiffCostFunction<GicpFunctor, 3, kPoseAmbientSize, kPoseAmbientSize>(
        new GicpFunctor{point_a, point_b, sqrt_information});
  }
};

/// The analytic GICP residuals of one correspondence, as plain data: what GicpCost
/// evaluates, and what StackedCost<GicpTerm> evaluates for every correspondence of a camera
/// pair without one cost object each.
struct GicpTerm {
  static constexpr int kNumResiduals = 3;

  Vec3 point_a;           ///< p, camera-a frame
  Vec3 point_b;           ///< q, camera-b frame
  Mat3 sqrt_information;  ///< L^T, world frame (GicpCost::SqrtInformation)

  /// r and, where not null, the ambient Jacobians dr/dx_a and dr/dx_b (3 x 7 each,
  /// row-major) at the pose blocks x_a = pose_a, x_b = pose_b.
  void Evaluate(const double* pose_a, const double* pose_b, double* residuals, double* jacobian_a,
                double* jacobian_b) const;

  /// r is linear in the features of the two poses (CompressedCost); the weight L^T is in
  /// the world frame, so they are the absolute poses, not the relative one:
  ///   theta = [vec(R_a); t_a; vec(R_b); t_b],  vec column by column,
  ///   r = L^T (R_a p + t_a - R_b q - t_b) = Phi theta,
  ///   Phi = L^T [p_0 I, p_1 I, p_2 I, I, -q_0 I, -q_1 I, -q_2 I, -I] = z^T (x) L^T,
  ///   z = (p, 1, -q, -1),  so Phi^T Phi = (z z^T) (x) (L L^T).
  static constexpr int kFeatureSize = 24;

  /// Adds weight2 Phi^T Phi to the lower triangle of `normal` (kFeatureSize^2, column-major).
  void AddNormal(double weight2, double* normal) const;

  /// r = Phi theta at features theta (Features): Evaluate's residuals without the poses'
  /// rotations, for many terms of the same pair of poses.
  void ResidualAt(const double* theta, double* residuals) const;

  /// theta at the pose blocks and, where not null, d theta/dx_a and d theta/dx_b
  /// (kFeatureSize x 7 each, row-major).
  static void Features(const double* pose_a, const double* pose_b, double* theta, double* dtheta_a,
                       double* dtheta_b);
};

/// Analytic GICP cost: 3 whitened residuals, parameter blocks (T_world_a, T_world_b), each
/// [qx, qy, qz, qw, tx, ty, tz] with rigfit::PoseManifold.
class GicpCost final : public ceres::SizedCostFunction<3, kPoseAmbientSize, kPoseAmbientSize> {
 public:
  /// point_a in camera a, point_b in camera b, sqrt_information = L^T (world frame).
  GicpCost(const Vec3& point_a, const Vec3& point_b, const Mat3& sqrt_information)
      : term_{point_a, point_b, sqrt_information} {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    term_.Evaluate(parameters[0], parameters[1], residuals,
                   jacobians == nullptr ? nullptr : jacobians[0],
                   jacobians == nullptr ? nullptr : jacobians[1]);
    return true;
  }

  /// The whitening L^T (upper triangular, 1/m) with L L^T = S^-1,
  /// S = R_world_a C_a R_world_a^T + R_world_b C_b R_world_b^T + epsilon_m2 I.
  /// cov_a (camera-a frame) and cov_b (camera-b frame) are symmetric positive
  /// semi-definite point covariances in m^2; epsilon_m2 > 0 makes S positive definite.
  static Mat3 SqrtInformation(const Mat3& cov_a, const Mat3& cov_b, const Mat3& R_world_a,
                              const Mat3& R_world_b, double epsilon_m2 = kGicpCovarianceEpsilon);

  /// The term of a correspondence: the weight is fixed from the rotations R_world_a,
  /// R_world_b at correspondence time (epsilon kGicpCovarianceEpsilon).
  static GicpTerm MakeTerm(const Vec3& point_a, const Vec3& point_b, const Mat3& cov_a,
                           const Mat3& cov_b, const Mat3& R_world_a, const Mat3& R_world_b) {
    return {point_a, point_b, SqrtInformation(cov_a, cov_b, R_world_a, R_world_b)};
  }

  /// The cost function of MakeTerm (the caller, usually ceres::Problem, owns it).
  static ceres::CostFunction* Create(const Vec3& point_a, const Vec3& point_b, const Mat3& cov_a,
                                     const Mat3& cov_b, const Mat3& R_world_a,
                                     const Mat3& R_world_b) {
    const GicpTerm term = MakeTerm(point_a, point_b, cov_a, cov_b, R_world_a, R_world_b);
    return new GicpCost(term.point_a, term.point_b, term.sqrt_information);
  }

 private:
  GicpTerm term_;
};

}  // namespace rigfit
