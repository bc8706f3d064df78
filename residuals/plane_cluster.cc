#include "residuals/plane_cluster.h"

#include <Eigen/Eigenvalues>

#include "residuals/pose_jacobians.h"

namespace rigfit {

void PlaneCluster::AddRay(const Vec3& p, double w, double sigma_w) {
  const Vec4 b(p.x() / p.z(), p.y() / p.z(), 1.0, w);
  moment_.noalias() += b * b.transpose() / (sigma_w * sigma_w);
  ++count_;
}

void PlaneCluster::AddPoint(const Vec3& p, double sigma_m) {
  const Vec4 b(p.x(), p.y(), p.z(), 1.0);
  moment_.noalias() += b * b.transpose() / (sigma_m * sigma_m);
  ++count_;
}

Mat4 PlaneCluster::SquareRoot() const {
  const Eigen::SelfAdjointEigenSolver<Mat4> eigen(moment_);
  const Vec4 root = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eigen.eigenvectors() * root.asDiagonal();
}

Mat4 DepthModelMatrix(double alpha, double beta) {
  Mat4 D = Mat4::Identity();
  D(3, 2) = beta;
  D(3, 3) = alpha;
  return D;
}

namespace {

/// r = scale L^T pi_c for the pose and plane blocks, and their Jacobians (the header's
/// derivation); scale = 1 / d_c with the ray model.
void EvaluateCluster(const Mat4& L, bool ray_model, double const* const* parameters,
                     double* residuals, double** jacobians) {
  const double* pose = parameters[0];
  const Eigen::Quaterniond q(pose[3], pose[0], pose[1], pose[2]);
  const Eigen::Map<const Vec3> t(pose + 4);
  const Eigen::Map<const Vec3> n(parameters[1]);
  const double d = parameters[1][3];
  const Eigen::Quaterniond q_inverse = q.conjugate();
  Vec4 pi;
  pi.head<3>() = q_inverse * n;
  pi(3) = n.dot(t) + d;
  const double scale = ray_model ? 1.0 / pi(3) : 1.0;
  Eigen::Map<Vec4> r(residuals);
  r = scale * (L.transpose() * pi);
  if (jacobians == nullptr) return;

  // dr = scale (L^T d pi - [ray model] r d(d_c)) for a block with d pi / dx = dpi.
  const auto chain = [&](const auto& dpi, double* out, int columns) {
    Eigen::Map<Eigen::Matrix<double, 4, Eigen::Dynamic, Eigen::RowMajor>> J(out, 4, columns);
    J = scale * (L.transpose() * dpi);
    if (ray_model) J -= scale * r * dpi.row(3);
  };
  if (jacobians[0] != nullptr) {
    Eigen::Matrix<double, 4, kPoseAmbientSize> dpi = Eigen::Matrix<double, 4, 7>::Zero();
    dpi.topLeftCorner<3, 4>() = InverseRotatePointJacobian(q, n);
    dpi.block<1, 3>(3, 4) = n.transpose();
    chain(dpi, jacobians[0], kPoseAmbientSize);
  }
  if (jacobians[1] != nullptr) {
    Mat4 dpi = Mat4::Zero();
    dpi.topLeftCorner<3, 3>() = q_inverse.toRotationMatrix();
    dpi.bottomLeftCorner<1, 3>() = t.transpose();
    dpi(3, 3) = 1.0;
    chain(dpi, jacobians[1], 4);
  }
}

}  // namespace

bool PlaneClusterCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  EvaluateCluster(L_, ray_model_, parameters, residuals, jacobians);
  return true;
}

bool PlaneClusterDepthCost::Evaluate(double const* const* parameters, double* residuals,
                                     double** jacobians) const {
  const double* depth = parameters[2];
  const double alpha = depth[0];
  // r = (D L)^T pi_c / (alpha d_c): the cluster residual with L' = D L, in units of the
  // measured inverse depth's sigma (alpha w + beta has alpha sigma_w).
  EvaluateCluster(DepthModelMatrix(alpha, depth[1]) * L_, true, parameters, residuals, jacobians);
  Eigen::Map<Vec4> r(residuals);
  r /= alpha;
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 4, kPoseAmbientSize, Eigen::RowMajor>>(jacobians[0]) /= alpha;
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(jacobians[1]) /= alpha;
  }
  if (jacobians[2] == nullptr) return true;
  Eigen::Map<Eigen::Matrix<double, 4, kDepthModelSize, Eigen::RowMajor>> J(jacobians[2]);
  J.col(0) = (L_.row(3).transpose() - r) / alpha;  // (L^T e_4 - r) / alpha
  J.col(1) = L_.row(2).transpose() / alpha;        // L^T e_3 / alpha
  return true;
}

}  // namespace rigfit
