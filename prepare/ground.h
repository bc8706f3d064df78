// Ground leveling: RANSAC finds the floor of each camera among its lowest points, and a
// correction of the world (applied on the left of T_world_camera) turns the floor normal
// onto +Y and moves the floor to y = 0.
#pragma once

#include <string>

#include "core/types.h"
#include "options/refine_options.h"

namespace rigfit {

/// Floor of one camera and the correction that levels it.
struct GroundResult {
  bool found = false;       ///< a near-horizontal plane with enough inliers was found
  bool accepted = false;    ///< the correction is within bounds and was applied
  std::string message;      ///< why not, when not found or not accepted
  PlanarFace plane_camera;  ///< the floor in the camera frame
  PlanarFace plane_world;   ///< the floor in the input world frame
  int inliers = 0;
  double inlier_rms_m = 0.0;
  /// Depth noise k of the stereo model sigma_z = k z^2 (1/m), measured on the floor
  /// (EstimateDepthNoise); 0 when no floor was found.
  double depth_noise = 0.0;
  /// World correction C: T_leveled = C * T_world_camera. Identity unless accepted.
  Pose correction = Pose::Identity();
  double correction_rotation_deg = 0.0;    ///< rotation angle of C
  double correction_translation_m = 0.0;   ///< how far C moves the camera centre
  Pose T_world_camera = Pose::Identity();  ///< the leveled pose (the input one if rejected)
};

/// Finds the floor among the camera-frame points (at the given pose) and levels the pose.
/// Never throws on bad geometry: `found` / `accepted` and `message` say what happened.
GroundResult LevelCamera(const PointCloud& points_camera, const Pose& T_world_camera,
                         const GroundOptions& options);

/// Robust estimate of k in sigma_z = k z^2 (1/m) from camera-frame points near a plane
/// (camera frame too). A depth error dz moves a point p along its ray p / z, so its
/// distance to the plane changes by dz (n . p) / z: r_i / (z_i |n . p_i|) ~ N(0, k^2), and
/// k = 1.4826 median |r_i| / (z_i |n . p_i|) (the MAD estimate, robust to the feet of
/// walls and boxes). Points farther than `window` from the plane are ignored.
double EstimateDepthNoise(const PointCloud& points_camera, const PlanarFace& plane_camera,
                          double window);

/// The correction that maps the world plane onto y = 0 with normal +Y by a rotation about
/// a horizontal axis through `pivot` (a point on the plane) followed by a vertical shift,
/// so that the horizontal position of the pivot does not change.
Pose LevelingCorrection(const PlanarFace& plane_world, const Vec3& pivot);

}  // namespace rigfit
