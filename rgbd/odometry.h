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
#include "rgbd/tracking_loop.h"

namespace rigfit {

/// The keyframe odometry's settings: the shared loop's (rgbd/tracking_loop.h) and the keyframes'.
struct OdometryOptions : TrackingLoopOptions {
  /// Track against a keyframe instead of the previous frame (on by default: the small errors
  /// of consecutive frame-to-frame steps do not add up while the keyframe stays); a new
  /// keyframe is taken when the camera has moved or turned more than these from it, or when
  /// the share of pixels that match it falls below keyframe_min_matched_ratio of the share its
  /// first tracked frame matched (half of them lost; on noisy depth, where the angle gate drops
  /// many pixels from the start, an absolute share renewed the keyframe every frame).
  bool keyframes = true;
  double keyframe_translation_m = 0.1;
  double keyframe_rotation_deg = 5.0;
  double keyframe_min_matched_ratio = 0.5;
};

struct OdometryFrame {
  int index = 0;           ///< frame index in the sequence
  TrackResult track;       ///< against its reference (the previous frame or the keyframe)
  bool keyframe = false;   ///< became the reference of the next frames
  bool recovered = false;  ///< suspected of divergence, re-tracked from the last good pose
  bool diverged = false;   ///< so was the re-track: kept the last good pose (a failure)
};

struct OdometryResult : TrackingRun {
  std::vector<OdometryFrame> frames;
};

OdometryResult RunOdometry(const RgbdSequence& sequence, const OdometryOptions& options,
                           const Log& log = {}, const std::function<void(int, int)>& progress = {});

}  // namespace rigfit
