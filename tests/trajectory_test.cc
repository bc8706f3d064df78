#include "core/trajectory.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <random>

#include "io/trajectory_tum.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::HasSubstr;

/// A smooth hand-held-like path: 50 poses over 5 s, a loop with yaw and some tilt.
Trajectory Loop(double t0 = 0.0) {
  Trajectory path;
  for (int k = 0; k < 50; ++k) {
    const double s = 0.1 * k;
    Pose T = Pose::Identity();
    T.linear() = ExpSO3(Vec3(0.1 * std::sin(s), 0.6 * s, 0.05 * std::cos(2 * s)));
    T.translation() = Vec3(std::cos(s), 1.5 + 0.1 * std::sin(3 * s), std::sin(s));
    path.timestamps.push_back(t0 + s);
    path.poses.push_back(T);
  }
  return path;
}

TEST(Trajectory, ItselfMovedRigidlyHasNoError) {
  const Trajectory gt = Loop();
  Trajectory est = gt;
  const Pose G = PosePlus(Pose::Identity(), (Vec6() << 0.3, -1.2, 0.4, 2.0, -0.5, 7.0).finished());
  for (Pose& T : est.poses) T = G * T;
  const TrajectoryErrors e = EvaluateTrajectory(est, gt, 0.02, 1);
  EXPECT_EQ(e.pairs, 50);
  EXPECT_LT(e.ate_rmse_m, 1e-9);
  EXPECT_LT(e.rpe_translation_rmse_m, 1e-9);
  EXPECT_LT(e.rpe_rotation_rmse_rad, 1e-9);
  EXPECT_TRUE((e.T_gt_est * G).isApprox(Pose::Identity(), 1e-9));
}

TEST(Trajectory, KnownOffsetsGiveKnownErrors) {
  const Trajectory gt = Loop();
  Trajectory est = gt;
  // Every other pose 1 cm up: after the (vertical) alignment the errors are +-5 mm, ATE 5 mm.
  for (size_t k = 0; k < est.poses.size(); k += 2) est.poses[k].translation().y() += 0.01;
  const TrajectoryErrors e = EvaluateTrajectory(est, gt, 0.02, 1);
  EXPECT_NEAR(e.ate_rmse_m, 0.005, 1e-4);
  EXPECT_NEAR(e.ate_max_m, 0.005, 2e-4);
  // Each relative motion of neighbours is off by 1 cm (in the camera's frame: its length).
  EXPECT_NEAR(e.rpe_translation_rmse_m, 0.01, 1e-9);
  EXPECT_EQ(e.rpe_pairs, 49);
}

TEST(Trajectory, AssociationByNearestTimestampWithinTheTolerance) {
  const std::vector<double> gt = {0.0, 0.1, 0.2, 0.3, 0.4};
  const std::vector<double> est = {0.005, 0.095, 0.15, 0.31, 1.0};
  // 0.15 is 0.05 from both neighbours: beyond 0.02. 1.0 matches nothing.
  EXPECT_EQ(AssociateByTimestamp(est, gt, 0.02),
            (std::vector<std::pair<int, int>>{{0, 0}, {1, 1}, {3, 3}}));
  // A ground-truth pose is used once, by the closest estimate.
  EXPECT_EQ(AssociateByTimestamp({0.09, 0.101}, gt, 0.02),
            (std::vector<std::pair<int, int>>{{1, 1}}));
}

TEST(Trajectory, TooFewMatchesIsAnError) {
  Trajectory est = Loop(100.0);  // no timestamp near the truth's
  EXPECT_THROW(EvaluateTrajectory(est, Loop(), 0.02, 1), std::invalid_argument);
}

TEST(Trajectory, EndPointDriftOfAnAnchoredEstimate) {
  const Trajectory gt = Loop();
  double path = 0.0;
  for (size_t k = 1; k < gt.poses.size(); ++k) {
    path += (gt.poses[k].translation() - gt.poses[k - 1].translation()).norm();
  }
  // The estimate starts at the truth and ends 3 cm off, drifting linearly.
  Trajectory est = gt;
  for (size_t k = 0; k < est.poses.size(); ++k) {
    est.poses[k].translation().x() += 0.03 * k / (est.poses.size() - 1);
  }
  const EndPointDrift drift = MeasureEndPointDrift(est, gt, 0.02);
  EXPECT_TRUE(drift.anchored);
  EXPECT_NEAR(drift.drift_m, 0.03, 1e-12);
  EXPECT_NEAR(drift.path_m, path, 1e-12);
  // Started elsewhere, it is not anchored; one matched pose is an error.
  est.poses[0].translation().y() += 1e-3;
  EXPECT_FALSE(MeasureEndPointDrift(est, gt, 0.02).anchored);
  Trajectory one;
  one.timestamps = {0.0};
  one.poses = {gt.poses[0]};
  EXPECT_THROW(MeasureEndPointDrift(one, gt, 0.02), std::invalid_argument);
}

