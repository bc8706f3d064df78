// The uncertainty of registered poses: the information of pose blocks from a problem's
// residual blocks, and the covariance of the poses when the depth noise belongs to the points,
// shared by every term a point is in (docs/residuals.md). Used by the pairwise and the joint
// solver.
#pragma once

#include <ceres/problem.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "options/refine_options.h"
#include "prepare/correspondences.h"
#include "uncertainty/inflation.h"

namespace rigfit {

/// Information of the given pose blocks (PoseManifold tangents, in the order given,
/// 6 per block) from the given residual blocks: J^T J / sigma^2 with sigma^2 = sum r^2 /
/// (m - 6 k) when scale_by_residuals, else J^T J (residuals already whitened by a known
/// noise model); loss functions not applied; the other blocks are held at their values.
Eigen::MatrixXd Information(ceres::Problem* problem, const std::vector<double*>& blocks,
                            const std::vector<ceres::ResidualBlockId>& residual_blocks,
                            bool scale_by_residuals = true);

/// The inverse of a symmetric positive semi-definite matrix; empty when it is singular or
/// nearly so (an eigenvalue at most 1e-12 of the largest): a direction nothing constrains has
/// no finite covariance, and reporting it as 0 would read as "known exactly".
Eigen::MatrixXd InverseOrEmpty(const Eigen::MatrixXd& H);

/// The Jacobian (PoseManifold tangents of `blocks`, in order; the manifolds' tangents of the
/// others) and residuals of the given residual blocks, rows in their order, loss functions not
/// applied; constant blocks are evaluated as variables.
void EvaluateJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                      const std::vector<ceres::ResidualBlockId>& residual_blocks,
                      std::vector<double>* residuals, ceres::CRSMatrix* J);

/// Covariance of the pose blocks `poses` (PoseManifold tangents, 6 each, in the order given; a
/// block of another tangent size, e.g. a surface bundle camera's depth model, takes its own
/// columns) with the blocks `nuisance` marginalised (their own manifolds' tangents), from every
/// residual block of the problem, whose residuals are whitened (no scale, loss functions not
/// applied): the inverse of the Schur complement A - sum_j B_j D_j^-1 B_j^T of J^T J. No
/// residual block may hold two nuisance blocks (their information is then block diagonal, as
/// the planes' of the surface bundle): std::logic_error otherwise. A nuisance block in no
/// residual block is left out (as ceres::Covariance does); empty when one is constrained in
/// some directions only, or the poses are not constrained (an eigenvalue at most 1e-12 of the
/// largest). The
/// blocks' order is the one given, not their addresses (ceres::Covariance sorts the blocks by
/// address, so its last digits depended on where the heap put them).
///
/// With `robust` (not null): also the covariance robust to errors shared by the residuals of
/// each nuisance block (a plane's pixels share its model error, the noise's correlation and
/// its wrongly assigned pixels, which the noise model does not know): the cluster-robust
/// sandwich with the small-sample correction "CR2" (Bell and McCaffrey 2002), each nuisance
/// block's residual blocks one cluster,
///   C_R = sum_j d_j d_j^T + C P C,   d_j = S (I - S L_j S)^-1/2 S s_j,   S = C^1/2,
/// with C the covariance returned, s_j = J_p^T r - B_j D_j^-1 J_j^T r the score of cluster j
/// (its residuals' gradient for the poses, block j eliminated), L_j = A_j - B_j D_j^-1 B_j^T
/// its information about the poses, and P the information of the residual blocks without a
/// nuisance block (priors, taken as modelled). Under the noise model E[C_R] = C; the leverage
/// S L_j S is capped at 0.99 (a cluster that alone fixes a direction). Empty when C is, or
/// fewer than two nuisance blocks are in a residual block with a free pose.
Eigen::MatrixXd MarginalPoseCovariance(ceres::Problem* problem, const std::vector<double*>& poses,
                                       const std::vector<double*>& nuisance,
                                       Eigen::MatrixXd* robust = nullptr);

/// `other` raised to `model` in every direction where it is smaller: in the frame where
/// `model` is the identity, the eigenvalues of `other` floored at 1 (symmetric, at least both).
/// Both symmetric; std::invalid_argument unless `model` is positive definite. Of a noisy
/// unbiased estimate of `model` (a robust covariance when the model holds) the result is
/// larger than `model` on average: 1.3 times in the trace in tests/covariance_test.cc's scene
/// (16 clusters, 6 parameters).
Eigen::MatrixXd CovarianceAtLeast(const Eigen::MatrixXd& model, const Eigen::MatrixXd& other);

/// The edge of SharedNoiseCovariance's coarse clusters (m, world frame): a cell holds many
/// pixels of one or two surfaces, so that the noise correlated over a few pixels and a
/// surface's bias stay within clusters (docs/uncertainty.md, "Inflation").
constexpr double kCovarianceCellM = 1.0;

