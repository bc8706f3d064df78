// Plain data types shared by every module: a rig capture as the solver sees it.
// No HDF5, JSON or YAML types here (io/ converts to and from these).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/pose.h"

namespace rigfit {

using PointCloud = std::vector<Vec3>;

/// Pinhole intrinsics of the camera frame (OpenCV: x right, y down, z forward), pixels.
struct PinholeIntrinsics {
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
};

/// One camera of a rig capture: either a depth image with intrinsics, or a point cloud.
struct CameraCapture {
  std::string serial;

  // Depth layout: row-major [height, width] depth in metres; invalid pixels are NaN.
  int width = 0;
  int height = 0;
  std::vector<float> depth_m;
  PinholeIntrinsics intrinsics;
  std::vector<float> confidence;    ///< optional, [height, width], larger = more reliable
  std::vector<std::uint8_t> color;  ///< optional, [height, width, 3] RGB
  /// Optional: a stereo camera's baseline in metres (depth = fx baseline_m / disparity);
  /// 0 when unknown or not a stereo camera.
  double baseline_m = 0.0;
  /// Finite depth samples beyond 1000 m that were read as invalid: sensor glitches
  /// (io/capture_h5.h; every sample of a burst counts).
  std::int64_t glitch_depth_samples = 0;

  // Points layout: points (and optional normals) in the camera frame, metres.
  PointCloud points;
  PointCloud normals;

  bool HasDepth() const { return !depth_m.empty(); }
  bool HasPoints() const { return !points.empty(); }
};

/// A synchronised capture of every camera of a rig, ordered by serial (string order).
struct RigCapture {
  std::vector<CameraCapture> cameras;
};

/// A plane n^T x + offset = 0 (n unit), in whichever frame its user says: the faces of a
/// scene, a camera's floor, the surface bundle's planes. The floor's normal is +Y in the world
/// (leveling defines up).
struct PlanarFace {
  Vec3 normal = Vec3::UnitY();
  double offset = 0.0;
  bool floor = false;

  double SignedDistance(const Vec3& x) const { return normal.dot(x) + offset; }
};

/// T_world_camera per camera serial.
using PoseMap = std::map<std::string, Pose>;

}  // namespace rigfit
