#include "registration/pairwise.h"

#include <ceres/solver.h>

#include <memory>
#include <sstream>

#include "prepare/correspondences.h"
#include "residuals/gravity_prior.h"
#include "uncertainty/covariance.h"

namespace rigfit {
namespace {

/// Fewer correspondences than this cannot constrain 6 degrees of freedom reliably.
constexpr size_t kMinCorrespondences = 30;
/// Levenberg-Marquardt iterations per ICP step (correspondences fixed).
constexpr int kSolverIterationsPerStep = 2;

/// One thread: a pair's problem is one stacked correspondence block and the gravity prior,
/// so Ceres has nothing to share out, and its per-thread sums of cost and gradient would
/// make the last bits of a result depend on the thread count (a diverging pair showed it).
ceres::Solver::Options StepSolverOptions() {
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = kSolverIterationsPerStep;
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  return options;
}

}  // namespace

PairwiseResult RegisterPair(const RegistrationCamera& source_camera,
                            const RegistrationCamera& target_camera, const IcpOptions& options,
                            int num_threads, const Log& log) {
  const CloudPyramid& source = *source_camera.pyramid;
  const CloudPyramid& target = *target_camera.pyramid;
  const Pose& T_world_target = target_camera.T_world_camera;
  PairwiseResult result;
  result.T_world_source = source_camera.T_world_camera;
  result.T_target_source = T_world_target.inverse() * result.T_world_source;
  if (source.levels.empty() || target.levels.size() != source.levels.size()) {
    result.message = "no levels to register";
    return result;
  }
  double source_pose[kPoseAmbientSize];
  double target_pose[kPoseAmbientSize];
  PoseToParameters(result.T_world_source, source_pose);
  PoseToParameters(T_world_target, target_pose);
  // The views of level s at the source pose T (the target does not move).
  const auto views = [&](size_t s, const Pose& T) {
    return std::make_pair(
        CameraView{&source.levels[s], T, source_pose, source_camera.depth_noise},
        CameraView{&target.levels[s], T_world_target, target_pose, target_camera.depth_noise});
  };
  const size_t finest = source.levels.size() - 1;
  const double coarsest_voxel = source.levels.front().voxel_size;
  {
    const auto [src, tgt] = views(finest, result.T_world_source);
    result.rmse_before_m = FitRmse(src, tgt, options, num_threads);
  }

  const ceres::Solver::Options solver_options = StepSolverOptions();
  const std::unique_ptr<ceres::LossFunction> loss(MakeCorrespondenceLoss(options));
  for (size_t s = 0; s <= finest; ++s) {
    const double max_distance =
        options.max_correspondence_distance_factor * source.levels[s].voxel_size;
    const int max_iterations = s < options.max_iterations.size() ? options.max_iterations[s] : 0;
    for (int it = 0; it < max_iterations; ++it) {
      const Pose T_current = PoseFromParameters(source_pose);
      const auto [src, tgt] = views(s, T_current);
      const std::vector<Correspondence> matches =
          FindCorrespondences(src, tgt, max_distance, options.max_normal_angle_deg, num_threads);
      if (matches.size() < kMinCorrespondences) {
        std::ostringstream m;
        m << "only " << matches.size() << " correspondences at voxel "
          << source.levels[s].voxel_size << " m";
        result.message = m.str();
        return result;
      }
      std::unique_ptr<ceres::Problem> problem = NewProblem();
      problem->AddParameterBlock(source_pose, kPoseAmbientSize, SharedPoseManifold());
      problem->AddParameterBlock(target_pose, kPoseAmbientSize, SharedPoseManifold());
      problem->SetParameterBlockConstant(target_pose);
      AddCorrespondenceTerms(problem.get(), options, src, tgt, matches, loss.get(),
                             TermStorage::kCompressed);
      if (options.gravity_weight > 0.0) {
        problem->AddResidualBlock(
            GravityPriorCost::Create(source_camera.T_world_camera.linear(), options.gravity_weight),
            nullptr, source_pose);
      }
      ceres::Solver::Summary summary;
      ceres::Solve(solver_options, problem.get(), &summary);
      ++result.iterations;
      const Vec6 step = PoseDifference(T_current, PoseFromParameters(source_pose));
      log.Debug("  voxel " + std::to_string(source.levels[s].voxel_size) + " iteration " +
                std::to_string(it) + ": " + std::to_string(matches.size()) +
                " correspondences, cost " + std::to_string(summary.final_cost));
      if (StepConverged(step, source.levels[s].voxel_size, s == finest)) break;
    }
  }

  result.T_world_source = PoseFromParameters(source_pose);
  result.T_target_source = T_world_target.inverse() * result.T_world_source;
  const auto [src, tgt] = views(finest, result.T_world_source);
  const OverlapStats overlap = MeasureOverlap(src, tgt, coarsest_voxel, options, num_threads);
  result.fitness = overlap.fitness;
  result.rmse_after_m = overlap.rmse_m;
  const std::vector<Correspondence> final_matches = FindCorrespondences(
      src, tgt, options.max_correspondence_distance_factor * src.level->voxel_size,
      options.max_normal_angle_deg, num_threads);
  result.correspondences = static_cast<int>(final_matches.size());
  if (final_matches.size() < kMinCorrespondences) {
    result.message = "only " + std::to_string(final_matches.size()) + " correspondences after ICP";
    return result;
  }
  result.converged = true;
  {
    std::unique_ptr<ceres::Problem> problem = NewProblem();
    problem->AddParameterBlock(source_pose, kPoseAmbientSize, SharedPoseManifold());
    problem->AddParameterBlock(target_pose, kPoseAmbientSize, SharedPoseManifold());
    problem->SetParameterBlockConstant(target_pose);
    AddCorrespondenceTerms(problem.get(), options, src, tgt, final_matches, nullptr,
                           TermStorage::kStacked);
    std::vector<ceres::ResidualBlockId> blocks;
    problem->GetResidualBlocks(&blocks);
    result.information = Information(problem.get(), {source_pose}, blocks);
  }
  if (result.fitness < options.min_fitness) {
    std::ostringstream m;
    m << "fitness " << result.fitness << " below min_fitness " << options.min_fitness;
    result.message = m.str();
    return result;
  }
  result.accepted = true;
  return result;
}

}  // namespace rigfit
