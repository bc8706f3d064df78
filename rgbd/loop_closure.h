// Loop closure over the keyframes of a finished run (issue 34; docs/rgbd.md, "Loop closure"):
// revisits are detected by pose proximity among keyframes far apart along the path, each
// candidate is verified by projective ICP between the two keyframes (rgbd/projective_icp.h),
// and the keyframes' poses are solved as a pose graph (registration/pose_graph.h) with
// sequential edges from the run and loop edges from the verified ICP, each weighed by its
// ICP's information. The keyframes then take the graph's poses and every frame between two
// keyframes a blend of the two keyframes' corrections (InterpolatedCorrections).
//
// Information of an edge a -> b: the ICP's normal equations H (projective_icp.h) are in the
// left update x = [w; dt] of T_a_b, T_a_b <- Exp(x) T_a_b, in camera a's axes. RelativePoseCost's
// error is e = [w; dt + w x t_a_b] to first order, e = J x with J = [I 0; -[t]_x I], so
//   information_e = J^-T (s H / rmse^2) J^-1,   J^-1 = [I 0; [t]_x I],
// with rmse the pairs' RMS distance and s = information_scale, which makes up for H's depth
// weights (normalised to 1 at 1 m, so H is smaller than the unweighted sum) and the pairs'
// correlated errors, calibrated on simulated loops.
#pragma once

#include <string>
#include <vector>

#include "core/log.h"
#include "core/pose.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "registration/pose_graph.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/photometric.h"
#include "rgbd/projective_icp.h"
#include "rgbd/slam.h"
#include "rgbd/tracking_loop.h"

