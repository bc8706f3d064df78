// The surface bundle's residual of one camera under spatially correlated noise: every pixel of
// the camera on every plane it sees in ONE residual block, whitened by the noise's covariance
// across pixels (derivation: docs/residuals.md, "Correlated noise").
//
// Pixel i of the camera on plane j has the whitened residual r_i = b_i^T x_j / sigma_i with
// x_j = pi_c,j / d_c,j (residuals/plane_cluster.h: b_i = [a_i; w_i], pi_c,j the plane in the
// camera frame, d_c,j its last entry; points cameras: x_j = pi_c,j). Stacked over the planes,
// r = A x with A fixed (it holds no parameter). Correlated noise of covariance Sigma over the
// pixels (unit variance on the diagonal) makes the generalised least-squares cost
//   r^T Sigma^-1 r = x^T (A^T Sigma^-1 A) x = || L^T x ||^2,   L L^T = A^T Sigma^-1 A,
// a (4 P) x (4 P) matrix for P planes: the residual is L^T x, 4 P numbers. Unlike the plane
// cluster's 4 x 4 moment, the planes' blocks are coupled: a pixel near a crease carries the
// difference of its neighbours on the other plane, where the smooth part of the noise cancels.
//
// Parameter blocks: the pose [qx, qy, qz, qw, tx, ty, tz] (core/pose.h) and the P planes
// [n; d] (4 each). Jacobians: per plane, dx_j as in PlaneClusterCost with L = I
// (dx_j = (d pi_j - x_j d(d_c,j)) / d_c,j with the ray model), then dr = L^T dx.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/dynamic_autodiff_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

/// The camera-planes residual as a templated functor: the automatic-differentiation reference
/// for CameraPlanesCost (same residuals, same parameter blocks).
struct CameraPlanesFunctor {
  Eigen::MatrixXd L;  ///< (4 P) x (4 P)
  bool ray_model = true;

  template <typename T>
  bool operator()(T const* const* parameters, T* residual) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const T* pose = parameters[0];
    const Eigen::Quaternion<T> q(pose[3], pose[0], pose[1], pose[2]);
    const Eigen::Map<const Vec3T> t(pose + 4);
    const int planes = static_cast<int>(L.rows()) / 4;
    Eigen::Matrix<T, Eigen::Dynamic, 1> x(4 * planes);
    for (int j = 0; j < planes; ++j) {
      const T* plane = parameters[1 + j];
      const Eigen::Map<const Vec3T> n(plane);
      x.template segment<3>(4 * j) = q.conjugate() * n;
      x(4 * j + 3) = n.dot(t) + plane[3];
      if (ray_model) x.template segment<4>(4 * j) /= n.dot(t) + plane[3];
    }
    Eigen::Map<Eigen::Matrix<T, Eigen::Dynamic, 1>>(residual, 4 * planes) =
        L.transpose().cast<T>() * x;
    return true;
  }

  /// The autodiff cost over a pose and L.rows() / 4 planes.
  static ceres::CostFunction* CreateAutoDiff(const Eigen::MatrixXd& L, bool ray_model);
};

/// Analytic camera-planes cost: 4 P residuals, parameter blocks (T_world_camera, plane_1, ...,
/// plane_P).
class CameraPlanesCost final : public ceres::CostFunction {
 public:
  /// L: (4 P) x (4 P) with L L^T the camera's whitened moment A^T Sigma^-1 A (P >= 1).
  CameraPlanesCost(Eigen::MatrixXd L, bool ray_model);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// L with L L^T = M (eigen-decomposition; negative round-off eigenvalues clamped to 0).
  static Eigen::MatrixXd SquareRoot(const Eigen::MatrixXd& M);

 private:
  Eigen::MatrixXd L_;
  bool ray_model_;
};

}  // namespace rigfit