TEST(Trajectory, LoopDriftIsTheErrorOfTheFirstToLastMotion) {
  // A closed truth: the last pose is the first one again.
  Trajectory gt = Loop();
  gt.timestamps.push_back(gt.timestamps.back() + (gt.timestamps[1] - gt.timestamps[0]));
  gt.poses.push_back(gt.poses.front());
  // The estimate, moved as a whole (the drift does not see it), ends 2 cm and 1 deg off.
  Pose moved = Pose::Identity();
  moved.translation() = Vec3(1.0, 2.0, 3.0);
  moved.linear() = ExpSO3(Vec3(0.1, 0.2, 0.3));
  Trajectory est = gt;
  for (Pose& pose : est.poses) pose = moved * pose;
  Pose off = Pose::Identity();
  off.translation() = Vec3(0.0, 0.02, 0.0);
  off.linear() = ExpSO3(Vec3(0.0, 0.0, 1.0 * kDegToRad));
  est.poses.back() = est.poses.back() * off;
  const LoopDrift drift = MeasureLoopDrift(est, gt, 0.02);
  EXPECT_TRUE(drift.closed);
  EXPECT_NEAR(drift.translation_m, 0.02, 1e-9);
  EXPECT_NEAR(drift.rotation_rad, 1.0 * kDegToRad, 1e-9);
  // An open truth is not a closed loop.
  EXPECT_FALSE(MeasureLoopDrift(est, Loop(), 0.02).closed);
}

class TumTrajectoryTest : public io_test::TempDirTest {};

TEST_F(TumTrajectoryTest, RoundTripIsExact) {
  const Trajectory path = Loop(1305031102.160407);
  const std::string file = Path("traj.txt");
  WriteTumTrajectory(file, path);
  const Trajectory back = ReadTumTrajectory(file);
  ASSERT_EQ(back.poses.size(), path.poses.size());
  for (size_t k = 0; k < path.poses.size(); ++k) {
    EXPECT_EQ(back.timestamps[k], path.timestamps[k]);
    EXPECT_TRUE(back.poses[k].isApprox(path.poses[k], 1e-15));
  }
}

TEST_F(TumTrajectoryTest, MalformedLinesNameFileAndLine) {
  const auto error = [&](const std::string& text) {
    const std::string file = Path("bad.txt");
    io_test::WriteText(file, text);
    return io_test::InputErrorMessage([&] { ReadTumTrajectory(file); });
  };
  const std::string ok = "1.0 0 0 0 0 0 0 1\n";
  EXPECT_THAT(error("# header\n1.0 0 0 0 0 0 1\n"),
              HasSubstr("bad.txt: line 2: expected 8 values"));
  EXPECT_THAT(error(ok + "2.0 0 0 x 0 0 0 1\n"), HasSubstr("line 2: 'x' is not a number"));
  EXPECT_THAT(error(ok + "2.0 0 0 nan 0 0 0 1\n"), HasSubstr("line 2: 'nan' is not finite"));
  EXPECT_THAT(error(ok + "0.5 0 0 0 0 0 0 1\n"),
              HasSubstr("line 2: timestamp 0.5 does not increase"));
  EXPECT_THAT(error("1.0 0 0 0 0 0 0 2\n"), HasSubstr("line 1: quaternion norm"));
  EXPECT_THAT(error("# nothing\n\n"), HasSubstr("bad.txt: no poses"));
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadTumTrajectory(Path("missing.txt")); }),
              HasSubstr("missing.txt"));
  // Printed with 4 decimals: the quaternion is normalised.
  io_test::WriteText(Path("rounded.txt"), "1.0 0 0 0 0.7071 0 0 0.7071\n");
  const Trajectory t = ReadTumTrajectory(Path("rounded.txt"));
  EXPECT_NEAR(Eigen::Quaterniond(t.poses[0].linear()).norm(), 1.0, 1e-12);
}

}  // namespace
}  // namespace rigfit
