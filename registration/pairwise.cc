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

/// The pair's two pose blocks (the target held constant) and its views.
struct PairBlocks {
  const RegistrationCamera& source_camera;
  const RegistrationCamera& target_camera;
  double source_pose[kPoseAmbientSize];
  double target_pose[kPoseAmbientSize];

  PairBlocks(const RegistrationCamera& source, const RegistrationCamera& target)
      : source_camera(source), target_camera(target) {
    PoseToParameters(source.T_world_camera, source_pose);
    PoseToParameters(target.T_world_camera, target_pose);
  }
  /// The views of level s at the source pose T (the target does not move).
  std::pair<CameraView, CameraView> Views(size_t s, const Pose& T) {
    return std::make_pair(
        CameraView{&source_camera.pyramid->levels[s], T, source_pose, source_camera.depth_noise},
        CameraView{&target_camera.pyramid->levels[s], target_camera.T_world_camera, target_pose,
                   target_camera.depth_noise});
  }
  /// A problem over both blocks, the target's constant.
  std::unique_ptr<ceres::Problem> Problem() {
    std::unique_ptr<ceres::Problem> problem = NewProblem();
    problem->AddParameterBlock(source_pose, kPoseAmbientSize, SharedPoseManifold());
    problem->AddParameterBlock(target_pose, kPoseAmbientSize, SharedPoseManifold());
    problem->SetParameterBlockConstant(target_pose);
    return problem;
  }
};

/// ICP coarse to fine: correspondences re-found at every step, then a few Levenberg-Marquardt
/// iterations. False (with the message set) when a step has too few correspondences.
bool IterateLevels(PairBlocks* pair, const IcpOptions& options, int num_threads, const Log& log,
                   PairwiseResult* result) {
  const CloudPyramid& source = *pair->source_camera.pyramid;
  const size_t finest = source.levels.size() - 1;
  const ceres::Solver::Options solver_options = StepSolverOptions();
  const std::unique_ptr<ceres::LossFunction> loss(MakeCorrespondenceLoss(options));
  for (size_t s = 0; s <= finest; ++s) {
    const double voxel = source.levels[s].voxel_size;
    const double max_distance = options.max_correspondence_distance_factor * voxel;
    const int max_iterations = s < options.max_iterations.size() ? options.max_iterations[s] : 0;
    for (int it = 0; it < max_iterations; ++it) {
      const Pose T_current = PoseFromParameters(pair->source_pose);
      const auto [src, tgt] = pair->Views(s, T_current);
      const std::vector<Correspondence> matches =
          FindCorrespondences(src, tgt, max_distance, options.max_normal_angle_deg, num_threads);
      if (matches.size() < kMinCorrespondences) {
        std::ostringstream m;
        m << "only " << matches.size() << " correspondences at voxel " << voxel << " m";
        result->message = m.str();
        return false;
      }
      std::unique_ptr<ceres::Problem> problem = pair->Problem();
      AddCorrespondenceTerms(problem.get(), options, {&src, &tgt, &matches}, loss.get(),
                             TermStorage::kCompressed);
      if (options.gravity_weight > 0.0) {
        problem->AddResidualBlock(
            GravityPriorCost::Create(pair->source_camera.T_world_camera.linear(),
                                     options.gravity_weight),
            nullptr, pair->source_pose);
      }
      ceres::Solver::Summary summary;
      ceres::Solve(solver_options, problem.get(), &summary);
      ++result->iterations;
      const Vec6 step = PoseDifference(T_current, PoseFromParameters(pair->source_pose));
      log.Debug("  voxel " + std::to_string(voxel) + " iteration " + std::to_string(it) + ": " +
                std::to_string(matches.size()) + " correspondences, cost " +
                std::to_string(summary.final_cost));
      if (StepConverged(step, voxel, s == finest)) break;
    }
  }
  return true;
}

}  // namespace

PairwiseResult RegisterPair(const RegistrationCamera& source_camera,
                            const RegistrationCamera& target_camera, const IcpOptions& options,
                            int num_threads, const Log& log) {
  const CloudPyramid& source = *source_camera.pyramid;
  const Pose& T_world_target = target_camera.T_world_camera;
  PairwiseResult result;
  result.T_world_source = source_camera.T_world_camera;
  result.T_target_source = T_world_target.inverse() * result.T_world_source;
  if (source.levels.empty() || target_camera.pyramid->levels.size() != source.levels.size()) {
    result.message = "no levels to register";
    return result;
  }
  PairBlocks pair(source_camera, target_camera);
  const size_t finest = source.levels.size() - 1;
  {
    const auto [src, tgt] = pair.Views(finest, result.T_world_source);
    result.rmse_before_m = FitRmse(src, tgt, options, num_threads);
  }
  if (!IterateLevels(&pair, options, num_threads, log, &result)) return result;

  result.T_world_source = PoseFromParameters(pair.source_pose);
  result.T_target_source = T_world_target.inverse() * result.T_world_source;
  const auto [src, tgt] = pair.Views(finest, result.T_world_source);
  const OverlapStats overlap =
      MeasureOverlap(src, tgt, source.levels.front().voxel_size, options, num_threads);
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
    std::unique_ptr<ceres::Problem> problem = pair.Problem();
    AddCorrespondenceTerms(problem.get(), options, {&src, &tgt, &final_matches}, nullptr,
                           TermStorage::kStacked);
    std::vector<ceres::ResidualBlockId> blocks;
    problem->GetResidualBlocks(&blocks);
    result.information = Information(problem.get(), {pair.source_pose}, blocks);
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
