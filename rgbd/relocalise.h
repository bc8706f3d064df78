// Relocalisation after a lone-plane stretch (docs/rgbd.md, "Degenerate views and divergence"):
// through frames that see one plane only, the turn about its normal and the slides along it
// are held at a prediction (rgbd/projective_icp.h, LonePlaneDirections), which no frame checks.
// Once the view has structure again, the frame is searched for over exactly those directions
// around its held pose: every candidate of a grid (turns about the plane's normal through the
// camera centre, slides along the plane) is scored by how many of the frame's structure pixels
// (normals away from the plane's) associate with an anchor, a well-tracked frame from before the
// stretch; the best candidates are tracked onto the anchor by the full projective ICP and the
// best accepted track gives the pose.
#pragma once

#include <string>
#include <vector>

#include "core/pose.h"
#include "rgbd/frame.h"
#include "rgbd/projective_icp.h"

namespace rigfit {

struct RelocaliseOptions {
  /// Off: the held pose stays (the behaviour before relocalisation).
  bool enabled = true;
  /// The grid: turns within +-max_turn_deg in turn_step_deg, slides within +-max_slide_m in
  /// slide_step_m along two axes of the plane.
  double max_turn_deg = 60.0;
  double turn_step_deg = 5.0;
  double max_slide_m = 0.6;
  double slide_step_m = 0.1;
  /// A pixel is structure when its normal is more than this from the plane's.
  double min_structure_angle_deg = 30.0;
  /// The best candidates tracked by the full ICP (per anchor).
  int tracked_candidates = 3;
  /// A track is accepted when it succeeds with no weak direction and no lone plane, matches at
  /// least this share of the frame's pixels, and its RMS distance is at most max_rmse_ratio
  /// times the frame's own track's.
  double min_matched_ratio = 0.5;
  double max_rmse_ratio = 1.5;
  /// Anchors kept: the last well-tracked frames at least anchor_spacing frames apart; frames
  /// after a stretch tried until one is relocalised.
  int anchors = 6;
  int anchor_spacing = 4;
  int attempts = 10;
};

/// A well-tracked frame to relocalise against.
struct Anchor {
  FramePyramid pyramid;
  Pose T_world_camera = Pose::Identity();
  int index = 0;
};

/// A frame held through a lone-plane stretch: where it is held and what holds it.
struct HeldFrame {
  const FramePyramid* pyramid = nullptr;
  Pose T_world_held = Pose::Identity();
  Vec3 n_world = Vec3::UnitZ();   ///< the lone plane's unit normal (world)
  double reference_rmse_m = 0.0;  ///< the RMS distance of the frame's own track
};

struct Relocalisation {
  bool success = false;
  Pose T_world_camera = Pose::Identity();
  TrackResult track;  ///< onto the anchor
  int anchor_index = -1;
  int candidates = 0;  ///< scored
};

/// Searches for `held.pyramid` around held.T_world_held over the free directions of the plane
/// of normal held.n_world, against each of `anchors`, as the header says; a track is accepted
/// relative to held.reference_rmse_m (RelocaliseOptions::max_rmse_ratio).
Relocalisation Relocalise(const HeldFrame& held, const std::vector<Anchor>& anchors,
                          const ProjectiveIcpOptions& icp, const RelocaliseOptions& options,
                          int threads);

}  // namespace rigfit
