// Which plane each pixel of the surface bundle sees, decided by its ray: the plane its ray meets
// first inside that camera's own extent of the plane (the cells of the plane where the
// segmentation put that camera's pixels, gaps of a cell closed), not where its measured point
// lies, which its depth noise moves. The segmentation (registration/plane_segmentation.h) selects
// pixels by their measured positions: by octree cell, by the planarity of each cell and by which
// neighbouring plane a point fits, so a pixel's depth error decides whether it is used, and the
// pixels of a face it drops (cell borders, cells that fail the test, points another fragment of
// the face fits as well) are left out. Cast against the planes, every pixel whose ray meets a
// camera's extent of a plane is used or not whatever its noise, except for the symmetric gates
// on its measured depth.
#pragma once

#include <vector>

#include "core/pose.h"
#include "registration/plane_segmentation.h"
#include "registration/surface_bundle.h"

namespace rigfit {

/// The band's edges select pixels by their measured height, which moves with their depth
/// noise: where a face leaves the band (at its top, and at the floor margin of the
/// segmentation) only the pixels whose noise moved them inward remain, and the face's plane
/// tilts (on the default simulated rig, most wall and furniture planes by 10-20 degrees at
/// 3-4 m). A pixel whose predicted point (where its ray meets the plane, which its own noise
/// does not move) lies this many of its vertical noise sigmas inside every edge was kept
/// whatever its noise, so the pixels so chosen are free of that selection.
constexpr double kWindowSigmas = 3.5;

/// The segmentation's noise along world +Y of a pixel at depth z whose ray (world direction,
/// unit camera z) is ray: sigma_z = k z^2 along the ray, and the model's base variance.
double VerticalSigma(const SurfaceCamera& camera, double z, const Vec3& ray, double base_variance);

/// The highest predicted height at which a pixel of a face is kept: the band's top, and
/// kWindowSigmas of its vertical noise under the top up to which the points were taken.
double PredictedTop(const SurfaceCamera& camera, double sigma_v);

/// The side of the cells of a plane's extent, in voxels (PlaneSegmentationOptions::voxel_size).
constexpr double kMembershipCellVoxels = 2.0;
/// How far, in cells, a camera's extent of a plane may grow where its own pixels agree with the
/// plane (chosen among 0 to 8 on simulated rigs, held-out seeds included).
constexpr int kMembershipGrowCells = 4;

/// Every pixel of every depth camera (ray_model) assigned anew from `segmented`, the
/// segmentation's pixels at `poses` (in the surface bundle, after its predicted-height window).
/// Planes a pixel's ray meets more than twice the gate from its measured depth are not looked
/// at, neither here nor in building the extents. A camera's extent of a plane: the cells
/// (kMembershipCellVoxels on the plane) where the rays of its segmented pixels meet the plane,
/// closed (dilated and eroded by one cell), grown by up to kMembershipGrowCells cells where the
/// camera's own pixels agree with the plane: the pixels whose rays meet the plane first in a
/// cell of that ring (and pass the tests below) join it when they are 5 or more, their whitened
/// depth residuals' mean is within 3 sigmas of zero and their chi-square within chi2_sigmas of
/// its degrees of freedom (the segmentation's planarity test), so that an object standing in
/// front of the plane, which the depth gate alone would let in, is kept out (a cell that fails
/// drops its pixels: it does not hand them to a plane behind). A pixel goes to the plane its ray
/// meets first inside this camera's (grown) extent, when
///  - its measured depth is within gate_sigmas of the predicted one (sigma_z = k z^2 and the
///    segmentation's BaseVariance);
///  - the ray meets no other plane's crease zone (every depth camera's extent of it, dilated by
///    a cell; a near-vertical plane's down to the floor, where faces stand) in front of that
///    plane, or behind it within gate_sigmas: where two planes meet, which one a pixel sees
///    depends on their estimates, and a face's foot hides the floor behind it;
///  - on the floor, its measured height (about y = 0, the leveled floor) is within gate_sigmas
///    of its vertical noise, floor_height_m and the band's depth under the floor (band_bottom:
///    the points were taken above it, so a wider gate would keep the noise that moved far
///    pixels up and not the one that moved them down); on a face, its predicted height is
///    inside the band (band_bottom, PredictedTop).
/// A (camera, plane) with fewer than min_points_per_camera pixels goes; points cameras keep
/// their segmented terms, in their order. Depth cameras' terms are ordered by camera, then
/// plane; the result is the same whatever num_threads (the cameras, and the planes' zones, are
/// shared out among them).
std::vector<SurfaceTerm> MembershipByRays(const std::vector<SurfaceCamera>& cameras,
                                          const std::vector<Pose>& poses,
                                          const std::vector<PlanarFace>& planes,
                                          const std::vector<SurfaceTerm>& segmented,
                                          const PlaneSegmentationOptions& segmentation,
                                          int num_threads = 1);

}  // namespace rigfit
