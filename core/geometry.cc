#include "core/geometry.h"

#include <algorithm>
#include <cmath>

namespace rigfit {

PointCloud UnprojectDepth(const CameraCapture& camera, const UnprojectOptions& options) {
  PointCloud points;
  if (!camera.HasDepth()) return points;
  const int stride = std::max(1, options.pixel_stride);
  const PinholeIntrinsics& K = camera.intrinsics;
  points.reserve(static_cast<size_t>(camera.width / stride + 1) * (camera.height / stride + 1));
  for (int v = 0; v < camera.height; v += stride) {
    for (int u = 0; u < camera.width; u += stride) {
      const double z = camera.depth_m[static_cast<size_t>(v) * camera.width + u];
      if (!(z >= options.min_depth_m && z <= options.max_depth_m)) continue;  // NaN fails too
      points.emplace_back(z * (u - K.cx) / K.fx, z * (v - K.cy) / K.fy, z);
    }
  }
  return points;
}

Eigen::Vector2i PixelOf(const PinholeIntrinsics& K, const Vec3& p) {
  return {static_cast<int>(std::lround(K.fx * p.x() / p.z() + K.cx)),
          static_cast<int>(std::lround(K.fy * p.y() / p.z() + K.cy))};
}

PointCloud CameraPoints(const CameraCapture& camera, const UnprojectOptions& options) {
  if (camera.HasDepth()) return UnprojectDepth(camera, options);
  PointCloud points;
  points.reserve(camera.points.size());
  for (const Vec3& p : camera.points) {
    if (p.allFinite() && p.z() >= options.min_depth_m && p.z() <= options.max_depth_m) {
      points.push_back(p);
    }
  }
  return points;
}

PointCloud Transform(const Pose& T, const PointCloud& points) {
  PointCloud out;
  out.reserve(points.size());
  for (const Vec3& p : points) out.push_back(T * p);
  return out;
}

double RotationAngle(const Mat3& R) {
  const double c = std::clamp(0.5 * (R.trace() - 1.0), -1.0, 1.0);
  // acos loses precision near 0; the norm of the skew part is sin(angle).
  const Vec3 s(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * s.norm(), c);
}

Pose RelativeErrorPose(const Pose& est_i, const Pose& est_j, const Pose& gt_i, const Pose& gt_j) {
  return (gt_i.inverse() * gt_j).inverse() * (est_i.inverse() * est_j);
}

RelativePoseError RelativeError(const Pose& est_i, const Pose& est_j, const Pose& gt_i,
                                const Pose& gt_j) {
  const Pose err = RelativeErrorPose(est_i, est_j, gt_i, gt_j);
  return {RotationAngle(err.linear()), err.translation().norm()};
}

double TiltErrorRad(const Pose& est, const Pose& gt) {
  const Vec3 up_est = est.linear().transpose() * kWorldUp;
  const Vec3 up_gt = gt.linear().transpose() * kWorldUp;
  return std::atan2(up_est.cross(up_gt).norm(), up_est.dot(up_gt));
}

Vec3 Signed(const Vec3& v) {
  int k = 0;
  v.cwiseAbs().maxCoeff(&k);
  return v[k] < 0.0 ? Vec3(-v) : v;
}

double Quantile(std::vector<double>* values, double q) {
  const auto k = static_cast<std::ptrdiff_t>(std::lround(q * (values->size() - 1)));
  std::nth_element(values->begin(), values->begin() + k, values->end());
  return (*values)[k];
}

}  // namespace rigfit