/// Cluster-robust sandwiches of a least-squares estimate from its realised residuals,
/// H^-1 (sum_g s_g s_g^T) H^-1 with s_g = sum_{t in g} J_t^T r_t (r_t whitened, loss not
/// applied), for two clusterings of the same terms: `fine` (each cluster what the noise model
/// already takes as one error: a point, the points matched to it, both directions) and `coarse`
/// (clusters that also hold the errors the model takes as independent: neighbouring pixels'
/// correlated noise, a surface's bias). Their ratio is the design effect of the residuals,
/// whatever their overall scale (nearest-neighbour association shrinks it): about 1 when the
/// errors are as independent as the model says (docs/uncertainty.md, "Inflation").
struct ClusterSandwiches {
  double cell_m = kCovarianceCellM;  ///< input: the edge of the coarse clusters' cubes
  Eigen::MatrixXd fine;
  Eigen::MatrixXd coarse;
};

/// The inflation of the pose whose tangent starts at `column` of the sandwiches: per half
/// (rotation, translation), sqrt(trace of `coarse` / trace of `fine`) over its 3 x 3 block,
/// at least 1; 1 where `fine`'s trace is 0.
SigmaInflation InflationOf(const ClusterSandwiches& sandwiches, int column);

/// Clusters of the residual blocks of a problem, per block in ceres::Problem::GetResidualBlocks'
/// order: the index of its fine and of its coarse cluster (ClusterSandwiches), -1 for a block in
/// none (a prior, taken as modelled).
struct BlockClusters {
  std::vector<int> fine;
  std::vector<int> coarse;
};

/// MarginalPoseCovariance's covariance C of `poses` (`nuisance` marginalised, the same
/// conditions), and in `sandwiches` its cluster-robust sandwiches C (sum_g s_g s_g^T) C over the
/// fine and over the coarse clusters of `clusters`, s_g = sum over the rows of cluster g of
/// (J_p - B_j D_j^-1 J_j)^T r (the row's score for the poses, its nuisance block j eliminated):
/// InflationOf gives each pose's design effect. With `unclustered` (not null): the information
/// J_p^T J_p of the residual blocks without a nuisance block (priors). Clusters finer than a
/// nuisance block's residual blocks come from splitting its residual blocks (e.g. the surface
/// bundle's plane clusters by where their pixels are), which leaves J^T J and C as they are.
/// Sandwiches empty when C is; std::invalid_argument unless `clusters` has one entry per residual
/// block.
Eigen::MatrixXd MarginalPoseSandwiches(ceres::Problem* problem, const std::vector<double*>& poses,
                                       const std::vector<double*>& nuisance,
                                       const BlockClusters& clusters, ClusterSandwiches* sandwiches,
                                       Eigen::MatrixXd* unclustered = nullptr);

/// The cube of edge `edge_m` (world frame) that holds `world`, of a grid offset by half a cube,
/// so that the leveled floor (y = 0) and surfaces at round coordinates lie inside cubes: a
/// surface on a cube's face would put each of its points on the side its noise sends it, and so
/// cluster the noise by its sign.
std::array<int64_t, 3> CellOf(const Vec3& world, double edge_m);

/// The terms a shared-noise covariance is taken over, and the views they link.
struct ViewTerms {
  const std::vector<CameraView>& views;    ///< every view, at its pose block
  const std::vector<int>& column;          ///< per view, its first column in C (-1: held fixed)
  const std::vector<MatchedViews>& terms;  ///< the correspondences between the views
};

/// Covariance of the poses that weighted least squares over the terms of `in.terms`
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
/// methods). `in.column[v]` is 6 times view v's index among the free views (its first tangent
/// column of C), -1 for a view held fixed; C is prior_information's size. Empty when there
/// are no terms or free views, or when H is singular (information below 1e-12 of the
/// largest in some direction, e.g. a free view in no term). The views' points are
/// split over up to num_threads threads; the result does not depend on it.
///
/// With `sandwiches` (not null): also the cluster-robust sandwiches of the terms' realised
/// residuals, the terms clustered by where their source point is in the world: `fine` in cubes
/// of the source view's voxel (a point, its nearest neighbours in the other views and their
/// terms back), `coarse` in cubes of sandwiches->cell_m; empty when the covariance is.
///
/// With `surface_bias` (not null): also H^-1 B H^-1, the covariance that each view's surfaces'
/// offsets of its inverse depth give the estimate (CameraView::surface_bias, the same offset for
/// every point of the view in one cube of kCovarianceCellM, independent between cubes and views):
/// B = sum over the views' cubes of g g^T, g = sum over the cube's points p of s_p (-z_p p) times
/// the view's surface_bias. Zero when no view has one; empty when the covariance is.
Eigen::MatrixXd SharedNoiseCovariance(const ViewTerms& in, const IcpOptions& options,
                                      const Eigen::MatrixXd& prior_information, int num_threads,
                                      ClusterSandwiches* sandwiches = nullptr,
                                      Eigen::MatrixXd* surface_bias = nullptr);

}  // namespace rigfit
