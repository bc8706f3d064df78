// Nearest-neighbour search (the k-d tree and the uniform grid) and per-camera preprocessing on
// rigfit's workload. Results and the command are recorded in docs/benchmarks.md.
//
// Clouds:
// - "band": N points sampled uniformly (by area) on the near-floor band (height 0 to 0.3 m)
//   of a synthetic 8 m x 6 m room with boxes: floor, wall feet, box sides and a low box top,
//   2 mm Gaussian noise along the surface normal, ordered by 2 cm voxel like the output of
//   VoxelDownsample. Correspondence queries are an independent
//   sample of the same surfaces moved by a small rigid motion (1 degree, 3 cm), as in an ICP
//   iteration near convergence, searched within 1.4x the mean point spacing.
// - "real": the small_gicp outdoor LiDAR pair (shared/data/small_gicp, ~69k points each):
//   tree on target, queries = source moved by the ground-truth T_target_source, 1 m bound.
// - "camera": a 640x360 depth image ray-cast from a camera 2.3 m up looking down into the
//   room (2 mm depth noise), unprojected with stride 2, cut to the band, then preprocessed.
#include <benchmark/benchmark.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <tuple>

#include "core/geometry.h"
#include "prepare/preprocess.h"
#include "search/knn.h"
#include "search/point_grid.h"

