#include "rgbd/tracking_loop.h"

#include <future>
#include <vector>

#include "core/errors.h"
#include "core/stopwatch.h"

namespace rigfit {
namespace {

/// The frame indices `options` select; bad options are InputErrors starting with `name`.
std::vector<int> SelectFrames(const RgbdSequence& sequence, const TrackingLoopOptions& options,
                              const std::string& name) {
  if (options.stride < 1) throw InputError(name + ": stride must be at least 1");
  if (options.max_frames < 0) throw InputError(name + ": max frames must be >= 0 (0: all)");
  if (options.restart_after_failures < 1) {
    throw InputError(name + ": restart after failures must be at least 1");
  }
  if (options.first_frame < 0 || options.first_frame >= sequence.size()) {
    throw InputError(name + ": first frame " + std::to_string(options.first_frame) +
                     " is not in the sequence (" + std::to_string(sequence.size()) + " frames)");
  }
  std::vector<int> indices;
  for (int i = options.first_frame; i < sequence.size(); i += options.stride) {
    if (options.max_frames > 0 && static_cast<int>(indices.size()) >= options.max_frames) break;
    indices.push_back(i);
  }
  return indices;
}

/// The loop's state from one frame to the next.
class TrackingLoop {
 public:
  TrackingLoop(const TrackingLoopOptions& options, TrackingTarget* target, const Log& log)
      : options_(options), target_(target), log_(log), guard_(options.guard) {}

  /// Tracks and hands over the frame `index` (loaded: the loop waited load_s for it).
  void Step(const RgbdFrame& frame, int index, bool first, double load_s) {
    run_.load_s += load_s;
    auto start = std::chrono::steady_clock::now();
    FramePyramid pyramid = BuildFramePyramid(frame, options_.frame, options_.threads);
    run_.preprocess_s += SecondsSince(start);

    TrackedStep step;
    step.index = index;
    step.first = first;
    if (first) {
      step.T_world_camera = frame.T_world_camera_gt.value_or(Pose::Identity());
      step.track.success = true;
    } else {
      start = std::chrono::steady_clock::now();
      Track(frame, pyramid, &step);
      run_.track_s += SecondsSince(start);
      Book(frame, pyramid, &step);
    }
    velocity_ = first
                    ? Pose::Identity()
                    : NextVelocity(T_world_previous_, step.T_world_camera, target_->MotionOrigin(),
                                   step.track, step.diverged, options_.guard);
    T_world_previous_ = step.T_world_camera;
    previous_timestamp_ = frame.timestamp;
    target_->Accept(step, frame, std::move(pyramid));
    run_.trajectory.timestamps.push_back(frame.timestamp);
    run_.trajectory.poses.push_back(step.T_world_camera);
  }

  TrackingRun TakeRun() { return std::move(run_); }

 private:
  /// Tracks from the prediction through the motion guard.
  void Track(const RgbdFrame& frame, const FramePyramid& pyramid, TrackedStep* step) {
    predicted_ = options_.prior == MotionPrior::kConstantVelocity ? T_world_previous_ * velocity_
                                                                  : T_world_previous_;
    const TrackFrom track_from = [&](const Pose& T_world_start) {
      return target_->Track(pyramid, step->index, T_world_start);
    };
    const GuardedTrack guarded =
        guard_.Track(track_from, predicted_, T_world_previous_,
                     frame.timestamp - previous_timestamp_, FrameName(*step, frame), log_);
    step->track = guarded.track;
    step->recovered = guarded.recovered;
    step->diverged = guarded.diverged;
    step->T_world_camera = guarded.T_world_camera;
  }

  /// Counts the tracked frame; a failed one keeps the prediction (the guard's last good pose
  /// when diverged), and enough failures in a row restart the track from it.
  void Book(const RgbdFrame& frame, const FramePyramid& pyramid, TrackedStep* step) {
    run_.recovered += step->recovered ? 1 : 0;
    run_.diverged += step->diverged ? 1 : 0;
    NoteLonePlane(frame, *step);
    if (step->track.success) {
      failures_in_a_row_ = 0;
      run_.weak_frames += step->track.weak_directions > 0 ? 1 : 0;
      return;
    }
    if (!step->diverged) step->T_world_camera = Reorthonormalized(predicted_);
    ++run_.failures;
    ++failures_in_a_row_;
    if (!step->diverged) {
      log_.Warning(FrameName(*step, frame) + ": tracking failed: " + step->track.message + "; " +
                   target_->FailureNote());
    }
    // A frame with no valid pixel cannot start a track.
    if (failures_in_a_row_ >= options_.restart_after_failures &&
        !pyramid.levels[0].valid_pixels.empty()) {
      log_.Warning("lost track for " + std::to_string(failures_in_a_row_) +
                   " frames: " + target_->RestartNote() + " from frame " +
                   std::to_string(step->index) + " at its predicted pose");
      ++run_.restarts;
      failures_in_a_row_ = 0;
      step->restart = true;
    }
  }

  /// Warns where a stretch of lone-plane views (TrackResult::lone_plane) starts and ends.
  void NoteLonePlane(const RgbdFrame& frame, const TrackedStep& step) {
    const bool lone = step.track.lone_plane;
    if (lone && lone_plane_frames_ == 0) {
      log_.Warning(FrameName(step, frame) +
                   ": sees a lone plane: the turn about its normal and the slides along it are "
                   "held at the prediction");
    } else if (!lone && lone_plane_frames_ > 0) {
      log_.Warning(FrameName(step, frame) + ": structure again after " +
                   std::to_string(lone_plane_frames_) +
                   " lone-plane frames (their pose along the plane is a prediction)");
    }
    lone_plane_frames_ = lone ? lone_plane_frames_ + 1 : 0;
  }

  static std::string FrameName(const TrackedStep& step, const RgbdFrame& frame) {
    return "frame " + std::to_string(step.index) + " (" + frame.source + ")";
  }

  const TrackingLoopOptions& options_;
  TrackingTarget* target_;
  const Log& log_;
  MotionGuard guard_;
  TrackingRun run_;
  Pose T_world_previous_ = Pose::Identity();
  Pose velocity_ = Pose::Identity();  // T_previous_current of the last step, weak parts damped
  Pose predicted_ = Pose::Identity();
  double previous_timestamp_ = 0.0;
  int failures_in_a_row_ = 0;
  int lone_plane_frames_ = 0;  // lone-plane frames in a row up to the last
};

}  // namespace

TrackingRun RunTracking(const RgbdSequence& sequence, const TrackingLoopOptions& options,
                        const std::string& name, TrackingTarget* target, const Log& log,
                        const std::function<void(int, int)>& progress) {
  const std::vector<int> indices = SelectFrames(sequence, options, name);
  TrackingLoop loop(options, target, log);
  const auto load = [&](std::size_t k) {
    return std::async(std::launch::async,
                      [&, index = indices[k]] { return target->Load(sequence, index); });
  };
  std::future<RgbdFrame> next = load(0);
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const auto start = std::chrono::steady_clock::now();
    const RgbdFrame frame = next.get();  // a loading error is thrown here, in frame order
    const double load_s = SecondsSince(start);
    if (k + 1 < indices.size()) next = load(k + 1);
    loop.Step(frame, indices[k], k == 0, load_s);
    if (progress) progress(static_cast<int>(k) + 1, static_cast<int>(indices.size()));
  }
  return loop.TakeRun();
}

}  // namespace rigfit
