// The pictures of `rigfit evaluate-trajectory --report` (report/trajectory_report.h): the
// plane of the plan view, the files and their sizes, and the two curves drawn where they
// belong; the CLI flag.
#include "report/trajectory_report.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/pose.h"
#include "io/png.h"
#include "io/trajectory_tum.h"
#include "report/html.h"
#include "report/palette.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

constexpr double kTolerance = 1e-9;
constexpr int kPoses = 300;
constexpr double kMaxDt = 0.02;

/// An ellipse of semi-axes 2 m (x) and 1 m (z) at 1.4 m height (+Y up), one pose per 1/30 s,
/// moved by T_world (a world frame whose up axis is not +Y, as TUM's motion capture).
Trajectory Ellipse(const Pose& T_world = Pose::Identity(), double scale = 1.0) {
  Trajectory t;
  for (int i = 0; i < kPoses; ++i) {
    const double a = 2.0 * M_PI * i / kPoses;
    Pose T = Pose::Identity();
    T.linear() = ExpSO3(Vec3(0.0, a, 0.0));
    T.translation() = Vec3(2.0 * scale * std::cos(a), 1.4, scale * std::sin(a));
    t.timestamps.push_back(i / 30.0);
    t.poses.push_back(T_world * T);
  }
  return t;
}

Pose SomeRigidMotion() {
  Pose T = Pose::Identity();
  T.linear() = ExpSO3(Vec3(1.1, -0.4, 0.7));
  T.translation() = Vec3(3.0, -2.0, 0.5);
  return T;
}

std::vector<Vec3> Positions(const Trajectory& t) {
  std::vector<Vec3> p;
  for (const Pose& T : t.poses) p.push_back(T.translation());
  return p;
}

class TrajectoryReport : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rigfit_trajectory_report_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

TEST(TrajectoryPlane, IsThePrincipalPlane) {
  const TrajectoryPlane plane = FitTrajectoryPlane(Positions(Ellipse()));
  EXPECT_NEAR((plane.origin - Vec3(0.0, 1.4, 0.0)).norm(), 0.0, kTolerance);
  EXPECT_TRUE(plane.axis_1.isApprox(Vec3::UnitX(), kTolerance));
  EXPECT_TRUE(plane.axis_2.isApprox(Vec3::UnitZ(), kTolerance));
  // In a world whose up axis is tilted, the same plane, turned with it (up to sign).
  const Pose T = SomeRigidMotion();
  const TrajectoryPlane moved = FitTrajectoryPlane(Positions(Ellipse(T)));
  EXPECT_NEAR(std::abs(moved.axis_1.dot(T.linear() * Vec3::UnitX())), 1.0, kTolerance);
  EXPECT_NEAR(std::abs(moved.axis_2.dot(T.linear() * Vec3::UnitZ())), 1.0, kTolerance);
  EXPECT_NEAR((moved.origin - T * Vec3(0.0, 1.4, 0.0)).norm(), 0.0, kTolerance);
}

