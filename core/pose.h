// rigfit's SE(3) conventions, written down once.
//
// Pose:   T_world_camera maps camera coordinates to world coordinates,
//         p_world = R * p_camera + t  (../shared/docs/formats.md).
// World:  gravity-aligned, +Y up; after ground leveling the floor is y = 0.
//         "Yaw" is a rotation about world +Y, "tilt" (pitch/roll) about world X and Z.
//
// Parameter block (ambient, 7 doubles), the layout every Ceres cost function uses:
//   x = [qx, qy, qz, qw, tx, ty, tz]
//   q: unit quaternion of R in Eigen's coefficient order (x, y, z, w), t: translation.
//
// Tangent space (6 doubles), the layout of every Jacobian after the manifold, of every
// covariance and of every information matrix:
//   delta = [wx, wy, wz, dx, dy, dz]
//   w: a rotation vector in WORLD axes, applied on the left (R' = Exp(w) R): |w| is the
//      rotation angle in radians, w_y is a change of yaw, w_x and w_z a change of tilt.
//   d: a translation of the camera centre in world axes (t' = t + d), metres.
// A camera therefore rotates about its own centre, and tangent covariances read directly
// as radians and metres in the world frame.
#pragma once

#include <ceres/manifold.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace rigfit {

using Pose = Eigen::Isometry3d;
using Vec3 = Eigen::Vector3d;
using Vec3f = Eigen::Vector3f;  ///< maps and images (rgbd/), where float is enough
using Mat3 = Eigen::Matrix3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;

inline constexpr int kPoseAmbientSize = 7;
inline constexpr int kPoseTangentSize = 6;

/// Angles are radians inside rigfit and degrees for people (options, reports).
inline constexpr double kRadToDeg = 180.0 / M_PI;
inline constexpr double kDegToRad = M_PI / 180.0;

/// Writes T into a 7-double parameter block [qx, qy, qz, qw, tx, ty, tz].
void PoseToParameters(const Pose& T, double* x);
/// Reads a 7-double parameter block; the quaternion is normalised.
Pose PoseFromParameters(const double* x);

/// Skew-symmetric matrix [v]_x with [v]_x u = v x u.
Mat3 Hat(const Vec3& v);
/// SO(3) exponential of a rotation vector (angle |w| about w / |w|).
Mat3 ExpSO3(const Vec3& w);
/// SO(3) logarithm: the rotation vector of R, with angle in [0, pi].
Vec3 LogSO3(const Mat3& R);
/// Whether the relative pose T moves at most translation_m and turns at most rotation_deg (the
/// keyframe rules of loop closure and SLAM's colour reference).
bool WithinMotion(const Pose& T, double translation_m, double rotation_deg);
/// Tangent difference of two poses in the convention above: T_b = Exp(delta) * T_a,
/// i.e. w = Log(R_b R_a^T), d = t_b - t_a.
Vec6 PoseDifference(const Pose& T_a, const Pose& T_b);
/// The inverse of PoseDifference: returns T with PoseDifference(T_a, T) = delta.
Pose PosePlus(const Pose& T_a, const Vec6& delta);
/// T with its rotation block made orthonormal again (through the normalised quaternion: the
/// nearest rotation to first order). A chain of pose products accumulates round-off in the
/// rotation, and Isometry3d's inverse (the transpose) then amplifies it at every step.
Pose Reorthonormalized(const Pose& T);

/// The Ceres manifold of a pose parameter block (7 ambient, 6 tangent), implementing the
/// tangent convention above. Use it with every parameter block that holds a pose.
class PoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return kPoseAmbientSize; }
  int TangentSize() const override { return kPoseTangentSize; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace rigfit