namespace rigfit {

struct LoopClosureOptions {
  /// Whether `rigfit track`, `rigfit slam` and their Python functions close loops by default.
  bool enabled = true;
  /// How the keyframes' pyramids are rebuilt and registered: the run's settings.
  FrameOptions frame;
  ProjectiveIcpOptions icp;
  /// HalveFrame this many times after loading (SlamOptions::halvings).
  int halvings = 0;
  /// Keyframes of a run without its own (slam): a frame becomes one when it moved or turned
  /// more than these from the last (OdometryOptions' rule).
  double keyframe_translation_m = 0.1;
  double keyframe_rotation_deg = 5.0;
  /// A revisit candidate: an earlier keyframe within these of a keyframe's pose, at least
  /// min_path_m back along the estimated path (the nearest such one is checked).
  double candidate_distance_m = 0.3;
  double candidate_angle_deg = 20.0;
  double min_path_m = 1.0;
  /// Across a lone-plane stretch the run could not relocalise (OpenStretch), a keyframe
  /// without a candidate looks further, as far as the relocalisation's grid reaches (its
  /// max_slide_m and max_turn_deg added to the thresholds above), for an earlier keyframe
  /// before the stretch; the pair is searched for over the plane's free directions
  /// (rgbd/relocalise.h, the earlier keyframe the anchor) and then checked as any candidate.
  /// The nearest max_searches_across such pairs per stretch are searched (about 0.1 s each at
  /// 320x240). The run's relocalisation settings.
  RelocaliseOptions relocalise;
  int max_searches_across = 30;
  /// A candidate is accepted when its ICP succeeds with no weak direction, matches at least
  /// min(min_matched_ratio, matched_share_ratio times the sequential edges' median share) of
  /// the later keyframe's pixels (noisy depth such as stereo matching's matches a third of
  /// them between neighbouring keyframes), and its RMS distance is at most max_rmse_ratio
  /// times the median of the sequential edges'. A candidate refined by colour may instead
  /// match that share of its overlap (OverlapShare: the pixels that land on the earlier
  /// keyframe's depth), against the sequential edges' median of the same: a revisit from 15-30
  /// degrees away sees less of the earlier view than a neighbour does, and colour, not the
  /// matched share, tells a plane registered onto the wrong plane.
  double min_matched_ratio = 0.5;
  double matched_share_ratio = 0.6;
  double max_rmse_ratio = 1.5;
  /// Colour (rgbd/photometric.h; the run's TrackingLoopOptions settings): a candidate whose
  /// keyframes both have colour is aligned by colour alone, then by ICP, then by colour with the
  /// ICP's information as a prior, and judged by the depth at the pose colour kept (VerifyLoop;
  /// docs/rgbd.md section 7). kOn: every candidate; kAuto: when the sequential edges' median
  /// share is below color_tracking_share (the depth the run refined by colour); kOff: none.
  ColorTracking color_tracking = ColorTracking::kAuto;
  double color_tracking_share = 0.6;
  PhotometricOptions photometric;
  /// The first alignment by colour, from the run's relative pose, may move this far (the
  /// scaled space of rgbd/photometric.h: metres, a rotation times the mean depth): about the
  /// candidate gate's reach. It also starts from that pose turned by color_start_turn_deg
  /// about each axis of the earlier keyframe, both ways (six more starts; 0: none), and keeps
  /// the kept alignment with the lowest grey-level residual: a wrong minimum from one start is
  /// often the right one from another.
  double color_max_change_m = 0.6;
  double color_start_turn_deg = 4.0;
  /// A candidate refined by colour is also rejected when its RMS grey-level residual exceeds
  /// max_grey_rmse_ratio times the sequential edges' median at the run's poses (a colour
  /// alignment caught in a wrong minimum leaves several times the right one's; a right one
  /// seen from further away than a neighbour leaves more than the neighbour; docs/rgbd.md).
  double max_grey_rmse_ratio = 2.0;
  /// Information = information_scale H / rmse^2 (header comment), plus floor_information on
  /// the diagonal (a sequential edge across a view that fixes no direction keeps the graph
  /// whole). The scale makes the sequential edges' chi-square against the ground truth about
  /// chi2(6)'s (median 5.3; docs/rgbd.md, "Loop closure").
  double information_scale = 20.0;
  double floor_information = 1.0;
  /// After the solve, a loop edge whose removal lowers the graph's cost (its chi-square)
  /// by more than max_loop_chi2 (chi2(6)'s 99.9% quantile) and more than max_loop_chi2_ratio
  /// times the median of the loops' disagrees with the sequential edges and the other loops:
  /// the worst such edge is dropped and the graph solved again (ConsistentLoopGraph). The
  /// ratio: the information is calibrated on simulated loops; on 7-Scenes loops that lower
  /// the ATE reach chi-square 116-125 together (docs/rgbd.md, "Loop closure").
  double max_loop_chi2 = 22.46;
  double max_loop_chi2_ratio = 5.0;
  int threads = 2;
};

/// A verified (or rejected) revisit: keyframe b (later) registered onto keyframe a.
struct LoopCheck {
  int frame_a = 0;  ///< positions in the run's trajectory
  int frame_b = 0;
  /// T_target_source = T_a_b; refined by colour: its pairs' share and RMS distance there.
  TrackResult track;
  bool color_refined = false;
  double grey_rmse = 0.0;  ///< refined by colour: its RMS grey-level residual there
  double overlap = 0.0;    ///< refined by colour: the later keyframe's OverlapShare there
  bool accepted = false;
  std::string reason;  ///< why rejected
  /// Accepted by the ICP: the graph's cost drop when it is left out (ConsistentLoopGraph).
  double chi2 = 0.0;
};

struct LoopClosureResult {
  Trajectory trajectory;         ///< corrected (the input's when nothing was accepted)
  std::vector<Pose> correction;  ///< per frame: T_world_corrected T_world_run^-1
  std::vector<int> keyframes;    ///< positions in the trajectory
  std::vector<LoopCheck> checks;
  int candidates = 0;
  int accepted = 0;              ///< verified by the ICP check
  int accepted_across = 0;       ///< of those, across an open lone-plane stretch
  int accepted_by_color = 0;     ///< of those, refined by colour (LoopCheck::color_refined)
  int rejected_after_solve = 0;  ///< of those, dropped by ConsistentLoopGraph
  bool applied = false;          ///< the graph was solved and the trajectory corrected
  std::string message;
  double seconds = 0.0;
};

/// The first frame and every frame that moved or turned more than the options' keyframe
/// thresholds from the last keyframe, among the `usable` ones (same size as the trajectory).
std::vector<bool> SelectKeyframes(const Trajectory& trajectory, const std::vector<bool>& usable,
                                  const LoopClosureOptions& options);

struct LoopGraph {
  PoseGraphResult graph;     ///< solved with the kept loops
  std::vector<bool> kept;    ///< per loop edge
  std::vector<double> chi2;  ///< per loop edge: its chi-square when last checked
};

/// Solves the pose graph of `sequential` and `loops` edges over `initial` (node 0 held) and
/// checks each loop against the rest: its chi-square is the drop in the graph's cost
/// (PoseGraphResult::cost) when it is left out, which for a consistent edge follows about
/// chi2(6) (the increase of a least-squares optimum by one measurement is its innovation's
/// Mahalanobis distance) when the edges' information is right. While the largest exceeds
/// both options.max_loop_chi2 and options.max_loop_chi2_ratio times the median of the kept
/// loops' that loop is dropped and the graph solved again. The ratio needs three loops or
/// more to drop one: a single loop cannot be told from a drifted chain, nor one of two from
/// the other.
LoopGraph ConsistentLoopGraph(const std::vector<Pose>& initial,
                              const std::vector<PoseGraphEdge>& sequential,
                              const std::vector<PoseGraphEdge>& loops,
                              const LoopClosureOptions& options);

/// Per pose of `run`: the correction C_k = T'_k T_k^-1 that puts the keyframes (positions
/// `keyframes`, increasing, the first 0) at `solved`, and every pose between keyframes j and
/// j + 1 between the poses it would take moved with either, C_j T_k and C_j+1 T_k, at the
/// share s = (k - k_j) / (k_j+1 - k_j): its rotation along the geodesic, its position on the
/// line. With `progress` (one non-decreasing value per pose, e.g. the drift accumulated up to
/// it), s = (progress_k - progress_j) / (progress_j+1 - progress_j) instead (0 where they are
/// equal). Poses after the last keyframe move with it. The corrected trajectory has no steps
/// at the keyframes. InputError on inconsistent sizes.
std::vector<Pose> InterpolatedCorrections(const Trajectory& run, const std::vector<int>& keyframes,
                                          const std::vector<Pose>& solved,
                                          const std::vector<double>& progress = {});

/// A keyframe as the loop closure registers it: its pyramid and, to refine by colour, its
/// grey pyramid (no levels: not refined by colour).
struct LoopKeyframe {
  FramePyramid pyramid;
  GreyPyramid grey;
};

/// What a candidate is judged against: the sequential edges' median RMS distance, share of
/// the later keyframe's pixels matched and RMS grey-level residual (0: not measured).
struct SequentialMedians {
  double rmse_m = 0.0;
  double matched_share = 1.0;
  double grey_rmse = 0.0;
  double overlap_matched = 1.0;  ///< the matched share of each edge's overlap
};

/// Registers `later` onto `earlier` from T_init (T_earlier_later), by ICP and then by colour
/// when both have grey levels (LoopClosureOptions::color_tracking), and judges it by the
/// options' acceptance rules against the sequential edges' medians.
LoopCheck VerifyLoop(const LoopKeyframe& later, const LoopKeyframe& earlier, const Pose& T_init,
                     const SequentialMedians& sequential, const LoopClosureOptions& options);

/// Closes the loops of a run: `frames` are the sequence indices of the trajectory's poses,
/// `keyframes` flags the poses to build the graph on (the first must be one). Never throws
/// on geometry; InputError on inconsistent sizes.
LoopClosureResult CloseLoops(const RgbdSequence& sequence, const std::vector<int>& frames,
                             const Trajectory& trajectory, const std::vector<bool>& keyframes,
                             const LoopClosureOptions& options, const Log& log = {},
                             const std::vector<OpenStretch>& open = {});

/// The loop-closure settings of a run of RunOdometry / RunSlam (their frame and ICP options;
/// SLAM's frames halved as the run halved them, SlamResult::halvings).
LoopClosureOptions LoopClosureOptionsOf(const OdometryOptions& options);
LoopClosureOptions LoopClosureOptionsOf(const SlamOptions& options, const SlamResult& run);

/// Closes the loops of an odometry run over its own keyframes and corrects its trajectory.
LoopClosureResult CloseOdometryLoops(const RgbdSequence& sequence, const OdometryOptions& options,
                                     OdometryResult* result, const Log& log = {});

/// Closes the loops of a SLAM run (keyframes by SelectKeyframes among its successful frames),
/// corrects its trajectory and moves every map point with the frame that last saw it.
LoopClosureResult CloseSlamLoops(const RgbdSequence& sequence, const SlamOptions& options,
                                 SlamResult* result, const Log& log = {});

}  // namespace rigfit
