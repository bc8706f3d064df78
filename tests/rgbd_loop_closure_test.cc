// Loop closure over a run's keyframes (rgbd/loop_closure.h): a small closed loop whose end
// drift the closure reduces, and a wrong revisit candidate rejected by its ICP check.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/pose.h"
#include "core/trajectory.h"
#include "rgbd/loop_closure.h"
#include "rgbd/odometry.h"
#include "rgbd_test_util.h"

namespace rigfit {
namespace {

using rgbd_test::LookAt;
using rgbd_test::RenderedSequence;
using rgbd_test::TestRoom;

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr double kNoise = 0.004;  // depth noise, metres at 1 m (grows as z^2)

// One loop of `frames` poses around a circle of radius 0.6 m at 1.4 m height, the camera
// looking outward-forward at the room's walls and furniture; the last pose is the first.
std::vector<Pose> Circle(int frames) {
  std::vector<Pose> poses;
  for (int i = 0; i < frames; ++i) {
    const double a = 2.0 * M_PI * i / (frames - 1);
    const Vec3 eye(0.6 * std::cos(a), 1.4, 0.6 * std::sin(a));
    const Vec3 target(2.5 * std::cos(a + 0.6), 0.7, 2.0 * std::sin(a + 0.6));
    poses.push_back(LookAt(eye, target));
  }
  return poses;
}

TEST(RgbdLoopClosure, ClosesASmallLoopAndReducesItsEndDrift) {
  const Scene room = TestRoom();
  const RenderedSequence sequence(room, Circle(121), kWidth, kHeight, kNoise);
  OdometryOptions options;
  OdometryResult run = RunOdometry(sequence, options);
  const Trajectory gt = sequence.GroundTruth();
  const LoopDrift before = MeasureLoopDrift(run.trajectory, gt, 0.01);
  const LoopClosureResult closed = CloseOdometryLoops(sequence, options, &run);
  const LoopDrift after = MeasureLoopDrift(run.trajectory, gt, 0.01);
  ASSERT_TRUE(before.closed);
  EXPECT_GT(closed.candidates, 0);
  EXPECT_GT(closed.accepted, 0);
  EXPECT_TRUE(closed.applied) << closed.message;
  // Measured: MEASURE
  EXPECT_GT(before.translation_m, 0.0);
  EXPECT_LT(after.translation_m, before.translation_m);
}

TEST(RgbdLoopClosure, RejectsACandidateThatIsNotTheSamePlace) {
  const Scene room = TestRoom();
  // Two views from the same spot facing opposite walls, claimed to be the same pose.
  const Pose T_a = LookAt(Vec3(0.0, 1.4, 0.0), Vec3(0.0, 0.8, -2.5));
  const Pose T_b = LookAt(Vec3(0.0, 1.4, 0.0), Vec3(2.5, 0.8, 0.5));
  const FrameOptions frame_options;
  const FramePyramid a =
      BuildFramePyramid(rgbd_test::Render(room, T_a, kWidth, kHeight, kNoise, 1), frame_options);
  const FramePyramid b =
      BuildFramePyramid(rgbd_test::Render(room, T_b, kWidth, kHeight, kNoise, 2), frame_options);
  const LoopClosureOptions options;
  const LoopCheck wrong = VerifyLoop(b, a, Pose::Identity(), 0.005, options);
  EXPECT_FALSE(wrong.accepted);
  EXPECT_FALSE(wrong.reason.empty());
  // The same view registered onto itself from a pose 3 cm and 2 degrees off is accepted.
  const Pose T_off = PosePlus(Pose::Identity(), (Vec6() << 0, 0.035, 0, 0.03, 0, 0).finished());
  const FramePyramid a2 =
      BuildFramePyramid(rgbd_test::Render(room, T_a, kWidth, kHeight, kNoise, 3), frame_options);
  const LoopCheck right = VerifyLoop(a2, a, T_off, 0.005, options);
  EXPECT_TRUE(right.accepted) << right.reason;
}

}  // namespace
}  // namespace rigfit
