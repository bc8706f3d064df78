#include "solver/joint.h"

#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <sstream>

#include "core/geometry.h"
#include "core/stopwatch.h"
#include "residuals/gravity_prior.h"
#include "solver/correspondences.h"
#include "solver/pose_graph.h"

namespace rigfit {
namespace {

/// A pair with fewer correspondences does not link its cameras in this iteration.
constexpr size_t kMinPairCorrespondences = 30;
/// A scale ends when no camera moves by more than this in one outer iteration (rad, m).
constexpr double kConvergedStep = 1e-6;
/// Levenberg-Marquardt iterations per outer iteration (correspondences fixed).
constexpr int kSolverIterationsPerStep = 3;

using PoseBlock = std::array<double, kPoseAmbientSize>;

/// Covariance of every free pose block (tangent space): the inverse of the joint
/// information over the free blocks (Information: whitened residuals, scaled by their
/// measured variance), eigenvalues below 1e-12 of the largest treated as unconstrained
/// (pseudo-inverse). Returns false when the information is empty or not finite.
bool PoseCovariances(ceres::Problem* problem, std::vector<PoseBlock>& blocks,
                     const std::vector<bool>& free, std::vector<Mat6>* out) {
  std::vector<double*> free_blocks;
  std::vector<size_t> index;
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (!free[i]) continue;
    free_blocks.push_back(blocks[i].data());
    index.push_back(i);
  }
  if (free_blocks.empty()) return false;
  std::vector<ceres::ResidualBlockId> residual_blocks;
  problem->GetResidualBlocks(&residual_blocks);
  const Eigen::MatrixXd information = Information(problem, free_blocks, residual_blocks);
  if (!information.allFinite()) return false;
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  if (!(lambda.maxCoeff() > 0.0)) return false;
  Eigen::VectorXd inverse = Eigen::VectorXd::Zero(lambda.size());
  for (int k = 0; k < lambda.size(); ++k) {
    if (lambda(k) > 1e-12 * lambda.maxCoeff()) inverse(k) = 1.0 / lambda(k);
  }
  const Eigen::MatrixXd covariance =
      eig.eigenvectors() * inverse.asDiagonal() * eig.eigenvectors().transpose();
  out->assign(blocks.size(), Mat6::Zero());
  for (size_t k = 0; k < index.size(); ++k) {
    (*out)[index[k]] = covariance.block<6, 6>(6 * k, 6 * k);
  }
  return true;
}

}  // namespace

