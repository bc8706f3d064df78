// The divergence guard (rgbd/motion_guard.h) in the keyframe odometry and frame-to-model SLAM:
// simulated hand-held sequences that see only the floor or only a wall for most of a second
// (sim/simulate_sequence.h, LonePlaneStretch) at 320x240 and 640x480 stay bounded and report
// their weak directions; a corrupted frame is detected, warned about and counted.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "core/pose.h"
#include "core/rgbd.h"
#include "rgbd/frame.h"
#include "rgbd/motion_guard.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"
#include "rgbd/relocalise.h"
#include "rgbd/slam.h"
#include "rgbd_test_util.h"
#include "sim/simulate_sequence.h"

namespace rigfit {
namespace {

// A Kinect-noise sequence whose camera turns to the lone plane from t = 0 and sees only it
// from 0.7 s for 0.8 s (24 frames at 30 Hz), then turns back for 0.1 s.
SimSequenceOptions LonePlaneSequence(LonePlane plane, int width, int height, int frames) {
  SimSequenceOptions o;
  o.frames = frames;
  o.width = width;
  o.height = height;
  o.seed = 3;
  o.color = false;
  o.lone_plane.plane = plane;
  o.lone_plane.start_s = 0.7;
  o.lone_plane.seconds = 0.8;
  return o;
}

// The largest distance of the estimate from the truth over the lone-plane frames (both start
// at the truth), and how many of them had weak directions.
struct StretchErrors {
  double max_error_m = 0.0;
  int weak_frames = 0;
  int stretch_frames = 0;
  int diverged = 0;  ///< over the whole run
};

StretchErrors MeasureStretch(const SimulatedSequence& sequence, const Trajectory& estimate,
                             const std::vector<int>& weak_directions) {
  StretchErrors e;
  for (std::size_t k = 0; k < estimate.poses.size(); ++k) {
    const double t = estimate.timestamps[k];
    if (!sequence.InLonePlaneStretch(t)) continue;
    ++e.stretch_frames;
    e.weak_frames += weak_directions[k] > 0 ? 1 : 0;
    const Vec3 error = estimate.poses[k].translation() - sequence.CameraPose(t).translation();
    e.max_error_m = std::max(e.max_error_m, error.norm());
  }
  return e;
}

/// The stretch's errors of a run of RunOdometry or RunSlam.
template <typename Result>
StretchErrors StretchOf(const SimulatedSequence& sequence, const Result& result) {
  std::vector<int> weak;
  for (const auto& f : result.frames) weak.push_back(f.track.weak_directions);
  StretchErrors e = MeasureStretch(sequence, result.trajectory, weak);
  e.diverged = result.diverged;
  return e;
}

StretchErrors TrackStretch(const SimulatedSequence& sequence) {
  return StretchOf(sequence, RunOdometry(sequence, OdometryOptions{}));
}

StretchErrors SlamStretch(const SimulatedSequence& sequence) {
  return StretchOf(sequence, RunSlam(sequence, SlamOptions{}));
}

// The stretches below are issue 34's target MISSED (docs/benchmarks.md, "Degenerate views and
// divergence"): the camera turns down (or round) within 0.7 s and the error grows through the
// turn and the stretch to decimetres. The bounds are 2x what is measured, so that a change
// that makes it worse is caught; the weak directions are reported through the stretch.
TEST(RgbdGuard, FloorOnlyStretchAt320x240StaysBoundedAndReportsWeakDirections) {
  const SimulatedSequence sequence(LonePlaneSequence(LonePlane::kFloor, 320, 240, 46));
  const StretchErrors track = TrackStretch(sequence);
  const StretchErrors slam = SlamStretch(sequence);
  EXPECT_EQ(track.stretch_frames, 25);  // 0.7 s to 1.5 s at 30 Hz, both ends
  // Measured: track 324 mm, slam 333 mm at most over the stretch (before the lone-plane test
  // held the floor's free directions: 502 and 134 mm, the noise pinning slam's by chance near
  // the truth).
  EXPECT_LT(track.max_error_m, 0.65);
  EXPECT_LT(slam.max_error_m, 0.67);
  EXPECT_LE(track.diverged + slam.diverged, 4);
  EXPECT_GE(track.weak_frames, 20);
  EXPECT_GE(slam.weak_frames, 20);
}

TEST(RgbdGuard, WallOnlyStretchAt320x240StaysBoundedAndReportsWeakDirections) {
  const SimulatedSequence sequence(LonePlaneSequence(LonePlane::kWall, 320, 240, 46));
  const StretchErrors track = TrackStretch(sequence);
  const StretchErrors slam = SlamStretch(sequence);
  // Measured: track 427 mm, slam 387 mm at most over the stretch (before the lone-plane test:
  // 661 and 1317 mm).
  EXPECT_LT(track.max_error_m, 0.85);
  EXPECT_LT(slam.max_error_m, 0.78);
  EXPECT_LE(track.diverged + slam.diverged, 10);
  EXPECT_GE(track.weak_frames, 20);
  EXPECT_GE(slam.weak_frames, 20);
}

TEST(RgbdGuard, FloorOnlyAt640x480HoldsItsThreeWeakDirections) {
  // Starting inside the stretch: every frame sees only the floor. Noise-free: with Kinect
  // noise the floor's weak eigenvalues come out above 1e-3 of the largest at 640x480 (0 or 1
  // weak directions per frame: the ratio does not catch them, docs/benchmarks.md).
  SimSequenceOptions o = LonePlaneSequence(LonePlane::kFloor, 640, 480, 8);
  o.noise = SequenceNoise::kNone;
  o.lone_plane.start_s = 0.0;
  const SimulatedSequence sequence(o);
  const OdometryResult track = RunOdometry(sequence, OdometryOptions{});
  const SlamResult slam = RunSlam(sequence, SlamOptions{});
  for (std::size_t k = 1; k < track.frames.size(); ++k) {
    // A floor fixes its normal's translation and the two tilts, not the rest.
    EXPECT_EQ(track.frames[k].track.weak_directions, 3) << k;
    EXPECT_EQ(slam.frames[k].track.weak_directions, 3) << k;
  }
  std::vector<int> weak(track.frames.size(), 3);
  const double track_error = MeasureStretch(sequence, track.trajectory, weak).max_error_m;
  const double slam_error = MeasureStretch(sequence, slam.trajectory, weak).max_error_m;
  // Measured: 107.6 mm for both after 7 frames: the camera's slide along the floor (1.5 cm a
  // frame), which no frame sees and no verified velocity predicts, is held at zero.
  EXPECT_LT(track_error, 0.2);
  EXPECT_LT(slam_error, 0.2);
}

// A Kinect-noise view of the floor alone, tracked from the true motion (3 frames apart): the
// noise (disparity quantised in bands that every view of the floor shows alike) lifts two of
// the floor's three free directions above the weak-direction ratio, and before the lone-plane
// test they pulled the estimate back towards the target's pose (here 4.1 mm and 0.11 deg away
// from the truth; 12.7 mm and 1.2 deg over one frame of the 600-frame loop). Now they are held.
TEST(RgbdGuard, ALonePlaneHoldsItsFreeDirectionsAgainstTheNoise) {
  SimSequenceOptions o = LonePlaneSequence(LonePlane::kFloor, 320, 240, 4);
  o.lone_plane.start_s = 0.0;
  const SimulatedSequence sequence(o);
  const RgbdFrame target = sequence.Frame(0);
  const RgbdFrame source = sequence.Frame(3);
  const FramePyramid target_pyramid = BuildFramePyramid(target, FrameOptions{});
  const FramePyramid source_pyramid = BuildFramePyramid(source, FrameOptions{});
  ASSERT_TRUE(LonePlaneNormal(source_pyramid.levels.back(), LonePlaneOptions{}));
  const Pose truth = target.T_world_camera_gt->inverse() * *source.T_world_camera_gt;
  const TrackResult track =
      TrackProjective(source_pyramid, target_pyramid, truth, ProjectiveIcpOptions{});
  ASSERT_TRUE(track.success);
  EXPECT_TRUE(track.lone_plane);
  EXPECT_EQ(track.weak_directions, 3);
  // Measured: 0.13 mm and 0.011 deg from the truth (the fixed directions' noise).
  const Pose error = truth.inverse() * track.T_target_source;
  EXPECT_LT(error.translation().norm(), 0.3e-3);
  EXPECT_LT(LogSO3(error.linear()).norm() * kRadToDeg, 0.025);
  // The target's lone plane checked once (the odometry's keyframe): the same track.
  const TrackResult cached =
      TrackProjective(source_pyramid, target_pyramid,
                      LonePlaneNormal(target_pyramid, ProjectiveIcpOptions{}.lone_plane), truth,
                      ProjectiveIcpOptions{});
  EXPECT_LT((cached.T_target_source.matrix() - track.T_target_source.matrix()).norm(), 1e-12);
  EXPECT_EQ(cached.lone_plane, track.lone_plane);
  // A view of the room is no lone plane.
  o.lone_plane.plane = LonePlane::kNone;
  const FramePyramid room = BuildFramePyramid(SimulatedSequence(o).Frame(0), FrameOptions{});
  EXPECT_FALSE(LonePlaneNormal(room.levels.back(), LonePlaneOptions{}));
}

// After a stretch the held pose can be tens of degrees and decimetres off along the plane's
// free directions; the search over them against an earlier frame finds the frame again.
TEST(RgbdGuard, RelocalisationFindsAFrameTurnedAndSlidAlongTheFloor) {
  SimSequenceOptions o = LonePlaneSequence(LonePlane::kNone, 320, 240, 6);
  const SimulatedSequence sequence(o);
  const RgbdFrame earlier = sequence.Frame(0);
  const RgbdFrame later = sequence.Frame(5);
  Anchor anchor{BuildFramePyramid(earlier, FrameOptions{}), *earlier.T_world_camera_gt, 0};
  const Vec3 up(0.0, 1.0, 0.0);  // the floor's normal in the simulated world
  const Pose truth = *later.T_world_camera_gt;
  Pose held = truth;
  held.linear() = ExpSO3(up * (25.0 * kDegToRad)) * truth.linear();
  held.translation() += Vec3(0.3, 0.0, -0.2);
  const FramePyramid pyramid = BuildFramePyramid(later, FrameOptions{});
  const Relocalisation found = Relocalise({&pyramid, held, up, 0.01}, {anchor},
                                          ProjectiveIcpOptions{}, RelocaliseOptions{}, 2);
  ASSERT_TRUE(found.success);
  EXPECT_EQ(found.anchor_index, 0);
  const Pose error = truth.inverse() * found.T_world_camera;
  // Measured: 0.38 mm and 0.005 deg (the start 25 deg and 0.36 m off).
  EXPECT_LT(error.translation().norm(), 0.8e-3);
  EXPECT_LT(LogSO3(error.linear()).norm() * kRadToDeg, 0.01);
}

// After the floor stretch, SLAM does not fuse a frame whose pose along the floor is still the
// held prediction: fused there, its structure would be mapped where it is not, and the map
// rendered at that pose would agree with the frame (seed 3 of the 600-frame loop: never
// relocalised, 97 mm ATE; 21.6 mm with this). This short sequence is never relocalised: the
// frames tried while attempts remain are left out of the map, the last attempt and the frames
// after it are fused again.
// Collects the warnings.
Log WarningsInto(std::vector<std::string>* warnings) {
  return Log{[warnings](LogLevel level, const std::string& message) {
    if (level == LogLevel::kWarning) warnings->push_back(message);
  }};
}

bool AnyContains(const std::vector<std::string>& lines, const std::string& text) {
  return std::any_of(lines.begin(), lines.end(),
                     [&](const std::string& line) { return line.find(text) != std::string::npos; });
}

TEST(RgbdGuard, SlamFusesNoFrameAfterAFloorStretchWhileItTriesToRelocaliseIt) {
  const SimulatedSequence sequence(LonePlaneSequence(LonePlane::kFloor, 320, 240, 58));
  std::vector<std::string> warnings;
  // The pure z^2 weights: with the 0.7 m floor, frame 54 lands 6.7 cm from its held
  // prediction and is declared diverged, which is not tried and so moves the window this test
  // checks (the fusion rule is the same).
  SlamOptions options;
  options.icp.weighting.noise_floor_depth_m = 0.0;
  const SlamResult slam = RunSlam(sequence, options, WarningsInto(&warnings));
  ASSERT_EQ(slam.relocalised, 0);
  EXPECT_TRUE(AnyContains(warnings, "not relocalised after the lone-plane stretch (10 frames"));
  int last_lone = -1;
  for (std::size_t k = 0; k < slam.frames.size(); ++k) {
    if (slam.frames[k].track.lone_plane) last_lone = static_cast<int>(k);
  }
  ASSERT_GT(last_lone, 0);
  // Recorded as open for loop closure: from the pose before the stretch to its last frame.
  ASSERT_EQ(slam.open_stretches.size(), 1u);
  EXPECT_EQ(slam.open_stretches[0].to, last_lone);
  EXPECT_TRUE(slam.frames[slam.open_stretches[0].from + 1].track.lone_plane);
  EXPECT_FALSE(slam.frames[slam.open_stretches[0].from].track.lone_plane);
  EXPECT_GT(slam.open_stretches[0].n_world.y(), 0.99);
  const int attempts = RelocaliseOptions{}.attempts;
  ASSERT_LT(last_lone + attempts + 1, static_cast<int>(slam.frames.size()));
  for (int k = last_lone + 1; k <= last_lone + attempts + 1; ++k) {
    ASSERT_TRUE(slam.frames[k].track.success) << k << ": " << slam.frames[k].track.message;
    const bool fused = slam.frames[k].fusion.input_points > 0;
    EXPECT_EQ(fused, k >= last_lone + attempts) << k;
  }
}

// `base` whose frame `corrupt` shows what frame `source` sees (a camera that jumps), with the
// timestamp and ground truth of `corrupt`.
rgbd_test::EditedSequence Corrupted(const RgbdSequence& base, int corrupt, int source) {
  const auto edit = [&base, corrupt, source](int index, RgbdFrame* frame) {
    if (index != corrupt) return;
    RgbdFrame seen = base.Frame(source);
    seen.index = frame->index;
    seen.timestamp = frame->timestamp;
    seen.T_world_camera_gt = frame->T_world_camera_gt;
    *frame = std::move(seen);
  };
  return rgbd_test::EditedSequence(base, edit, "corrupted " + base.Describe());
}

TEST(RgbdGuard, ACorruptedFrameIsDetectedWarnedAndCounted) {
  SimSequenceOptions o;
  o.frames = 20;
  o.width = 320;
  o.height = 240;
  o.color = false;
  o.seed = 5;
  const SimulatedSequence base(o);
  const rgbd_test::EditedSequence sequence = Corrupted(base, 12, 18);
  std::vector<std::string> track_warnings, slam_warnings;
  const OdometryResult track =
      RunOdometry(sequence, OdometryOptions{}, WarningsInto(&track_warnings));
  const SlamResult slam = RunSlam(sequence, SlamOptions{}, WarningsInto(&slam_warnings));
  EXPECT_EQ(track.diverged + track.recovered, 1);
  EXPECT_EQ(slam.diverged + slam.recovered, 1);
  EXPECT_TRUE(track.frames[12].diverged || track.frames[12].recovered);
  EXPECT_TRUE(slam.frames[12].diverged || slam.frames[12].recovered);
  EXPECT_TRUE(AnyContains(track_warnings, "frame 12"));
  EXPECT_TRUE(AnyContains(slam_warnings, "frame 12"));
  // The frames after it are tracked again: the end is where the truth is. Measured: track
  // 0.9 mm, slam 2.9 mm.
  const Trajectory gt = base.GroundTruth();
  EXPECT_LT((track.trajectory.poses.back().translation() - gt.poses.back().translation()).norm(),
            2e-3);
  EXPECT_LT((slam.trajectory.poses.back().translation() - gt.poses.back().translation()).norm(),
            6e-3);
}

// A TrackFrom that ends every track at `end_from_prediction` when started at the prediction
// and at `end_from_previous` when started anywhere else, with the given residual.
TrackFrom ScriptedTrack(const Pose& prediction, const Pose& end_from_prediction,
                        const Pose& end_from_previous, double rmse_m) {
  return [=](const Pose& start) {
    TrackResult track;
    track.success = true;
    track.matched_ratio = 0.9;
    track.rmse_m = rmse_m;
    const bool from_prediction = start.isApprox(prediction);
    return std::make_pair(track, from_prediction ? end_from_prediction : end_from_previous);
  };
}

Pose Moved(double x_m) {
  Pose T = Pose::Identity();
  T.translation().x() = x_m;
  return T;
}

// Residuals of 2 mm make the history; a frame at 10 mm (above 3 times it) is suspect.
void FillHistory(MotionGuard* guard) {
  for (int k = 0; k < 5; ++k) {
    const Pose T = Moved(0.01 * k);
    guard->Track(ScriptedTrack(T, T, T, 0.002), T, T, 0.033, "frame", Log{});
  }
}

TEST(RgbdGuard, AResidualRiseTheReTrackConfirmsIsTheViewsAndAccepted) {
  MotionGuard guard(GuardOptions{});
  FillHistory(&guard);
  // Both starts end at the same pose (5 mm on from the last good one): the far wall that came
  // into view raised the residual, not a wrong minimum.
  std::vector<std::string> warnings;
  const Pose previous = Moved(0.04), predicted = Moved(0.05);
  const GuardedTrack same =
      guard.Track(ScriptedTrack(predicted, Moved(0.045), Moved(0.045), 0.01), predicted, previous,
                  0.033, "frame 5", WarningsInto(&warnings));
  EXPECT_TRUE(same.track.success);
  EXPECT_TRUE(same.recovered);
  EXPECT_FALSE(same.diverged);
  EXPECT_TRUE(same.T_world_camera.isApprox(Moved(0.045)));
  EXPECT_TRUE(AnyContains(warnings, "to the same pose: accepted"));
  // The re-track 2 cm away from the track (above same_pose_m, 1 cm): diverged, as before.
  MotionGuard other(GuardOptions{});
  FillHistory(&other);
  const GuardedTrack apart = other.Track(ScriptedTrack(predicted, Moved(0.045), Moved(0.065), 0.01),
                                         predicted, previous, 0.033, "frame 5", Log{});
  EXPECT_TRUE(apart.diverged);
  EXPECT_TRUE(apart.T_world_camera.isApprox(previous));
}

TEST(RgbdGuard, ARestartForgetsTheResidualsOfTheTrackBefore) {
  MotionGuard guard(GuardOptions{});
  FillHistory(&guard);
  TrackResult track;
  track.success = true;
  track.matched_ratio = 0.9;
  track.rmse_m = 0.01;
  const Pose still = Pose::Identity();
  EXPECT_EQ(guard.Suspect(track, still, still, 0.033),
            "the residual rose to 10.000000 mm (recent 2.000000 mm)");
  guard.Forget();
  EXPECT_EQ(guard.Suspect(track, still, still, 0.033), "");
}

TEST(RgbdGuard, DampingActsOnTheWeakDirectionsOnly) {
  // A velocity of 1 cm along camera x and 2 cm along z, 0.01 rad about y; x is weak.
  Pose velocity = Pose::Identity();
  velocity.translation() = Vec3(0.01, 0.0, 0.02);
  velocity.linear() = ExpSO3(Vec3(0.0, 0.01, 0.0));
  Vec6 weak_x = Vec6::Zero();
  weak_x(3) = 1.0;
  const Pose damped = DampWeakVelocity(velocity, {weak_x}, 2.0, Mat3::Identity(), 0.5);
  EXPECT_NEAR(damped.translation().x(), 0.005, 1e-12);
  EXPECT_NEAR(damped.translation().z(), 0.02, 1e-12);
  EXPECT_LT((LogSO3(damped.linear()) - Vec3(0.0, 0.01, 0.0)).norm(), 1e-12);
  EXPECT_EQ(WeakDirectionName(weak_x), "translation along camera x");
  // Turned into another camera's axes, the same direction there.
  const Mat3 R = ExpSO3(Vec3(0.0, 0.0, M_PI / 2));  // target x = previous y
  Vec6 weak_target_x = Vec6::Zero();
  weak_target_x(3) = 1.0;
  Pose along_y = Pose::Identity();
  along_y.translation() = Vec3(0.0, 0.01, 0.0);
  EXPECT_NEAR(DampWeakVelocity(along_y, {weak_target_x}, 2.0, R, 0.0).translation().norm(), 0.0,
              1e-12);
}

}  // namespace
}  // namespace rigfit
