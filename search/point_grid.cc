#include "search/point_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace rigfit {
namespace {

/// Bits per cell coordinate in a key.
constexpr int kKeyBits = 21;
constexpr std::int64_t kMaxCellsPerAxis = (std::int64_t{1} << kKeyBits) - 1;

/// The largest occupancy bitmap, in cells (4 MiB).
constexpr double kMaxOccupancyBits = 1 << 25;

/// Fibonacci hashing: the key times 2^64 / golden ratio, top bits.
constexpr std::uint64_t kHashMultiplier = 0x9E3779B97F4A7C15ull;

}  // namespace

PointGrid::PointGrid(const PointCloud& points, double radius) : radius_(radius) {
  if (!(radius > 0.0) || !std::isfinite(radius)) {
    throw std::invalid_argument("PointGrid: radius must be finite and > 0");
  }
  cell_size_ = 2.0 * radius;
  if (!std::isfinite(cell_size_)) throw std::invalid_argument("PointGrid: radius too large");
  std::vector<int> finite;
  finite.reserve(points.size());
  Vec3 lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo;
  for (size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) continue;
    finite.push_back(static_cast<int>(i));
    lo = lo.cwiseMin(points[i]);
    hi = hi.cwiseMax(points[i]);
  }
  if (finite.empty()) return;
  if (!(hi - lo).allFinite()) {
    throw std::invalid_argument("PointGrid: the points span more than a double can hold");
  }
  cell_size_ =
      std::max(cell_size_, (hi - lo).maxCoeff() / static_cast<double>(kMaxCellsPerAxis - 1));
  origin_ = lo;
  for (int a = 0; a < 3; ++a) {
    cells_[a] = static_cast<std::int64_t>(std::floor((hi[a] - lo[a]) / cell_size_)) + 1;
  }
  if (static_cast<double>(cells_[0]) * static_cast<double>(cells_[1]) *
          static_cast<double>(cells_[2]) <=
      kMaxOccupancyBits) {
    occupancy_.assign((cells_[0] * cells_[1] * cells_[2] + 63) / 64, 0);
  }
  std::vector<std::uint64_t> keys(finite.size());
  for (size_t n = 0; n < finite.size(); ++n) {
    const Vec3 cell = ((points[finite[n]] - origin_) / cell_size_).array().floor();
    const std::int64_t x = static_cast<std::int64_t>(cell.x());
    const std::int64_t y = static_cast<std::int64_t>(cell.y());
    const std::int64_t z = static_cast<std::int64_t>(cell.z());
    keys[n] = Key(x, y, z);
    if (!occupancy_.empty()) {
      const std::int64_t bit = Bit(x, y, z);
      occupancy_[bit >> 6] |= std::uint64_t{1} << (bit & 63);
    }
  }
  std::vector<int> order(finite.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return keys[a] < keys[b]; });
  points_.resize(order.size());
  indices_.resize(order.size());
  size_t occupied = 0;
  for (size_t n = 0; n < order.size(); ++n) {
    indices_[n] = finite[order[n]];
    points_[n] = points[indices_[n]];
    if (n == 0 || keys[order[n]] != keys[order[n - 1]]) ++occupied;
  }
  int bits = 4;
  while ((size_t{1} << bits) < 2 * occupied) ++bits;
  hash_shift_ = 64 - bits;
  table_.assign(size_t{1} << bits, Cell{kNoKey, 0, 0});
  for (size_t begin = 0; begin < order.size();) {
    const std::uint64_t key = keys[order[begin]];
    size_t end = begin + 1;
    while (end < order.size() && keys[order[end]] == key) ++end;
    size_t slot = Slot(key);
    while (table_[slot].key != kNoKey) slot = (slot + 1) & (table_.size() - 1);
    table_[slot] = {key, static_cast<int>(begin), static_cast<int>(end)};
    begin = end;
  }
}

std::uint64_t PointGrid::Key(std::int64_t x, std::int64_t y, std::int64_t z) {
  return (static_cast<std::uint64_t>(x) << (2 * kKeyBits)) |
         (static_cast<std::uint64_t>(y) << kKeyBits) | static_cast<std::uint64_t>(z);
}

size_t PointGrid::Slot(std::uint64_t key) const {
  return static_cast<size_t>((key * kHashMultiplier) >> hash_shift_);
}

const PointGrid::Cell* PointGrid::Find(std::uint64_t key) const {
  for (size_t slot = Slot(key);; slot = (slot + 1) & (table_.size() - 1)) {
    const Cell& cell = table_[slot];
    if (cell.key == key) return &cell;
    if (cell.key == kNoKey) return nullptr;
  }
}

bool PointGrid::Nearest(const Vec3& query, double max_distance, int* index,
                        double* squared_distance) const {
  if (points_.empty() || !(max_distance > 0.0) || !query.allFinite()) return false;
  // The cells that the cube of side 2 max_distance around the query overlaps, clipped to
  // the occupied range.
  std::int64_t lo[3], hi[3];
  double box_cells = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double from = std::floor((query[a] - max_distance - origin_[a]) / cell_size_);
    const double to = std::floor((query[a] + max_distance - origin_[a]) / cell_size_);
    if (to < 0.0 || from >= static_cast<double>(cells_[a])) return false;
    lo[a] = static_cast<std::int64_t>(std::max(from, 0.0));
    hi[a] = static_cast<std::int64_t>(std::min(to, static_cast<double>(cells_[a] - 1)));
    box_cells *= static_cast<double>(hi[a] - lo[a] + 1);
  }
  double best = max_distance * max_distance;
  int best_n = -1;
  const auto scan = [&](int begin, int end) {
    for (int n = begin; n < end; ++n) {
      // Summed in x, y, z order as nanoflann's L2_Simple_Adaptor does, so that the squared
      // distances equal the k-d tree's to the bit.
      const Vec3 d = points_[n] - query;
      const double d2 = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
      if (d2 < best) {
        best = d2;
        best_n = n;
      }
    }
  };
  if (box_cells > static_cast<double>(table_.size())) {
    // A radius wide against the cells: reading every point costs less than every cell.
    scan(0, static_cast<int>(points_.size()));
  } else {
    for (std::int64_t x = lo[0]; x <= hi[0]; ++x) {
      for (std::int64_t y = lo[1]; y <= hi[1]; ++y) {
        for (std::int64_t z = lo[2]; z <= hi[2]; ++z) {
          if (!occupancy_.empty()) {
            const std::int64_t bit = Bit(x, y, z);
            if (!(occupancy_[bit >> 6] >> (bit & 63) & 1)) continue;
          }
          if (const Cell* cell = Find(Key(x, y, z))) scan(cell->begin, cell->end);
        }
      }
    }
  }
  if (best_n < 0) return false;
  *index = indices_[best_n];
  *squared_distance = best;
  return true;
}

}  // namespace rigfit
