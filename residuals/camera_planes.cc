#include "residuals/camera_planes.h"

#include <Eigen/Eigenvalues>
#include <utility>

#include "residuals/plane_cluster.h"

namespace rigfit {

ceres::CostFunction* CameraPlanesFunctor::CreateAutoDiff(const Eigen::MatrixXd& L, bool ray_model) {
  auto* cost = new ceres::DynamicAutoDiffCostFunction<CameraPlanesFunctor>(
      new CameraPlanesFunctor{L, ray_model});
  cost->AddParameterBlock(kPoseAmbientSize);
  for (int j = 0; j < L.rows() / 4; ++j) cost->AddParameterBlock(4);
  cost->SetNumResiduals(static_cast<int>(L.rows()));
  return cost;
}

CameraPlanesCost::CameraPlanesCost(Eigen::MatrixXd L, bool ray_model)
    : L_(std::move(L)), ray_model_(ray_model) {
  set_num_residuals(static_cast<int>(L_.rows()));
  mutable_parameter_block_sizes()->push_back(kPoseAmbientSize);
  for (int j = 0; j < L_.rows() / 4; ++j) mutable_parameter_block_sizes()->push_back(4);
}

Eigen::MatrixXd CameraPlanesCost::SquareRoot(const Eigen::MatrixXd& M) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(M);
  const Eigen::VectorXd root = eigen.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eigen.eigenvectors() * root.asDiagonal();
}

bool CameraPlanesCost::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const int planes = static_cast<int>(L_.rows()) / 4;
  // Each plane's x_j and dx_j: the plane cluster's residual and Jacobians with L = I.
  const PlaneClusterCost plane_cost(Mat4::Identity(), ray_model_);
  Eigen::VectorXd x(4 * planes);
  RowMajor dx_pose(4 * planes, kPoseAmbientSize);
  Eigen::Matrix<double, 4, 4, Eigen::RowMajor> dx_plane;
  const bool want = jacobians != nullptr;
  for (int j = 0; j < planes; ++j) {
    const double* blocks[2] = {parameters[0], parameters[1 + j]};
    Eigen::Matrix<double, 4, kPoseAmbientSize, Eigen::RowMajor> dpose;
    double* plane_jacobians[2] = {dpose.data(), nullptr};
    if (want && jacobians[1 + j] != nullptr) plane_jacobians[1] = dx_plane.data();
    if (!plane_cost.Evaluate(blocks, x.data() + 4 * j, want ? plane_jacobians : nullptr)) {
      return false;
    }
    if (!want) continue;
    dx_pose.middleRows<4>(4 * j) = dpose;
    if (jacobians[1 + j] != nullptr) {
      Eigen::Map<RowMajor>(jacobians[1 + j], 4 * planes, 4).noalias() =
          L_.middleRows<4>(4 * j).transpose() * dx_plane;
    }
  }
  Eigen::Map<Eigen::VectorXd>(residuals, 4 * planes).noalias() = L_.transpose() * x;
  if (want && jacobians[0] != nullptr) {
    Eigen::Map<RowMajor>(jacobians[0], 4 * planes, kPoseAmbientSize).noalias() =
        L_.transpose() * dx_pose;
  }
  return true;
}

}  // namespace rigfit