namespace rigfit {
namespace {

constexpr double kRoomX = 8.0;
constexpr double kRoomZ = 6.0;
constexpr double kRoomHeight = 2.8;
constexpr double kBandHeight = 0.3;
constexpr double kNoise = 0.002;

struct Box {
  Vec3 min;
  Vec3 max;
};
const std::vector<Box>& Boxes() {
  static const std::vector<Box> boxes = {{Vec3(2.0, 0.0, 2.0), Vec3(2.6, 0.8, 2.5)},
                                         {Vec3(5.0, 0.0, 1.0), Vec3(6.0, 0.4, 1.8)},
                                         {Vec3(3.5, 0.0, 4.0), Vec3(4.3, 1.2, 4.6)},
                                         {Vec3(6.5, 0.0, 4.5), Vec3(7.2, 0.25, 5.2)}};
  return boxes;
}

/// A rectangle origin + s u + t v, s, t in [0, 1], with unit normal.
struct Rect {
  Vec3 origin, u, v, normal;
  double Area() const { return u.norm() * v.norm(); }
};

std::vector<Rect> BandSurfaces() {
  std::vector<Rect> rects;
  rects.push_back({Vec3::Zero(), Vec3(kRoomX, 0, 0), Vec3(0, 0, kRoomZ), Vec3::UnitY()});
  const Vec3 h(0, kBandHeight, 0);
  rects.push_back({Vec3::Zero(), Vec3(kRoomX, 0, 0), h, Vec3::UnitZ()});
  rects.push_back({Vec3(0, 0, kRoomZ), Vec3(kRoomX, 0, 0), h, -Vec3::UnitZ()});
  rects.push_back({Vec3::Zero(), Vec3(0, 0, kRoomZ), h, Vec3::UnitX()});
  rects.push_back({Vec3(kRoomX, 0, 0), Vec3(0, 0, kRoomZ), h, -Vec3::UnitX()});
  for (const Box& b : Boxes()) {
    const Vec3 size = b.max - b.min;
    const Vec3 up(0, std::min(size.y(), kBandHeight), 0);
    rects.push_back({b.min, Vec3(size.x(), 0, 0), up, -Vec3::UnitZ()});
    rects.push_back({b.min + Vec3(0, 0, size.z()), Vec3(size.x(), 0, 0), up, Vec3::UnitZ()});
    rects.push_back({b.min, Vec3(0, 0, size.z()), up, -Vec3::UnitX()});
    rects.push_back({b.min + Vec3(size.x(), 0, 0), Vec3(0, 0, size.z()), up, Vec3::UnitX()});
    if (size.y() <= kBandHeight) {
      rects.push_back({b.min + Vec3(0, size.y(), 0), Vec3(size.x(), 0, 0), Vec3(0, 0, size.z()),
                       Vec3::UnitY()});
    }
  }
  return rects;
}

bool UnderABox(const Vec3& p) {
  for (const Box& b : Boxes()) {
    if (p.x() > b.min.x() && p.x() < b.max.x() && p.z() > b.min.z() && p.z() < b.max.z()) {
      return true;
    }
  }
  return false;
}

double BandArea() {
  double area = 0.0;
  for (const Rect& r : BandSurfaces()) area += r.Area();
  for (const Box& b : Boxes()) area -= (b.max.x() - b.min.x()) * (b.max.z() - b.min.z());
  return area;
}

PointCloud SampleBand(int n, std::uint32_t seed) {
  const std::vector<Rect> rects = BandSurfaces();
  std::vector<double> areas;
  for (const Rect& r : rects) areas.push_back(r.Area());
  std::mt19937 rng(seed);
  std::discrete_distribution<int> pick(areas.begin(), areas.end());
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, kNoise);
  PointCloud points;
  points.reserve(n);
  while (static_cast<int>(points.size()) < n) {
    const Rect& r = rects[pick(rng)];
    const Vec3 p = r.origin + uniform(rng) * r.u + uniform(rng) * r.v;
    if (&r == &rects[0] && UnderABox(p)) continue;
    points.push_back(p + noise(rng) * r.normal);
  }
  // In the order VoxelDownsample returns (by 2 cm voxel), as the solvers' clouds come.
  const auto voxel = [](const Vec3& p) {
    return std::make_tuple(std::floor(p.x() / 0.02), std::floor(p.y() / 0.02),
                           std::floor(p.z() / 0.02));
  };
  std::sort(points.begin(), points.end(),
            [&](const Vec3& a, const Vec3& b) { return voxel(a) < voxel(b); });
  return points;
}

double MeanSpacing(int n) { return std::sqrt(BandArea() / n); }

/// Correspondence queries: an independent band sample moved by 1 degree about +Y and 3 cm.
PointCloud MovedQueries(int n) {
  Pose motion = Pose::Identity();
  motion.linear() = Eigen::AngleAxisd(kDegToRad, Vec3::UnitY()).toRotationMatrix();
  motion.translation() = Vec3(0.02, 0.01, -0.02);
  return Transform(motion, SampleBand(n, 1000 + n));
}

const PointCloud& CachedBand(int n) {
  static std::map<int, PointCloud> clouds;
  auto it = clouds.find(n);
  if (it == clouds.end()) it = clouds.emplace(n, SampleBand(n, n)).first;
  return it->second;
}

/// Points of a binary little-endian PLY with float or double x, y, z vertex properties.
/// Returns an empty cloud if the file is missing or has another layout.
PointCloud ReadBinaryPlyPoints(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::string line;
  if (!std::getline(file, line) || line != "ply") return {};
  size_t count = 0, stride = 0;
  int offset[3] = {-1, -1, -1};
  bool little_endian = false, float32 = true, in_vertex = false;
  while (std::getline(file, line) && line != "end_header") {
    std::istringstream words(line);
    std::string keyword, type, name;
    words >> keyword;
    if (keyword == "format") {
      words >> type;
      little_endian = type == "binary_little_endian";
    } else if (keyword == "element") {
      words >> name;
      in_vertex = name == "vertex";
      if (in_vertex) words >> count;
    } else if (keyword == "property" && in_vertex) {
      words >> type >> name;
      const size_t size = (type == "double" || type == "float64") ? 8 : 4;
      const int axis = name == "x" ? 0 : name == "y" ? 1 : name == "z" ? 2 : -1;
      if (axis >= 0) {
        offset[axis] = static_cast<int>(stride);
        float32 = size == 4;
      }
      stride += size;
    }
  }
  if (!little_endian || offset[0] < 0 || offset[1] < 0 || offset[2] < 0) return {};
  std::vector<char> data(count * stride);
  if (!file.read(data.data(), static_cast<std::streamsize>(data.size()))) return {};
  PointCloud points(count);
  for (size_t i = 0; i < count; ++i) {
    for (int axis = 0; axis < 3; ++axis) {
      const char* field = data.data() + i * stride + offset[axis];
      if (float32) {
        float value;
        std::memcpy(&value, field, sizeof(value));
        points[i][axis] = value;
      } else {
        std::memcpy(&points[i][axis], field, sizeof(double));
      }
    }
  }
  return points;
}

struct RealPair {
  PointCloud target;
  PointCloud source_in_target;  ///< source moved by the ground-truth T_target_source
};

const RealPair& Real() {
  static const RealPair pair = [] {
    const std::string dir = std::string(RIGFIT_SHARED_DATA_DIR) + "/small_gicp/";
    RealPair p;
    p.target = ReadBinaryPlyPoints(dir + "target.ply");
    const PointCloud source = ReadBinaryPlyPoints(dir + "source.ply");
    std::ifstream file(dir + "T_target_source.txt");
    Eigen::Matrix4d T;
    for (int i = 0; i < 16; ++i) file >> T(i / 4, i % 4);
    if (!file || source.empty()) return RealPair{};
    Pose T_target_source = Pose::Identity();
    T_target_source.matrix() = T;
    p.source_in_target = Transform(T_target_source, source);
    return p;
  }();
  return pair;
}

// ---------------------------------------------------------------------------------------
// k-d tree: build, bounded nearest neighbour, k = 20 nearest neighbours.

void BM_Build(benchmark::State& state) {
  const PointCloud& points = CachedBand(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    KdTree tree(points);
    benchmark::DoNotOptimize(tree);
  }
  state.counters["points"] = static_cast<double>(points.size());
}

/// Bounded nearest-neighbour queries on any index with KdTree's Nearest (KdTree, PointGrid).
template <typename Index>
void RunNearest(benchmark::State& state, const Index& index, const PointCloud& queries,
                double max_distance) {
  int matched = 0;
  for (auto _ : state) {
    matched = 0;
    for (const Vec3& q : queries) {
      int found;
      double squared_distance;
      matched += index.Nearest(q, max_distance, &found, &squared_distance);
    }
    benchmark::DoNotOptimize(matched);
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(queries.size()));
  state.counters["queries"] = static_cast<double>(queries.size());
  state.counters["matched"] = static_cast<double>(matched) / queries.size();
}

void RunKNearest(benchmark::State& state, const KdTree& tree, const PointCloud& queries, int k) {
  std::vector<int> indices;
  std::vector<double> squared_distances;
  for (auto _ : state) {
    for (const Vec3& q : queries) {
      tree.KNearest(q, k, &indices, &squared_distances);
      benchmark::DoNotOptimize(indices.data());
    }
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(queries.size()));
  state.counters["queries"] = static_cast<double>(queries.size());
}

void BM_Nearest(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const KdTree tree(CachedBand(n));
  static const PointCloud queries = MovedQueries(30000);
  RunNearest(state, tree, queries, 1.4 * MeanSpacing(n));
}

/// The correspondence search's grid (search/point_grid.h) on the same queries, built for
/// the query radius.
void BM_GridNearest(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const double radius = 1.4 * MeanSpacing(n);
  const PointGrid grid(CachedBand(n), radius);
  static const PointCloud queries = MovedQueries(30000);
  RunNearest(state, grid, queries, radius);
}

void BM_KNearest20(benchmark::State& state) {
  const PointCloud& points = CachedBand(static_cast<int>(state.range(0)));
  const KdTree tree(points);
  RunKNearest(state, tree, points, 20);
}

void BM_RealBuild(benchmark::State& state) {
  const PointCloud& points = Real().target;
  if (points.empty()) return state.SkipWithError("small_gicp/target.ply not readable");
  for (auto _ : state) {
    KdTree tree(points);
    benchmark::DoNotOptimize(tree);
  }
  state.counters["points"] = static_cast<double>(points.size());
}

void BM_RealNearest(benchmark::State& state) {
  if (Real().target.empty()) return state.SkipWithError("small_gicp data not readable");
  const KdTree tree(Real().target);
  RunNearest(state, tree, Real().source_in_target, 1.0);
}

void BM_RealGridNearest(benchmark::State& state) {
  if (Real().target.empty()) return state.SkipWithError("small_gicp data not readable");
  const PointGrid grid(Real().target, 1.0);
  RunNearest(state, grid, Real().source_in_target, 1.0);
}

void BM_RealKNearest20(benchmark::State& state) {
  if (Real().target.empty()) return state.SkipWithError("small_gicp data not readable");
  const KdTree tree(Real().target);
  RunKNearest(state, tree, Real().target, 20);
}

BENCHMARK(BM_Build)->Arg(5000)->Arg(10000)->Arg(20000)->Arg(40000)->Arg(100000)->Unit(
    benchmark::kMillisecond);
BENCHMARK(BM_Nearest)
    ->Arg(5000)
    ->Arg(20000)
    ->Arg(40000)
    ->Arg(100000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GridNearest)
    ->Arg(5000)
    ->Arg(20000)
    ->Arg(40000)
    ->Arg(100000)
    ->Unit(benchmark::kMillisecond);
BENCHMARK(BM_KNearest20)->Arg(5000)->Arg(20000)->Arg(40000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RealBuild)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RealNearest)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RealGridNearest)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RealKNearest20)->Unit(benchmark::kMillisecond);

