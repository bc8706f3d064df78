#include "solver/correspondences.h"

#include <ceres/crs_matrix.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "core/parallel.h"
#include "residuals/compressed_cost.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"
#include "residuals/stacked_cost.h"

namespace rigfit {
namespace {

/// A normal angle that accepts every pair of normals (overlap statistics).
constexpr double kAnyNormalAngleDeg = 180.0;

/// The normal check never widens beyond this (degrees): far below the 90 degrees between
/// the faces of a box corner or a leg, which must not pair up.
constexpr double kWidestNoisyNormalAngleDeg = 60.0;

}  // namespace

std::vector<Correspondence> FindCorrespondences(const CameraView& source, const CameraView& target,
                                                double max_distance, double max_normal_angle_deg,
                                                int num_threads) {
  const ScaleLevel& src = *source.level;
  const ScaleLevel& tgt = *target.level;
  const Pose T_target_source = target.T_world_camera.inverse() * source.T_world_camera;
  const double max_angle = max_normal_angle_deg * M_PI / 180.0;
  const double widest_angle = std::max(max_angle, kWidestNoisyNormalAngleDeg * M_PI / 180.0);
  const double cos_max_angle = std::cos(max_angle);
  const double cos_widest_angle = std::cos(widest_angle);
  // The normal error of a point, as an angle: its depth noise over its normal's support.
  const auto normal_error = [](const CameraView& view, const Vec3& p) {
    const double support = view.level->normal_support;
    return support > 0.0 ? std::atan(view.depth_noise * p.z() * p.z() / support) : 0.0;
  };
  const int n = static_cast<int>(src.points.size());
  std::vector<Correspondence> found(n);
  std::vector<char> ok(n, 0);
  ParallelFor(n, num_threads, [&](int i) {
    if (!src.geometry.IsValid(i)) return;
    int j = 0;
    double d2 = 0.0;
    if (!tgt.tree->Nearest(T_target_source * src.points[i], max_distance, &j, &d2) ||
        !tgt.geometry.IsValid(j)) {
      return;
    }
    // The widened angle lies between max_angle and widest_angle: only normals between the
    // two need it.
    const double cos_between =
        (T_target_source.linear() * src.geometry.normals[i]).dot(tgt.geometry.normals[j]);
    if (cos_between < cos_widest_angle) return;
    if (cos_between < cos_max_angle) {
      const double angle = std::min(
          max_angle + normal_error(source, src.points[i]) + normal_error(target, tgt.points[j]),
          widest_angle);
      if (cos_between < std::cos(angle)) return;
    }
    found[i] = {i, j, d2};
    ok[i] = 1;
  });
  std::vector<Correspondence> out;
  out.reserve(n);
  for (int i = 0; i < n; ++i) {
    if (ok[i]) out.push_back(found[i]);
  }
  return out;
}

bool StepConverged(const Vec6& step, double voxel_size, bool finest) {
  // A coarser scale only has to bring the cameras well inside the next scale's
  // correspondence distance: 0.05 of its own voxel against 1.4 of the next one's (half as
  // large by default) is 14 times inside.
  constexpr double kConvergedStepVoxels = 0.01;
  constexpr double kCoarseConvergedStepVoxels = 0.05;
  const double limit = (finest ? kConvergedStepVoxels : kCoarseConvergedStepVoxels) * voxel_size;
  constexpr double kLeverM = 1.0;  // rotation as arc length at this radius
  return step.head<3>().norm() * kLeverM < limit && step.tail<3>().norm() < limit;
}

double PointToPlaneVariance(const CameraView& source, const CameraView& target,
                            const Correspondence& c, const IcpOptions& options) {
  const Vec3& p = source.level->points[c.source];
  const Vec3& q = target.level->points[c.target];
  const Vec3& n_t = target.level->geometry.normals[c.target];
  // The target normal in the source frame: R_s^T R_t n_t.
  const double np =
      (source.T_world_camera.linear().transpose() * (target.T_world_camera.linear() * n_t)).dot(p);
  const double nq = n_t.dot(q);
  const double k_s = source.depth_noise * p.z() * np;
  const double k_t = target.depth_noise * q.z() * nq;
  // The share of the whole depth noise that counts whatever the normal.
  const double f_s = options.plane_noise_share * source.depth_noise * p.z() * p.z();
  const double f_t = options.plane_noise_share * target.depth_noise * q.z() * q.z();
  return k_s * k_s + k_t * k_t + f_s * f_s + f_t * f_t + options.min_noise_m * options.min_noise_m;
}

ceres::LossFunction* MakeCorrespondenceLoss(const IcpOptions& options) {
  const double scale = options.robust_loss_scale;
  switch (options.robust_loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kTukey:
      return new ceres::TukeyLoss(scale);
    case RobustLoss::kNone:
      return nullptr;
  }
  return nullptr;
}

std::unique_ptr<ceres::CostFunction> CorrespondenceCost(
    const IcpOptions& options, const CameraView& source, const CameraView& target,
    const std::vector<Correspondence>& correspondences, const ceres::LossFunction* loss,
    TermStorage storage) {
  const ScaleLevel& src = *source.level;
  const ScaleLevel& tgt = *target.level;
  const double k_s2 = source.depth_noise * source.depth_noise;
  const double k_t2 = target.depth_noise * target.depth_noise;
  const double floor2 = options.min_noise_m * options.min_noise_m;
  // GICP shapes are plane-regularised, V diag(1, 1, eps) V^T (m^2): the in-plane freedom
  // stays (1 m^2, as in small_gicp), the eps along the normal is replaced by the noise model.
  const auto shape = [](const LocalGeometry& g, int i) {
    return Mat3(g.covariances[i] - kGicpPlaneEpsilon * g.normals[i] * g.normals[i].transpose());
  };
  const double* parameters[2] = {source.pose_block, target.pose_block};
  // term(c) of every correspondence c into `cost`, weighted by the loss at the views' poses.
  const auto add_terms = [&](auto* cost, const auto& term) {
    for (const Correspondence& c : correspondences) {
      const auto t = term(c);
      using Term = std::decay_t<decltype(t)>;
      double r[Term::kNumResiduals];
      t.Evaluate(parameters[0], parameters[1], r, nullptr, nullptr);
      cost->Add(t, RobustWeight(loss, r, Term::kNumResiduals));
    }
  };
  const auto add_block = [&](const auto& term) -> std::unique_ptr<ceres::CostFunction> {
    if (correspondences.empty()) return nullptr;
    using Term = std::decay_t<decltype(term(correspondences.front()))>;
    if (storage == TermStorage::kStacked) {
      auto stacked = std::make_unique<StackedCost<Term>>();
      stacked->Reserve(correspondences.size());
      add_terms(stacked.get(), term);
      return stacked;
    }
    auto compressed = std::make_unique<CompressedCost<Term>>();
    add_terms(compressed.get(), term);
    compressed->Compress();
    return compressed;
  };
  if (options.method == RegistrationMethod::kGicp) {
    // Covariance of a point: in-plane shape + k^2 z^2 p p^T (depth noise along the ray)
    // + its plane-error share beta^2 k^2 z^4 and half of the residual floor, isotropic.
    const double share2 = options.plane_noise_share * options.plane_noise_share;
    return add_block([&](const Correspondence& c) {
      const Vec3& p = src.points[c.source];
      const Vec3& q = tgt.points[c.target];
      const Mat3 C_p = shape(src.geometry, c.source) + k_s2 * p.z() * p.z() * p * p.transpose() +
                       (share2 * k_s2 * std::pow(p.z(), 4) + 0.5 * floor2) * Mat3::Identity();
      const Mat3 C_q = shape(tgt.geometry, c.target) + k_t2 * q.z() * q.z() * q * q.transpose() +
                       (share2 * k_t2 * std::pow(q.z(), 4) + 0.5 * floor2) * Mat3::Identity();
      return GicpCost::MakeTerm(p, q, C_p, C_q, source.T_world_camera.linear(),
                                target.T_world_camera.linear());
    });
  }
  // r is linear in n, so a normal scaled by 1 / sigma whitens it.
  return add_block([&](const Correspondence& c) {
    const double variance = PointToPlaneVariance(source, target, c, options);
    return PointToPlaneTerm{src.points[c.source], tgt.points[c.target],
                            tgt.geometry.normals[c.target] / std::sqrt(variance)};
  });
}

ceres::ResidualBlockId AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                                              const CameraView& source, const CameraView& target,
                                              const std::vector<Correspondence>& correspondences,
                                              const ceres::LossFunction* loss,
                                              TermStorage storage) {
  std::unique_ptr<ceres::CostFunction> cost =
      CorrespondenceCost(options, source, target, correspondences, loss, storage);
  if (cost == nullptr) return nullptr;
  return problem->AddResidualBlock(cost.release(), nullptr, source.pose_block, target.pose_block);
}

