// The tracking settings `rigfit track` and `rigfit slam` take as flags and rigfit.track as
// keywords (docs/python.md): checked and applied to the options structs in one place, so that
// the CLI and the Python module accept the same values with the same messages.
#pragma once

#include <string>
#include <vector>

#include "core/setting_error.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"
#include "rgbd/tracking_loop.h"

namespace rigfit {

/// Largest number of tracking threads.
inline constexpr int kMaxTrackingThreads = 64;

/// The name of a motion prior as --prior and rigfit.track's prior take it: "constant-velocity"
/// or "identity".
const char* MotionPriorName(MotionPrior prior);

/// The name of a colour-tracking mode as `rigfit track --color-tracking` and rigfit.track's
/// color_tracking take it: "auto", "on" or "off" (TrackingLoopOptions::color_tracking).
const char* ColorTrackingName(ColorTracking mode);

/// Sets `--color-tracking` (rigfit.track's color_tracking) from its name. Throws SettingError
/// "{color_tracking} must be auto, on or off, got X".
void ApplyColorTracking(const std::string& mode, TrackingLoopOptions* loop);

/// Checks and applies to `loop` the settings both commands have: prior ("constant-velocity" or
/// "identity"), iterations (1 to 6 counts in [0, 100], finest level first; their count is the
/// number of pyramid levels), and checks those already in `loop`: min_depth < max_depth
/// (frame), max_distance > 0 and max_angle in (0, 180] (icp.association), huber >= 0, threads
/// in [1, kMaxTrackingThreads], max_frames >= 0. Throws SettingError (core/setting_error.h) on
/// a bad value.
void ApplyTrackingSettings(const std::string& prior, const std::vector<int>& iterations,
                           TrackingLoopOptions* loop);

/// Sets the convergence test of `rigfit track --min-step` (rigfit.track's min_step): a
/// pyramid level ends when a step moves the camera less than min_step_m metres and turns it
/// less than min_step_m radians. Throws SettingError "{min_step} must be > 0".
void ApplyMinStep(double min_step_m, ProjectiveIcpOptions* icp);

/// Sets the weak-direction ratio of `--weak-ratio` (rigfit.track's and rigfit.slam's
/// weak_ratio; docs/rgbd.md section 4a). Throws SettingError "{weak_ratio} must be in
/// (0, 1)".
void ApplyWeakRatio(double weak_ratio, ProjectiveIcpOptions* icp);

}  // namespace rigfit
