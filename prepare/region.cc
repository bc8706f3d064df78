#include "prepare/region.h"

#include <algorithm>
#include <cmath>

#include "core/geometry.h"

namespace rigfit {

PointCloud NearFloorBand(const PointCloud& points_camera, const Pose& T_world_camera,
                         const RegionOptions& options) {
  if (options.band_height <= 0.0) return points_camera;
  PointCloud band;
  for (const Vec3& p : points_camera) {
    const double y = (T_world_camera * p).y();
    if (y >= -options.band_below && y <= options.band_height) band.push_back(p);
  }
  return band;
}

bool FloorModel::IsFloor(const Vec3& p) const {
  const Vec3 n_c = NormalInCamera();
  const double height = (T_world_camera * p).y();
  const double sigma_v = depth_noise * p.z() * std::abs(n_c.dot(p));
  return std::abs(height) <= std::max(thickness_m, 3.0 * sigma_v) && n_c.dot(-p) > 0.0;
}

void SnapFloorNormals(CloudPyramid* pyramid, const FloorModel& floor) {
  const Vec3 n_c = floor.NormalInCamera();
  // Plane-regularised covariance with the floor normal (preprocess.h, LocalGeometry).
  const Mat3 plane_covariance =
      Mat3::Identity() - (1.0 - kGicpPlaneEpsilon) * n_c * n_c.transpose();
  for (ScaleLevel& level : pyramid->levels) {
    for (size_t i = 0; i < level.points.size(); ++i) {
      if (!floor.IsFloor(level.points[i])) continue;
      level.geometry.normals[i] = n_c;
      level.geometry.covariances[i] = plane_covariance;
    }
  }
}

GroundBox RobustGroundBox(const PointCloud& points_world) {
  GroundBox box;
  if (points_world.empty()) return box;
  std::vector<double> xs, zs;
  xs.reserve(points_world.size());
  zs.reserve(points_world.size());
  for (const Vec3& p : points_world) {
    xs.push_back(p.x());
    zs.push_back(p.z());
  }
  box.min_x = Quantile(&xs, 0.005);
  box.max_x = Quantile(&xs, 0.995);
  box.min_z = Quantile(&zs, 0.005);
  box.max_z = Quantile(&zs, 0.995);
  box.empty = false;
  return box;
}

double InflatedOverlapArea(const GroundBox& a, const GroundBox& b, double margin) {
  if (a.empty || b.empty) return 0.0;
  const double dx = std::min(a.max_x, b.max_x) - std::max(a.min_x, b.min_x) + 2.0 * margin;
  const double dz = std::min(a.max_z, b.max_z) - std::max(a.min_z, b.min_z) + 2.0 * margin;
  return dx > 0.0 && dz > 0.0 ? dx * dz : 0.0;
}

std::vector<CandidatePair> FindCandidatePairs(const std::vector<GroundBox>& boxes,
                                              double overlap_margin, double min_overlap_area) {
  std::vector<CandidatePair> pairs;
  for (size_t a = 0; a < boxes.size(); ++a) {
    for (size_t b = a + 1; b < boxes.size(); ++b) {
      const double area = InflatedOverlapArea(boxes[a], boxes[b], overlap_margin);
      if (area > 0.0 && area >= min_overlap_area) {
        pairs.push_back({static_cast<int>(a), static_cast<int>(b), area});
      }
    }
  }
  return pairs;
}

}  // namespace rigfit
