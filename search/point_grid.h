// Exact nearest-neighbour search within a radius known in advance, on a uniform grid: the
// correspondence search's index (a scale's correspondence distance is fixed when the scale
// is built). On rigfit's clouds it answers those queries faster than the k-d tree of
// search/knn.h, which stays the index for k nearest neighbours and for wider radii
// (docs/benchmarks.md, "Issue 5: correspondence search on a grid").
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// A cloud's points sorted into cubic cells of side 2 * radius, each occupied cell found
/// through a hash of its coordinates. A query within max_distance <= radius reads the 2 x 2
/// x 2 cells that the cube of side 2 max_distance around it overlaps; a wider one reads more
/// cells and is still exact. Keeps its own copy of the points (in cell order, for locality),
/// so the cloud may change or go away; queries are const and may run concurrently.
class PointGrid {
 public:
  /// Throws std::invalid_argument unless radius is finite and > 0 and the cloud's finite
  /// points span a finite extent. Non-finite points are left out (never found). Over a cloud
  /// wider than 2^21 - 2 cells the cells grow to fit, which costs speed, not exactness: one
  /// outlier far away makes every cell, and every query, larger.
  PointGrid(const PointCloud& points, double radius);

  /// The nearest point strictly closer than max_distance, as KdTree::Nearest: its index in
  /// the cloud and squared distance (the same arithmetic as the tree's, so equal). Ties go to
  /// either. Returns false, leaving the outputs untouched, when there is none (empty cloud,
  /// max_distance <= 0, non-finite query).
  bool Nearest(const Vec3& query, double max_distance, int* index, double* squared_distance) const;

  /// The radius the grid was built for: queries up to it read at most 8 cells.
  double radius() const { return radius_; }

 private:
  struct Cell {
    std::uint64_t key;
    int begin;  ///< into points_ and indices_
    int end;
  };
  static constexpr std::uint64_t kNoKey = ~std::uint64_t{0};

  /// Cell coordinates, each in [0, 2^21), packed into one key.
  static std::uint64_t Key(std::int64_t x, std::int64_t y, std::int64_t z);
  size_t Slot(std::uint64_t key) const;
  const Cell* Find(std::uint64_t key) const;
  /// Bit number of a cell of the occupied range in occupancy_.
  std::int64_t Bit(std::int64_t x, std::int64_t y, std::int64_t z) const {
    return (x * cells_[1] + y) * cells_[2] + z;
  }

  double radius_;
  double cell_size_;
  Vec3 origin_ = Vec3::Zero();         ///< the lowest corner of cell (0, 0, 0)
  std::int64_t cells_[3] = {0, 0, 0};  ///< cells per axis
  int hash_shift_ = 0;                 ///< 64 - log2(table_.size())
  std::vector<Cell> table_;            ///< open addressing, linear probing, half full at most
  /// One bit per cell of the occupied range, x-major (empty when the range has more than
  /// kMaxOccupancyBits cells): an empty cell is skipped without a probe of the table.
  std::vector<std::uint64_t> occupancy_;
  PointCloud points_;         ///< the finite points in cell order
  std::vector<int> indices_;  ///< their indices in the input cloud
};

}  // namespace rigfit