std::unique_ptr<ceres::Problem> NewProblem() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return std::make_unique<ceres::Problem>(options);
}

ceres::Manifold* SharedPoseManifold() {
  static PoseManifold manifold;
  return &manifold;
}

OverlapStats MeasureOverlap(const CameraView& source, const CameraView& target,
                            double coarsest_voxel_size, const IcpOptions& options,
                            int num_threads) {
  OverlapStats stats;
  const size_t n = source.level->points.size();
  if (n == 0) return stats;
  const double factor = options.max_correspondence_distance_factor;
  const double fit_distance = factor * source.level->voxel_size;
  // One search at the wider distance serves both: a point's nearest neighbour within the
  // narrower one is its nearest neighbour within the wider one, when that is close enough.
  const std::vector<Correspondence> matches = FindCorrespondences(
      source, target, factor * std::max(coarsest_voxel_size, source.level->voxel_size),
      kAnyNormalAngleDeg, num_threads);
  stats.fitness = static_cast<double>(matches.size()) / n;
  double sum = 0.0;
  int fits = 0;
  for (const Correspondence& c : matches) {
    if (c.squared_distance >= fit_distance * fit_distance) continue;
    sum += c.squared_distance;
    ++fits;
  }
  stats.rmse_m = fits > 0 ? std::sqrt(sum / fits) : 0.0;
  return stats;
}

