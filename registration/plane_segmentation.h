// Planar patches of a rig's merged world cloud, for the surface bundle
// (registration/surface_bundle.h): an adaptive octree whose cells are kept when a plane explains
// their points within the noise (a noise-normalised chi-square test, not a fixed eigenvalue ratio,
// which ignores range) and some camera has enough points in them; coplanar neighbours merged; the
// floor as one plane; planes that at least two cameras see kept; points that fit a neighbouring
// plane as well, or whose ray meets the two planes within their noise of each other (where two
// planes meet), left out.
#pragma once

#include <vector>

#include "core/pose.h"
#include "core/types.h"

namespace rigfit {

/// Cell sizes and model error are in voxels (icp.voxel_size), so that the same settings serve
/// a room (2 cm voxels: cells of 1 m down to 6.25 cm) and a small scanned object. Smaller
/// cells find more of the faces standing on the floor: on the default simulated rig (seeds
/// 0..9) 6.25 cm gave 8.8 mm of RMS relative translation error, 12.5 cm 16.8 mm.
struct PlaneSegmentationOptions {
  double voxel_size = 0.02;        ///< m
  double max_cell_voxels = 50.0;   ///< the octree's top cells
  double min_cell_voxels = 3.125;  ///< no cell is split below this
  int min_points_per_camera = 30;  ///< a camera sees a cell or a plane with this many points
  /// A plane is kept when this many cameras see it. Not asked of the octree's cells: at range
  /// the noise along the ray (2-5 cm at 3-5 m) scatters a face's points over the small cells
  /// around it, so whether a cell held 30 points of a second camera depended on where that
  /// camera's noise put them, and the cells kept, and the planes' pixels, followed the noise
  /// (measured: docs/benchmarks.md, tried and not kept).
  int min_cameras = 2;
  /// Added to every point's noise along the normal: surface roughness, curvature within a
  /// cell and what is left of the misregistration (the caller inflates it for the first
  /// rounds, when the poses are a centimetre off).
  double model_sigma_voxels = 0.15;
  double min_noise_m = 0.001;  ///< the sensor's noise floor (icp.min_noise_m)
  /// A cell is planar when its chi-square per degree of freedom is at most
  /// 1 + chi2_sigmas sqrt(2 / dof): that many standard deviations of the statistic.
  double chi2_sigmas = 4.0;
  double merge_angle_deg = 3.0;  ///< neighbouring planes closer than this may merge
  double gate_sigmas = 3.5;      ///< points farther from their plane (whitened) are left out
  /// Planes within this angle of horizontal and this close to y = 0 are the floor.
  double floor_angle_deg = 3.0;
  double floor_height_m = 0.05;
  /// The world is leveled (floor y = 0): the points within gate_sigmas (and floor_height_m) of
  /// it are the floor, taken out before the octree so that the cells of the faces standing on
  /// it hold those faces alone (a cell with a face and the floor crease fails the test, or at
  /// long range passes it as a slanted plane that is neither).
  bool leveled_floor = true;
  /// With leveled_floor: points above the floor's gate but within floor_margin_sigmas of
  /// their vertical noise of it (and below floor_margin_m) are left out of every plane. At the
  /// band's range the depth noise (2-4 cm at 3-4 m) spreads the bottom of every face standing on
  /// the floor into and just above the floor's gate: those points fit neither plane well.
  /// Scaled by the noise, the margin leaves noise-free faces whole.
  double floor_margin_sigmas = 7.0;
  double floor_margin_m = 0.08;
};

/// The variance every point has along any direction on top of its ray noise: the model error
/// (model_sigma_voxels) and the sensor's noise floor (min_noise_m), m^2.
double BaseVariance(const PlaneSegmentationOptions& options);

/// The chi-square test of whitened residuals: chi2 within `sigmas` standard deviations of its
/// dof degrees of freedom (chi2 / dof <= 1 + sigmas sqrt(2 / dof)); false for dof <= 0.
bool WithinNoise(double chi2, int dof, double sigmas);

/// One point of the merged cloud.
struct SegmentPoint {
  Vec3 world = Vec3::Zero();
  /// R_world_camera a, a = p / z the pixel's ray: a depth error sigma_z moves the point by
  /// sigma_z ray_world. Zero for points cameras (no ray model).
  Vec3 ray_world = Vec3::Zero();
  double sigma_z = 0.0;  ///< depth noise along the ray (m), k z^2
  double depth = 0.0;    ///< the measured depth z (m): world = centre + depth ray_world
  int camera = 0;
};

/// A plane found (PlanarFace: +Y for the floor) and its points.
struct SegmentedPlane : PlanarFace {
  std::vector<int> points;  ///< indices into the segmented points, each in one plane at most
};

/// The planes of `points` (cameras numbered 0 .. num_cameras - 1). Deterministic: the result
/// does not depend on num_threads.
std::vector<SegmentedPlane> SegmentPlanes(const std::vector<SegmentPoint>& points, int num_cameras,
                                          const PlaneSegmentationOptions& options,
                                          int num_threads = 1);

}  // namespace rigfit
