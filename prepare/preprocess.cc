#include "prepare/preprocess.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/parallel.h"

namespace rigfit {
namespace {

/// A neighbourhood is degenerate (coincident or collinear points) when its middle
/// eigenvalue is at most this fraction of the largest.
constexpr double kDegenerateEigenvalueRatio = 1e-9;

/// Below this many points per thread, extra threads cost more than they save.
constexpr int kMinPointsPerThread = 1000;

/// A point's voxel coordinates floor(p / voxel_size), kept as doubles (exact integers) so
/// that no coordinate range can overflow, and the point's index as tie-break.
struct VoxelKey {
  double x, y, z;
  int index;

  bool SameVoxel(const VoxelKey& other) const {
    return x == other.x && y == other.y && z == other.z;
  }
  bool operator<(const VoxelKey& other) const {
    return std::tie(x, y, z, index) < std::tie(other.x, other.y, other.z, other.index);
  }
};

struct PointGeometry {
  Vec3 normal = Vec3::Zero();
  Mat3 covariance = Mat3::Identity();
  double planarity = 0.0;
};

/// Geometry of one neighbourhood. Covariance of the neighbours q_i about their mean mu,
///   S = 1/n sum_i (q_i - mu)(q_i - mu)^T = V diag(l2, l1, l0) V^T,  l0 >= l1 >= l2,
/// computed in two passes (mean first) so that clouds far from the origin lose no digits.
/// The normal is the eigenvector of l2, turned toward the viewpoint.
PointGeometry NeighbourhoodGeometry(const PointCloud& points, const std::vector<int>& neighbours,
                                    const Vec3& point, const Vec3& viewpoint) {
  PointGeometry geometry;
  const int n = static_cast<int>(neighbours.size());
  if (n < 3) return geometry;

  Vec3 mean = Vec3::Zero();
  for (int j : neighbours) mean += points[j];
  mean /= n;
  Mat3 scatter = Mat3::Zero();
  for (int j : neighbours) {
    const Vec3 d = points[j] - mean;
    scatter.noalias() += d * d.transpose();
  }
  scatter /= n;

  // Eigenvalues in increasing order: l2, l1, l0. The closed-form solver is as accurate as
  // the iterative one on centred planar neighbourhoods (same normals within 1e-14 rad, noisy
  // or not) and 2.5x faster: BM_NormalEigenSolver in bench/knn_bench.cc.
  Eigen::SelfAdjointEigenSolver<Mat3> solver;
  solver.computeDirect(scatter);
  const Vec3& eigenvalues = solver.eigenvalues();
  const double l0 = eigenvalues(2);
  const double l1 = eigenvalues(1);
  const double l2 = std::max(eigenvalues(0), 0.0);
  if (!(l0 > 0.0) || l1 <= kDegenerateEigenvalueRatio * l0) return geometry;

  const Mat3& V = solver.eigenvectors();
  Vec3 normal = V.col(0).normalized();
  if (normal.dot(viewpoint - point) < 0.0) normal = -normal;
  geometry.normal = normal;
  geometry.covariance = V * Vec3(kGicpPlaneEpsilon, 1.0, 1.0).asDiagonal() * V.transpose();
  geometry.planarity = (l1 - l2) / l0;
  return geometry;
}

}  // namespace

PointCloud VoxelDownsample(const PointCloud& points, double voxel_size) {
  if (!(voxel_size > 0.0) || !std::isfinite(voxel_size)) {
    throw std::invalid_argument("VoxelDownsample: voxel_size must be > 0 and finite, got " +
                                std::to_string(voxel_size));
  }
  std::vector<VoxelKey> keys;
  keys.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3& p = points[i];
    if (!p.allFinite()) continue;
    keys.push_back({std::floor(p.x() / voxel_size), std::floor(p.y() / voxel_size),
                    std::floor(p.z() / voxel_size), static_cast<int>(i)});
  }
  std::sort(keys.begin(), keys.end());

  PointCloud centroids;
  for (size_t begin = 0; begin < keys.size();) {
    Vec3 sum = Vec3::Zero();
    size_t end = begin;
    for (; end < keys.size() && keys[end].SameVoxel(keys[begin]); ++end) {
      sum += points[keys[end].index];
    }
    centroids.push_back(sum / static_cast<double>(end - begin));
    begin = end;
  }
  return centroids;
}

LocalGeometry EstimateLocalGeometry(const PointCloud& points, const KdTree& tree, int k,
                                    const Vec3& viewpoint, int num_threads) {
  if (k < 5) {
    throw std::invalid_argument("EstimateLocalGeometry: k must be >= 5, got " + std::to_string(k));
  }
  if (num_threads < 1) {
    throw std::invalid_argument("EstimateLocalGeometry: num_threads must be >= 1, got " +
                                std::to_string(num_threads));
  }
  if (tree.size() != points.size()) {
    throw std::invalid_argument("EstimateLocalGeometry: the tree holds " +
                                std::to_string(tree.size()) + " points, the cloud " +
                                std::to_string(points.size()));
  }
  const int n = static_cast<int>(points.size());
  LocalGeometry geometry;
  geometry.normals.resize(n);
  geometry.covariances.resize(n);
  geometry.planarity.resize(n);
  // Plain threads (ParallelFor) rather than OpenMP: a join blocks, where libgomp's default
  // barrier spins, which on shared cores doubled the CPU time of this step
  // (docs/benchmarks.md). Each thread keeps its own neighbour buffers, on its own stack (no
  // cache line shared with another thread's).
  const int chunks = std::max(1, std::min(num_threads, n / kMinPointsPerThread));
  ParallelForChunks(n, chunks, [&](int, int begin, int end) {
    std::vector<int> neighbours;
    std::vector<double> distances;
    for (int i = begin; i < end; ++i) {
      tree.KNearest(points[i], k, &neighbours, &distances);
      const PointGeometry g = NeighbourhoodGeometry(points, neighbours, points[i], viewpoint);
      geometry.normals[i] = g.normal;
      geometry.covariances[i] = g.covariance;
      geometry.planarity[i] = g.planarity;
    }
  });
  return geometry;
}

bool ScaleLevel::Nearest(const Vec3& query, double max_distance, int* index,
                         double* squared_distance) const {
  if (!(max_distance > 0.0)) return false;  // NaN too, as the tree
  if (grid) {
    const bool within = max_distance <= grid->radius();
    if (grid->Nearest(query, within ? max_distance : grid->radius(), index, squared_distance)) {
      return true;
    }
    if (within) return false;
  }
  return tree->Nearest(query, max_distance, index, squared_distance);
}

CloudPyramid BuildPyramid(const PointCloud& points, const std::vector<double>& voxel_sizes, int k,
                          const Vec3& viewpoint, double search_factor, int num_threads) {
  CloudPyramid pyramid;
  pyramid.levels.resize(voxel_sizes.size());
  for (size_t i = 0; i < voxel_sizes.size(); ++i) {
    ScaleLevel& level = pyramid.levels[i];
    level.voxel_size = voxel_sizes[i];
    level.normal_support = voxel_sizes[i] * std::sqrt(k / M_PI);
    level.points = VoxelDownsample(points, voxel_sizes[i]);
    level.tree = std::make_unique<KdTree>(level.points);
    level.grid = std::make_unique<PointGrid>(level.points, search_factor * voxel_sizes[i]);
    level.geometry = EstimateLocalGeometry(level.points, *level.tree, k, viewpoint, num_threads);
  }
  return pyramid;
}

}  // namespace rigfit
