#include "report/view3d_scenes.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "report/palette.h"

namespace rigfit {
namespace {

/// The first voxel of a map too large for the view (metres), and the margin of each next try.
constexpr double kFirstVoxelM = 0.005;
constexpr double kVoxelGrowth = 1.05;

std::vector<Vec3f> ToFloat(const PointCloud& points) {
  std::vector<Vec3f> out;
  out.reserve(points.size());
  for (const Vec3& p : points) out.push_back(p.cast<float>());
  return out;
}

/// Every valid pixel of the camera in its frame, with its colour when the capture has one.
ViewCloud WholeView(const CameraCapture& camera, int index) {
  ViewCloud cloud{kWholeLayer, index, {}, {}, {}};
  const PointCloud points = CameraPoints(camera, UnprojectOptions{});
  cloud.points = ToFloat(points);
  if (camera.HasDepth() && !camera.color.empty()) {
    cloud.rgb.reserve(3 * points.size());
    for (const Vec3& p : points) {
      const Eigen::Vector2i uv = PixelOf(camera.intrinsics, p);
      const size_t pixel = static_cast<size_t>(uv.y()) * camera.width + uv.x();
      cloud.rgb.insert(cloud.rgb.end(), &camera.color[3 * pixel], &camera.color[3 * pixel] + 3);
    }
  }
  return cloud;
}

/// A voxel's sums while averaging.
struct VoxelSum {
  Vec3 position = Vec3::Zero();
  Vec3 color = Vec3::Zero();
  int count = 0;
};

/// The map's points and colours (3 bytes each, or none) averaged per voxel of `voxel_m`.
ViewCloud VoxelAverage(const MapPoints& map, double voxel_m) {
  std::unordered_map<std::uint64_t, VoxelSum> voxels;
  const bool colored = !map.colors.empty();
  for (size_t i = 0; i < map.positions.size(); ++i) {
    const Vec3f& p = map.positions[i];
    if (!p.allFinite()) continue;
    std::uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {  // 21 bits per axis: +-10 km at 1 cm
      key = (key << 21) | (static_cast<std::uint64_t>(std::floor(p[k] / voxel_m)) & 0x1fffff);
    }
    VoxelSum& v = voxels[key];
    v.position += p.cast<double>();
    if (colored) v.color += map.colors[i].cast<double>();
    ++v.count;
  }
  ViewCloud cloud;
  for (const auto& [key, v] : voxels) {
    cloud.points.push_back((v.position / v.count).cast<float>());
    if (!colored) continue;
    for (int k = 0; k < 3; ++k) {
      cloud.rgb.push_back(static_cast<std::uint8_t>(std::clamp(v.color[k] / v.count, 0.0, 255.0)));
    }
  }
  return cloud;
}

ViewCloud MapCloud(const MapPoints& map) {
  if (map.positions.size() <= kMaxViewMapPoints) {
    ViewCloud cloud{kMapLayer, -1, map.positions, {}, {}};
    for (const Vec3f& c : map.colors) {
      for (int k = 0; k < 3; ++k) {
        cloud.rgb.push_back(static_cast<std::uint8_t>(std::clamp(c[k], 0.0f, 255.0f)));
      }
    }
    return cloud;
  }
  // A map is mostly surfaces: its voxels fall as 1 / voxel^2, so the next voxel is scaled by
  // the square root of the excess (and grown by kVoxelGrowth more, so that few tries fit).
  for (double voxel_m = kFirstVoxelM;;) {
    ViewCloud cloud = VoxelAverage(map, voxel_m);
    const double excess = static_cast<double>(cloud.points.size()) / kMaxViewMapPoints;
    if (excess <= 1.0) return cloud;
    voxel_m *= kVoxelGrowth * std::sqrt(excess);
  }
}

/// The 1st percentile of the points' heights along up (0 without points).
double FloorHeight(const std::vector<Vec3f>& points, const Vec3& up) {
  std::vector<double> heights;
  const size_t stride = std::max<size_t>(1, points.size() / 100000);
  for (size_t i = 0; i < points.size(); i += stride)
    heights.push_back(up.dot(points[i].cast<double>()));
  if (heights.empty()) return 0.0;
  const auto nth = heights.begin() + heights.size() / 100;
  std::nth_element(heights.begin(), nth, heights.end());
  return *nth;
}

/// The colour of the plane at `index`: hues a golden angle apart, so that neighbours differ.
Rgb PlaneColor(int index) {
  const double hue = std::fmod(0.08 + 0.618033988749895 * index, 1.0) * 6.0;
  const double f = hue - std::floor(hue);
  const double v = 0.85, s = 0.65;
  const double p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  const double rgb[6][3] = {{v, t, p}, {q, v, p}, {p, v, t}, {p, q, v}, {t, p, v}, {v, p, q}};
  const double* c = rgb[static_cast<int>(hue) % 6];
  const auto byte = [](double x) { return static_cast<std::uint8_t>(std::lround(255 * x)); };
  return {byte(c[0]), byte(c[1]), byte(c[2])};
}

/// z of (b - a) x (c - a) in 2-D.
double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// The convex hull of the points, counter-clockwise (gift wrapping from the point farthest
/// from their mean, a corner however rounding orders nearly equal coordinates); a turn
/// smaller than `tolerance` (in the cross product's units) counts as straight, the farther
/// point taken. Empty when the hull's area is not above the tolerance.
std::vector<Eigen::Vector2d> ConvexHull(const std::vector<Eigen::Vector2d>& points,
                                        double tolerance) {
  if (points.size() < 3) return {};
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : points) mean += p / static_cast<double>(points.size());
  const auto nearer = [&](const auto& a, const auto& b) {
    return (a - mean).squaredNorm() < (b - mean).squaredNorm();
  };
  const size_t start = std::max_element(points.begin(), points.end(), nearer) - points.begin();
  std::vector<Eigen::Vector2d> hull;
  size_t current = start;
  do {
    hull.push_back(points[current]);
    size_t next = current == 0 ? 1 : 0;
    for (size_t i = 0; i < points.size(); ++i) {
      const double turn = Cross(points[current], points[next], points[i]);
      const bool farther = (points[i] - points[current]).squaredNorm() >
                           (points[next] - points[current]).squaredNorm();
      if (turn < -tolerance || (turn <= tolerance && farther)) next = i;
    }
    current = next;
  } while (current != start && hull.size() <= points.size());
  double area = 0.0;
  for (size_t k = 0; k < hull.size(); ++k) {
    area += Cross(Eigen::Vector2d::Zero(), hull[k], hull[(k + 1) % hull.size()]);
  }
  return hull.size() >= 3 && area > tolerance ? hull : std::vector<Eigen::Vector2d>{};
}

}  // namespace

