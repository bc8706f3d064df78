#include "search/point_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "prepare/preprocess.h"
#include "search/knn.h"

namespace rigfit {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// n points in [-1, 1] x [-1, 1] x [-0.3, 0.3], shifted by `offset`.
PointCloud RandomCloud(int n, std::uint32_t seed, const Vec3& offset = Vec3::Zero()) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  PointCloud points(n);
  for (Vec3& p : points) p = offset + Vec3(uniform(rng), uniform(rng), 0.3 * uniform(rng));
  return points;
}

/// The nearest point strictly within max_distance by brute force: (squared distance, index),
/// index -1 for none.
std::pair<double, int> BruteForceNearest(const PointCloud& points, const Vec3& q,
                                         double max_distance) {
  std::pair<double, int> best(max_distance * max_distance, -1);
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 d = points[i] - q;
    const double d2 = d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
    if (d2 < best.first) best = {d2, static_cast<int>(i)};
  }
  return best;
}

/// Every query, at every radius, against brute force: the same index and squared distance
/// (random clouds have no ties), and the outputs untouched when there is no match.
void ExpectMatchesBruteForce(const PointGrid& grid, const PointCloud& points,
                             const PointCloud& queries, const std::vector<double>& radii) {
  for (const double max_distance : radii) {
    int found = 0;
    for (const Vec3& q : queries) {
      const auto truth = BruteForceNearest(points, q, max_distance);
      int index = -1;
      double squared_distance = -1.0;
      const bool ok = grid.Nearest(q, max_distance, &index, &squared_distance);
      ASSERT_EQ(ok, truth.second >= 0) << "radius " << max_distance << " query " << q.transpose();
      if (ok) {
        ++found;
        EXPECT_EQ(index, truth.second);
        EXPECT_EQ(squared_distance, truth.first);
      } else {
        EXPECT_EQ(index, -1);
        EXPECT_EQ(squared_distance, -1.0);
      }
    }
    // Each radius must exercise both outcomes, or the comparison proves little.
    EXPECT_GT(found, 0) << "radius " << max_distance;
    EXPECT_LT(found, static_cast<int>(queries.size())) << "radius " << max_distance;
  }
}

TEST(PointGrid, NearestMatchesBruteForceWithinAndBeyondItsRadius) {
  const PointCloud points = RandomCloud(3000, 1);
  // Queries inside the cloud and up to 0.5 beyond its bounds on every side.
  PointCloud queries = RandomCloud(300, 2);
  for (Vec3& q : RandomCloud(300, 3)) queries.push_back(1.5 * q);
  const PointGrid grid(points, 0.03);
  EXPECT_EQ(grid.radius(), 0.03);
  // Below, at and above the radius it was built for: 8 cells, then 27 and many more.
  ExpectMatchesBruteForce(grid, points, queries, {0.01, 0.03, 0.05, 0.2, 0.5});
}

TEST(PointGrid, AgreesWithTheKdTreeOnAStructuredCloud) {
  // A depth-camera-like band: a floor and a wall foot, 2 cm apart, voxel-ordered, 5 m away.
  PointCloud points;
  for (int i = 0; i < 150; ++i) {
    for (int k = 0; k < 100; ++k) points.emplace_back(0.02 * i - 1.5, -1.2, 3.0 + 0.02 * k);
    for (int j = 0; j < 15; ++j) points.emplace_back(0.02 * i - 1.5, -1.2 + 0.02 * j, 5.0);
  }
  std::mt19937 rng(4);
  std::normal_distribution<double> noise(0.0, 0.004);
  for (Vec3& p : points) p += Vec3(noise(rng), noise(rng), noise(rng));
  const PointGrid grid(points, 0.028);
  const KdTree tree(points);
  PointCloud queries;
  for (const Vec3& p : points) queries.push_back(p + Vec3(0.011, -0.007, 0.013));
  int matched = 0;
  for (const Vec3& q : queries) {
    int grid_index = -1, tree_index = -1;
    double grid_d2 = -1.0, tree_d2 = -1.0;
    const bool in_grid = grid.Nearest(q, 0.028, &grid_index, &grid_d2);
    ASSERT_EQ(in_grid, tree.Nearest(q, 0.028, &tree_index, &tree_d2));
    EXPECT_EQ(grid_index, tree_index);
    EXPECT_EQ(grid_d2, tree_d2);
    matched += in_grid;
  }
  EXPECT_GT(matched, static_cast<int>(queries.size()) / 2);
}

