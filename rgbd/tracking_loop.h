// The loop that tracks a sequence frame by frame, shared by the keyframe odometry
// (rgbd/odometry.h) and frame-to-model SLAM (rgbd/slam.h): which frames, the motion prior, the
// motion guard (rgbd/motion_guard.h), failures and restarts, timings. What a frame is tracked
// against, and what follows once its pose is known, is the caller's TrackingTarget: a keyframe
// for the odometry; the model rendered at the start pose, then fusion, for SLAM.
#pragma once

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/log.h"
#include "core/pose.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "rgbd/frame.h"
#include "rgbd/motion_guard.h"
#include "rgbd/photometric.h"
#include "rgbd/projective_icp.h"
#include "rgbd/relocalise.h"

namespace rigfit {

enum class MotionPrior {
  kIdentity,          ///< each frame starts at the previous frame's pose
  kConstantVelocity,  ///< each frame starts where the last motion would put it
};

/// The settings odometry and SLAM share (OdometryOptions and SlamOptions extend them).
/// When a frame's track is refined by colour (TrackingLoopOptions::color_tracking).
enum class ColorTracking { kOff, kAuto, kOn };

struct TrackingLoopOptions {
  FrameOptions frame;
  ProjectiveIcpOptions icp;
  MotionPrior prior = MotionPrior::kConstantVelocity;
  /// Weak directions held, divergence detected and recovered (rgbd/motion_guard.h); off, the
  /// lone-plane hold (icp.lone_plane) and the relocalisation are off too.
  GuardOptions guard;
  /// After a lone-plane stretch, the frame searched for over the plane's free directions
  /// against the frames before it (rgbd/relocalise.h; with the guard only).
  RelocaliseOptions relocalise;
  /// A frame's weak directions (a lone plane's, or those the eigenvalues find) aligned by
  /// colour against the previous frame, when both have colour (rgbd/photometric.h; with the
  /// guard only).
  PhotometricOptions photometric;
  /// Colour tracking (rgbd/photometric.h): a frame with colour, tracked with no weak
  /// direction, refined against its reference's colour with the depth's information as a
  /// prior. kOn: every such frame; kAuto: those that matched fewer than color_tracking_share of
  /// their pixels (noisy depth, e.g. stereo matching, whose noisy normals the angle gate
  /// drops; Kinect-like and real depth match more); kOff: none. Only where the target keeps a
  /// colour reference (TrackingTarget::ColorReference: the odometry's keyframe).
  ColorTracking color_tracking = ColorTracking::kAuto;
  double color_tracking_share = 0.6;
  /// After this many failed frames in a row the track is lost and restarts from the current
  /// frame at its predicted pose (the odometry's next reference; SLAM's new map), counted in
  /// restarts.
  int restart_after_failures = 5;
  /// Frames [first_frame, first_frame + max_frames) with the given stride; max_frames 0 = all.
  int first_frame = 0;
  int max_frames = 0;
  int stride = 1;
  int threads = 2;
};

/// A lone-plane stretch the run could not relocalise (rgbd/relocalise.h): the poses after
/// `from` (the last before the stretch) keep what colour or the prediction gave them along the
/// plane of normal n_world from `to` (its last lone-plane frame) on. Loop closure searches
/// across it (rgbd/loop_closure.h).
struct OpenStretch {
  int from = 0;  ///< positions in the run's trajectory
  int to = 0;
  Vec3 n_world = Vec3::UnitY();
};

/// What a run's frames went through (OdometryResult and SlamResult extend it).
struct TrackingRun {
  Trajectory trajectory;  ///< T_world_camera of every tracked frame
  int failures = 0;       ///< frames whose tracking failed (their pose is the prediction)
  int restarts = 0;       ///< times the track was lost and restarted (restart_after_failures)
  int recovered = 0;      ///< frames suspected of divergence and recovered (MotionGuard)
  int diverged = 0;       ///< frames declared diverged (counted in failures too)
  int weak_frames = 0;    ///< frames tracked with weak directions (held, or aligned by colour)
  int relocalised = 0;    ///< frames relocalised after a lone-plane stretch (rgbd/relocalise.h)
  int color_aligned = 0;  ///< weak-direction frames whose weak directions colour measured
  int color_tracked = 0;  ///< frames refined by colour tracking (TrackingLoopOptions)
  int color_rescued = 0;  ///< of them, frames whose depth track failed: colour alone
  /// Of them, frames whose depth track was unverified (not converged, or re-tracked by the
  /// guard) and that colour alone from the prediction aligned better (a lower grey residual).
  int color_alone = 0;
  std::vector<OpenStretch> open_stretches;
  /// The loop from the first frame's request to the last frame's hand-over (wall time):
  /// waiting for frames, tracking them and handing them over (SLAM: fusing).
  double loop_s = 0.0;
  double load_s = 0.0;  ///< waiting for frames: the loading not overlapped with tracking
  /// Building the frames' pyramids, on the loader's thread while the frame before is tracked
  /// (not part of loop_s but where the loop waits for it, in load_s).
  double preprocess_s = 0.0;
  double track_s = 0.0;  ///< tracking (SLAM: rendering the model apart, SlamResult::render_s)
};

/// One frame as the loop leaves it to the target.
struct TrackedStep {
  int index = 0;       ///< frame index in the sequence
  bool first = false;  ///< the run's first frame: at its ground-truth pose or the identity
  TrackResult track;   ///< against the target (success for the first frame)
  Pose T_world_camera = Pose::Identity();
  bool recovered = false;    ///< suspected of divergence, re-tracked from the last good pose
  bool diverged = false;     ///< so was the re-track: kept the last good pose (a failure)
  bool restart = false;      ///< the track was lost: the target restarts from this frame
  bool relocalised = false;  ///< its pose found anew after a lone-plane stretch
  /// Its weak directions measured by colour (rgbd/photometric.h), not held: the velocity keeps
  /// them.
  bool color_aligned = false;
  /// Structure again after a lone-plane stretch, not relocalised yet: its pose along the
  /// plane is still the held prediction (SLAM does not fuse it into the map).
  bool unverified = false;
  /// Its depth track failed and colour alone tracked it (colour tracking): its depth is not
  /// trusted, so it becomes no keyframe and SLAM does not fuse it.
  bool color_rescued = false;
};

/// A frame's grey images and its pose: what colour tracking measures against.
struct ColorReference {
  const GreyPyramid* grey = nullptr;
  Pose T_world_reference = Pose::Identity();
};

/// What a frame is tracked against, and what happens once its pose is known.
class TrackingTarget {
 public:
  virtual ~TrackingTarget() = default;
  /// The frame as it is tracked (timed as loading): SLAM halves it and checks its colour.
  /// Called on a thread of its own while the previous frame is tracked and accepted: it reads
  /// no state that Track or Accept change.
  virtual RgbdFrame Load(const RgbdSequence& sequence, int index) const {
    return sequence.Frame(index);
  }
  /// Tracks `pyramid` (frame `index`) started at T_world_start: the track and the frame's pose.
  virtual std::pair<TrackResult, Pose> Track(const FramePyramid& pyramid, int index,
                                             const Pose& T_world_start) = 0;
  /// The pose of the camera the last Track measured the frame against (the keyframe's; the
  /// rendered model's start pose), whose axes the track's weak directions are given in.
  virtual Pose MotionOrigin() const = 0;
  /// What colour tracking measures the next frames against; none (a null grey) when the
  /// target keeps no colour.
  virtual ColorReference ColorReferenceOf() const { return {}; }
  /// The frame, its pose known (called for every frame, failed ones included).
  virtual void Accept(const TrackedStep& step, const RgbdFrame& frame, FramePyramid pyramid) = 0;
  /// The warnings' words: what a failed frame is left with, what a restart restarts.
  virtual std::string FailureNote() const { return "kept the prediction"; }
  virtual std::string RestartNote() const { return "restarted"; }
};

/// Whether the frame has a colour image of its pyramid's finest size.
bool HasColor(const RgbdFrame& frame, const FramePyramid& pyramid);

/// Tracks the frames of `sequence` that `options` select against `target`; `name` starts the
/// messages of bad options ("odometry: stride must be at least 1", InputError).
/// progress(done, total) after each frame. The next frame is loaded (TrackingTarget::Load) and
/// its pyramid built on a thread of its own while the current one is tracked, as a camera's
/// driver delivers frames: TrackingRun::load_s is the time the loop waited for them. `sequence`
/// must allow Frame() from that thread (one call at a time).
TrackingRun RunTracking(const RgbdSequence& sequence, const TrackingLoopOptions& options,
                        const std::string& name, TrackingTarget* target, const Log& log,
                        const std::function<void(int, int)>& progress);

}  // namespace rigfit
