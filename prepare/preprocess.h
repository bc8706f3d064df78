// Per-camera preprocessing shared by the joint and pairwise solvers: voxel downsampling,
// normals and GICP covariances from k nearest neighbours, and a coarse-to-fine pyramid that
// caches all of it (with a k-d tree and a grid) per scale. Everything stays in the frame of the
// input points (the camera frame): the solvers move the points with the current pose.
#pragma once

#include <memory>
#include <vector>

#include "core/types.h"
#include "search/knn.h"
#include "search/point_grid.h"

namespace rigfit {

/// Voxel-grid downsampling: one point per occupied voxel, the centroid of the input points
/// that fall in it. Voxel (i, j, k) holds the points p with floor(p / voxel_size) = (i, j, k).
/// The output is ordered by voxel (i, then j, then k), so equal inputs give equal outputs.
/// Non-finite points are skipped; an empty input gives an empty output.
/// Throws std::invalid_argument when voxel_size is not > 0 (a programmer error: options are
/// validated by OptionProblems before any solver runs).
PointCloud VoxelDownsample(const PointCloud& points, double voxel_size);

/// GICP plane regularisation: the eigenvalues of a local covariance are replaced by
/// (1, 1, kGicpPlaneEpsilon), the small one along the normal.
inline constexpr double kGicpPlaneEpsilon = 1e-3;

/// Local surface geometry, one entry per point of a cloud.
///
/// A point is invalid when fewer than 3 neighbours exist or its neighbours are (numerically)
/// coincident or collinear, i.e. the middle eigenvalue of their covariance is at most 1e-9
/// times the largest: its normal is then the zero vector (the test consumers use), its
/// covariance the identity and its planarity 0.
struct LocalGeometry {
  /// Unit surface normals, oriented toward the viewpoint (n . (viewpoint - p) >= 0).
  PointCloud normals;
  /// Plane-regularised GICP covariances (Segal, Haehnel, Thrun, "Generalized-ICP", RSS
  /// 2009, Sec. III-B; as small_gicp's RegularizationMethod::PLANE):
  ///   C = V diag(1, 1, eps) V^T,  eps = kGicpPlaneEpsilon,
  /// with V the eigenvectors of the neighbourhood covariance, the last one the normal.
  /// Unitless: the shape of the local surface, not its extent.
  std::vector<Mat3> covariances;
  /// Planarity (l1 - l2) / l0 of the neighbourhood covariance eigenvalues l0 >= l1 >= l2
  /// (Demantke et al., "Dimensionality based scale selection in 3D lidar point clouds",
  /// 2011), in [0, 1]: near 1 on a plane, low on edges, corners, lines and clutter.
  std::vector<double> planarity;

  size_t size() const { return normals.size(); }
  bool IsValid(size_t i) const { return !normals[i].isZero(); }
};

/// Normals, covariances and planarity of every point from its k nearest neighbours (the
/// point itself included) found with `tree`, which must be built on `points`. Normals are
/// oriented toward `viewpoint` (the camera centre in the cloud's frame: the origin for
/// camera-frame points). Splits the points over up to num_threads threads (std::thread); the
/// result does not depend on it. Throws std::invalid_argument when k < 5, num_threads < 1 or the
/// tree size differs from the cloud's.
LocalGeometry EstimateLocalGeometry(const PointCloud& points, const KdTree& tree, int k,
                                    const Vec3& viewpoint, int num_threads = 1);

/// One scale of a camera's cloud: its downsampled points, a tree and a grid over them and
/// their local geometry. The tree refers to `points`: never modify or move `points` out of a
/// level (moving the whole ScaleLevel or CloudPyramid is fine).
struct ScaleLevel {
  double voxel_size = 0.0;
  /// Radius (m) of the neighbourhood each normal is fitted to: k neighbours on a surface
  /// sampled once per voxel cover about voxel_size sqrt(k / pi).
  double normal_support = 0.0;
  PointCloud points;
  std::unique_ptr<KdTree> tree;
  /// For the correspondence search within the scale's correspondence distance; may be null.
  std::unique_ptr<PointGrid> grid;
  LocalGeometry geometry;

  /// The nearest point strictly closer than max_distance, as KdTree::Nearest. The grid
  /// answers when max_distance is within its radius, or first, up to that radius, since a
  /// point found there is the nearest at any distance; the tree answers the rest.
  bool Nearest(const Vec3& query, double max_distance, int* index, double* squared_distance) const;
};

/// A camera's cloud at every scale, built once and shared by both solvers.
struct CloudPyramid {
  std::vector<ScaleLevel> levels;  ///< in the order of the voxel sizes given
};

/// Downsamples `points` (in their own frame) once per voxel size, each level directly from
/// the input, and builds each level's tree, grid (radius search_factor x its voxel size: the
/// correspondence distance) and local geometry (k neighbours, normals toward viewpoint,
/// num_threads threads for the geometry). Throws std::invalid_argument as VoxelDownsample,
/// EstimateLocalGeometry and PointGrid do.
CloudPyramid BuildPyramid(const PointCloud& points, const std::vector<double>& voxel_sizes, int k,
                          const Vec3& viewpoint, double search_factor, int num_threads = 2);

}  // namespace rigfit