TEST(PointGrid, EmptyNonFiniteAndInvalidArguments) {
  int index = -1;
  double squared_distance = -1.0;
  EXPECT_FALSE(PointGrid(PointCloud(), 0.1).Nearest(Vec3::Zero(), kInf, &index, &squared_distance));
  const double nan = std::nan("");
  // Non-finite points are never found; the finite ones keep their input indices.
  const PointCloud points = {Vec3(nan, 0, 0), Vec3(1.0, 2.0, 3.0), Vec3(kInf, 0, 0)};
  const PointGrid grid(points, 0.1);
  ASSERT_TRUE(grid.Nearest(Vec3(1.0, 2.0, 3.05), 0.1, &index, &squared_distance));
  EXPECT_EQ(index, 1);
  EXPECT_NEAR(squared_distance, 0.0025, 1e-15);
  ASSERT_TRUE(grid.Nearest(Vec3(0.0, 0.0, 0.0), kInf, &index, &squared_distance));
  EXPECT_EQ(index, 1);
  // The bound is strict, as the tree's.
  index = -1;
  EXPECT_FALSE(grid.Nearest(Vec3(1.0, 2.0, 3.5), 0.5, &index, &squared_distance));
  EXPECT_FALSE(grid.Nearest(Vec3(1.0, 2.0, 3.0), 0.0, &index, &squared_distance));
  EXPECT_FALSE(grid.Nearest(Vec3(1.0, 2.0, 3.0), -1.0, &index, &squared_distance));
  EXPECT_FALSE(grid.Nearest(Vec3(nan, 2.0, 3.0), kInf, &index, &squared_distance));
  EXPECT_EQ(index, -1);
  EXPECT_THROW(PointGrid(points, 0.0), std::invalid_argument);
  EXPECT_THROW(PointGrid(points, -1.0), std::invalid_argument);
  EXPECT_THROW(PointGrid(points, kInf), std::invalid_argument);
  EXPECT_THROW(PointGrid(points, 1e308), std::invalid_argument);  // cells of 2e308
  const double huge = std::numeric_limits<double>::max();
  EXPECT_THROW(PointGrid(PointCloud{Vec3(-huge, 0, 0), Vec3(huge, 0, 0)}, 0.1),
               std::invalid_argument);
}

TEST(PointGrid, DuplicatesReturnEitherCopy) {
  PointCloud points = RandomCloud(500, 6);
  points.push_back(points[17]);  // index 500 duplicates index 17
  const PointGrid grid(points, 0.05);
  int index = -1;
  double squared_distance = -1.0;
  ASSERT_TRUE(grid.Nearest(points[17], 0.05, &index, &squared_distance));
  EXPECT_TRUE(index == 17 || index == 500) << index;
  EXPECT_EQ(squared_distance, 0.0);
}

TEST(PointGrid, PointsOnCellBoundariesAreFound) {
  // A lattice of spacing 2 x radius = the cell size, from the origin of the grid (its
  // lowest point): every point lies on cell faces, edges and corners.
  const double radius = 0.05;
  PointCloud points;
  for (int i = 0; i < 8; ++i) {
    for (int j = 0; j < 8; ++j) {
      for (int k = 0; k < 3; ++k) points.emplace_back(0.1 * i, 0.1 * j, 0.1 * k);
    }
  }
  const PointGrid grid(points, radius);
  PointCloud queries;
  for (const Vec3& p : points) {
    for (const Vec3& offset : {Vec3(0.0, 0.0, 0.0), Vec3(0.049, 0.0, 0.0), Vec3(-0.049, 0.0, 0.0),
                               Vec3(0.0, -0.03, 0.03), Vec3(0.02, 0.02, -0.02)}) {
      queries.push_back(p + offset);
    }
  }
  queries.push_back(Vec3(-0.2, 0.0, 0.0));  // beyond the lowest cells, nothing in range
  ExpectMatchesBruteForce(grid, points, queries, {0.03, 0.05, 0.12});
}