// ---------------------------------------------------------------------------------------
// Eigen solvers for the 3x3 neighbourhood covariance: time per decomposition and the
// largest normal error against the true plane (noise = range(0) micrometres), and the
// largest angle between the two solvers' normals.

double AngleRad(const Vec3& a, const Vec3& b) {
  return std::atan2(a.cross(b).norm(), std::abs(a.dot(b)));
}

struct PlanePatches {
  std::vector<Mat3> covariances;
  PointCloud normals;
};

/// Centred covariances of 20 points on random 10 cm square plane patches 7 m from the origin.
PlanePatches MakePlanePatches(double noise) {
  std::mt19937 rng(7);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-0.05, 0.05);
  PlanePatches patches;
  for (int t = 0; t < 10000; ++t) {
    const Vec3 n = Vec3(gauss(rng), gauss(rng), gauss(rng)).normalized();
    const Vec3 a = n.unitOrthogonal(), b = n.cross(a);
    PointCloud points;
    Vec3 mean = Vec3::Zero();
    for (int i = 0; i < 20; ++i) {
      points.push_back(Vec3(3.0, 1.5, 6.0) + uniform(rng) * a + uniform(rng) * b +
                       noise * gauss(rng) * n);
      mean += points.back() / 20.0;
    }
    Mat3 covariance = Mat3::Zero();
    for (const Vec3& p : points) covariance += (p - mean) * (p - mean).transpose() / 20.0;
    patches.covariances.push_back(covariance);
    patches.normals.push_back(n);
  }
  return patches;
}

