// Correspondence search and the registration terms built from correspondences: shared by
// the pairwise and the joint solver.
#pragma once

#include <ceres/loss_function.h>
#include <ceres/problem.h>

#include <memory>
#include <vector>

#include "core/types.h"
#include "rig/options.h"
#include "rig/preprocess.h"

namespace rigfit {

/// Point `source` of one camera's level matched to point `target` of another's.
struct Correspondence {
  int source = 0;
  int target = 0;
  double squared_distance = 0.0;  ///< in the world, at the poses of the search (m^2)
};

/// One camera's side of a registration term: its cloud at the current scale, its pose (as
/// used for the correspondence search), its Ceres pose block and its depth noise model.
struct CameraView {
  const ScaleLevel* level = nullptr;
  Pose T_world_camera = Pose::Identity();
  double* pose_block = nullptr;
  double depth_noise = 0.0;  ///< k of sigma_z = k z^2 (1/m); 0 for none
};

/// For every source point, the nearest target point at the views' poses, kept when both
/// points have a valid normal and the normals are within max_normal_angle_deg of each
/// other (points of different surfaces, such as the faces of a leg or a box corner that
/// each camera sees differently, do not pair up), widened by the expected error of both
/// normals under the depth noise, atan(k z^2 / normal_support) each, up to 60 degrees: a
/// fixed angle rejects far, noisy points by the noise of their normals, a selection that
/// measured as a bias (docs/benchmarks.md); 60 degrees still keeps perpendicular faces apart. The
/// search radius is max_distance: a radius widened with the depth noise (3 sigma at the points'
/// depth) was measured to bias far points toward the wrong structure (docs/benchmarks.md). Ordered
/// by source index; deterministic whatever num_threads.
std::vector<Correspondence> FindCorrespondences(const CameraView& source, const CameraView& target,
                                                double max_distance, double max_normal_angle_deg,
                                                int num_threads);

/// Whether an outer ICP iteration (correspondences found, then the poses solved with them
/// fixed) has converged at a scale: its pose step, PoseDifference(before, after), moved the
/// camera by less than 0.01 voxel_size at the finest scale (0.2 mm at a 2 cm voxel) and
/// 0.05 voxel_size at a coarser one, which only has to hand over well inside the next
/// scale's correspondence distance; translation in metres, rotation as arc length at 1 m.
/// Re-found correspondences of noisy points keep moving the optimum a little at every
/// iteration; steps this small are far below the scale's resolution (docs/benchmarks.md).
bool StepConverged(const Vec6& step, double voxel_size, bool finest);

/// Variance (m^2) of the point-to-plane residual n . (T_s p - T_t q) of a correspondence
/// under the depth noise model of both views (docs/residuals.md, "Weights"): each point's
/// depth noise projected on the target normal, (k z (n . p))^2, plus the plane-error share of
/// its whole depth noise, (plane_noise_share k z^2)^2, plus min_noise_m^2.
double PointToPlaneVariance(const CameraView& source, const CameraView& target,
                            const Correspondence& c, const IcpOptions& options);

/// The robust loss of the options on whitened residuals (nullptr for none).
ceres::LossFunction* MakeCorrespondenceLoss(const IcpOptions& options);

/// How CorrespondenceCost stores the terms of a camera pair.
enum class TermStorage {
  /// StackedCost: one row (point-to-plane) or three (GICP) per correspondence, in order.
  /// For what needs the rows, such as a residual variance.
  kStacked,
  /// CompressedCost: the same cost, gradient and Gauss-Newton matrix at every pose in
  /// 13 (point-to-plane) or 24 (GICP) rows, whatever the number of correspondences. For
  /// solving.
  kCompressed,
};

/// The terms of the correspondences (point-to-plane or GICP, per options.method) between
/// the pose blocks of the source and target cameras, each whitened by the depth noise model
/// of both points (docs/residuals.md, "Weights"): a depth error moves a point along its ray,
/// so a point p at depth z has covariance k^2 z^2 p p^T in its camera frame, plus the
/// plane-error share (plane_noise_share k z^2)^2 and min_noise_m^2 per residual. GICP
/// weights use the poses of the views. All of them form ONE cost function over the blocks
/// (source.pose_block, target.pose_block), stored as `storage` says, `loss` entering as
/// iteratively reweighted least squares at the current values of the pose blocks. Null
/// when there are no correspondences. Reads only, so calls may run concurrently.
std::unique_ptr<ceres::CostFunction> CorrespondenceCost(
    const IcpOptions& options, const CameraView& source, const CameraView& target,
    const std::vector<Correspondence>& correspondences, const ceres::LossFunction* loss,
    TermStorage storage);

/// Adds CorrespondenceCost(...) to `problem` between the views' pose blocks (the problem
/// owns it, the caller `loss`). Returns the residual block (nullptr when there are no
/// correspondences).
ceres::ResidualBlockId AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                                              const CameraView& source, const CameraView& target,
                                              const std::vector<Correspondence>& correspondences,
                                              const ceres::LossFunction* loss, TermStorage storage);