TEST(PointGrid, ACloudWiderThanTheKeysSpanStaysExact) {
  // 1 km across at a 0.1 mm radius: 5 million cells per axis, more than a key holds, so the
  // cells grow (not observable from outside: this checks that queries stay exact). At 5 cm a
  // query's cube covers more cells than are occupied, so the grid reads every point instead.
  PointCloud points = RandomCloud(2000, 8);
  points.push_back(Vec3(1000.0, 0.0, 0.0));
  const PointGrid grid(points, 1e-4);
  PointCloud queries = RandomCloud(200, 9);
  for (Vec3& q : queries) q = points[&q - queries.data()] + 0.7e-4 * q.normalized();
  queries.push_back(Vec3(1000.0, 0.0, 5e-5));
  queries.push_back(Vec3(500.0, 0.0, 0.0));  // nothing near
  ExpectMatchesBruteForce(grid, points, queries, {1e-4, 0.05});
}

TEST(PointGrid, ManyCellsStayExactWithAndWithoutTheOccupancyBitmap) {
  // Empty cells are skipped through a bitmap of the occupied range when it has at most 2^25
  // cells, through the hash table alone beyond. At a 1 mm radius the random cloud spans
  // 1000 x 1000 x 300 cells (no bitmap), at 5 mm 200 x 200 x 60 (bitmap); queries near points
  // and in the empty space between them.
  const PointCloud points = RandomCloud(3000, 14);
  PointCloud queries = RandomCloud(300, 15);
  for (size_t i = 0; i < 150; ++i) {
    const double offset = i < 100 ? 0.8e-3 : 3e-3;
    queries[i] = points[i] + offset * (queries[i] - points[i]).normalized();
  }
  for (const double radius : {1e-3, 5e-3}) {
    SCOPED_TRACE(radius);
    const PointGrid grid(points, radius);
    ExpectMatchesBruteForce(grid, points, queries, {radius, 4 * radius});
  }
}

TEST(ScaleLevel, NearestUsesTheGridWithinItsRadiusAndTheTreeBeyond) {
  const PointCloud points = RandomCloud(3000, 10);
  ScaleLevel level;
  level.points = points;
  level.tree = std::make_unique<KdTree>(level.points);
  level.grid = std::make_unique<PointGrid>(level.points, 0.02);
  const PointCloud queries = RandomCloud(300, 11);
  for (const double max_distance : {0.01, 0.02, 0.05, kInf}) {
    for (const Vec3& q : queries) {
      const auto truth = BruteForceNearest(points, q, max_distance);
      int index = -1;
      double squared_distance = -1.0;
      ASSERT_EQ(level.Nearest(q, max_distance, &index, &squared_distance), truth.second >= 0);
      EXPECT_EQ(index, truth.second);
      if (truth.second >= 0) {
        EXPECT_EQ(squared_distance, truth.first);
      }
    }
  }
  int index = -1;
  double squared_distance = -1.0;
  for (const double bad : {0.0, -1.0, std::nan("")}) {
    EXPECT_FALSE(level.Nearest(queries[0], bad, &index, &squared_distance)) << bad;
  }
  EXPECT_EQ(index, -1);
}

TEST(ScaleLevel, TheGridAnswersWithinItsRadiusTheTreeOnlyBeyond) {
  // Two indexes over different clouds tell which one answered: the grid holds one point
  // more than the tree, at index 2.
  ScaleLevel level;
  level.points = {Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0)};
  level.tree = std::make_unique<KdTree>(level.points);
  level.grid = std::make_unique<PointGrid>(
      PointCloud{Vec3(0.0, 0.0, 0.0), Vec3(1.0, 0.0, 0.0), Vec3(0.5, 0.0, 0.0)}, 0.1);
  int index = -1;
  double squared_distance = -1.0;
  // Within the grid's radius the grid answers, wider searches ask it first.
  ASSERT_TRUE(level.Nearest(Vec3(0.52, 0.0, 0.0), 0.05, &index, &squared_distance));
  EXPECT_EQ(index, 2);
  ASSERT_TRUE(level.Nearest(Vec3(0.52, 0.0, 0.0), kInf, &index, &squared_distance));
  EXPECT_EQ(index, 2);
  // Nothing within the grid's radius: the tree answers the wider search.
  ASSERT_TRUE(level.Nearest(Vec3(0.75, 0.0, 0.0), 0.3, &index, &squared_distance));
  EXPECT_EQ(index, 1);
  EXPECT_NEAR(squared_distance, 0.0625, 1e-15);
  // Within its radius the grid's "none" is final.
  EXPECT_FALSE(level.Nearest(Vec3(0.75, 0.0, 0.0), 0.1, &index, &squared_distance));
}

}  // namespace
}  // namespace rigfit