Vec3 SmallestEigenvector(const Mat3& covariance, bool direct) {
  Eigen::SelfAdjointEigenSolver<Mat3> solver;
  if (direct) {
    solver.computeDirect(covariance);
  } else {
    solver.compute(covariance);
  }
  return solver.eigenvectors().col(0);
}

void BM_NormalEigenSolver(benchmark::State& state, bool direct) {
  const PlanePatches patches = MakePlanePatches(1e-6 * static_cast<double>(state.range(0)));
  for (auto _ : state) {
    for (const Mat3& c : patches.covariances) {
      benchmark::DoNotOptimize(SmallestEigenvector(c, direct));
    }
  }
  double max_error = 0.0, max_difference = 0.0;
  for (size_t i = 0; i < patches.covariances.size(); ++i) {
    const Vec3 n = SmallestEigenvector(patches.covariances[i], direct);
    max_error = std::max(max_error, AngleRad(n, patches.normals[i]));
    max_difference =
        std::max(max_difference, AngleRad(n, SmallestEigenvector(patches.covariances[i], !direct)));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(patches.covariances.size()));
  state.counters["max_err_rad"] = max_error;
  state.counters["max_diff_rad"] = max_difference;
}
BENCHMARK_CAPTURE(BM_NormalEigenSolver, iterative, false)->Arg(0)->Arg(2000);
BENCHMARK_CAPTURE(BM_NormalEigenSolver, direct, true)->Arg(0)->Arg(2000);

// ---------------------------------------------------------------------------------------
// One camera's preprocessing, stage by stage.

struct CameraScene {
  CameraCapture camera;
  Pose T_world_camera = Pose::Identity();
  PointCloud unprojected;  ///< camera frame, stride 2
  PointCloud band;         ///< camera frame, world height in [-0.05, 0.3]
};

/// Distance along the unnormalised ray o + t d to the first surface of the room.
double RayCast(const Vec3& o, const Vec3& d) {
  double t_hit = std::numeric_limits<double>::infinity();
  // Inside the room: the exit through floor, ceiling or a wall is the smallest positive t.
  const Vec3 room_min(0.0, 0.0, 0.0), room_max(kRoomX, kRoomHeight, kRoomZ);
  for (int axis = 0; axis < 3; ++axis) {
    if (d[axis] > 0) t_hit = std::min(t_hit, (room_max[axis] - o[axis]) / d[axis]);
    if (d[axis] < 0) t_hit = std::min(t_hit, (room_min[axis] - o[axis]) / d[axis]);
  }
  for (const Box& b : Boxes()) {  // slab test
    double t_near = 0.0, t_far = t_hit;
    for (int axis = 0; axis < 3; ++axis) {
      const double t0 = (b.min[axis] - o[axis]) / d[axis];
      const double t1 = (b.max[axis] - o[axis]) / d[axis];
      t_near = std::max(t_near, std::min(t0, t1));
      t_far = std::min(t_far, std::max(t0, t1));
    }
    if (t_near <= t_far) t_hit = std::min(t_hit, t_near);
  }
  return t_hit;
}

