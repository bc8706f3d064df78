// Projective point-to-plane ICP between two preprocessed frames (KinectFusion, section 3.5;
// the reference design ../shared/seeds/dense_slam_point_fusion.txt, sections 2.1-2.3;
// derivation and the design's questions answered in docs/rgbd.md).
//
// Source points p (source camera frame) are moved by the current estimate T = T_target_source
// and projected into the target's vertex map: the target pixel they land on gives q and its
// normal n (target frame). The residual of a pair is the point-to-plane distance
//
//   r = n^T (R p + t - q).
//
// An update [dR | dt] multiplies T on the LEFT, T <- [dR | dt] T, with dR = Exp(w) and the
// small-angle model dR ~ I + [w]_x for the linearisation: with p' = R p + t,
//
//   r(w, dt) ~ n^T (p' - q) + n^T (w x p') + n^T dt = A x + b,
//   A = [ (p' x n)^T  n^T ]   (1 x 6),   b = n^T (p' - q),   x = [w; dt],
//
// and the Gauss-Newton step solves the 6x6 normal equations (sum A^T A) x = -sum A^T b.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "core/pose.h"
#include "rgbd/frame.h"

namespace rigfit {

struct AssociationOptions {
  /// |R p + t - q| must be below this (metres): pairs farther apart are not the same surface
  /// point (the design's second filter; docs/rgbd.md).
  double max_distance_m = 0.1;
  /// The angle between the moved source normal R n_p and the target normal n_q must be
  /// below this (degrees).
  double max_normal_angle_deg = 30.0;
};

/// What became of a source pixel in the association (tests and statistics).
enum class AssociationOutcome {
  kMatched,
  kNoSourcePoint,   ///< the source pixel has no vertex or normal
  kBehindCamera,    ///< R p + t has z <= 0 in the target camera
  kOutsideImage,    ///< projects outside the target image
  kNoTargetPoint,   ///< lands on a target pixel without vertex or normal
  kTooFar,          ///< |R p + t - q| >= max_distance_m
  kNormalsDisagree  ///< angle(R n_p, n_q) >= max_normal_angle_deg
};

/// A source-target pair: p in the source frame, q and its unit normal n in the target frame.
struct ProjectiveCorrespondence {
  Vec3 p;
  Vec3 q;
  Vec3 n;
};

/// The projective association of source pixel i under T_target_source (seed section 2.1):
/// the pixel of the target that R p + t projects to (rounded to the nearest), kept when the
/// conditions above hold. On kMatched, *target_index is that pixel.
AssociationOutcome AssociatePixel(const FrameLevel& source, int i, const FrameLevel& target,
                                  const Pose& T_target_source, const AssociationOptions& options,
                                  int* target_index);

/// How much of the source the target sees under T_target_source: the share of the source's
/// valid pixels that land on a target pixel with a vertex and normal, matched or not (kMatched,
/// kTooFar, kNormalsDisagree); 0 for a source without valid pixels. Matched pixels over it is
/// the share of the views' overlap that agrees, whatever the overlap's size.
double OverlapShare(const FrameLevel& source, const FrameLevel& target, const Pose& T_target_source,
                    const AssociationOptions& options);

/// Every matched pair of the source's pixels, in pixel order.
std::vector<ProjectiveCorrespondence> FindCorrespondences(const FrameLevel& source,
                                                          const FrameLevel& target,
                                                          const Pose& T_target_source,
                                                          const AssociationOptions& options,
                                                          int threads = 2);

/// How the pairs are weighed. With depth_noise, a pair's residual is divided by its standard
/// deviation for a sensor whose depth noise grows as z^2 (structured light, stereo: Kinect,
/// RealSense, ZED): sigma^2 ~ z_p^4 + z_q^4 with z_p the source point's depth in its own
/// camera and z_q the target point's, normalised to 1 for two points at 1 m; a near point
/// then counts more than a far one, as its depth is better -- down to noise_floor_depth_m:
/// nearer, a depth counts as that one (z <- max(z, floor)). There the point-to-plane error is
/// no longer the depth's: the projective association's pixel and the normal's error grow as z,
/// not z^2, and an unchecked z^4 lets one near surface outweigh the rest of the view
/// (docs/rgbd.md, "Weights for real sensors"). The Huber kernel (delta > 0) acts on that (whitened)
/// residual: w = min(1, delta / |r|).
struct PairWeighting {
  double huber_delta_m = 0.0;
  bool depth_noise = false;
  double noise_floor_depth_m = 0.0;
};

/// Tracking's default: depth-noise weights on (the sensors rigfit reads all have z^2 noise),
/// their floor at 0.7 m (docs/rgbd.md, "Weights for real sensors").
inline constexpr PairWeighting kTrackingWeighting{0.0, true, 0.7};

/// The noise weight 1 / sigma^2 of a pair (PairWeighting::depth_noise): 2 / (z_p^4 + z_q^4),
/// each depth raised to floor_m first.
inline double DepthNoiseWeight(double z_p, double z_q, double floor_m = 0.0) {
  z_p = std::max(z_p, floor_m);
  z_q = std::max(z_q, floor_m);
  return 2.0 / (z_p * z_p * z_p * z_p + z_q * z_q * z_q * z_q);
}

/// The normal equations of one Gauss-Newton step at T_target_source: H = sum w A^T A,
/// g = sum w A^T b, w the pair's weight (PairWeighting).
struct NormalEquations {
  Mat6 H = Mat6::Zero();
  Vec6 g = Vec6::Zero();
  double squared_error = 0.0;     ///< sum b^2 (unweighted)
  double weighted_squares = 0.0;  ///< sum w b^2
  int count = 0;
};

/// The normal equations of a list of pairs (the reference path).
NormalEquations BuildNormalEquations(const std::vector<ProjectiveCorrespondence>& pairs,
                                     const Pose& T_target_source, const PairWeighting& weighting,
                                     int threads = 2);

/// The same normal equations with the association done on the fly, without a list of pairs
/// (the fast path: one pass over the source pixels, accumulated per thread).
NormalEquations AccumulateProjective(const FrameLevel& source, const FrameLevel& target,
                                     const Pose& T_target_source, const AssociationOptions& options,
                                     const PairWeighting& weighting, int threads = 2);

/// Directions the normal equations do not fix: eigenvectors of H (rotation scaled by
/// `length_m`, so that a radian and `length_m` metres weigh alike) whose eigenvalue is below
/// `ratio` times the largest. A flat wall leaves the two translations along it and the
/// rotation about its normal.
struct StepSolution {
  Vec6 x = Vec6::Zero();  ///< [w; dt]: rotation vector (rad) and translation (m)
  int weak_directions = 0;
  std::vector<Vec6> weak;  ///< the held directions, unit in the scaled space
  /// The smallest eigenvalue of the scaled H over its largest (0 without a system).
  double conditioning = 0.0;
};

/// Solves H x = -g in the span of the well-determined directions; the weak directions
/// (above) get no step instead of a jump along them. `held` (orthonormal, in the scaled space
/// [length_m w; dt]) are weak whatever their eigenvalue: the solve is confined to their
/// complement (a lone plane's free directions, LonePlaneDirections).
StepSolution SolveStep(const NormalEquations& equations, double length_m, double ratio,
                       const std::vector<Vec6>& held = {});

/// When a frame sees a single plane and nothing else.
struct LonePlaneOptions {
  /// A frame is a lone plane when at least this share of its valid pixels lie within
  /// max_distance_m of one plane with normals within max_angle_deg of its normal (0: never).
  double min_share = 0.97;
  double max_distance_m = 0.03;
  double max_angle_deg = 15.0;
};

/// The unit normal (camera axes) of the plane that `level` shows alone, or nothing when it
/// shows more (LonePlaneOptions). The plane is fitted to the mean normal of the pixels near it
/// in angle, then its offset to their median distance along it.
std::optional<Vec3> LonePlaneNormal(const FrameLevel& level, const LonePlaneOptions& options);

/// LonePlaneNormal of the pyramid's coarsest level, confirmed at its finest: there too at least
/// min_share of the valid pixels within max_distance_m of the plane (offset: their median).
/// The coarse levels keep normals mostly where a surface faces the camera, so that a wall seen
/// with the slanted surfaces beside it (a box corner) could look alone there.
std::optional<Vec3> LonePlaneNormal(const FramePyramid& pyramid, const LonePlaneOptions& options);

/// The three directions a view of a lone plane with unit normal n does not fix, in the scaled
/// space [length_m w; dt] of SolveStep: the rotation about n (a rotation about any axis along
/// n maps every plane with normal n onto itself) and the two translations across n.
std::vector<Vec6> LonePlaneDirections(const Vec3& n);

/// [Exp(w) | dt] * T: the left-multiplied update of the linearisation above.
Pose ApplyLeftUpdate(const Vec6& x, const Pose& T);

struct ProjectiveIcpOptions {
  AssociationOptions association;
  PairWeighting weighting = kTrackingWeighting;
  /// Gauss-Newton iterations per pyramid level, finest first (KinectFusion: 10, 5, 4).
  std::vector<int> iterations = {10, 5, 4};
  /// Converged when the step's rotation and translation are both below these.
  double converged_rotation_rad = 1e-4;
  double converged_translation_m = 1e-4;
  /// Weak directions: eigenvalue below this ratio of the largest (scaled by the mean depth;
  /// docs/rgbd.md, "Degenerate views and divergence", for the value).
  double weak_direction_ratio = 1e-3;
  /// Tracking fails when fewer than this share of the finest level's valid source pixels
  /// are matched at the end (the frames do not overlap, or the motion was too fast).
  double min_matched_ratio = 0.1;
  /// A source or target that shows a lone plane holds its three free directions whatever
  /// the eigenvalues say: a sensor's noise (disparity quantisation: the same bands in every
  /// view of the plane) lifts two of them above weak_direction_ratio and pins them to the
  /// target's pose (docs/rgbd.md, "Degenerate views and divergence").
  LonePlaneOptions lone_plane;
};

struct TrackResult {
  Pose T_target_source = Pose::Identity();
  bool success = false;
  std::string message;
  int iterations = 0;  ///< Gauss-Newton steps over all levels
  /// The finest level that runs steps (level 0 unless its iterations are 0) stopped on a step
  /// below the thresholds.
  bool converged = false;
  /// correspondences, matched_ratio and rmse_m: the pairs of the last Gauss-Newton system at
  /// the finest level (one step before the estimate, a step below the convergence threshold
  /// or that level's last).
  int correspondences = 0;
  double matched_ratio = 0.0;
  double rmse_m = 0.0;      ///< RMS point-to-plane distance of the final pairs
  int weak_directions = 0;  ///< held at the finest level's last step
  /// Those directions (StepSolution::weak: [w; dt] with the rotation scaled by length_m, in
  /// the target camera's axes) and that step's conditioning.
  std::vector<Vec6> weak;
  double conditioning = 0.0;
  double length_m = 1.0;    ///< the scale of the rotation: the source's mean depth
  bool lone_plane = false;  ///< the source or the target showed a lone plane (held its three)
  Vec3 plane_normal = Vec3::Zero();  ///< that plane's unit normal in the target's axes
  /// The information of the estimate's left update x = [w; dt] (target axes): the finest
  /// level's last H over its weighted residual variance sum w b^2 / (pairs - 6), the noise's
  /// scale measured, the pairs taken as independent (zero without 7 pairs). What the colour
  /// tracking weighs the depth by (rgbd/photometric.h).
  Mat6 information = Mat6::Zero();
};

/// Coarse-to-fine projective ICP of `source` onto `target` from T_init (T_target_source):
/// at each level, Gauss-Newton steps of AccumulateProjective until converged or the level's
/// iterations run out. Never throws on geometry: failure is success = false with a message.
TrackResult TrackProjective(const FramePyramid& source, const FramePyramid& target,
                            const Pose& T_init, const ProjectiveIcpOptions& options,
                            int threads = 2);

/// The same with the target's lone plane known: n_target is LonePlaneNormal(target,
/// options.lone_plane), computed once for a target that many frames are tracked against (the
/// odometry's keyframe).
TrackResult TrackProjective(const FramePyramid& source, const FramePyramid& target,
                            const std::optional<Vec3>& n_target, const Pose& T_init,
                            const ProjectiveIcpOptions& options, int threads = 2);

/// Gauss-Newton on a FIXED set of pairs until converged (the closed-form path of the
/// two-path comparison; docs/rgbd.md).
Pose SolvePairsGaussNewton(const std::vector<ProjectiveCorrespondence>& pairs, const Pose& T_init,
                           const PairWeighting& weighting, int max_iterations, int threads = 2);

/// The same problem solved by Ceres: one PointToPlaneCost (residuals/point_to_plane.h) per
/// pair (its normal scaled by the square root of the depth-noise weight, which whitens the
/// residual), the source pose T_target_source on the pose manifold, the target's pose the
/// fixed identity, a HuberLoss when weighting.huber_delta_m > 0.
Pose SolvePairsCeres(const std::vector<ProjectiveCorrespondence>& pairs, const Pose& T_init,
                     const PairWeighting& weighting, int threads = 1);

}  // namespace rigfit
