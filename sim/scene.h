// The simulated room: a set of solid oriented boxes (floor slab, wall slabs, baseboards,
// furniture) in the world frame (+Y up, floor y = 0), with analytic ray casting and
// point-to-surface distances for the simulator, its tests and benchmarks.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/pose.h"
#include "core/types.h"

namespace rigfit {

/// What a box of the scene stands for.
enum class SurfaceKind { kFloor, kWall, kBaseboard, kFurniture };

/// A pinhole camera looking into the scene: its pose, intrinsics and image size.
struct SceneCamera {
  Pose T_world_camera = Pose::Identity();
  PinholeIntrinsics K;
  int width = 0;
  int height = 0;
};

/// A solid box: the points p with |R_world_box^T (p - center)| <= half_extents per axis.
struct OrientedBox {
  Vec3 center = Vec3::Zero();
  Mat3 R_world_box = Mat3::Identity();
  Vec3 half_extents = Vec3::Zero();
  SurfaceKind kind = SurfaceKind::kFurniture;
  std::array<std::uint8_t, 3> albedo_rgb = {128, 128, 128};  ///< colour of its faces
};

/// The first surface a ray meets.
struct RayHit {
  /// The hit is origin + t * direction (t is a distance only for a unit direction).
  double t = 0.0;
  Vec3 normal_world = Vec3::Zero();  ///< outward unit normal of the face hit
  int box_index = -1;                ///< index into Scene::boxes
};

/// A rectangular room seen from inside: floor slab under y = 0, wall slabs outside
/// |x| = size_x / 2 and |z| = size_z / 2, and whatever boxes stand on the floor.
struct Scene {
  double size_x_m = 0.0;  ///< inner room extent along world x
  double size_z_m = 0.0;  ///< inner room extent along world z
  double wall_height_m = 0.0;
  std::vector<OrientedBox> boxes;

  /// The first box face hit by the ray origin + t * direction, t > 0, from outside the
  /// boxes; nullopt when the ray leaves the room (over the walls). direction need not be
  /// unit: with direction = R_world_camera * ((u - cx) / fx, (v - cy) / fy, 1) the hit's t
  /// is the depth (camera z) of pixel (u, v).
  std::optional<RayHit> Raycast(const Vec3& origin, const Vec3& direction) const;

  /// Distance from p_world to the nearest box face (faces hidden inside other boxes
  /// count too, so it is exact for visible points and a lower bound elsewhere).
  double DistanceToSurface(const Vec3& p_world) const;
};

/// The faces that the rays through a camera's points hit (points in the camera frame at the
/// pose T_world_camera, e.g. a noise-free capture's): labels[i] is the index into `faces` of
/// the plane point i lies on, a plane being added on first sight (so several cameras share one
/// list; coplanar faces of different boxes are one plane); -1 where the ray meets nothing.
void LabelFaces(const Scene& scene, const Pose& T_world_camera, const std::vector<Vec3>& points,
                std::vector<PlanarFace>* faces, std::vector<int>* labels);

/// Where the ray origin + t * direction enters the box at some t > min_t (parameter and
/// outward normal of the face entered); nullopt when it misses or starts inside the box.
std::optional<RayHit> RaycastBox(const OrientedBox& box, const Vec3& origin, const Vec3& direction,
                                 double min_t);

/// Signed distance of p_world to the box surface: negative inside.
double SignedDistance(const OrientedBox& box, const Vec3& p_world);

}  // namespace rigfit
