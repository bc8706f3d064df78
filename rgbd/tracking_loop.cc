#include "rgbd/tracking_loop.h"

#include <algorithm>
#include <future>
#include <vector>

#include "core/errors.h"
#include "core/format.h"
#include "core/stopwatch.h"
#include "rgbd/loop_closure.h"

namespace rigfit {
namespace {

/// The frame indices `options` select; bad options are InputErrors starting with `name`.
std::vector<int> SelectFrames(const RgbdSequence& sequence, const TrackingLoopOptions& options,
                              const std::string& name) {
  if (options.stride < 1) throw InputError(name + ": stride must be at least 1");
  if (options.max_frames < 0) throw InputError(name + ": max frames must be >= 0 (0: all)");
  if (!(options.color_tracking_share >= 0.0 && options.color_tracking_share <= 1.0)) {
    throw InputError(name + ": colour tracking's matched share must be in [0, 1]");
  }
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

/// Directions of a left update in the scaled space [length_m w; dt] given in the axes of
/// camera b, as directions in the axes of camera a (T_a_b: the adjoint, [R w; R dt + t x R w]),
/// orthonormalised (Gram-Schmidt; none is lost: the adjoint is invertible).
std::vector<Vec6> InAxesOf(const Pose& T_a_b, const std::vector<Vec6>& directions,
                           double length_m) {
  std::vector<Vec6> mapped;
  for (const Vec6& d : directions) {
    const Vec3 w = T_a_b.linear() * d.head<3>() / length_m;
    Vec6 x;
    x << length_m * w, T_a_b.linear() * d.tail<3>() + T_a_b.translation().cross(w);
    for (const Vec6& e : mapped) x -= e.dot(x) * e;
    mapped.push_back(x.normalized());
  }
  return mapped;
}

/// The information of a left update [w; dt] given in the axes of camera a, for the update in
/// the axes of camera b: Ad^T P_a Ad with Ad the adjoint of T_a_b (InAxesOf's map,
/// [R w; R dt + t x R w]); P_a itself when the axes are the same.
Mat6 InformationInAxesOf(const Pose& T_a_b, const Mat6& P_a) {
  if (T_a_b.matrix() == Pose::Identity().matrix()) return P_a;
  const Mat3 R = T_a_b.linear();
  Mat6 Ad = Mat6::Zero();
  Ad.topLeftCorner<3, 3>() = R;
  Ad.bottomRightCorner<3, 3>() = R;
  Ad.bottomLeftCorner<3, 3>() = Hat(T_a_b.translation()) * R;
  return Ad.transpose() * P_a * Ad;
}

/// A frame as the loader hands it over: read, and its pyramid built.
struct LoadedFrame {
  RgbdFrame frame;
  FramePyramid pyramid;
  double preprocess_s = 0.0;  ///< building the pyramid, on the loader's thread
};

/// The loop's state from one frame to the next.
class TrackingLoop {
 public:
  TrackingLoop(const TrackingLoopOptions& options, TrackingTarget* target, const Log& log)
      : options_(options), target_(target), log_(log), guard_(options.guard) {}

  /// Tracks and hands over the frame `index` (loaded and preprocessed: the loop waited load_s
  /// for it).
  void Step(LoadedFrame loaded, int index, bool first, double load_s) {
    run_.load_s += load_s;
    run_.preprocess_s += loaded.preprocess_s;
    const RgbdFrame& frame = loaded.frame;
    FramePyramid& pyramid = loaded.pyramid;

    TrackedStep step;
    step.index = index;
    step.first = first;
    if (first) {
      step.T_world_camera = frame.T_world_camera_gt.value_or(Pose::Identity());
      step.track.success = true;
    } else {
      const auto start = std::chrono::steady_clock::now();
      Track(frame, pyramid, &step);
      TrackByColor(frame, pyramid, &step);
      AlignByColor(frame, pyramid, &step);
      Book(frame, pyramid, &step);
      Relocalise(frame, pyramid, &step);
      NoteTrack(frame, step);
      run_.track_s += SecondsSince(start);
    }
    KeepAnchor(pyramid, step);
    TrackResult measured = step.track;
    if (step.color_aligned) measured.weak.clear();  // colour measured them: not damped
    if (first) {
      velocity_ = verified_velocity_ = Pose::Identity();
    } else if (step.color_rescued) {
      // Colour alone, where the depth failed: its step is not verified by the depth and does
      // not become the motion model's (a wrong one would carry every held frame after it).
      velocity_ = verified_velocity_;
    } else {
      velocity_ = NextVelocity(T_world_previous_, step.T_world_camera, target_->MotionOrigin(),
                               measured, step.diverged, options_.guard);
      if (step.track.success && !step.diverged) verified_velocity_ = velocity_;
    }
    T_world_previous_ = step.T_world_camera;
    previous_timestamp_ = frame.timestamp;
    // The next frame aligns against this one's image at this pose: not after a failed or
    // diverged frame, whose pose is not where its image was taken.
    if (AligningByColor() && step.track.success && !step.diverged) {
      previous_color_ = frame.color;
    } else {
      previous_color_.clear();
    }
    target_->Accept(step, frame, std::move(pyramid));
    run_.trajectory.timestamps.push_back(frame.timestamp);
    run_.trajectory.poses.push_back(step.T_world_camera);
    drift_.push_back((drift_.empty() ? 0.0 : drift_.back()) + (step.color_aligned ? 0.0 : 1.0));
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

  bool AligningByColor() const { return options_.guard.enabled && options_.photometric.enabled; }

  /// Whether colour tracking refines this track (TrackingLoopOptions::color_tracking). A track
  /// with weak directions only where the depth matches poorly throughout (the frame and the
  /// recent frames' median below color_tracking_share, not a lone plane): there the depth's
  /// other directions are no better than its weak ones; elsewhere AlignByColor aligns the weak
  /// directions alone.
  bool TracksByColor(const TrackResult& track) const {
    if (options_.color_tracking == ColorTracking::kOff || !track.success) return false;
    const double share = options_.color_tracking_share;
    const bool poor_depth = track.matched_ratio < share;
    if (!track.weak.empty() &&
        (!poor_depth || track.lone_plane || guard_.RecentMatchedShare() >= share)) {
      return false;
    }
    return options_.color_tracking == ColorTracking::kOn || poor_depth;
  }

  /// Colour tracking (rgbd/photometric.h, "Colour tracking"): a track refined against the
  /// target's colour reference over all six directions, the depth's information as a prior,
  /// and, where the depth's track is unverified (not converged, or re-tracked by the guard),
  /// also aligned by colour alone from the prediction, the lower grey-level residual kept; the
  /// depth's estimate kept when neither is (debug log); a frame whose depth track failed or
  /// diverged aligned by colour alone from the prediction (RescueByColor).
  void TrackByColor(const RgbdFrame& frame, const FramePyramid& pyramid, TrackedStep* step) {
    const ColorReference reference = target_->ColorReferenceOf();
    if (reference.grey == nullptr || !HasColor(frame, pyramid)) return;
    if (!step->track.success) {
      RescueByColor(frame, pyramid, reference, step);
      return;
    }
    if (!TracksByColor(step->track)) return;
    // The depth's information, from the axes it was measured in into the reference's.
    const Mat6 prior = InformationInAxesOf(
        target_->MotionOrigin().inverse() * reference.T_world_reference, step->track.information);
    const GreyPyramid grey = BuildGreyPyramid(frame.color, pyramid);
    Pose T_world_camera;
    PhotometricResult refined =
        AlignAllByColor(pyramid, grey, reference, {prior, step->track.length_m},
                        step->T_world_camera, &T_world_camera);
    if (step->recovered || !step->track.converged) {
      // The depth's estimate is unverified (the guard re-tracked it, or its ICP ran out of
      // steps): colour alone from the prediction too, the lower grey-level residual kept.
      Pose T_world_alone;
      const PhotometricResult alone =
          AlignAllByColor(pyramid, grey, reference, {Mat6::Zero(), step->track.length_m},
                          predicted_, &T_world_alone);
      if (alone.success && (!refined.success || alone.rmse < refined.rmse)) {
        refined = alone;
        T_world_camera = T_world_alone;
        ++run_.color_alone;
      }
    }
    if (!refined.success) {
      log_.Debug(FrameName(*step, frame) + ": not refined by colour: " + refined.message);
      return;
    }
    step->T_world_camera = T_world_camera;
    ++run_.color_tracked;
    if (!step->track.weak.empty()) {  // colour measured the weak directions too
      step->color_aligned = true;
      ++run_.color_aligned;
    }
  }

  /// A frame whose depth track failed (too few pixels matched) or diverged, not a lone plane's
  /// (the guard's stretch handles those), aligned by colour alone (the depth's estimate is what
  /// failed) from the prediction; kept when the alignment
  /// is and it lies within the guard's jump of the prediction: the frame is then tracked, its
  /// weak directions none (colour measured every direction), counted in color_rescued.
  void RescueByColor(const RgbdFrame& frame, const FramePyramid& pyramid,
                     const ColorReference& reference, TrackedStep* step) {
    if (options_.color_tracking == ColorTracking::kOff || step->track.lone_plane ||
        !(step->diverged || step->track.matched_ratio < options_.icp.min_matched_ratio)) {
      return;
    }
    Pose T_world_camera;
    const PhotometricResult aligned =
        AlignAllByColor(pyramid, BuildGreyPyramid(frame.color, pyramid), reference,
                        {Mat6::Zero(), step->track.length_m}, predicted_, &T_world_camera);
    if (!aligned.success ||
        !WithinMotion(predicted_.inverse() * T_world_camera, options_.guard.max_correction_m,
                      options_.guard.max_correction_deg)) {
      log_.Debug(FrameName(*step, frame) + ": not tracked by colour either: " +
                 (aligned.success ? "too far from the prediction" : aligned.message));
      return;
    }
    log_.Warning(FrameName(*step, frame) + ": the depth " +
                 (step->diverged ? "diverged" : "matched too few pixels") +
                 "; tracked by colour alone");
    step->T_world_camera = T_world_camera;
    step->track.success = true;
    step->track.weak.clear();
    step->track.weak_directions = 0;
    step->diverged = false;
    step->color_rescued = true;
    ++run_.color_tracked;
    ++run_.color_rescued;
  }

  /// The prior of AlignAllByColor: the information of the move from the start (the
  /// reference's axes) and the rotation's scale (TrackResult::length_m).
  struct ColorPrior {
    Mat6 information;
    double length_m = 1.0;
  };

  /// Aligns the frame (its pyramid and grey pyramid) to `reference`'s colour over all six
  /// directions from T_world_start with `prior`; the aligned pose in *T_world_camera.
  PhotometricResult AlignAllByColor(const FramePyramid& pyramid, const GreyPyramid& grey,
                                    const ColorReference& reference, const ColorPrior& prior,
                                    const Pose& T_world_start, Pose* T_world_camera) const {
    const Pose& T_world_reference = reference.T_world_reference;
    const PhotometricResult aligned = AlignPhotometric(
        {&pyramid, &grey, reference.grey, AllDirections(), prior.length_m, &prior.information},
        T_world_reference.inverse() * T_world_start, options_.photometric, options_.threads);
    *T_world_camera = Reorthonormalized(T_world_reference * aligned.T_reference_source);
    return aligned;
  }

  /// A frame with weak directions (a lone plane's three, or what the eigenvalues found) and
  /// colour, after a frame with colour: those directions aligned by colour against that frame
  /// (rgbd/photometric.h), the rest kept; left held when the alignment is not kept (debug log).
  void AlignByColor(const RgbdFrame& frame, const FramePyramid& pyramid, TrackedStep* step) {
    const TrackResult& track = step->track;
    if (!AligningByColor() || step->color_aligned || !track.success || track.weak.empty() ||
        !HasColor(frame, pyramid) || previous_color_.size() != frame.color.size()) {
      return;
    }
    const Pose T_previous_target = T_world_previous_.inverse() * target_->MotionOrigin();
    const GreyPyramid grey = BuildGreyPyramid(frame.color, pyramid);
    const GreyPyramid previous = BuildGreyPyramid(previous_color_, pyramid);
    const PhotometricResult aligned = AlignPhotometric(
        {&pyramid, &grey, &previous, InAxesOf(T_previous_target, track.weak, track.length_m),
         track.length_m},
        T_world_previous_.inverse() * step->T_world_camera, options_.photometric, options_.threads);
    if (!aligned.success) {
      log_.Debug(FrameName(*step, frame) +
                 ": weak directions not aligned by colour: " + aligned.message);
      return;
    }
    step->T_world_camera = Reorthonormalized(T_world_previous_ * aligned.T_reference_source);
    step->color_aligned = true;
    ++run_.color_aligned;
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
      guard_.Forget();
    }
  }

  /// After a lone-plane stretch, relocalises the first frames with structure against the
  /// anchors (rgbd/relocalise.h) until one succeeds: that frame takes the found pose, the
  /// previous pose moves with it (the velocity stays), and the frames since the stretch began
  /// are blended between their poses and the corrected ones (InterpolatedCorrections), from
  /// the anchor it was found against (the frames before the stretch may have drifted too).
  /// A frame tried in vain while attempts remain is left unverified (SLAM does not fuse it).
  void Relocalise(const RgbdFrame& frame, const FramePyramid& pyramid, TrackedStep* step) {
    const TrackResult& track = step->track;
    if (!options_.guard.enabled || !options_.relocalise.enabled || !track.success) return;
    if (track.lone_plane) {
      plane_world_ = target_->MotionOrigin().linear() * track.plane_normal;
      if (attempts_left_ == 0) {
        stretch_from_ = static_cast<int>(run_.trajectory.poses.size()) - 1;
        stretch_frames_ = stretch_held_ = 0;
      }
      ++stretch_frames_;
      stretch_held_ += step->color_aligned ? 0 : 1;
      stretch_to_ = static_cast<int>(run_.trajectory.poses.size());
      attempts_left_ = options_.relocalise.attempts;
      return;
    }
    if (attempts_left_ == 0 || anchors_.empty()) return;
    --attempts_left_;
    const Relocalisation found =
        rigfit::Relocalise({&pyramid, step->T_world_camera, plane_world_, track.rmse_m}, anchors_,
                           options_.icp, StretchSearch(), options_.threads);
    if (!found.success) {
      step->unverified = attempts_left_ > 0;
      if (attempts_left_ == 0) {
        run_.open_stretches.push_back({stretch_from_, stretch_to_, plane_world_});
        log_.Warning(FrameName(*step, frame) + ": not relocalised after the lone-plane stretch (" +
                     std::to_string(options_.relocalise.attempts) +
                     " frames tried): the poses since it keep what colour or the prediction "
                     "gave them along the plane (loop closure searches across it)");
      }
      return;
    }
    const Pose correction = found.T_world_camera * step->T_world_camera.inverse();
    log_.Warning(FrameName(*step, frame) + ": relocalised against frame " +
                 std::to_string(found.anchor_index) + " after the lone-plane stretch: moved " +
                 std::to_string(correction.translation().norm()) + " m, turned " +
                 std::to_string(LogSO3(correction.linear()).norm() * kRadToDeg) + " deg");
    for (std::size_t a = 0; a < anchors_.size(); ++a) {
      if (anchors_[a].index == found.anchor_index) stretch_from_ = anchor_positions_[a];
    }
    BlendSinceStretch(found.T_world_camera, step->T_world_camera);
    T_world_previous_ = Reorthonormalized(correction * T_world_previous_);
    step->T_world_camera = found.T_world_camera;
    step->relocalised = true;
    ++run_.relocalised;
    attempts_left_ = 0;
  }

  /// The relocalisation's search: its whole grid after a stretch held at the prediction, one
  /// step of it each way after a stretch colour measured (at most a tenth of its frames held):
  /// what is left to find is the drift of a few frames, and a wide grid only adds wrong
  /// minima.
  RelocaliseOptions StretchSearch() const {
    RelocaliseOptions search = options_.relocalise;
    if (10 * stretch_held_ <= stretch_frames_) {
      search.max_turn_deg = std::min(search.max_turn_deg, search.turn_step_deg);
      search.max_slide_m = std::min(search.max_slide_m, search.slide_step_m);
    }
    return search;
  }

  /// Moves the trajectory's poses after stretch_from_ towards where the relocalised frame
  /// (held at T_world_held, found at T_world_found) puts them, by their share of the drift:
  /// each frame since adds one share, a frame aligned by colour none (its motion was measured).
  void BlendSinceStretch(const Pose& T_world_found, const Pose& T_world_held) {
    std::vector<Pose>& poses = run_.trajectory.poses;
    if (stretch_from_ < 0 || stretch_from_ >= static_cast<int>(poses.size())) return;
    Trajectory since;
    since.poses.assign(poses.begin() + stretch_from_, poses.end());
    since.poses.push_back(T_world_held);
    since.timestamps.assign(since.poses.size(), 0.0);
    std::vector<double> progress(drift_.begin() + stretch_from_, drift_.end());
    progress.push_back(progress.back() + 1.0);
    const int last = static_cast<int>(since.poses.size()) - 1;
    const std::vector<Pose> corrections =
        InterpolatedCorrections(since, {0, last}, {since.poses.front(), T_world_found}, progress);
    for (int k = 1; k < last; ++k) {
      poses[stretch_from_ + k] = Reorthonormalized(corrections[k] * poses[stretch_from_ + k]);
    }
  }

  /// Keeps a copy of a well-tracked frame (no weak direction, no stretch pending) as an anchor.
  void KeepAnchor(const FramePyramid& pyramid, const TrackedStep& step) {
    if (!options_.guard.enabled || !options_.relocalise.enabled) return;
    if (!step.first && (!step.track.success || step.track.weak_directions > 0)) return;
    if (attempts_left_ > 0 || step.restart) return;
    if (!anchors_.empty() &&
        step.index - anchors_.back().index < options_.relocalise.anchor_spacing) {
      return;
    }
    anchors_.push_back({pyramid, step.T_world_camera, step.index});
    anchor_positions_.push_back(static_cast<int>(run_.trajectory.poses.size()));
    if (static_cast<int>(anchors_.size()) > std::max(1, options_.relocalise.anchors)) {
      anchors_.erase(anchors_.begin());
      anchor_positions_.erase(anchor_positions_.begin());
    }
  }

  /// The frame's track in a debug message: its steps, matched share, residual, conditioning
  /// and weak directions (what the guard and the colour alignment go by).
  void NoteTrack(const RgbdFrame& frame, const TrackedStep& step) const {
    const TrackResult& t = step.track;
    std::string text;
    Appendf(&text,
            "%s: %s in %d steps, matched share %.3f, RMS %.2f mm, conditioning %.2e, %d weak "
            "direction(s)%s",
            FrameName(step, frame).c_str(), t.success ? "tracked" : "failed", t.iterations,
            t.matched_ratio, t.rmse_m * 1e3, t.conditioning, t.weak_directions,
            step.color_aligned ? ", aligned by colour" : "");
    log_.Debug(text);
  }

  /// Warns where a stretch of lone-plane views (TrackResult::lone_plane) starts and ends.
  void NoteLonePlane(const RgbdFrame& frame, const TrackedStep& step) {
    const bool lone = step.track.lone_plane;
    if (lone && lone_plane_frames_ == 0) {
      log_.Warning(FrameName(step, frame) +
                   ": sees a lone plane: the turn about its normal and the slides along it are "
                   "held at the prediction, or aligned by colour where the frames have it");
    } else if (!lone && lone_plane_frames_ > 0) {
      log_.Warning(FrameName(step, frame) + ": structure again after " +
                   std::to_string(lone_plane_frames_) + " lone-plane frames (" +
                   std::to_string(lone_plane_aligned_) +
                   " of them aligned by colour; the others' pose along the plane is a "
                   "prediction)");
    }
    lone_plane_aligned_ = lone ? lone_plane_aligned_ + (step.color_aligned ? 1 : 0) : 0;
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
  Pose verified_velocity_ = Pose::Identity();  // the velocity after the last depth-tracked step
  double previous_timestamp_ = 0.0;
  std::vector<std::uint8_t> previous_color_;  // the last frame's, when aligning by colour
  std::vector<double> drift_;  // per trajectory pose: frames up to it not aligned by colour
  int failures_in_a_row_ = 0;
  int lone_plane_frames_ = 0;   // lone-plane frames in a row up to the last
  int lone_plane_aligned_ = 0;  // those of them aligned by colour
  // Relocalisation: well-tracked frames, the last stretch's plane, the trajectory position of
  // the frame before it, and the frames with structure still to try after it.
  std::vector<Anchor> anchors_;
  std::vector<int> anchor_positions_;  // their positions in the trajectory
  Vec3 plane_world_ = Vec3::UnitY();
  int stretch_from_ = -1;
  int stretch_to_ = -1;  // the trajectory position of its last lone-plane frame
  int attempts_left_ = 0;
  int stretch_frames_ = 0;  // the last stretch's lone-plane frames
  int stretch_held_ = 0;    // those of them not aligned by colour
};

}  // namespace

bool HasColor(const RgbdFrame& frame, const FramePyramid& pyramid) {
  return frame.color.size() ==
         3 * static_cast<std::size_t>(pyramid.levels[0].width) * pyramid.levels[0].height;
}

TrackingRun RunTracking(const RgbdSequence& sequence, const TrackingLoopOptions& options,
                        const std::string& name, TrackingTarget* target, const Log& log,
                        const std::function<void(int, int)>& progress) {
  const std::vector<int> indices = SelectFrames(sequence, options, name);
  TrackingLoop loop(options, target, log);
  // The frame after the current one is loaded and preprocessed on a thread of its own (its
  // pyramid on as many threads as the tracking's), which its pose does not take part in. At the
  // default priority: a lowered one (nice 19) was as fast on an idle machine but waited 4.9 s
  // of 6.4 for 37 TUM frames beside other processes.
  const auto load = [&](std::size_t k) {
    return std::async(std::launch::async, [&, index = indices[k]] {
      LoadedFrame loaded{target->Load(sequence, index), {}, 0.0};
      const auto start = std::chrono::steady_clock::now();
      loaded.pyramid = BuildFramePyramid(loaded.frame, options.frame, options.threads);
      loaded.preprocess_s = SecondsSince(start);
      return loaded;
    });
  };
  const auto loop_start = std::chrono::steady_clock::now();
  std::future<LoadedFrame> next = load(0);
  for (std::size_t k = 0; k < indices.size(); ++k) {
    const auto start = std::chrono::steady_clock::now();
    LoadedFrame loaded = next.get();  // a loading error is thrown here, in frame order
    const double load_s = SecondsSince(start);
    if (k + 1 < indices.size()) next = load(k + 1);
    loop.Step(std::move(loaded), indices[k], k == 0, load_s);
    if (progress) progress(static_cast<int>(k) + 1, static_cast<int>(indices.size()));
  }
  TrackingRun run = loop.TakeRun();
  run.loop_s = SecondsSince(loop_start);
  return run;
}

}  // namespace rigfit
