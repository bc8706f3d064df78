#include "core/pose.h"

#include <cmath>

namespace rigfit {
namespace {

/// Unit quaternion of the rotation vector w: (sin(|w|/2) w/|w|, cos(|w|/2)).
Eigen::Quaterniond QuaternionExp(const Vec3& w) {
  const double theta = w.norm();
  // sin(theta/2)/theta, with its Taylor series where the division loses precision.
  const double s = theta > 1e-6 ? std::sin(0.5 * theta) / theta : 0.5 - theta * theta / 48.0;
  Eigen::Quaterniond q;
  q.w() = std::cos(0.5 * theta);
  q.vec() = s * w;
  return q;
}

/// Rotation vector of a unit quaternion with QuaternionExp(QuaternionLog(q)) == q exactly
/// (sign included): the angle is in [0, 2 pi), larger than pi when q.w() < 0.
Vec3 QuaternionLog(const Eigen::Quaterniond& q) {
  const double n = q.vec().norm();
  const double theta = 2.0 * std::atan2(n, q.w());
  // theta / n -> 2 / w as n -> 0 (w > 0 there unless the angle is 2 pi).
  const double scale = n > 1e-9 ? theta / n : 2.0 / q.w();
  return scale * q.vec();
}

/// The quaternion of a parameter block (Eigen order x, y, z, w), not normalised.
Eigen::Quaterniond QuaternionOf(const double* x) { return {x[3], x[0], x[1], x[2]}; }

void StoreQuaternion(const Eigen::Quaterniond& q, double* x) {
  x[0] = q.x();
  x[1] = q.y();
  x[2] = q.z();
  x[3] = q.w();
}

}  // namespace

void PoseToParameters(const Pose& T, double* x) {
  StoreQuaternion(Eigen::Quaterniond(T.linear()).normalized(), x);
  x[4] = T.translation().x();
  x[5] = T.translation().y();
  x[6] = T.translation().z();
}

Pose PoseFromParameters(const double* x) {
  Pose T = Pose::Identity();
  T.linear() = QuaternionOf(x).normalized().toRotationMatrix();
  T.translation() = Vec3(x[4], x[5], x[6]);
  return T;
}

Mat3 Hat(const Vec3& v) {
  Mat3 m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

Mat3 ExpSO3(const Vec3& w) { return QuaternionExp(w).toRotationMatrix(); }

Vec3 LogSO3(const Mat3& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();  // the hemisphere with angle in [0, pi]
  return QuaternionLog(q);
}

bool WithinMotion(const Pose& T, double translation_m, double rotation_deg) {
  return T.translation().norm() <= translation_m &&
         LogSO3(T.linear()).norm() <= rotation_deg * kDegToRad;
}

Vec6 PoseDifference(const Pose& T_a, const Pose& T_b) {
  Vec6 delta;
  delta.head<3>() = LogSO3(T_b.linear() * T_a.linear().transpose());
  delta.tail<3>() = T_b.translation() - T_a.translation();
  return delta;
}

Pose Reorthonormalized(const Pose& T) {
  Pose R = T;
  R.linear() = Eigen::Quaterniond(T.linear()).normalized().toRotationMatrix();
  return R;
}

Pose PosePlus(const Pose& T_a, const Vec6& delta) {
  Pose T = Pose::Identity();
  T.linear() = ExpSO3(delta.head<3>()) * T_a.linear();
  T.translation() = T_a.translation() + delta.tail<3>();
  return T;
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  StoreQuaternion(
      (QuaternionExp(Vec3(delta[0], delta[1], delta[2])) * QuaternionOf(x)).normalized(),
      x_plus_delta);
  for (int i = 4; i < 7; ++i) x_plus_delta[i] = x[i] + delta[i - 1];
  return true;
}

// d(Exp(w) q)/dw at w = 0, with Exp(w) ~ (w/2, 1):
//   vector part  q_w w/2 + (w/2) x q_v = 0.5 (q_w I - [q_v]_x) w
//   scalar part  -(w/2) . q_v          = -0.5 q_v^T w
bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  const Vec3 qv(x[0], x[1], x[2]);
  const double qw = x[3];
  J.setZero();
  J.block<3, 3>(0, 0) = 0.5 * (qw * Mat3::Identity() - Hat(qv));
  J.block<1, 3>(3, 0) = -0.5 * qv.transpose();
  J.block<3, 3>(4, 3).setIdentity();
  return true;
}

// Minus keeps the hemisphere of y x^-1 (no sign canonicalisation) so that
// Plus(x, Minus(y, x)) == y in ambient coordinates, as Ceres requires of a manifold.
bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  const Vec3 w = QuaternionLog((QuaternionOf(y) * QuaternionOf(x).conjugate()).normalized());
  for (int i = 0; i < 3; ++i) y_minus_x[i] = w[i];
  for (int i = 4; i < 7; ++i) y_minus_x[i - 1] = y[i] - x[i];
  return true;
}

// d Minus(y, x)/dy at y = x, with Log(q) ~ 2 q_v near identity:
//   vec(y x*) = x_w y_v - y_w x_v + [x_v]_x y_v   =>   dw/dy_v = 2 (x_w I + [x_v]_x),
//   dw/dy_w = -2 x_v.  (MinusJacobian * PlusJacobian = I for a unit quaternion.)
bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  const Vec3 qv(x[0], x[1], x[2]);
  const double qw = x[3];
  J.setZero();
  J.block<3, 3>(0, 0) = 2.0 * (qw * Mat3::Identity() + Hat(qv));
  J.block<3, 1>(0, 3) = -2.0 * qv;
  J.block<3, 3>(3, 4).setIdentity();
  return true;
}

}  // namespace rigfit
