// Plane-cluster residual of the surface bundle: every pixel of one camera on one world plane
// in ONE residual block (derivation: docs/residuals.md, "Surface bundle").
//
// A world plane n^T x + d = 0 (n unit) seen by a camera T_world_camera = (R, t) is, in the
// camera frame, pi_c = [n_c; d_c] = [R^T n; n^T t + d]: pi_c^T [p; 1] = 0 for its points p.
//
// Depth cameras (the ray model). Pixel i has the ray a_i = K^-1 [u v 1]^T = p_i / z_i and the
// measured inverse depth w_i; the plane predicts h_i = -n_c^T a_i / d_c, so with
// b_i = [a_i; w_i]
//   w_i - h_i = b_i^T pi_c / d_c,
// exact for noise along the viewing ray. With stereo noise sigma_z = k z^2 the inverse depth
// has sigma_w = k whatever the range: the whitened sum over the pixels is
//   sum_i (b_i^T pi_c)^2 / (sigma_i^2 d_c^2) = || L^T pi_c ||^2 / d_c^2,
//   L L^T = M = sum_i b_i b_i^T / sigma_i^2   (4 x 4, fixed: it holds no parameter),
// so the residual r = L^T pi_c / d_c (4 numbers) carries every pixel, whatever their count.
// Points cameras (scanner clouds, no ray model): b_i = [p_i; 1] and r = L^T pi_c, the metric
// point-to-plane distances whitened by sigma_i.
//
// Parameter blocks: the pose [qx, qy, qz, qw, tx, ty, tz] (core/pose.h, PoseManifold) and the
// plane [n; d] (4: the normal on ceres::SphereManifold<3> times the offset on the line, ONE block
// so that the Schur complement can eliminate the planes; the floor's normal is held by a
// ceres::SubsetManifold).
// Ambient Jacobians (J_inv(q, n) = d(R(q)^T n)/dq, residuals/pose_jacobians.h):
//   d pi_c/dq = [J_inv(q, n); 0],   d pi_c/dt = [0; n^T],
//   d pi_c/d[n; d] = [R^T 0; t^T 1],
//   dr = (L^T d pi_c - r d(d_c)) / d_c   (ray model; d(d_c) the last row of d pi_c),
//   dr = L^T d pi_c                        (points cameras).
//
// A depth camera's depth model (icp.depth_model, docs/residuals.md "Depth model"): its measured
// inverse depth read as w' = alpha w + beta. As a_z = 1, b' = [a; alpha w + beta] = D b with D
// the identity but for its last row [0 0 beta alpha], so the cluster's moment becomes D M D^T
// and the residual r = L^T D^T pi_c / d_c, D^T pi_c = [n_c; alpha d_c] + beta d_c e_3 (one more
// parameter block [alpha, beta]), divided by alpha: the noise is the measured w's, and
// alpha w + beta has alpha sigma_w (weighted by sigma_w alone, alpha < 1 shrank every pixel's
// noise and the solve drifted to alpha ~0.95). Its Jacobians are those above with L' = D L,
// divided by alpha, and
//   dr/dalpha = (L^T e_4 - r) / alpha,   dr/dbeta = L^T e_3 / alpha.
#pragma once

#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

using Mat4 = Eigen::Matrix4d;
using Vec4 = Eigen::Vector4d;

/// The depth model's parameter block [alpha, beta] (scale; offset in inverse depth, 1/m).
inline constexpr int kDepthModelSize = 2;

/// D with [a; alpha w + beta] = D [a; w] for a ray a (a_z = 1) and its inverse depth w.
Mat4 DepthModelMatrix(double alpha, double beta);

/// The pixels of one camera on one plane, summed: M = sum_i b_i b_i^T / sigma_i^2.
class PlaneCluster {
 public:
  /// Adds a pixel of a depth camera: its camera-frame point p (z > 0), its measured inverse
  /// depth w (1 / z, or the noise-corrected value, docs/residuals.md) and its sigma_w.
  void AddRay(const Vec3& p, double w, double sigma_w);
  /// Adds a point of a points camera with its metric sigma.
  void AddPoint(const Vec3& p, double sigma_m);

