// The scenes of the reports' 3-D views (report/view3d.h): a rig's cameras with their bands
// and whole views at several sets of poses (`refine`, `compare`), and a fused map with its
// trajectories or cameras (`slam`, `fuse`).
#pragma once

#include <string>
#include <vector>

#include "options/refine_options.h"
#include "report/map_view.h"
#include "report/view3d.h"
#include "rig/diagnostics.h"
#include "rig/refine.h"

namespace rigfit {

/// A named set of T_world_camera for every camera of a rig (e.g. "before": the leveled poses).
struct NamedPoses {
  std::string name;
  const PoseMap* poses = nullptr;
};

/// The rig's scene: per camera, in its frame, its band (`rig`, at the finest voxel) with the
/// residual of each point at every pose set (PointResiduals; colour scale up to the
/// correspondence distance) and its whole view (every valid pixel within `unproject`'s depth
/// range, in the capture's colour when it has one); each camera a frustum in CameraColor of
/// its index; the pose sets in order (the page opens on the last). Up is +Y, the floor y = 0.
View3dScene RigView3dScene(const RigCapture& capture, const DiagnosticRig& rig,
                           const std::vector<NamedPoses>& pose_sets, const IcpOptions& icp,
                           int num_threads);

/// The convex hull of the points projected onto the plane (normal unit): its corners on the
/// plane in order, counter-clockwise seen from the side the normal points to, points on an
/// edge between two corners dropped. Empty when the points span no area.
std::vector<Vec3> PlanePatch(const PlanarFace& plane, const std::vector<Vec3>& points);

/// The surface bundle's planes (RefineResult::surface, kept with icp.keep_surface_diagnostics)
/// as patches over their pixels (PlanePatch of every camera's pixels on the plane, moved to the
/// world by T_world_camera, one per camera in capture order), one colour per plane. Empty when
/// the report holds no planes.
std::vector<ViewPlane> SurfacePlanes(const SurfaceBundleReport& surface,
                                     const std::vector<Pose>& T_world_camera);

/// A map holds at most this many points in the view; a larger one is voxel-averaged.
inline constexpr size_t kMaxViewMapPoints = 2000000;

/// The map's points (voxel-averaged when more than kMaxViewMapPoints: positions and colours
/// averaged per voxel, the voxel grown from 5 mm until they fit) in the world, the
/// overlays' paths, and the camera overlays' poses as frustums (60 degrees, labelled with the
/// overlay's label); up is axes.up, the floor grid at the 1st percentile of the points' height.
View3dScene MapView3dScene(const std::string& title, const MapPoints& map,
                           const std::vector<MapOverlay>& overlays, const MapViewAxes& axes);

}  // namespace rigfit
