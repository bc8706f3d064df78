// Exact nearest-neighbour search over a 3D point cloud: the one adapter every solver uses,
// so the k-d tree library can be swapped here and nowhere else.
//
// Two backends sit behind it, chosen at run time: nanoflann 1.4 (KDTreeSingleIndexAdaptor)
// and FLANN 1.9 (KDTreeSingleIndex, the exact single-tree index; FLANN's randomised
// KDTreeIndex is approximate unless its check count is unlimited). Both are exact and
// return the same neighbours (ties aside). nanoflann is the default: on voxel-ordered
// near-floor band clouds of 5k-100k points its bounded nearest-neighbour queries (the
// solvers' inner loop) took 8-14% less time; tree builds were within 8% either way and
// k = 20 queries level with FLANN's or faster. On the raw 69k-point LiDAR scans of shared/data,
// FLANN's k = 20 queries were 6-17% faster and neither backend won the bounded queries
// consistently. docs/benchmarks.md ("Nearest-neighbour backend and preprocessing") has the numbers.
#pragma once

#include <memory>
#include <vector>

#include "core/types.h"

namespace rigfit {

enum class KnnBackend { kNanoflann, kFlann };

/// The backend used when none is named: the faster one on rigfit's workload.
inline constexpr KnnBackend kDefaultKnnBackend = KnnBackend::kNanoflann;

/// A k-d tree over a point cloud.
///
/// The tree refers to the cloud's storage: the points must outlive the tree and must not
/// change while it is in use. Moving the std::vector that holds them is fine (the buffer
/// moves with it); copying it, resizing it or writing into it is not.
///
/// Queries are const and keep no shared mutable state, so any number of threads may query
/// one tree concurrently. Squared distances are Euclidean, in square metres.
class KdTree {
 public:
  explicit KdTree(const PointCloud& points, KnnBackend backend = kDefaultKnnBackend);
  ~KdTree();
  KdTree(KdTree&&) noexcept;
  KdTree& operator=(KdTree&&) noexcept;
  KdTree(const KdTree&) = delete;
  KdTree& operator=(const KdTree&) = delete;

  /// The nearest point strictly closer than max_distance (pass infinity for no bound).
  /// Returns false, leaving the outputs untouched, when there is none (empty cloud,
  /// max_distance <= 0, non-finite query).
  bool Nearest(const Vec3& query, double max_distance, int* index, double* squared_distance) const;

  /// The min(k, size()) nearest points, closest first (ties in any order). Both outputs
  /// are resized to that count; k <= 0 or a non-finite query gives empty outputs.
  void KNearest(const Vec3& query, int k, std::vector<int>* indices,
                std::vector<double>* squared_distances) const;

  size_t size() const;
  KnnBackend backend() const;

  /// The backend-specific tree; defined in knn.cc.
  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
  KnnBackend backend_;
};

}  // namespace rigfit
