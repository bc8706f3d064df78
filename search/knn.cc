#include "search/knn.h"

#include <algorithm>
#include <cstdint>
#include <limits>
#include <nanoflann.hpp>

namespace rigfit {
namespace {

/// Points per leaf (nanoflann's default). A leaf of 20 builds 15-20% faster
/// and answers k = 20 queries 0-4% faster, but its bounded nearest-neighbour queries, the
/// solvers' hot loop, were 8% slower at 5k points and equal (within 2%) at 20k-40k.
constexpr int kLeafMaxSize = 10;

/// nanoflann's RESULTSET concept for the k smallest (squared distance, index) pairs strictly
/// below a bound, kept sorted by insertion into caller-owned arrays. The bound shrinks to the
/// k-th distance once k pairs are held, which is what prunes the tree search.
class BoundedKnnResult {
 public:
  BoundedKnnResult(int capacity, double max_squared_distance, int* indices, double* distances)
      : capacity_(capacity),
        worst_(max_squared_distance),
        indices_(indices),
        distances_(distances) {}

  int count() const { return count_; }

  // nanoflann's RESULTSET concept.
  size_t size() const { return static_cast<size_t>(count_); }
  bool full() const { return true; }
  double worstDist() const { return worst_; }
  bool addPoint(double squared_distance, std::uint32_t index) {
    if (squared_distance >= worst_) return true;
    int i = std::min(count_, capacity_ - 1);
    for (; i > 0 && distances_[i - 1] > squared_distance; --i) {
      distances_[i] = distances_[i - 1];
      indices_[i] = indices_[i - 1];
    }
    distances_[i] = squared_distance;
    indices_[i] = static_cast<int>(index);
    if (count_ < capacity_) ++count_;
    if (count_ == capacity_) worst_ = distances_[capacity_ - 1];
    return true;
  }

 private:
  int capacity_;
  int count_ = 0;
  double worst_;
  int* indices_;
  double* distances_;
};

/// nanoflann's RESULTSET concept for the one nearest point strictly below a bound.
class NearestResult {
 public:
  explicit NearestResult(double max_squared_distance) : worst_(max_squared_distance) {}
  size_t size() const { return index_ < 0 ? 0 : 1; }
  bool full() const { return true; }
  bool addPoint(double squared_distance, std::uint32_t index) {
    if (squared_distance < worst_) {
      worst_ = squared_distance;
      index_ = static_cast<int>(index);
    }
    return true;
  }
  double worstDist() const { return worst_; }
  int index() const { return index_; }

 private:
  double worst_;
  int index_ = -1;
};

/// nanoflann's dataset concept over the cloud's buffer (not the std::vector object, so
/// that moving the vector keeps the tree valid).
struct CloudAdaptor {
  const Vec3* points = nullptr;
  size_t count = 0;

  size_t kdtree_get_point_count() const { return count; }
  double kdtree_get_pt(size_t i, size_t dim) const { return points[i][dim]; }
  template <class BoundingBox>
  bool kdtree_get_bbox(BoundingBox&) const {
    return false;
  }
};

}  // namespace

class KdTree::Impl {
 public:
  explicit Impl(const PointCloud& points)
      : cloud_{points.data(), points.size()},
        tree_(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(kLeafMaxSize)) {}

  /// Searches the tree, feeding every candidate below result->worstDist() to result.
  template <class Result>
  void Search(const Vec3& query, Result* result) const {
    tree_.findNeighbors(*result, query.data(), nanoflann::SearchParams());
  }
  size_t size() const { return cloud_.count; }

 private:
  using Tree =
      nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, CloudAdaptor>,
                                          CloudAdaptor, 3, std::uint32_t>;
  CloudAdaptor cloud_;
  Tree tree_;
};

KdTree::KdTree(const PointCloud& points) : impl_(std::make_unique<Impl>(points)) {}

KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

bool KdTree::Nearest(const Vec3& query, double max_distance, int* index,
                     double* squared_distance) const {
  if (!(max_distance > 0.0) || !query.allFinite()) return false;
  NearestResult result(max_distance * max_distance);
  impl_->Search(query, &result);
  if (result.index() < 0) return false;
  *index = result.index();
  *squared_distance = result.worstDist();
  return true;
}

void KdTree::KNearest(const Vec3& query, int k, std::vector<int>* indices,
                      std::vector<double>* squared_distances) const {
  const int capacity =
      query.allFinite() ? static_cast<int>(std::min<size_t>(std::max(k, 0), impl_->size())) : 0;
  indices->resize(capacity);
  squared_distances->resize(capacity);
  if (capacity == 0) return;
  BoundedKnnResult result(capacity, std::numeric_limits<double>::infinity(), indices->data(),
                          squared_distances->data());
  impl_->Search(query, &result);
  indices->resize(result.count());
  squared_distances->resize(result.count());
}

size_t KdTree::size() const { return impl_->size(); }

}  // namespace rigfit
