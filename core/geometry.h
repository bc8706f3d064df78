// Geometry basics: depth to camera-frame points, moving clouds between frames, and the
// gauge-free pose errors used by tests, benchmarks and `rigfit evaluate`.
#pragma once

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// World up direction (+Y): the floor is y = 0 after ground leveling.
inline const Vec3 kWorldUp = Vec3::UnitY();

/// Which pixels of a depth image become points.
struct UnprojectOptions {
  int pixel_stride = 1;       ///< use every n-th pixel in u and v
  double min_depth_m = 0.1;   ///< closer samples are dropped
  double max_depth_m = 10.0;  ///< farther samples are dropped
};

/// Camera-frame points of the valid depth pixels: p = z * ((u - cx) / fx, (v - cy) / fy, 1),
/// with (u, v) the pixel centre coordinates (integer indices, OpenCV convention).
PointCloud UnprojectDepth(const CameraCapture& camera, const UnprojectOptions& options);

/// The camera's points in its own frame: unprojected depth, or its `points` as given
/// (filtered by the same range limits, measured as distance along z).
PointCloud CameraPoints(const CameraCapture& camera, const UnprojectOptions& options);

/// The pixel (u, v) a camera-frame point of a depth image was unprojected from
/// (UnprojectDepth): its projection by K, rounded. z > 0.
Eigen::Vector2i PixelOf(const PinholeIntrinsics& K, const Vec3& p);

/// Where the ray origin + s ray meets the plane n^T x + d = 0: s (the depth, for a ray a = p / z
/// of a camera at origin); infinity when the ray runs parallel to the plane (|n^T ray| < 1e-9).
inline double RayPlaneDepth(const Vec3& origin, const Vec3& ray, const Vec3& n, double d) {
  const double denominator = n.dot(ray);
  return std::abs(denominator) < 1e-9 ? std::numeric_limits<double>::infinity()
                                      : -(n.dot(origin) + d) / denominator;
}

/// Weighted total least squares plane through `count` points (point(k) the k-th, weight(k) its
/// weight): the normal is the eigenvector of the smallest eigenvalue of the weighted scatter
/// about the weighted mean, in the eigen solver's sign.
template <typename PointAt, typename WeightAt>
PlanarFace FitPlane(size_t count, const PointAt& point, const WeightAt& weight) {
  Vec3 mean = Vec3::Zero();
  double total = 0.0;
  for (size_t k = 0; k < count; ++k) {
    mean += weight(k) * point(k);
    total += weight(k);
  }
  mean /= total;
  Mat3 scatter = Mat3::Zero();
  for (size_t k = 0; k < count; ++k) {
    const Vec3 d = point(k) - mean;
    scatter.noalias() += weight(k) * d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig(scatter);
  PlanarFace plane;
  plane.normal = eig.eigenvectors().col(0);
  plane.offset = -plane.normal.dot(mean);
  return plane;
}

/// T * p for every point.
PointCloud Transform(const Pose& T, const PointCloud& points);

/// The error of the relative pose T_i^-1 T_j of an estimate against ground truth, as a
/// pose: (gt_i^-1 gt_j)^-1 (est_i^-1 est_j).
Pose RelativeErrorPose(const Pose& est_i, const Pose& est_j, const Pose& gt_i, const Pose& gt_j);

/// Error of the relative pose T_i^-1 T_j of an estimate against ground truth.
struct RelativePoseError {
  double rotation_rad = 0.0;
  double translation_m = 0.0;
};
RelativePoseError RelativeError(const Pose& est_i, const Pose& est_j, const Pose& gt_i,
                                const Pose& gt_j);

/// Angle between world up as seen by the estimated and by the true camera: the tilt
/// (pitch/roll) error, blind to yaw and translation.
double TiltErrorRad(const Pose& est, const Pose& gt);

/// Rotation angle of R (radians, [0, pi]).
double RotationAngle(const Mat3& R);

/// v signed so that its largest component is positive (a direction's sign made definite).
Vec3 Signed(const Vec3& v);

/// The q-quantile (q in [0, 1]) of non-empty `values`, the element at the rounded rank
/// q (n - 1); values is reordered.
double Quantile(std::vector<double>* values, double q);

}  // namespace rigfit
