#include "search/knn.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <thread>
#include <utility>

namespace rigfit {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

PointCloud RandomCloud(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  PointCloud points(n);
  for (Vec3& p : points) p = Vec3(uniform(rng), uniform(rng), 0.3 * uniform(rng));
  return points;
}

double SquaredDistance(const Vec3& a, const Vec3& b) {
  const Vec3 d = a - b;
  return d.x() * d.x() + d.y() * d.y() + d.z() * d.z();
}

/// (squared distance, index) of every point, closest first.
std::vector<std::pair<double, int>> BruteForceSorted(const PointCloud& points, const Vec3& q) {
  std::vector<std::pair<double, int>> all(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    all[i] = {SquaredDistance(points[i], q), static_cast<int>(i)};
  }
  std::sort(all.begin(), all.end());
  return all;
}

TEST(KdTreeTest, NearestMatchesBruteForceWithAndWithoutBound) {
  const PointCloud points = RandomCloud(3000, 1);
  const PointCloud queries = RandomCloud(400, 2);
  const KdTree tree(points);
  ASSERT_EQ(tree.size(), points.size());

  // The mean spacing is about 0.04, so a 0.03 bound leaves many queries without a match.
  int found_with_bound = 0;
  for (const Vec3& q : queries) {
    const auto truth = BruteForceSorted(points, q).front();
    int index = -1;
    double squared_distance = -1.0;
    ASSERT_TRUE(tree.Nearest(q, kInf, &index, &squared_distance));
    EXPECT_EQ(index, truth.second);
    EXPECT_DOUBLE_EQ(squared_distance, truth.first);

    const double max_distance = 0.03;
    index = -1;
    const bool found = tree.Nearest(q, max_distance, &index, &squared_distance);
    EXPECT_EQ(found, truth.first < max_distance * max_distance);
    if (found) {
      ++found_with_bound;
      EXPECT_EQ(index, truth.second);
      EXPECT_DOUBLE_EQ(squared_distance, truth.first);
    } else {
      EXPECT_EQ(index, -1);  // untouched
    }
  }
  EXPECT_GT(found_with_bound, 50);
  EXPECT_LT(found_with_bound, 350);
}

TEST(KdTreeTest, KNearestMatchesBruteForceSorted) {
  const PointCloud points = RandomCloud(2000, 3);
  const PointCloud queries = RandomCloud(200, 4);
  const KdTree tree(points);
  std::vector<int> indices;
  std::vector<double> squared_distances;
  for (const int k : {1, 5, 20}) {
    for (const Vec3& q : queries) {
      const auto truth = BruteForceSorted(points, q);
      tree.KNearest(q, k, &indices, &squared_distances);
      ASSERT_EQ(indices.size(), static_cast<size_t>(k));
      ASSERT_EQ(squared_distances.size(), static_cast<size_t>(k));
      for (int j = 0; j < k; ++j) {
        EXPECT_EQ(indices[j], truth[j].second);
        EXPECT_DOUBLE_EQ(squared_distances[j], truth[j].first);
      }
    }
  }
}

TEST(KdTreeTest, KLargerThanCloudReturnsAllPointsSorted) {
  const PointCloud points = RandomCloud(7, 5);
  const KdTree tree(points);
  const Vec3 q(0.1, -0.2, 0.0);
  std::vector<int> indices;
  std::vector<double> squared_distances;
  tree.KNearest(q, 20, &indices, &squared_distances);
  const auto truth = BruteForceSorted(points, q);
  ASSERT_EQ(indices.size(), 7u);
  for (int j = 0; j < 7; ++j) {
    EXPECT_EQ(indices[j], truth[j].second);
    EXPECT_DOUBLE_EQ(squared_distances[j], truth[j].first);
  }
  tree.KNearest(q, 0, &indices, &squared_distances);
  EXPECT_TRUE(indices.empty());
  EXPECT_TRUE(squared_distances.empty());
  tree.KNearest(q, -3, &indices, &squared_distances);
  EXPECT_TRUE(indices.empty());
}

TEST(KdTreeTest, EmptyCloudFindsNothing) {
  const PointCloud points;
  const KdTree tree(points);
  EXPECT_EQ(tree.size(), 0u);
  int index = -1;
  double squared_distance = -1.0;
  EXPECT_FALSE(tree.Nearest(Vec3::Zero(), kInf, &index, &squared_distance));
  EXPECT_EQ(index, -1);
  std::vector<int> indices = {1, 2};
  std::vector<double> squared_distances = {1.0, 2.0};
  tree.KNearest(Vec3::Zero(), 5, &indices, &squared_distances);
  EXPECT_TRUE(indices.empty());
  EXPECT_TRUE(squared_distances.empty());
}

TEST(KdTreeTest, SinglePointAndInvalidArguments) {
  const PointCloud points = {Vec3(1.0, 2.0, 3.0)};
  const KdTree tree(points);
  int index = -1;
  double squared_distance = -1.0;
  ASSERT_TRUE(tree.Nearest(Vec3(1.0, 2.0, 3.5), 1.0, &index, &squared_distance));
  EXPECT_EQ(index, 0);
  EXPECT_DOUBLE_EQ(squared_distance, 0.25);
  // The bound is strict: a point exactly at max_distance is not a match.
  EXPECT_FALSE(tree.Nearest(Vec3(1.0, 2.0, 3.5), 0.5, &index, &squared_distance));
  EXPECT_FALSE(tree.Nearest(Vec3(1.0, 2.0, 3.0), 0.0, &index, &squared_distance));
  EXPECT_FALSE(tree.Nearest(Vec3(1.0, 2.0, 3.0), -1.0, &index, &squared_distance));
  const Vec3 nan_query(std::nan(""), 0.0, 0.0);
  EXPECT_FALSE(tree.Nearest(nan_query, kInf, &index, &squared_distance));
  std::vector<int> indices;
  std::vector<double> squared_distances;
  tree.KNearest(nan_query, 3, &indices, &squared_distances);
  EXPECT_TRUE(indices.empty());
}

TEST(KdTreeTest, DuplicatePointsReturnEitherCopyAtTheSameDistance) {
  PointCloud points = RandomCloud(500, 6);
  points.push_back(points[17]);  // index 500 duplicates index 17
  const KdTree tree(points);
  int index = -1;
  double squared_distance = -1.0;
  ASSERT_TRUE(tree.Nearest(points[17], kInf, &index, &squared_distance));
  EXPECT_TRUE(index == 17 || index == 500) << index;
  EXPECT_EQ(squared_distance, 0.0);
  std::vector<int> indices;
  std::vector<double> squared_distances;
  tree.KNearest(points[17], 2, &indices, &squared_distances);
  ASSERT_EQ(indices.size(), 2u);
  EXPECT_EQ(std::min(indices[0], indices[1]), 17);
  EXPECT_EQ(std::max(indices[0], indices[1]), 500);
}

TEST(KdTreeTest, MovingTheCloudOrTheTreeKeepsItValid) {
  PointCloud points = RandomCloud(1000, 7);
  const PointCloud copy = points;
  KdTree tree(points);
  const PointCloud moved = std::move(points);
  const KdTree moved_tree = std::move(tree);
  const Vec3 q(0.2, 0.1, 0.0);
  int index = -1;
  double squared_distance = -1.0;
  ASSERT_TRUE(moved_tree.Nearest(q, kInf, &index, &squared_distance));
  EXPECT_EQ(index, BruteForceSorted(copy, q).front().second);
}

TEST(KdTreeTest, ConcurrentQueriesAgreeWithSerialOnes) {
  const PointCloud points = RandomCloud(5000, 8);
  const PointCloud queries = RandomCloud(4000, 9);
  const KdTree tree(points);
  std::vector<int> serial(queries.size(), -1);
  for (size_t i = 0; i < queries.size(); ++i) {
    double squared_distance;
    tree.Nearest(queries[i], 0.05, &serial[i], &squared_distance);
  }
  std::vector<int> parallel(queries.size(), -1);
  std::vector<std::vector<int>> knn(queries.size());
  auto work = [&](size_t begin, size_t end) {
    std::vector<double> squared_distances;
    for (size_t i = begin; i < end; ++i) {
      double squared_distance;
      tree.Nearest(queries[i], 0.05, &parallel[i], &squared_distance);
      tree.KNearest(queries[i], 8, &knn[i], &squared_distances);
    }
  };
  std::thread first(work, 0, queries.size() / 2);
  std::thread second(work, queries.size() / 2, queries.size());
  first.join();
  second.join();
  EXPECT_EQ(parallel, serial);
  std::vector<double> squared_distances;
  std::vector<int> indices;
  for (size_t i = 0; i < queries.size(); i += 97) {
    tree.KNearest(queries[i], 8, &indices, &squared_distances);
    EXPECT_EQ(knn[i], indices);
  }
}

}  // namespace
}  // namespace rigfit
