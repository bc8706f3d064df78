#include "residuals/relative_pose.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "residuals/pose_jacobians.h"

namespace rigfit {
namespace {

/// Information matrices whose smallest eigenvalue is below this fraction of the largest
/// are treated as rank-deficient (Cholesky would divide by a rounding-level pivot).
constexpr double kRankTolerance = 1e-12;

}  // namespace

RelativePoseCost::RelativePoseCost(const Pose& T_a_b_measured, const Mat6& sqrt_information)
    : q_a_b_measured_(Eigen::Quaterniond(T_a_b_measured.linear()).normalized()),
      t_a_b_measured_(T_a_b_measured.translation()),
      sqrt_information_(sqrt_information) {}

Mat6 RelativePoseCost::SqrtInformation(const Mat6& information) {
  const Mat6 symmetric = 0.5 * (information + information.transpose());
  const Eigen::SelfAdjointEigenSolver<Mat6> eigen(symmetric);
  const Vec6& lambda = eigen.eigenvalues();  // ascending
  if (lambda(0) > kRankTolerance * lambda(5)) {
    return symmetric.llt().matrixU();
  }
  // W = Lambda^1/2 V^T: W^T W = V Lambda V^T.
  return lambda.cwiseMax(0.0).cwiseSqrt().asDiagonal() * eigen.eigenvectors().transpose();
}

bool RelativePoseCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Quaterniond> q_a(parameters[0]);
  const Eigen::Map<const Vec3> t_a(parameters[0] + 4);
  const Eigen::Map<const Eigen::Quaterniond> q_b(parameters[1]);
  const Eigen::Map<const Vec3> t_b(parameters[1] + 4);

  // dq = conj(q_a) q_b conj(q_m) with dq_w >= 0; e = [2 vec(dq); R_a^T (t_b - t_a) - t_m]
  const Eigen::Quaterniond q_m_conj = q_a_b_measured_.conjugate();
  const Eigen::Quaterniond q_b_m = q_b * q_m_conj;
  Eigen::Quaterniond dq = q_a.conjugate() * q_b_m;
  const double s = dq.w() < 0.0 ? -1.0 : 1.0;
  const Vec3 t_ba = t_b - t_a;
  Vec6 e;
  e.head<3>() = 2.0 * s * dq.vec();
  e.tail<3>() = q_a.conjugate() * t_ba - t_a_b_measured_;
  Eigen::Map<Vec6> r(residuals);
  r = sqrt_information_ * e;
  if (jacobians == nullptr) return true;

  // dr/dx = W de/dx = W_rot de_rot/dx + W_t de_t/dx, with W_rot, W_t the column halves of W.
  using Mat67 = Eigen::Matrix<double, 6, kPoseAmbientSize, Eigen::RowMajor>;
  const auto W_rot = sqrt_information_.leftCols<3>();
  const auto W_t = sqrt_information_.rightCols<3>();
  const Mat3 R_a_T = q_a.toRotationMatrix().transpose();
  if (jacobians[0] != nullptr) {
    // de_rot/dq_a = 2 s [P_R(q_b conj(q_m)) C]_vec, C = diag(-1, -1, -1, 1);
    // de_t/dq_a = J_RT(q_a, t_b - t_a), de_t/dt_a = -R_a^T
    Mat34 de_rot = 2.0 * s * QuaternionRightProduct(q_b_m).topRows<3>();
    de_rot.leftCols<3>() *= -1.0;
    Eigen::Map<Mat67> J(jacobians[0]);
    J.leftCols<4>() = W_rot * de_rot + W_t * InverseRotatePointJacobian(q_a, t_ba);
    J.rightCols<3>() = -W_t * R_a_T;
  }
  if (jacobians[1] != nullptr) {
    // de_rot/dq_b = 2 s [P_L(conj(q_a)) P_R(conj(q_m))]_vec, de_t/dt_b = R_a^T
    const Mat34 de_rot = 2.0 * s * QuaternionLeftProduct(q_a.conjugate()).topRows<3>() *
                         QuaternionRightProduct(q_m_conj);
    Eigen::Map<Mat67> J(jacobians[1]);
    J.leftCols<4>() = W_rot * de_rot;
    J.rightCols<3>() = W_t * R_a_T;
  }
  return true;
}

Mat6 EdgeInformationFromTangentInformation(const Mat6& information_tangent_b,
                                           const Pose& T_world_a) {
  // delta_b = A^-1 e with A = blockdiag(R_a^T, R_a^T), so
  // delta_b^T H delta_b = e^T A^-T H A^-1 e and A^-1 = blockdiag(R_a, R_a).
  Mat6 A_inv = Mat6::Zero();
  A_inv.topLeftCorner<3, 3>() = T_world_a.linear();
  A_inv.bottomRightCorner<3, 3>() = T_world_a.linear();
  return A_inv.transpose() * information_tangent_b * A_inv;
}

}  // namespace rigfit
