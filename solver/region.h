// The region that takes part in registration (the near-floor band) and the camera pairs
// whose regions may overlap.
#pragma once

#include <vector>

#include "core/types.h"
#include "solver/options.h"

namespace rigfit {

/// The camera-frame points whose world height (at T_world_camera) lies in
/// [-band_below, band_height]; every point when band_height is 0.
PointCloud NearFloorBand(const PointCloud& points_camera, const Pose& T_world_camera,
                         const RegionOptions& options);

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