JointResult RegisterJoint(const std::vector<RegistrationCamera>& cameras,
                          const std::vector<CandidatePair>& pairs, int reference,
                          const IcpOptions& options, int num_threads, const Log& log) {
  const size_t n = cameras.size();
  JointResult result;
  result.poses.resize(n);
  for (size_t i = 0; i < n; ++i) result.poses[i] = cameras[i].T_world_camera;
  result.connected.assign(n, false);
  result.pair_correspondences.assign(pairs.size(), 0);
  result.covariance.assign(n, Mat6::Zero());
  if (n == 0 || cameras[0].pyramid == nullptr) return result;
  const size_t levels = cameras[0].pyramid->levels.size();

  std::vector<PoseBlock> blocks(n);
  for (size_t i = 0; i < n; ++i) PoseToParameters(cameras[i].T_world_camera, blocks[i].data());
  const std::unique_ptr<ceres::LossFunction> loss(MakeCorrespondenceLoss(options));
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = kSolverIterationsPerStep;
  solver_options.num_threads = num_threads;
  solver_options.logging_type = ceres::SILENT;

  std::unique_ptr<ceres::Problem> problem;
  for (size_t s = 0; s < levels; ++s) {
    const double max_distance =
        options.max_correspondence_distance_factor * cameras[0].pyramid->levels[s].voxel_size;
    const int max_iterations = s < options.max_iterations.size() ? options.max_iterations[s] : 0;
    for (int it = 0; it < max_iterations; ++it) {
      std::vector<Pose> current(n);
      std::vector<CameraView> views(n);
      for (size_t i = 0; i < n; ++i) {
        current[i] = PoseFromParameters(blocks[i].data());
        views[i] = {&cameras[i].pyramid->levels[s], current[i], blocks[i].data(),
                    cameras[i].depth_noise};
      }
      auto start = std::chrono::steady_clock::now();
      std::vector<std::vector<Correspondence>> matches(2 * pairs.size());
      for (size_t k = 0; k < pairs.size(); ++k) {
        const CameraView& a = views[pairs[k].a];
        const CameraView& b = views[pairs[k].b];
        matches[2 * k] =
            FindCorrespondences(a, b, max_distance, options.max_normal_angle_deg, num_threads);
        matches[2 * k + 1] =
            FindCorrespondences(b, a, max_distance, options.max_normal_angle_deg, num_threads);
        result.pair_correspondences[k] =
            static_cast<int>(matches[2 * k].size() + matches[2 * k + 1].size());
      }
      result.correspondences_s += SecondsSince(start);
      start = std::chrono::steady_clock::now();
      problem = NewProblem();
      for (PoseBlock& b : blocks) {
        problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
      }
      size_t total = 0;
      std::vector<std::pair<int, int>> links;
      for (size_t k = 0; k < pairs.size(); ++k) {
        const size_t count = result.pair_correspondences[k];
        if (count < kMinPairCorrespondences) continue;
        links.emplace_back(pairs[k].a, pairs[k].b);
        AddCorrespondenceTerms(problem.get(), options, views[pairs[k].a], views[pairs[k].b],
                               matches[2 * k], loss.get());
        AddCorrespondenceTerms(problem.get(), options, views[pairs[k].b], views[pairs[k].a],
                               matches[2 * k + 1], loss.get());
        total += count;
      }
      result.connected = ConnectedTo(reference, n, links);
      for (size_t i = 0; i < n; ++i) {
        if (!result.connected[i]) {
          problem->SetParameterBlockConstant(blocks[i].data());
          continue;
        }
        if (static_cast<int>(i) != reference && options.gravity_weight > 0.0) {
          problem->AddResidualBlock(
              GravityPriorCost::Create(cameras[i].T_world_camera.linear(), options.gravity_weight),
              nullptr, blocks[i].data());
        }
      }
      problem->SetParameterBlockConstant(blocks[reference].data());
      ceres::Solver::Summary summary;
      ceres::Solve(solver_options, problem.get(), &summary);
      result.solve_s += SecondsSince(start);
      ++result.iterations;
      result.usable = summary.IsSolutionUsable();
      if (!result.usable) {
        result.message = "joint solve: " + summary.message;
        return result;
      }
      double max_rotation = 0.0, max_translation = 0.0;
      for (size_t i = 0; i < n; ++i) {
        const Vec6 step = PoseDifference(current[i], PoseFromParameters(blocks[i].data()));
        max_rotation = std::max(max_rotation, step.head<3>().norm());
        max_translation = std::max(max_translation, step.tail<3>().norm());
      }
      std::ostringstream m;
      m << "joint: voxel " << cameras[0].pyramid->levels[s].voxel_size << " iteration " << it
        << ": " << total << " correspondences, cost " << summary.final_cost << ", step "
        << max_rotation * 180.0 / M_PI << " deg " << max_translation * 1e3 << " mm";
      log.Debug(m.str());
      if (max_rotation < kConvergedStep && max_translation < kConvergedStep) break;
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (result.connected[i]) result.poses[i] = PoseFromParameters(blocks[i].data());
  }
  if (problem != nullptr) {
    std::vector<bool> free = result.connected;
    free[reference] = false;
    result.covariance_ok = PoseCovariances(problem.get(), blocks, free, &result.covariance);
  }
  return result;
}

}  // namespace rigfit
