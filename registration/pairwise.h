// Pairwise mode, step 1: multi-scale ICP of one camera pair, each ICP step a Ceres solve,
// with the gravity prior on the moving camera, the fitness gate and the information
// matrix of the final correspondences.
#pragma once

#include <ceres/problem.h>

#include <string>
#include <vector>

#include "core/log.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/preprocess.h"

namespace rigfit {

struct PairwiseResult {
  bool converged = false;  ///< ICP ran to the end (false: too few correspondences)
  bool accepted = false;   ///< converged and fitness >= min_fitness
  std::string message;
  /// The source camera's pose after ICP (the target camera does not move).
  Pose T_world_source = Pose::Identity();
  /// The measured relative pose T_target_source = T_world_target^-1 T_world_source.
  Pose T_target_source = Pose::Identity();
  /// Overlap and fit at the finest level (OverlapStats), at the start and at the end.
  double fitness = 0.0;
  double rmse_before_m = 0.0;
  double rmse_after_m = 0.0;
  int correspondences = 0;  ///< at the end, finest level
  int iterations = 0;       ///< ICP iterations over all scales
  /// Information of the source pose in its PoseManifold tangent (world rotation vector,
  /// world translation), target fixed: J^T J / sigma^2 of the final correspondence
  /// residuals, sigma^2 their measured variance.
  Mat6 information = Mat6::Zero();
};

/// A camera as the registration sees it: its pyramid (levels in the order of
/// options.scales), its leveled pose and its depth noise (k of sigma_z = k z^2, 1/m).
struct RegistrationCamera {
  const CloudPyramid* pyramid = nullptr;
  Pose T_world_camera = Pose::Identity();
  double depth_noise = 0.0;
  double surface_bias = 0.0;  ///< CameraView::surface_bias
};

/// Registers the source camera onto the target camera. The gravity prior keeps the
/// source's pitch/roll near its leveled pose. Never throws on bad geometry.
PairwiseResult RegisterPair(const RegistrationCamera& source, const RegistrationCamera& target,
                            const IcpOptions& options, int num_threads, const Log& log);

}  // namespace rigfit
