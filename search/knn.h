// Exact nearest-neighbour search over a 3D point cloud: the one adapter every solver uses,
// so the k-d tree library (nanoflann's KDTreeSingleIndexAdaptor) can be swapped here and
// nowhere else.
#pragma once

#include <memory>
#include <vector>

#include "core/types.h"

namespace rigfit {

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
  explicit KdTree(const PointCloud& points);
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

  /// The tree; defined in knn.cc.
  class Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace rigfit