  const Mat4& Moment() const { return moment_; }
  int Count() const { return count_; }
  /// L with L L^T = M (eigen-decomposition; negative round-off eigenvalues clamped to 0).
  Mat4 SquareRoot() const;

 private:
  Mat4 moment_ = Mat4::Zero();
  int count_ = 0;
};

/// The cluster residual as a templated functor: the automatic-differentiation reference for
/// PlaneClusterCost (same residuals, same parameter blocks).
struct PlaneClusterFunctor {
  Mat4 L;
  bool ray_model = true;

  template <typename T>
  bool operator()(const T* pose, const T* plane, T* residual) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Quaternion<T> q(pose[3], pose[0], pose[1], pose[2]);
    const Eigen::Map<const Vec3T> t(pose + 4);
    const Eigen::Map<const Vec3T> n(plane);
    Eigen::Matrix<T, 4, 1> pi;
    pi.template head<3>() = q.conjugate() * n;
    pi(3) = n.dot(t) + plane[3];
    const Eigen::Matrix<T, 4, 1> s = L.transpose().cast<T>() * pi;
    for (int k = 0; k < 4; ++k) residual[k] = ray_model ? s(k) / pi(3) : s(k);
    return true;
  }

  static ceres::CostFunction* CreateAutoDiff(const Mat4& L, bool ray_model) {
    return new ceres::AutoDiffCostFunction<PlaneClusterFunctor, 4, kPoseAmbientSize, 4>(
        new PlaneClusterFunctor{L, ray_model});
  }
};

/// Analytic plane-cluster cost: 4 residuals, parameter blocks (T_world_camera, [n; d]).
class PlaneClusterCost final : public ceres::SizedCostFunction<4, kPoseAmbientSize, 4> {
 public:
  PlaneClusterCost(const Mat4& L, bool ray_model) : L_(L), ray_model_(ray_model) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// ray_model: a depth camera's cluster (r = L^T pi_c / d_c); false: a points camera's
  /// (r = L^T pi_c). The caller (usually ceres::Problem) owns the cost.
  static ceres::CostFunction* Create(const PlaneCluster& cluster, bool ray_model) {
    return new PlaneClusterCost(cluster.SquareRoot(), ray_model);
  }

 private:
  Mat4 L_;
  bool ray_model_;
};

/// The cluster residual with the camera's depth model, as a templated functor: the
/// automatic-differentiation reference for PlaneClusterDepthCost (depth cameras only).
struct PlaneClusterDepthFunctor {
  Mat4 L;

  template <typename T>
  bool operator()(const T* pose, const T* plane, const T* depth, T* residual) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Quaternion<T> q(pose[3], pose[0], pose[1], pose[2]);
    const Eigen::Map<const Vec3T> t(pose + 4);
    const Eigen::Map<const Vec3T> n(plane);
    const T d_c = n.dot(t) + plane[3];
    Eigen::Matrix<T, 4, 1> pi;  // D^T pi_c
    pi.template head<3>() = q.conjugate() * n;
    pi(2) += depth[1] * d_c;
    pi(3) = depth[0] * d_c;
    const Eigen::Matrix<T, 4, 1> s = L.transpose().cast<T>() * pi;
    for (int k = 0; k < 4; ++k) residual[k] = s(k) / (depth[0] * d_c);
    return true;
  }

  static ceres::CostFunction* CreateAutoDiff(const Mat4& L) {
    return new ceres::AutoDiffCostFunction<PlaneClusterDepthFunctor, 4, kPoseAmbientSize, 4,
                                           kDepthModelSize>(new PlaneClusterDepthFunctor{L});
  }
};

/// Analytic plane-cluster cost of a depth camera with its depth model: 4 residuals, parameter
/// blocks (T_world_camera, [n; d], [alpha, beta]).
class PlaneClusterDepthCost final
    : public ceres::SizedCostFunction<4, kPoseAmbientSize, 4, kDepthModelSize> {
 public:
  explicit PlaneClusterDepthCost(const Mat4& L) : L_(L) {}

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  static ceres::CostFunction* Create(const PlaneCluster& cluster) {
    return new PlaneClusterDepthCost(cluster.SquareRoot());
  }

 private:
  Mat4 L_;
};

}  // namespace rigfit