namespace {

/// The Jacobian (PoseManifold tangents of `blocks`, in order) and residuals of the given
/// residual blocks, loss functions not applied; constant blocks are evaluated as variables.
void EvaluateJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                      const std::vector<ceres::ResidualBlockId>& residual_blocks,
                      std::vector<double>* residuals, ceres::CRSMatrix* J) {
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = blocks;
  eval.residual_blocks = residual_blocks;
  eval.apply_loss_function = false;
  std::vector<double*> made_variable;
  for (double* block : blocks) {
    if (!problem->IsParameterBlockConstant(block)) continue;
    problem->SetParameterBlockVariable(block);
    made_variable.push_back(block);
  }
  problem->Evaluate(eval, nullptr, residuals, nullptr, J);
  for (double* block : made_variable) problem->SetParameterBlockConstant(block);
}

/// J^T J of a sparse Jacobian (dense, J.num_cols square).
Eigen::MatrixXd Gram(const ceres::CRSMatrix& J) {
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(J.num_cols, J.num_cols);
  for (int row = 0; row < J.num_rows; ++row) {
    for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
      for (int b = J.rows[row]; b < J.rows[row + 1]; ++b) {
        JtJ(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
      }
    }
  }
  return JtJ;
}

}  // namespace

Eigen::MatrixXd Information(ceres::Problem* problem, const std::vector<double*>& blocks,
                            const std::vector<ceres::ResidualBlockId>& residual_blocks,
                            bool scale_by_residuals) {
  std::vector<double> residuals;
  ceres::CRSMatrix J;
  EvaluateJacobian(problem, blocks, residual_blocks, &residuals, &J);
  const Eigen::MatrixXd JtJ = Gram(J);
  if (!scale_by_residuals) return JtJ;
  double sum_sq = 0.0;
  for (double r : residuals) sum_sq += r * r;
  const double dof = static_cast<double>(residuals.size()) - J.num_cols;
  if (dof <= 0.0 || sum_sq <= 0.0) return JtJ;
  return JtJ / (sum_sq / dof);
}

Eigen::MatrixXd ClusterRobustCovariance(ceres::Problem* problem, const std::vector<double*>& blocks,
                                        const std::vector<ceres::ResidualBlockId>& residual_blocks,
                                        const std::vector<int>& row_cluster) {
  std::vector<double> residuals;
  ceres::CRSMatrix J;
  EvaluateJacobian(problem, blocks, residual_blocks, &residuals, &J);
  if (J.num_rows != static_cast<int>(row_cluster.size()) || J.num_cols == 0) return {};
  const Eigen::MatrixXd H = Gram(J);
  if (!H.allFinite()) return {};
  const int clusters = *std::max_element(row_cluster.begin(), row_cluster.end()) + 1;
  if (clusters < 2) return {};
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(J.num_cols, clusters);
  for (int row = 0; row < J.num_rows; ++row) {
    for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
      g(J.cols[a], row_cluster[row]) += J.values[a] * residuals[row];
    }
  }
  const Eigen::MatrixXd meat = g * g.transpose() * (clusters / (clusters - 1.0));
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  if (!(lambda.maxCoeff() > 0.0)) return {};
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(lambda.size());
  for (int k = 0; k < lambda.size(); ++k) {
    if (lambda(k) > 1e-12 * lambda.maxCoeff()) inverse(k) = 1.0 / lambda(k);
  }
  const Eigen::MatrixXd H_plus =
      eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  Eigen::MatrixXd covariance = H_plus * meat * H_plus;
  if (!covariance.allFinite()) return {};
  return covariance;
}

}  // namespace rigfit
