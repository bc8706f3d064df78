#include "rgbd/odometry.h"

#include <optional>
#include <utility>

namespace rigfit {
namespace {

/// Tracks each frame against the last keyframe (every frame is one when keyframes are off).
class KeyframeTarget : public TrackingTarget {
 public:
  explicit KeyframeTarget(const OdometryOptions& options) : options_(options) {}

  std::pair<TrackResult, Pose> Track(const FramePyramid& pyramid, int /*index*/,
                                     const Pose& T_world_start) override {
    TrackResult track = TrackProjective(pyramid, reference_, reference_plane_,
                                        T_world_reference_.inverse() * T_world_start, options_.icp,
                                        options_.threads);
    return {track, Reorthonormalized(T_world_reference_ * track.T_target_source)};
  }

  Pose MotionOrigin() const override { return T_world_reference_; }

  ColorReference ColorReferenceOf() const override {
    return {reference_grey_ ? &*reference_grey_ : nullptr, T_world_reference_};
  }

  /// A failed frame is nobody's reference: the next frame tries the last good one, unless the
  /// track restarts here.
  void Accept(const TrackedStep& step, const RgbdFrame& frame, FramePyramid pyramid) override {
    OdometryFrame tracked;
    tracked.index = step.index;
    tracked.track = step.track;
    tracked.recovered = step.recovered;
    tracked.diverged = step.diverged;
    // The share of pixels the keyframe's first tracked frame matched: what "half of them lost"
    // is measured against (on noisy depth the angle gate drops many from the start).
    if (first_after_keyframe_ && step.track.success && !step.color_rescued) {
      first_share_ = step.track.matched_ratio;
    }
    tracked.keyframe = step.first || step.restart || step.relocalised ||
                       (step.track.success && !step.color_rescued && NewKeyframe(step));
    first_after_keyframe_ = tracked.keyframe;
    if (tracked.keyframe) {
      // Its grey images, when colour tracking may measure against them.
      reference_grey_.reset();
      if (options_.color_tracking != ColorTracking::kOff && HasColor(frame, pyramid)) {
        reference_grey_ = BuildGreyPyramid(frame.color, pyramid);
      }
      first_share_ = 1.0;
      reference_ = std::move(pyramid);
      T_world_reference_ = step.T_world_camera;
      reference_plane_ = LonePlaneNormal(reference_, options_.icp.lone_plane);
    }
    frames_.push_back(tracked);
  }

  std::vector<OdometryFrame> TakeFrames() { return std::move(frames_); }

 private:
  bool NewKeyframe(const TrackedStep& step) const {
    const Pose from_reference = T_world_reference_.inverse() * step.T_world_camera;
    return !options_.keyframes ||
           from_reference.translation().norm() > options_.keyframe_translation_m ||
           LogSO3(from_reference.linear()).norm() > options_.keyframe_rotation_deg * kDegToRad ||
           step.track.matched_ratio < options_.keyframe_min_matched_ratio * first_share_;
  }

  const OdometryOptions& options_;
  FramePyramid reference_;
  std::optional<Vec3> reference_plane_;        // its lone plane (LonePlaneNormal), checked once
  std::optional<GreyPyramid> reference_grey_;  // its grey images (colour tracking)
  Pose T_world_reference_ = Pose::Identity();
  double first_share_ = 1.0;
  bool first_after_keyframe_ = false;
  std::vector<OdometryFrame> frames_;
};

}  // namespace

OdometryResult RunOdometry(const RgbdSequence& sequence, const OdometryOptions& options,
                           const Log& log, const std::function<void(int, int)>& progress) {
  OdometryOptions run = options;
  if (!run.guard.enabled) run.icp.lone_plane.min_share = 0.0;  // the behaviour before the guard
  KeyframeTarget target(run);
  OdometryResult result;
  static_cast<TrackingRun&>(result) =
      RunTracking(sequence, run, "odometry", &target, log, progress);
  result.frames = target.TakeFrames();
  return result;
}

}  // namespace rigfit
