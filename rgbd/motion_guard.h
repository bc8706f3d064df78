// Keeps a tracked camera from diverging silently (docs/rgbd.md, "Degenerate views and
// divergence"), for the keyframe odometry (rgbd/odometry.h) and frame-to-model SLAM
// (rgbd/slam.h) alike:
//  - degenerate views: the directions the point-to-plane system does not fix (TrackResult::weak,
//    SolveStep's eigen-analysis of the scaled information matrix) are held at the prediction by
//    the solve, and the constant-velocity prior does not extrapolate them unverified: the
//    velocity's components along them are damped frame after frame (DampWeakVelocity);
//  - divergence: a tracked frame whose pose jumps away from the prediction or moves faster than
//    a hand-held camera, whose matched share collapses or whose residual rises against the
//    recent frames' is suspect (MotionGuard::Suspect); it is re-tracked from the last good pose,
//    accepted when that passes (recovered), else declared diverged: it keeps the last good pose
//    and the velocity is dropped. Both are warned and counted.
#pragma once

#include <deque>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/log.h"
#include "core/pose.h"
#include "rgbd/projective_icp.h"

namespace rigfit {

struct GuardOptions {
  /// Off: every tracked frame is accepted as it is (the behaviour before the guard).
  bool enabled = true;
  /// Each frame keeps this share of the velocity's component along its weak directions.
  double weak_velocity_damping = 0.9;
  /// A jump: the tracked pose is farther than this from the prediction...
  double max_correction_m = 0.05;
  double max_correction_deg = 5.0;
  /// ...or the camera moved faster than this since the previous frame (needs timestamps).
  double max_speed_mps = 3.0;
  double max_angular_speed_dps = 360.0;
  /// A collapse: the matched share falls below this share of the recent frames' median...
  double min_matched_share = 0.5;
  /// ...or the RMS residual rises above this multiple of their median.
  double max_rmse_growth = 3.0;
  /// Accepted frames whose matched share and residual make the recent medians.
  int history = 15;
  /// A frame suspect by its matched share or residual alone is accepted when its re-track from
  /// the last good pose ends within these of its track: two starts agree, so what changed is
  /// the view (a far wall coming into view raises the residual), not the track.
  double same_pose_m = 0.01;
  double same_pose_deg = 1.0;
};

/// The velocity T_previous_current with its components along `weak` (TrackResult::weak: unit
/// vectors [length_m w; dt] in the target camera's axes) multiplied by `damping`.
/// R_target_previous turns the previous camera's axes (the velocity's) into the target's.
Pose DampWeakVelocity(const Pose& velocity, const std::vector<Vec6>& weak, double length_m,
                      const Mat3& R_target_previous, double damping);

/// The velocity that predicts the next frame: T_previous_current, damped along the track's weak
/// directions (given in the axes of T_world_target, the camera it was tracked against) when
/// the guard is enabled; the identity after a diverged frame (its motion is unknown).
Pose NextVelocity(const Pose& T_world_previous, const Pose& T_world_current,
                  const Pose& T_world_target, const TrackResult& track, bool diverged,
                  const GuardOptions& options);

/// "translation along camera x", "rotation about camera z", ...: the dominant axis of a weak
/// direction (TrackResult::weak).
std::string WeakDirectionName(const Vec6& weak);

/// A frame's track and pose as the guard leaves them.
struct GuardedTrack {
  TrackResult track;
  Pose T_world_camera = Pose::Identity();
  bool recovered = false;  ///< suspect, then re-tracked from the last good pose
  bool diverged = false;   ///< suspect, and so was the re-track: kept the last good pose
};

/// Tracks a frame from a start pose (T_world_camera): the track and the tracked pose.
using TrackFrom = std::function<std::pair<TrackResult, Pose>(const Pose& T_world_start)>;

class MotionGuard {
 public:
  explicit MotionGuard(const GuardOptions& options) : options_(options) {}

  /// Why the tracked frame looks like divergence, empty when it does not. T_prediction_estimate
  /// is the estimate against the prediction, T_previous_estimate against the previous frame,
  /// dt_s the time since it (<= 0: unknown).
  std::string Suspect(const TrackResult& track, const Pose& T_prediction_estimate,
                      const Pose& T_previous_estimate, double dt_s) const;

  /// Tracks from `predicted`; a successful but suspect track is warned about and re-tracked from
  /// T_world_previous (the last good pose), as the header says. A failed track is returned as
  /// it is (the callers' failure handling). Accepted tracks join the recent history.
  GuardedTrack Track(const TrackFrom& track_from, const Pose& predicted,
                     const Pose& T_world_previous, double dt_s, const std::string& frame_name,
                     const Log& log);

  /// Drops the recent history: a restarted track (a new map or keyframe) is not compared with
  /// the residuals of the one before.
  void Forget();

  /// The recent accepted frames' median matched share; 1 before there are enough of them.
  double RecentMatchedShare() const;

 private:
  /// Suspect's two halves: the motion (a jump, a speed) and the history (matched share,
  /// residual against the recent frames').
  std::string SuspectMotion(const Pose& T_prediction_estimate, const Pose& T_previous_estimate,
                            double dt_s) const;
  std::string SuspectHistory(const TrackResult& track) const;
  /// Whether two tracked poses agree within same_pose_m and same_pose_deg.
  bool SamePose(const Pose& a, const Pose& b) const;
  void Remember(const TrackResult& track);

  GuardOptions options_;
  std::deque<double> matched_;
  std::deque<double> rmse_;
};

}  // namespace rigfit