/// A problem that does not own loss functions or manifolds (they are shared by many
/// blocks and owned by the caller), but owns cost functions.
std::unique_ptr<ceres::Problem> NewProblem();

/// The pose manifold shared by every pose block (stateless; never owned by a problem).
ceres::Manifold* SharedPoseManifold();

/// How much two views overlap and how well they fit.
struct OverlapStats {
  /// Fraction of source points with a target point within the coarsest scale's
  /// correspondence distance, so that depth noise larger than the finest voxel does not
  /// read as missing overlap (normals not compared).
  double fitness = 0.0;
  /// Point-to-point RMSE of the matches within the view's own scale's correspondence
  /// distance (normals not compared), m.
  double rmse_m = 0.0;
};
OverlapStats MeasureOverlap(const CameraView& source, const CameraView& target,
                            double coarsest_voxel_size, const IcpOptions& options, int num_threads);

/// MeasureOverlap(...).rmse_m alone, from a search within the view's own scale's
/// correspondence distance only (the grid's radius), not the coarsest one: cheaper.
double FitRmse(const CameraView& source, const CameraView& target, const IcpOptions& options,
               int num_threads);

/// Information of the given pose blocks (PoseManifold tangents, in the order given,
/// 6 per block) from the given residual blocks: J^T J / sigma^2 with sigma^2 = sum r^2 /
/// (m - 6 k) when scale_by_residuals, else J^T J (residuals already whitened by a known
/// noise model); loss functions not applied; the other blocks are held at their values.
Eigen::MatrixXd Information(ceres::Problem* problem, const std::vector<double*>& blocks,
                            const std::vector<ceres::ResidualBlockId>& residual_blocks,
                            bool scale_by_residuals = true);

/// The correspondences of one pair direction between two views.
struct MatchedViews {
  const CameraView* source = nullptr;
  const CameraView* target = nullptr;
  const std::vector<Correspondence>* matches = nullptr;
};

/// Covariance of the poses that weighted least squares over the terms of `terms`
/// (CorrespondenceCost's terms of options.method and weights, loss not applied) estimates,
/// when the noise is the one the weights model but belongs to the POINTS, not to the terms:
/// each point p of a view has one error, of covariance k^2 z^2 p p^T (depth, along its ray)
/// + (plane_noise_share k z^2)^2 I (plane error) in its camera frame, and that same error
/// enters every term the point is in, as source or target, in every pair. The residual
/// floor min_noise_m is independent per term (point-to-plane) or half of it per point (GICP),
/// as in the weights. Linearised at the views' pose blocks (T_world_camera gives the GICP
/// weights' rotations and the point-to-plane noise projection; keep the two equal):
///   C = H^-1 (sum_p s_p C_p s_p^T + sum_t J_t^T F_t J_t + P) H^-1,
///   H = sum_t J_t^T J_t + P,   s_p = sum over the terms t of point p of J_t^T dr_t/dp,
/// with r_t the whitened residuals, J_t their tangent Jacobians, F_t their independent
/// variance and P = prior_information (the gravity priors', independent of the points).
/// For point-to-plane, whose weights are exactly that noise, C = H^-1 when every point is in
/// one term; counting the same points twice leaves C unchanged where it halves H^-1 (both
/// methods). `column[v]` is 6 times view v's index among the free views (its first tangent
/// column of C), -1 for a view held fixed; C is prior_information's size. Empty when there
/// are no terms or free views, or when H is singular (information below 1e-12 of the
/// largest in some direction, e.g. a free view in no term). The views' points are
/// split over up to num_threads threads; the result does not depend on it.
Eigen::MatrixXd SharedNoiseCovariance(const std::vector<CameraView>& views,
                                      const std::vector<int>& column,
                                      const std::vector<MatchedViews>& terms,
                                      const IcpOptions& options,
                                      const Eigen::MatrixXd& prior_information, int num_threads);

}  // namespace rigfit