std::vector<Vec3> PlanePatch(const PlanarFace& plane, const std::vector<Vec3>& points) {
  const Vec3 n = plane.normal.normalized();
  // u, v: an orthonormal basis of the plane with u x v = n.
  const Vec3 u = n.unitOrthogonal();
  const Vec3 v = n.cross(u);
  const Vec3 origin = -plane.offset / plane.normal.norm() * n;
  std::vector<Eigen::Vector2d> in_plane;
  in_plane.reserve(points.size());
  double extent = 0.0;
  for (const Vec3& p : points) {
    in_plane.emplace_back(u.dot(p - origin), v.dot(p - origin));
    extent = std::max(extent, in_plane.back().cwiseAbs().maxCoeff());
  }
  std::vector<Vec3> corners;
  for (const Eigen::Vector2d& c : ConvexHull(in_plane, 1e-12 * extent * extent))
    corners.push_back(origin + c.x() * u + c.y() * v);
  return corners;
}

std::vector<ViewPlane> SurfacePlanes(const SurfaceBundleReport& surface,
                                     const std::vector<Pose>& T_world_camera) {
  std::vector<std::vector<Vec3>> members(surface.plane_list.size());
  for (const SurfaceTerm& term : surface.terms) {
    const Pose& T = T_world_camera.at(term.camera);
    const PointCloud& points = surface.points.at(term.camera);
    for (const int i : term.pixels) members.at(term.plane).push_back(T * points.at(i));
  }
  std::vector<ViewPlane> planes;
  for (size_t j = 0; j < members.size(); ++j) {
    ViewPlane plane{PlaneColor(static_cast<int>(j)), surface.plane_list[j].floor,
                    PlanePatch(surface.plane_list[j], members[j])};
    if (!plane.corners.empty()) planes.push_back(std::move(plane));
  }
  return planes;
}

View3dScene RigView3dScene(const RigCapture& capture, const DiagnosticRig& rig,
                           const std::vector<NamedPoses>& pose_sets, const IcpOptions& icp,
                           int num_threads) {
  View3dScene scene;
  scene.residual_range_m =
      icp.max_correspondence_distance_factor * rig.bands.front().levels.front().voxel_size;
  std::vector<std::vector<std::vector<float>>> residuals;  // [pose set][camera][point]
  for (const NamedPoses& set : pose_sets) {
    ViewPoseSet& view_set = scene.pose_sets.emplace_back();
    view_set.name = set.name;
    for (const std::string& serial : rig.serials)
      view_set.T_world_camera.push_back(set.poses->at(serial));
    residuals.push_back(PointResiduals(rig, *set.poses, icp, num_threads));
  }
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    const CameraCapture& camera = capture.cameras[i];
    const int index = static_cast<int>(i);
    scene.cameras.push_back(
        {camera.serial, CameraColor(index), camera.intrinsics, camera.width, camera.height});
    ViewCloud band{kBandLayer, index, ToFloat(rig.bands[i].levels.front().points), {}, {}};
    for (const auto& set : residuals) band.residuals_m.push_back(set[i]);
    scene.clouds.push_back(std::move(band));
    scene.clouds.push_back(WholeView(camera, index));
  }
  return scene;
}

View3dScene MapView3dScene(const std::string& title, const MapPoints& map,
                           const std::vector<MapOverlay>& overlays, const MapViewAxes& axes) {
  View3dScene scene;
  scene.title = title;
  scene.up = axes.up;
  scene.clouds.push_back(MapCloud(map));
  scene.floor_m = FloorHeight(scene.clouds.front().points, axes.up);
  ViewPoseSet cameras{"cameras", {}};
  for (const MapOverlay& overlay : overlays) {
    if (overlay.cameras) {
      for (const Pose& T : overlay.poses) {
        scene.cameras.push_back({overlay.label, overlay.color, {}, 0, 0});
        cameras.T_world_camera.push_back(T);
      }
      continue;
    }
    ViewPath& path = scene.paths.emplace_back();
    path.label = overlay.label;
    path.color = overlay.color;
    for (const Pose& T : overlay.poses) path.positions.push_back(T.translation());
  }
  if (!scene.cameras.empty()) scene.pose_sets.push_back(std::move(cameras));
  return scene;
}

}  // namespace rigfit
