// Correspondence search and the registration terms built from correspondences, weighed by the
// depth noise model: shared by the pairwise and the joint solver (and the covariance of their
// poses, uncertainty/covariance.h).
#pragma once

#include <ceres/loss_function.h>
#include <ceres/problem.h>

#include <memory>
#include <vector>

#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/preprocess.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"

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
  /// 1-sigma of the offset a surface's inverse depth has, the same over the surface (1/m; a
  /// stereo camera's per-surface disparity bias, IcpOptions::surface_bias_px); 0 for none. It
  /// widens the covariance (SharedNoiseCovariance), not the weights.
  double surface_bias = 0.0;
};

/// The correspondences of one pair direction between two views.
struct MatchedViews {
  const CameraView* source = nullptr;
  const CameraView* target = nullptr;
  const std::vector<Correspondence>* matches = nullptr;
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

/// The noise of point p of a view (its camera frame), as the weights model it (docs/residuals.md,
/// "Weights"): its depth error along the ray, k^2 z^2 p p^T, plus its plane-error share,
/// (plane_noise_share k z^2)^2, isotropic; GICP puts half the residual floor into each point's
/// noise too (`floor_share`).
Mat3 PointNoise(const CameraView& view, const Vec3& p, const IcpOptions& options,
                double floor_share);

/// The whitened point-to-plane term of a correspondence: r is linear in n, so a normal
/// scaled by 1 / sigma whitens it.
PointToPlaneTerm MakePointToPlaneTerm(const CameraView& source, const CameraView& target,
                                      const Correspondence& c, const IcpOptions& options);

/// The GICP term of a correspondence: the covariance of a point is its plane-regularised
/// shape, V diag(1, 1, eps) V^T (m^2: the in-plane freedom stays, 1 m^2 as in small_gicp; the
/// eps along the normal is replaced by the noise model), plus PointNoise with half the floor.
GicpTerm MakeGicpTerm(const CameraView& source, const CameraView& target, const Correspondence& c,
                      const IcpOptions& options);

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
/// the pose blocks of the views of `m` (source and target), each whitened by the depth noise model
/// of both points (docs/residuals.md, "Weights"): a depth error moves a point along its ray,
/// so a point p at depth z has covariance k^2 z^2 p p^T in its camera frame, plus the
/// plane-error share (plane_noise_share k z^2)^2 and min_noise_m^2 per residual. GICP
/// weights use the poses of the views. All of them form ONE cost function over the blocks
/// (m.source->pose_block, m.target->pose_block), stored as `storage` says, `loss` entering as
/// iteratively reweighted least squares at the current values of the pose blocks. Null
/// when there are no correspondences. Reads only, so calls may run concurrently.
std::unique_ptr<ceres::CostFunction> CorrespondenceCost(const IcpOptions& options,
                                                        const MatchedViews& m,
                                                        const ceres::LossFunction* loss,
                                                        TermStorage storage);

/// Adds CorrespondenceCost(...) to `problem` between the views' pose blocks (the problem
/// owns it, the caller `loss`). Returns the residual block (nullptr when there are no
/// correspondences).
ceres::ResidualBlockId AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                                              const MatchedViews& m,
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

}  // namespace rigfit
