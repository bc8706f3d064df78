// `rigfit track` end to end: a small synthetic sequence written by `rigfit simulate-sequence`
// is tracked, the trajectory file read back and measured against the sequence's ground truth;
// bad input is refused naming what is wrong.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/trajectory.h"
#include "io/ply.h"
#include "io/png.h"
#include "io/trajectory_tum.h"
#include "report/html.h"
#include "report/image.h"
#include "report/map_view.h"
#include "report/palette.h"
#include "sim/simulate_sequence.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

constexpr int kWidth = 160;
constexpr int kHeight = 120;
constexpr int kFrames = 24;

class CliTrack : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ =
        new fs::path(fs::temp_directory_path() / ("rigfit_cli_track_" + std::to_string(getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    const cli_test::RunResult r =
        cli_test::RunRigfit({"simulate-sequence", "--out", (*dir_ / "seq").string(), "--frames",
                             std::to_string(kFrames), "--width", std::to_string(kWidth), "--height",
                             std::to_string(kHeight), "--noise", "none", "--no-color"},
                            *dir_);
    ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
  }
  /// The intrinsics the sequence was rendered with (the TUM layout does not carry them).
  static std::string Intrinsics() {
    const PinholeIntrinsics K = SequenceIntrinsics(kWidth, kHeight);
    return std::to_string(K.fx) + "," + std::to_string(K.fy) + "," + std::to_string(K.cx) + "," +
           std::to_string(K.cy);
  }

  static fs::path* dir_;
};
fs::path* CliTrack::dir_ = nullptr;

TEST_F(CliTrack, TracksASyntheticSequenceToTheMillimetre) {
  const fs::path out = *dir_ / "traj.txt";
  const cli_test::RunResult r =
      cli_test::RunRigfit({"track", (*dir_ / "seq").string(), "--out", out.string(), "--intrinsics",
                           Intrinsics(), "--evaluate"},
                          *dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.out.find("tracked 24 frames (0 failed"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("ATE RMSE"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("end-point drift"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("mm per metre"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("24/24 frames"), std::string::npos) << r.err;              // progress
  EXPECT_EQ(r.err.find("normals may be too noisy"), std::string::npos) << r.err;  // 0.96 matched
  const Trajectory estimate = ReadTumTrajectory(out.string());
  const Trajectory truth = ReadTumTrajectory((*dir_ / "seq" / "groundtruth.txt").string());
  ASSERT_EQ(estimate.poses.size(), static_cast<std::size_t>(kFrames));
  // The first pose is the ground truth's; the walk covers about 0.3 m.
  EXPECT_TRUE(estimate.poses[0].isApprox(truth.poses[0], 1e-9));
  const TrajectoryErrors e = EvaluateTrajectory(estimate, truth, 0.02, 1);
  EXPECT_EQ(e.pairs, kFrames);
  // Noise-free depth at 160x120 (a pixel is 1.2 cm at 1 m): millimetres over 0.3 m.
  EXPECT_LT(e.ate_rmse_m, 2e-3);
  EXPECT_LT(e.rpe_translation_rmse_m, 2e-3);
}

// Stereo depth's normals are too noisy to associate by: the run says so and names the flags
// that help, those not given.
TEST_F(CliTrack, FewPixelsMatchedOnStereoDepthWarnNamingTheFlags) {
  const fs::path seq = *dir_ / "stereo";
  const cli_test::RunResult sim =
      cli_test::RunRigfit({"simulate-sequence", "--out", seq.string(), "--frames", "10", "--width",
                           std::to_string(kWidth), "--height", std::to_string(kHeight), "--noise",
                           "stereo", "--no-color"},
                          *dir_);
  ASSERT_EQ(sim.exit_code, 0) << cli_test::Describe(sim);
  const auto track = [&](std::vector<std::string> flags) {
    std::vector<std::string> args = {
        "track",        seq.string(), "--out",  (*dir_ / "stereo.txt").string(),
        "--intrinsics", Intrinsics(), "--quiet"};
    args.insert(args.end(), flags.begin(), flags.end());
    const cli_test::RunResult r = cli_test::RunRigfit(args, *dir_);
    EXPECT_EQ(r.exit_code, 0) << cli_test::Describe(r);
    return r.err;
  };
  // Measured: 0.39 of the pixels matched with the defaults, 0.50 with the range growing.
  const std::string defaults = track({});
  EXPECT_NE(defaults.find("normals may be too noisy"), std::string::npos) << defaults;
  EXPECT_NE(defaults.find("try --bilateral-range-grows and --max-angle 60"), std::string::npos)
      << defaults;
  const std::string grows = track({"--bilateral-range-grows"});
  EXPECT_NE(grows.find("; try --max-angle 60 ("), std::string::npos) << grows;
}

TEST_F(CliTrack, AFloorOnlySequenceReportsItsWeakDirectionsInTheSummaryAndTheFile) {
  // Every frame sees only the floor: its slides and the turn about its normal are weak.
  const fs::path seq = *dir_ / "floor";
  const cli_test::RunResult sim = cli_test::RunRigfit(
      {"simulate-sequence", "--out", seq.string(), "--frames", "6", "--width",
       std::to_string(kWidth), "--height", std::to_string(kHeight), "--noise", "none", "--no-color",
       "--lone-plane", "floor", "--lone-plane-start", "0"},
      *dir_);
  ASSERT_EQ(sim.exit_code, 0) << cli_test::Describe(sim);
  for (const std::string command : {"track", "slam"}) {
    const fs::path out = *dir_ / (command + "-floor.txt");
    const cli_test::RunResult r = cli_test::RunRigfit(
        {command, seq.string(), "--out", out.string(), "--intrinsics", Intrinsics()}, *dir_);
    ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
    EXPECT_NE(r.out.find("degenerate views: 5 frame(s) with weak directions, 0 of them aligned "
                         "by colour, 0 relocalised after a lone plane; divergence: 0 frame(s) "
                         "recovered, 0 diverged"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.err.find("held at the prediction"), std::string::npos) << r.err;
    const std::string file = cli_test::ReadText(out);
    EXPECT_NE(file.find("# rigfit " + command +
                        ": frames 6, failed 0, restarts 0, recovered 0, diverged 0, "
                        "weak-direction frames 5, relocalised 0, aligned by colour 0"),
              std::string::npos)
        << file;
    EXPECT_EQ(ReadTumTrajectory(out.string()).poses.size(), 6u);  // the '#' lines are skipped
  }
}

TEST_F(CliTrack, VerboseShowsEachFramesTrack) {
  const fs::path seq = *dir_ / "floor-verbose";
  const cli_test::RunResult sim =
      cli_test::RunRigfit({"simulate-sequence", "--out", seq.string(), "--frames", "4", "--width",
                           std::to_string(kWidth), "--height", std::to_string(kHeight), "--noise",
                           "none", "--lone-plane", "floor", "--lone-plane-start", "0"},
                          *dir_);
  ASSERT_EQ(sim.exit_code, 0) << cli_test::Describe(sim);
  for (const std::string command : {"track", "slam"}) {
    const fs::path out = *dir_ / (command + "-verbose.txt");
    std::vector<std::string> args = {command,      seq.string(),   "--out",
                                     out.string(), "--intrinsics", Intrinsics()};
    const cli_test::RunResult plain = cli_test::RunRigfit(args, *dir_);
    args.push_back("--verbose");
    const cli_test::RunResult told = cli_test::RunRigfit(args, *dir_);
    ASSERT_EQ(plain.exit_code, 0) << cli_test::Describe(plain);
    ASSERT_EQ(told.exit_code, 0) << cli_test::Describe(told);
    EXPECT_EQ(plain.err.find("debug:"), std::string::npos) << plain.err;
    // Every frame after the first, with what the guard goes by: a lone floor holds three.
    for (const std::string frame : {"frame 1 ", "frame 2 ", "frame 3 "}) {
      EXPECT_NE(told.err.find(command + ": debug: " + frame), std::string::npos) << told.err;
    }
    EXPECT_NE(told.err.find(" mm, conditioning "), std::string::npos) << told.err;
    EXPECT_NE(told.err.find(", 3 weak direction(s)"), std::string::npos) << told.err;
  }
}

TEST_F(CliTrack, EvaluateTrajectoryReportsTheEndDriftOfAClosedLoop) {
  const fs::path seq = *dir_ / "loop";
  const cli_test::RunResult sim =
      cli_test::RunRigfit({"simulate-sequence", "--out", seq.string(), "--frames", "3", "--width",
                           "16", "--height", "16", "--no-color", "--closed-loop"},
                          *dir_);
  ASSERT_EQ(sim.exit_code, 0) << cli_test::Describe(sim);
  const std::string gt = (seq / "groundtruth.txt").string();
  const cli_test::RunResult r = cli_test::RunRigfit({"evaluate-trajectory", gt, gt}, *dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.out.find("closed loop (the ground truth ends where it starts): end drift 0.00 mm / "
                       "0.000 deg"),
            std::string::npos)
      << r.out;
}

TEST_F(CliTrack, EvaluateOnASequenceTooShortToCompareWarns) {
  const fs::path out = *dir_ / "short.txt";
  const cli_test::RunResult r =
      cli_test::RunRigfit({"track", (*dir_ / "seq").string(), "--out", out.string(), "--intrinsics",
                           Intrinsics(), "--max-frames", "2", "--evaluate"},
                          *dir_);
  EXPECT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.err.find("warning: --evaluate:"), std::string::npos) << r.err;
  EXPECT_EQ(ReadTumTrajectory(out.string()).poses.size(), 2u);  // the trajectory is written
}

TEST_F(CliTrack, RefusesBadInputNamingIt) {
  const fs::path out = *dir_ / "bad.txt";
  const std::string seq = (*dir_ / "seq").string();
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"track", (*dir_ / "missing").string(), "--out", out.string()}, "missing"},
      {{"track", seq, "--out", out.string(), "--iterations", "1,1,1,1,1,1,1"}, "--iterations"},
      {{"track", seq, "--out", out.string(), "--prior", "sideways"}, "--prior"},
      {{"track", seq, "--out", out.string(), "--max-depth", "0.1"}, "--max-depth"},
      {{"track", seq, "--out", out.string(), "--intrinsics", "500,500"}, "--intrinsics"},
      {{"track", seq, "--out", out.string(), "--first", "99"}, "first frame 99"},
      {{"track", seq, "--out", out.string(), "--max-frames", "-5"}, "--max-frames"},
      {{"track", seq, "--out", out.string(), "--threads", "1000"}, "--threads"},
  };
  for (const auto& [args, expected] : cases) {
    const cli_test::RunResult r = cli_test::RunRigfit(args, *dir_);
    EXPECT_EQ(r.exit_code, 2) << args[3] << "\n" << cli_test::Describe(r);
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

// `rigfit slam` (frame-to-model) on the same sequence: the trajectory to the millimetre, the
// map written as a PLY with normals and not overwritten without --force, and drawn from above
// with the trajectory (--report).
TEST_F(CliTrack, SlamTracksAndWritesTheMap) {
  const fs::path out = *dir_ / "slam.txt";
  const fs::path map = *dir_ / "map.ply";
  const fs::path report = *dir_ / "slam_report";
  const std::vector<std::string> args = {
      "slam",     (*dir_ / "seq").string(), "--out",        out.string(), "--map",     map.string(),
      "--report", report.string(),          "--intrinsics", Intrinsics(), "--evaluate"};
  const cli_test::RunResult r = cli_test::RunRigfit(args, *dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.out.find("tracked and fused 24 frames (0 failed"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("24/24 frames, map"), std::string::npos) << r.err;  // progress
  const Trajectory estimate = ReadTumTrajectory(out.string());
  const Trajectory truth = ReadTumTrajectory((*dir_ / "seq" / "groundtruth.txt").string());
  const TrajectoryErrors e = EvaluateTrajectory(estimate, truth, 0.02, 1);
  EXPECT_EQ(e.pairs, kFrames);
  EXPECT_LT(e.ate_rmse_m, 2e-3);
  const PlyCloud cloud = ReadPly(map.string());
  EXPECT_GT(cloud.points.size(), 1000u);
  EXPECT_EQ(cloud.normals.size(), cloud.points.size());
  // The picture: its size, the map's points coloured by height (no colour in the sequence)
  // over a tenth of the plot at least, the estimate drawn over them.
  EXPECT_NE(r.out.find("report: " + (report / kMapTopFile).string()), std::string::npos) << r.out;
  const Image image = ReadPng((report / kMapTopFile).string());
  ASSERT_EQ(image.width, kMapViewWidth);
  ASSERT_EQ(image.height, kMapViewHeight);
  int drawn = 0, estimate_pixels = 0;
  for (int y = kMapPlotTop; y < kMapPlotBottom; ++y) {
    for (int x = kMapPlotLeft; x < kMapPlotRight; ++x) {
      drawn += image.At(x, y) != kWhite ? 1 : 0;
      estimate_pixels += image.At(x, y) == CameraColor(0) ? 1 : 0;
    }
  }
  EXPECT_GT(drawn, (kMapPlotRight - kMapPlotLeft) * (kMapPlotBottom - kMapPlotTop) / 10);
  EXPECT_GT(estimate_pixels, 100);
  const std::string page = cli_test::ReadText((report / kReportIndexFile).string());
  EXPECT_NE(page.find("tracked and fused 24 frames"), std::string::npos);
  EXPECT_NE(page.find("ATE RMSE"), std::string::npos);
  EXPECT_NE(page.find("up axis (the normal"), std::string::npos) << page;
  // Again without --force: refused, exit 2.
  const cli_test::RunResult again = cli_test::RunRigfit(args, *dir_);
  EXPECT_EQ(again.exit_code, 2);
  EXPECT_NE(again.err.find("--force"), std::string::npos) << again.err;
}

TEST_F(CliTrack, SlamRefusesBadInput) {
  const fs::path out = *dir_ / "slam_bad.txt";
  const std::string seq = (*dir_ / "seq").string();
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"slam", (*dir_ / "missing").string(), "--out", out.string()}, "missing"},
      {{"slam", seq, "--out", out.string(), "--intrinsics", "500,500"}, "--intrinsics"},
      {{"slam", seq, "--out", out.string(), "--model-weight", "0.5"}, "--model-weight"},
      {{"slam", seq, "--out", out.string(), "--dormant-frames", "-1"}, "--dormant-frames"},
      {{"slam", seq, "--out", out.string(), "--fuse-angle", "0"}, "--fuse-angle"},
      {{"slam", seq, "--out", out.string(), "--cover-radius", "-1"}, "--cover-radius"},
      {{"slam", seq, "--out", out.string(), "--model-recent", "-1"}, "--model-recent"},
      {{"slam", seq, "--out", out.string(), "--halve", "-1"}, "--halve"},
      {{"slam", seq, "--out", out.string(), "--report", (*dir_ / "no" / "report").string()},
       "slam: --report"},
  };
  for (const auto& [args, expected] : cases) {
    const cli_test::RunResult r = cli_test::RunRigfit(args, *dir_);
    EXPECT_EQ(r.exit_code, 2) << args[3] << "\n" << cli_test::Describe(r);
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

}  // namespace
}  // namespace rigfit
