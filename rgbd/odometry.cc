#include "rgbd/odometry.h"

#include <algorithm>

#include "core/errors.h"
#include "core/stopwatch.h"

namespace rigfit {

OdometryResult RunOdometry(const RgbdSequence& sequence, const OdometryOptions& options,
                           const Log& log, const std::function<void(int, int)>& progress) {
  if (options.stride < 1) throw InputError("odometry: stride must be at least 1");
  if (options.max_frames < 0) throw InputError("odometry: max frames must be >= 0 (0: all)");
  if (options.restart_after_failures < 1) {
    throw InputError("odometry: restart after failures must be at least 1");
  }
  if (options.first_frame < 0 || options.first_frame >= sequence.size()) {
    throw InputError("odometry: first frame " + std::to_string(options.first_frame) +
                     " is not in the sequence (" + std::to_string(sequence.size()) + " frames)");
  }
  std::vector<int> indices;
  for (int i = options.first_frame; i < sequence.size(); i += options.stride) {
    if (options.max_frames > 0 && static_cast<int>(indices.size()) >= options.max_frames) break;
    indices.push_back(i);
  }

  OdometryResult result;
  FramePyramid reference;
  Pose T_world_reference = Pose::Identity();
  Pose T_world_previous = Pose::Identity();
  Pose velocity = Pose::Identity();  // T_previous_current of the last step, weak parts damped
  double previous_timestamp = 0.0;
  int failures_in_a_row = 0;
  MotionGuard guard(options.guard);
  for (std::size_t k = 0; k < indices.size(); ++k) {
    auto start = std::chrono::steady_clock::now();
    const RgbdFrame frame = sequence.Frame(indices[k]);
    result.load_s += SecondsSince(start);
    start = std::chrono::steady_clock::now();
    FramePyramid pyramid = BuildFramePyramid(frame, options.frame, options.threads);
    result.preprocess_s += SecondsSince(start);

    OdometryFrame tracked;
    tracked.index = indices[k];
    Pose T_world_current;
    if (k == 0) {
      T_world_current = frame.T_world_camera_gt.value_or(Pose::Identity());
      tracked.track.success = true;
      tracked.keyframe = true;
    } else {
      start = std::chrono::steady_clock::now();
      const Pose predicted = options.prior == MotionPrior::kConstantVelocity
                                 ? T_world_previous * velocity
                                 : T_world_previous;
      const TrackFrom track_from = [&](const Pose& T_world_start) {
        TrackResult track =
            TrackProjective(pyramid, reference, T_world_reference.inverse() * T_world_start,
                            options.icp, options.threads);
        return std::make_pair(track, Reorthonormalized(T_world_reference * track.T_target_source));
      };
      const GuardedTrack guarded =
          guard.Track(track_from, predicted, T_world_previous, frame.timestamp - previous_timestamp,
                      "frame " + std::to_string(indices[k]) + " (" + frame.source + ")", log);
      result.track_s += SecondsSince(start);
      tracked.track = guarded.track;
      tracked.recovered = guarded.recovered;
      tracked.diverged = guarded.diverged;
      result.recovered += guarded.recovered ? 1 : 0;
      result.diverged += guarded.diverged ? 1 : 0;
      if (tracked.track.success) {
        T_world_current = guarded.T_world_camera;
        failures_in_a_row = 0;
        result.weak_frames += tracked.track.weak_directions > 0 ? 1 : 0;
      } else {
        T_world_current = guarded.diverged ? guarded.T_world_camera : Reorthonormalized(predicted);
        ++result.failures;
        ++failures_in_a_row;
        if (!guarded.diverged) {
          log.Warning("frame " + std::to_string(indices[k]) + " (" + frame.source +
                      "): tracking failed: " + tracked.track.message + "; kept the prediction");
        }
      }
      const Pose from_reference = T_world_reference.inverse() * T_world_current;
      // A failed frame is nobody's reference: the next frame tries the last good one, unless
      // restart_after_failures frames in a row have failed against it (the track is lost, or
      // the reference had nothing to track against): then tracking restarts from this frame.
      // A frame with no valid pixel cannot be a reference either.
      const bool restart = failures_in_a_row >= options.restart_after_failures &&
                           !pyramid.levels[0].valid_pixels.empty();
      if (restart) {
        log.Warning("lost track for " + std::to_string(failures_in_a_row) +
                    " frames: restarted from frame " + std::to_string(indices[k]) +
                    " at its predicted pose");
        ++result.restarts;
        failures_in_a_row = 0;
      }
      tracked.keyframe =
          restart ||
          (tracked.track.success &&
           (!options.keyframes ||
            from_reference.translation().norm() > options.keyframe_translation_m ||
            LogSO3(from_reference.linear()).norm() > options.keyframe_rotation_deg * kDegToRad ||
            tracked.track.matched_ratio < options.keyframe_min_matched_ratio));
    }
    velocity = NextVelocity(T_world_previous, T_world_current, T_world_reference, tracked.track,
                            tracked.diverged, options.guard);
    if (k == 0) velocity = Pose::Identity();
    T_world_previous = T_world_current;
    previous_timestamp = frame.timestamp;
    if (tracked.keyframe) {
      reference = std::move(pyramid);
      T_world_reference = T_world_current;
    }
    result.trajectory.timestamps.push_back(frame.timestamp);
    result.trajectory.poses.push_back(T_world_current);
    result.frames.push_back(tracked);
    if (progress) progress(static_cast<int>(k) + 1, static_cast<int>(indices.size()));
  }
  return result;
}

}  // namespace rigfit
