// How well the cameras of a rig fit each other at given poses, measured the way the
// registration sees them: the near-floor band of every camera at the finest voxel, and per
// candidate pair the point-to-plane residuals of its finest-scale correspondences. Used by
// `rigfit compare` (before and after each mode) and by the report of `rigfit refine`.
#pragma once

#include <string>
#include <vector>

#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/preprocess.h"
#include "prepare/region.h"
#include "rig/refine.h"

namespace rigfit {

/// Every camera's near-floor band at the finest voxel, selected at the leveled poses and
/// prepared (normals, floor normals snapped) exactly as the registration prepares its finest
/// scale, and the candidate pairs the registration uses.
struct DiagnosticRig {
  std::vector<std::string> serials;  ///< capture order
  /// Per camera, a one-level pyramid: the band in the camera frame at the finest voxel.
  std::vector<CloudPyramid> bands;
  std::vector<CandidatePair> pairs;
};

/// Builds the DiagnosticRig of a capture from a refine result's leveling (its leveled
/// poses and per-camera ground results: a run of Refine with or without registration).
/// Bands are selected at the leveled poses, so that the same camera-frame points are
/// compared at every set of poses; candidate pairs come from the leveled poses too.
DiagnosticRig PrepareDiagnostics(const RigCapture& capture, const RefineResult& leveling,
                                 const RefineOptions& options, int num_threads);

/// The fit of one candidate pair at a set of poses.
struct PairDiagnostics {
  int a = 0;  ///< camera indices into DiagnosticRig::serials
  int b = 0;
  /// Band points with a valid normal, of both cameras: the correspondences searched.
  int points = 0;
  /// Correspondences in both directions (a to b and b to a), found as the registration
  /// finds them at its finest scale: nearest neighbour within
  /// max_correspondence_distance_factor x voxel_size, normals within max_normal_angle_deg.
  int correspondences = 0;
  /// correspondences / points: the share of the overlap-capable points that found a match.
  double inlier_fraction = 0.0;
  /// Signed point-to-plane residual of every correspondence in the world, metres:
  ///   r = (R_t n_q) . (T_s p - T_t q)
  /// with p the source point, q its target match, n_q the target normal (camera frames).
  std::vector<double> residuals_m;
  /// Root mean square of residuals_m; 0 when there are none.
  double rmse_m = 0.0;
  /// The correspondences whose target surface is off the floor: world normal more than 45 deg
  /// from vertical (walls, baseboards, box sides, table legs). The floor dominates rmse_m yet
  /// says nothing of yaw and horizontal position; these residuals do.
  int off_floor_correspondences = 0;
  /// Root mean square of the off-floor residuals; 0 when there are none.
  double off_floor_rmse_m = 0.0;
};

/// The fit of every candidate pair of `rig` at `poses` (T_world_camera per serial; every
/// camera of the rig must have one: std::out_of_range otherwise). Deterministic whatever
/// num_threads.
std::vector<PairDiagnostics> Diagnose(const DiagnosticRig& rig, const PoseMap& poses,
                                      const IcpOptions& options, int num_threads);

/// Per camera of `rig`, per point of its band, the residual (as PairDiagnostics::residuals_m)
/// of its correspondence of smallest |r| at `poses` over every candidate pair it is the source
/// of; NaN for a point without one. Deterministic whatever num_threads.
std::vector<std::vector<float>> PointResiduals(const DiagnosticRig& rig, const PoseMap& poses,
                                               const IcpOptions& options, int num_threads);

}  // namespace rigfit
