// Derivatives with respect to the ambient quaternion of a pose parameter block, shared by
// the analytic cost functions (derivations: docs/residuals.md, "Ambient derivatives").
//
// A pose block is x = [qx, qy, qz, qw, tx, ty, tz] (core/pose.h). Ceres asks a cost
// function for the Jacobian with respect to these 7 ambient numbers; rigfit::PoseManifold
// then maps it to the 6-dimensional tangent: J_tangent = J_ambient * PlusJacobian(x).
//
// Rotation of a vector. With q = (u, w), u = (qx, qy, qz) the vector part and w = qw,
//   R(q) v = v + 2 w (u x v) + 2 u x (u x v).                                        (R)
// This polynomial is what Eigen evaluates for both `q * v` and `q.toRotationMatrix()`,
// and therefore what the templated (autodiff) functors differentiate. It is a rotation
// only for |q| = 1, which PoseManifold::Plus guarantees for every pose the solver visits
// (it normalises after each step); off the unit sphere the formula is still a
// polynomial, and the functions here differentiate exactly that polynomial so that
// analytic and automatic derivatives agree to rounding. Because R(q) and the normalised
// rotation coincide on the sphere, their derivatives along the sphere (the range of
// PlusJacobian) coincide too, so the tangent Jacobians are those of the true rotation.
//
// The inverse rotation uses R(q)^T = R(conj(q)), conj(q) = (-u, w): the symmetric part of
// (R) is even in u and the antisymmetric part 2 w [u]_x is odd, so the identity holds for
// every q, unit or not.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/pose.h"

namespace rigfit {

using Mat34 = Eigen::Matrix<double, 3, 4>;
using Mat44 = Eigen::Matrix<double, 4, 4>;
using Row4 = Eigen::Matrix<double, 1, 4>;

/// d(R(q) v)/dq, columns in parameter order (qx, qy, qz, qw), for q not necessarily unit:
///   d/du = -2 w [v]_x + 2 ((u.v) I + u v^T - 2 v u^T),   d/dw = 2 u x v.
inline Mat34 RotatePointJacobian(const Eigen::Quaterniond& q, const Vec3& v) {
  const Vec3 u = q.vec();
  const double w = q.w();
  Mat34 J;
  J.leftCols<3>() = -2.0 * w * Hat(v) + 2.0 * (u.dot(v) * Mat3::Identity() + u * v.transpose() -
                                               2.0 * v * u.transpose());
  J.col(3) = 2.0 * u.cross(v);
  return J;
}

/// a^T d(R(q) v)/dq (1 x 4) without forming the 3 x 4 matrix (a^T [v]_x = (a x v)^T):
///   d/du = 2 (-w (a x v) + (u.v) a + (a.u) v - 2 (a.v) u)^T,   d/dw = 2 a.(u x v).
inline Row4 ProjectedRotatePointJacobian(const Eigen::Quaterniond& q, const Vec3& v,
                                         const Vec3& a) {
  const Vec3 u = q.vec();
  const double w = q.w();
  Row4 J;
  J.head<3>() =
      2.0 * (-w * a.cross(v) + u.dot(v) * a + a.dot(u) * v - 2.0 * a.dot(v) * u).transpose();
  J(3) = 2.0 * a.dot(u.cross(v));
  return J;
}

/// d(R(q)^T v)/dq = d(R(conj(q)) v)/dq, from (R) with u -> -u:
///   d/du = 2 w [v]_x + 2 ((u.v) I + u v^T - 2 v u^T),   d/dw = -2 u x v.
inline Mat34 InverseRotatePointJacobian(const Eigen::Quaterniond& q, const Vec3& v) {
  const Vec3 u = q.vec();
  const double w = q.w();
  Mat34 J;
  J.leftCols<3>() = 2.0 * w * Hat(v) + 2.0 * (u.dot(v) * Mat3::Identity() + u * v.transpose() -
                                              2.0 * v * u.transpose());
  J.col(3) = -2.0 * u.cross(v);
  return J;
}

/// Matrix of left multiplication by p in (x, y, z, w) order: p * q = QuaternionLeftProduct(p)
/// [q.vec(); q.w()], from (p q).vec = p_w q_v + q_w p_v + p_v x q_v, (p q).w = p_w q_w - p_v.q_v.
inline Mat44 QuaternionLeftProduct(const Eigen::Quaterniond& p) {
  Mat44 M;
  M.topLeftCorner<3, 3>() = p.w() * Mat3::Identity() + Hat(p.vec());
  M.topRightCorner<3, 1>() = p.vec();
  M.bottomLeftCorner<1, 3>() = -p.vec().transpose();
  M(3, 3) = p.w();
  return M;
}

/// Matrix of right multiplication by q in (x, y, z, w) order: p * q = QuaternionRightProduct(q)
/// [p.vec(); p.w()].
inline Mat44 QuaternionRightProduct(const Eigen::Quaterniond& q) {
  Mat44 M;
  M.topLeftCorner<3, 3>() = q.w() * Mat3::Identity() - Hat(q.vec());
  M.topRightCorner<3, 1>() = q.vec();
  M.bottomLeftCorner<1, 3>() = -q.vec().transpose();
  M(3, 3) = q.w();
  return M;
}

}  // namespace rigfit
