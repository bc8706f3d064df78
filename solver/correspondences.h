// Correspondence search and the registration terms built from correspondences: shared by
// the pairwise and the joint solver.
#pragma once

#include <ceres/loss_function.h>
#include <ceres/problem.h>

#include <memory>
#include <vector>

#include "core/types.h"
#include "solver/options.h"
#include "solver/preprocess.h"

namespace rigfit {

/// Point `source` of one camera's level matched to point `target` of another's.
struct Correspondence {
  int source = 0;
  int target = 0;
  double squared_distance = 0.0;  ///< in the world, at the poses of the search (m^2)
};

/// For every source point, the nearest target point closer than max_distance at the given
/// poses, kept when both points have a valid normal and the normals are within
/// max_normal_angle_deg of each other: points of different surfaces (the faces of a leg or
/// a box corner that each camera sees differently) do not pair up. Ordered by source
/// index; deterministic whatever num_threads.
std::vector<Correspondence> FindCorrespondences(const ScaleLevel& source,
                                                const Pose& T_world_source,
                                                const ScaleLevel& target,
                                                const Pose& T_world_target, double max_distance,
                                                double max_normal_angle_deg, int num_threads);

/// One camera's side of a registration term: its cloud at the current scale, its pose (as
/// used for the correspondence search), its Ceres pose block and its depth noise model.
struct CameraView {
  const ScaleLevel* level = nullptr;
  Pose T_world_camera = Pose::Identity();
  double* pose_block = nullptr;
  double depth_noise = 0.0;  ///< k of sigma_z = k z^2 (1/m); 0 for none
};

/// The robust loss of the options on whitened residuals (nullptr for none).
ceres::LossFunction* MakeCorrespondenceLoss(const IcpOptions& options);

/// Adds one residual block per correspondence (point-to-plane or GICP, per
/// options.method) between the pose blocks of the source and target cameras, each
/// whitened by the depth noise model of both points (docs/residuals.md, "Weights"):
/// a depth error moves a point along its ray, so a point p at depth z has covariance
/// k^2 z^2 p p^T in its camera frame, plus min_noise_m^2 per residual. GICP weights use
/// the poses of the views. The problem owns the cost functions, the caller `loss`.
void AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                            const CameraView& source, const CameraView& target,
                            const std::vector<Correspondence>& correspondences,
                            ceres::LossFunction* loss);

/// A problem that does not own loss functions or manifolds (they are shared by many
/// blocks and owned by the caller), but owns cost functions.
std::unique_ptr<ceres::Problem> NewProblem();

/// The pose manifold shared by every pose block (stateless; never owned by a problem).
ceres::Manifold* SharedPoseManifold();

/// Root mean square of the correspondence distances (m); 0 when there are none.
double CorrespondenceRmse(const std::vector<Correspondence>& correspondences);

}  // namespace rigfit
