// The region that takes part in registration (the near-floor band) and the camera pairs
// whose regions may overlap.
#pragma once

#include <vector>

#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/preprocess.h"

namespace rigfit {

/// The camera-frame points whose world height (at T_world_camera) lies in
/// [-band_below, band_height]; every point when band_height is 0.
PointCloud NearFloorBand(const PointCloud& points_camera, const Pose& T_world_camera,
                         const RegionOptions& options);

/// Which points of a leveled camera are floor. A point counts as floor when its leveled
/// height is within max(thickness_m, 3 sigma_v) of y = 0, with sigma_v = k z |n_c . p| the
/// vertical part of its depth noise (n_c the floor normal in the camera frame, k the
/// depth noise of sigma_z = k z^2).
struct FloorModel {
  Pose T_world_camera = Pose::Identity();  ///< leveled
  double depth_noise = 0.0;
  double thickness_m = 0.02;

  Vec3 NormalInCamera() const { return T_world_camera.linear().transpose() * Vec3::UnitY(); }
  bool IsFloor(const Vec3& p_camera) const;
};

/// Gives the floor points of every level the floor's own normal (and a plane-shaped GICP
/// covariance). A plane carries no information about yaw or horizontal position, but the
/// normals that neighbourhoods of noisy floor points yield are tilted by the depth noise
/// (which acts along each camera's rays), and would invent both information and bias in
/// exactly those directions.
void SnapFloorNormals(CloudPyramid* pyramid, const FloorModel& floor);

/// Axis-aligned box of a cloud in the world XZ (ground) plane.
struct GroundBox {
  double min_x = 0.0, max_x = 0.0, min_z = 0.0, max_z = 0.0;
  bool empty = true;
};

/// XZ box of the world points between the 0.5th and 99.5th percentiles per axis, so that a
/// few stray depth samples do not inflate it.
GroundBox RobustGroundBox(const PointCloud& points_world);

/// Area of the intersection of two boxes, each inflated by margin on every side.
double InflatedOverlapArea(const GroundBox& a, const GroundBox& b, double margin);

struct CandidatePair {
  int a = 0;  ///< index of the first camera (a < b)
  int b = 0;
  double overlap_area_m2 = 0.0;  ///< inflated XZ box intersection
};

/// Pairs (a < b) whose inflated XZ boxes intersect by at least min_overlap_area.
std::vector<CandidatePair> FindCandidatePairs(const std::vector<GroundBox>& boxes,
                                              double overlap_margin, double min_overlap_area);

}  // namespace rigfit