const CameraScene& Camera() {
  static const CameraScene scene = [] {
    CameraScene s;
    const Vec3 centre(0.5, 2.3, 0.5);
    const Vec3 forward = (Vec3(4.5, 0.0, 3.5) - centre).normalized();
    const Vec3 right = forward.cross(Vec3::UnitY()).normalized();
    s.T_world_camera.linear() << right, forward.cross(right), forward;  // x right, y down
    s.T_world_camera.translation() = centre;
    CameraCapture& c = s.camera;
    c.width = 640;
    c.height = 360;
    c.intrinsics = {330.0, 330.0, 319.5, 179.5};
    c.depth_m.resize(static_cast<size_t>(c.width) * c.height);
    std::mt19937 rng(11);
    std::normal_distribution<double> noise(0.0, kNoise);
    const Mat3 R = s.T_world_camera.linear();
    for (int v = 0; v < c.height; ++v) {
      for (int u = 0; u < c.width; ++u) {
        // With the ray (x/z, y/z, 1) in the camera frame, the ray parameter is the depth.
        const Vec3 ray((u - c.intrinsics.cx) / c.intrinsics.fx,
                       (v - c.intrinsics.cy) / c.intrinsics.fy, 1.0);
        const double depth = RayCast(centre, R * ray) + noise(rng);
        c.depth_m[static_cast<size_t>(v) * c.width + u] = static_cast<float>(depth);
      }
    }
    UnprojectOptions options;
    options.pixel_stride = 2;
    options.min_depth_m = 0.2;
    options.max_depth_m = 10.0;
    s.unprojected = UnprojectDepth(c, options);
    for (const Vec3& p : s.unprojected) {
      const double height = (s.T_world_camera * p).y();
      if (height >= -0.05 && height <= kBandHeight) s.band.push_back(p);
    }
    return s;
  }();
  return scene;
}

void CameraCounters(benchmark::State& state) {
  state.counters["unprojected"] = static_cast<double>(Camera().unprojected.size());
  state.counters["band"] = static_cast<double>(Camera().band.size());
}

double VoxelArg(const benchmark::State& state) { return 1e-3 * state.range(0); }

void BM_CameraUnproject(benchmark::State& state) {
  UnprojectOptions options;
  options.pixel_stride = 2;
  options.min_depth_m = 0.2;
  for (auto _ : state) benchmark::DoNotOptimize(UnprojectDepth(Camera().camera, options));
  CameraCounters(state);
}

void BM_CameraVoxel(benchmark::State& state) {
  PointCloud points;
  for (auto _ : state) points = VoxelDownsample(Camera().band, VoxelArg(state));
  CameraCounters(state);
  state.counters["points"] = static_cast<double>(points.size());
}

void BM_CameraTree(benchmark::State& state) {
  const PointCloud points = VoxelDownsample(Camera().band, VoxelArg(state));
  for (auto _ : state) {
    KdTree tree(points);
    benchmark::DoNotOptimize(tree);
  }
  state.counters["points"] = static_cast<double>(points.size());
}

void BM_CameraGeometry(benchmark::State& state) {
  const PointCloud points = VoxelDownsample(Camera().band, VoxelArg(state));
  const KdTree tree(points);
  const int threads = static_cast<int>(state.range(1));
  for (auto _ : state) {
    benchmark::DoNotOptimize(EstimateLocalGeometry(points, tree, 20, Vec3::Zero(), threads));
  }
  state.counters["points"] = static_cast<double>(points.size());
}

void BM_CameraPyramid(benchmark::State& state) {
  const std::vector<double> voxel_sizes = {0.08, 0.04, 0.02};
  const int threads = static_cast<int>(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        BuildPyramid(Camera().band, voxel_sizes, 20, Vec3::Zero(), 1.4, threads));
  }
  CameraCounters(state);
}

BENCHMARK(BM_CameraUnproject)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CameraVoxel)->Arg(80)->Arg(40)->Arg(20)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_CameraTree)->Arg(80)->Arg(40)->Arg(20)->Unit(benchmark::kMillisecond);
// Wall-clock time, and CPU time summed over all threads (the compute cost, which stays
// meaningful when other jobs share the cores).
BENCHMARK(BM_CameraGeometry)
    ->ArgsProduct({{80, 40, 20}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();
BENCHMARK(BM_CameraPyramid)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MeasureProcessCPUTime();

}  // namespace
}  // namespace rigfit

BENCHMARK_MAIN();