// An estimate that is the truth moved rigidly: after the alignment both curves coincide, so
// the estimate (on top) covers every ground-truth position and the wider grey line shows
// only as a rim; every error is 0 and the error curve lies on the 0 line.
TEST_F(TrajectoryReport, IdenticalTrajectoriesCoincide) {
  const Trajectory gt = Ellipse();
  const Trajectory est = Ellipse(SomeRigidMotion());
  const TrajectoryErrors errors = EvaluateTrajectory(est, gt, kMaxDt, 1);
  ASSERT_LT(errors.ate_max_m, 1e-9);
  const std::vector<std::string> files =
      WriteTrajectoryReport((dir_ / "report").string(), est, gt, errors, kMaxDt);
  ASSERT_EQ(files.size(), 3u);
  EXPECT_EQ(files[0], (dir_ / "report" / kTrajectoryPlanFile).string());
  EXPECT_EQ(files[1], (dir_ / "report" / kTrajectoryAteFile).string());
  EXPECT_EQ(files[2], (dir_ / "report" / kReportIndexFile).string());

  const Image plan = ReadPng(files[0]);
  ASSERT_EQ(plan.width, kPlanViewWidth);
  ASSERT_EQ(plan.height, kPlanViewHeight);
  const std::vector<PlotCurve> curves =
      TrajectoryPlanCurves(est, gt, errors, FitTrajectoryPlane(Positions(gt)));
  ASSERT_EQ(curves.size(), 2u);
  const PlotFrame frame = FitPlotFrame(curves, kPlanViewWidth, kPlanViewHeight, true, false);
  // Equal scale on both axes.
  EXPECT_NEAR((frame.max_x - frame.min_x) / (frame.x1 - frame.x0 - 1),
              (frame.max_y - frame.min_y) / (frame.y1 - frame.y0 - 1), kTolerance);
  const Rgb estimate_color = curves[1].color;
  const Rgb truth_color = curves[0].color;
  EXPECT_EQ(estimate_color, CameraColor(0));
  for (size_t i = 0; i < curves[0].x.size(); ++i) {
    const int c = static_cast<int>(std::lround(frame.Column(curves[0].x[i])));
    const int r = static_cast<int>(std::lround(frame.Row(curves[0].y[i])));
    EXPECT_EQ(plan.At(c, r), estimate_color) << i;
  }
  int rim = 0;
  for (int y = 0; y < plan.height; ++y) {
    for (int x = 0; x < plan.width; ++x) rim += plan.At(x, y) == truth_color ? 1 : 0;
  }
  EXPECT_GT(rim, 1000);  // a closed curve of about 1000 pixels, 2 pixels of rim either side

  const Image ate = ReadPng(files[1]);
  ASSERT_EQ(ate.width, kTimePlotWidth);
  ASSERT_EQ(ate.height, kTimePlotHeight);
  PlotCurve zero{"", CameraColor(0), 2, {}, {}};
  for (int i = 0; i < kPoses; ++i) {
    zero.x.push_back(gt.timestamps[i] - gt.timestamps[0]);
    zero.y.push_back(0.0);
  }
  const PlotFrame ate_frame = FitPlotFrame({zero}, kTimePlotWidth, kTimePlotHeight, false, true);
  for (int i = 0; i < kPoses; i += 10) {
    EXPECT_EQ(ate.At(static_cast<int>(std::lround(ate_frame.Column(zero.x[i]))),
                     static_cast<int>(std::lround(ate_frame.Row(0.0)))),
              CameraColor(0))
        << i;
  }
}

// An estimate 30% too large cannot be aligned onto the truth: the two curves are at least
// 0.3 m (tens of pixels) apart, each drawn at its own positions.
TEST_F(TrajectoryReport, DifferentTrajectoriesAreEachWhereTheyBelong) {
  const Trajectory gt = Ellipse();
  const Trajectory est = Ellipse(SomeRigidMotion(), 1.3);
  const TrajectoryErrors errors = EvaluateTrajectory(est, gt, kMaxDt, 1);
  const std::vector<std::string> files =
      WriteTrajectoryReport(dir_.string(), est, gt, errors, kMaxDt);
  const Image plan = ReadPng(files[0]);
  const std::vector<PlotCurve> curves =
      TrajectoryPlanCurves(est, gt, errors, FitTrajectoryPlane(Positions(gt)));
  const PlotFrame frame = FitPlotFrame(curves, kPlanViewWidth, kPlanViewHeight, true, false);
  for (const PlotCurve& curve : curves) {
    for (size_t i = 0; i < curve.x.size(); ++i) {
      const int c = static_cast<int>(std::lround(frame.Column(curve.x[i])));
      const int r = static_cast<int>(std::lround(frame.Row(curve.y[i])));
      EXPECT_EQ(plan.At(c, r), curve.color) << curve.label << " " << i;
    }
  }
  // The aligned estimate surrounds the truth: its point on the first axis lies further out.
  EXPECT_GT(curves[1].x[0], curves[0].x[0] + 0.3);
}

TEST_F(TrajectoryReport, CliWritesTheReportAndRefusesAMissingParent) {
  const fs::path gt = dir_ / "gt.txt";
  WriteTumTrajectory(gt.string(), Ellipse());
  const cli_test::RunResult r = cli_test::RunRigfit(
      {"evaluate-trajectory", gt.string(), gt.string(), "--report", (dir_ / "out").string()}, dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.out.find("report: " + (dir_ / "out" / kTrajectoryPlanFile).string()),
            std::string::npos)
      << r.out;
  EXPECT_TRUE(fs::exists(dir_ / "out" / kTrajectoryAteFile));
  // The page shows what the command printed.
  const std::string page = cli_test::ReadText(dir_ / "out" / kReportIndexFile);
  const std::string ate_line = r.out.substr(r.out.find("ATE (absolute"));
  EXPECT_NE(page.find(ate_line.substr(0, ate_line.find('\n'))), std::string::npos) << page;
  const cli_test::RunResult bad =
      cli_test::RunRigfit({"evaluate-trajectory", gt.string(), gt.string(), "--report",
                           (dir_ / "no" / "such").string()},
                          dir_);
  EXPECT_EQ(bad.exit_code, 2) << cli_test::Describe(bad);
  EXPECT_NE(bad.err.find("--report"), std::string::npos) << bad.err;
}

}  // namespace
}  // namespace rigfit
