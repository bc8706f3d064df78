// Frame-to-frame dense RGB-D odometry over a sequence: each frame is tracked by projective
// point-to-plane ICP (rgbd/projective_icp.h) against the previous frame, or against the last
// keyframe, and the motions are chained into a trajectory (docs/rgbd.md).
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "rgbd/frame.h"
#include "rgbd/motion_guard.h"
#include "rgbd/projective_icp.h"

namespace rigfit {

enum class MotionPrior {
  kIdentity,          ///< each frame starts at the previous frame's pose
  kConstantVelocity,  ///< each frame starts where the last motion would put it
};

struct OdometryOptions {
  FrameOptions frame;
  ProjectiveIcpOptions icp;
  MotionPrior prior = MotionPrior::kConstantVelocity;
  /// Weak directions held, divergence detected and recovered (rgbd/motion_guard.h).
  GuardOptions guard;
  /// Track against a keyframe instead of the previous frame (on by default: the small errors
  /// of consecutive frame-to-frame steps do not add up while the keyframe stays); a new
  /// keyframe is taken when the camera has moved or turned more than these from it, or when
  /// fewer than keyframe_min_matched_ratio of the pixels still match it.
  bool keyframes = true;
  double keyframe_translation_m = 0.1;
  double keyframe_rotation_deg = 5.0;
  double keyframe_min_matched_ratio = 0.5;
  /// After this many failed frames in a row the track is lost: the next reference is the
  /// current frame at its predicted pose (counted in OdometryResult::restarts).
  int restart_after_failures = 5;
  /// Frames [first_frame, first_frame + max_frames) with the given stride; max_frames 0 = all.
  int first_frame = 0;
  int max_frames = 0;
  int stride = 1;
  int threads = 2;
};

/// One tracked frame.
struct OdometryFrame {
  int index = 0;           ///< frame index in the sequence
  TrackResult track;       ///< against its reference (the previous frame or the keyframe)
  bool keyframe = false;   ///< became the reference of the next frames
  bool recovered = false;  ///< suspected of divergence, re-tracked from the last good pose
  bool diverged = false;   ///< so was the re-track: kept the last good pose (a failure)
};

struct OdometryResult {
  Trajectory trajectory;  ///< T_world_camera of every tracked frame
  std::vector<OdometryFrame> frames;
  int failures = 0;     ///< frames whose tracking failed (their pose is the prediction)
  int restarts = 0;     ///< times the track was lost and restarted (restart_after_failures)
  int recovered = 0;    ///< frames suspected of divergence and recovered (MotionGuard)
  int diverged = 0;     ///< frames declared diverged (counted in failures too)
  int weak_frames = 0;  ///< frames tracked with weak directions held
  double load_s = 0.0;
  double preprocess_s = 0.0;
  double track_s = 0.0;
};

/// Tracks the sequence. The first frame's pose is its ground truth when the sequence has one
/// (so that the trajectory lives in the dataset's world frame), the identity otherwise.
/// Each track goes through the MotionGuard (rgbd/motion_guard.h): a suspect frame is re-tracked
/// from the previous pose against the same keyframe; a diverged one keeps the previous pose.
/// A frame whose tracking fails keeps the predicted pose, is counted and logged as a warning,
/// and is not used as a reference (the next frame is tracked against the last good one) until
/// restart_after_failures frames in a row have failed.
/// `progress(done, total)` is called after every frame.
OdometryResult RunOdometry(const RgbdSequence& sequence, const OdometryOptions& options,
                           const Log& log = {}, const std::function<void(int, int)>& progress = {});

}  // namespace rigfit
