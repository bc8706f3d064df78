// report/compare.h: the verdict over three runs, on results built by hand (the runs' numbers
// set, no refinement), and the input checks. `rigfit compare` end to end is
// tests/cli_compare_test.cc.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "core/errors.h"
#include "report/compare.h"

namespace rigfit {
namespace {

/// A comparison with the truth whose runs have these RMS relative errors (mm, deg).
CompareResult WithErrors(const std::vector<std::pair<double, double>>& errors_mm_deg) {
  CompareResult c;
  c.has_gt = true;
  const char* names[] = {"pairwise", "joint", "surface_bundle"};
  for (size_t r = 0; r < errors_mm_deg.size(); ++r) {
    CompareRun run;
    run.name = names[r];
    run.success = true;
    run.errors.rms_translation_m = errors_mm_deg[r].first * 1e-3;
    run.errors.rms_rotation_rad = errors_mm_deg[r].second * kDegToRad;
    c.runs.push_back(run);
  }
  return c;
}

TEST(CompareVerdictTest, NamesTheRunBestOnEveryMeasure) {
  const std::string v = CompareVerdict(WithErrors({{28.44, 0.384}, {13.11, 0.107}, {9.0, 0.09}}));
  EXPECT_THAT(v, testing::StartsWith("surface_bundle is best (against the ground truth): "));
  EXPECT_NE(v.find("RMS relative translation error 28.44 mm (pairwise), 13.11 mm (joint), "
                   "9.00 mm (surface_bundle)"),
            std::string::npos)
      << v;
}

TEST(CompareVerdictTest, RunsWithinFivePercentOfTheBestTie) {
  // Joint and the surface bundle within 5% of each other on both measures, pairwise behind.
  std::string v = CompareVerdict(WithErrors({{20.0, 0.3}, {10.0, 0.100}, {10.4, 0.098}}));
  EXPECT_THAT(v, testing::StartsWith("joint and surface_bundle are even (within 5%) and best"));
  // All three within 5% on both: no winner.
  v = CompareVerdict(WithErrors({{10.0, 0.1}, {10.2, 0.101}, {10.3, 0.102}}));
  EXPECT_THAT(v, testing::StartsWith("no clear winner (against the ground truth, within 5%)"));
  // Best on one measure, tied with pairwise on the other: still the best.
  v = CompareVerdict(WithErrors({{20.0, 0.100}, {10.0, 0.101}, {15.0, 0.3}}));
  EXPECT_THAT(v, testing::StartsWith("joint is best"));
  EXPECT_EQ(v.find("even"), std::string::npos) << v;
  // Best on one measure, all three even on the other: that one is named even.
  v = CompareVerdict(WithErrors({{20.0, 0.100}, {10.0, 0.101}, {15.0, 0.102}}));
  EXPECT_THAT(v, testing::StartsWith("joint is best"));
  EXPECT_NE(v.find("; even: RMS relative rotation error"), std::string::npos) << v;
}

TEST(CompareVerdictTest, SmallNumbersPrintWithThreeSignificantDigits) {
  // 0.0006, 0.0008 and 0.0012 deg differ by more than 5%: written apart, not all as 0.001.
  const std::string v =
      CompareVerdict(WithErrors({{0.03, 0.0006}, {0.04, 0.0008}, {0.0612, 0.0012}}));
  EXPECT_NE(v.find("RMS relative translation error 0.0300 mm (pairwise), 0.0400 mm (joint), "
                   "0.0612 mm (surface_bundle)"),
            std::string::npos)
      << v;
  EXPECT_NE(v.find("RMS relative rotation error 0.000600 deg (pairwise), 0.000800 deg (joint), "
                   "0.001200 deg (surface_bundle)"),
            std::string::npos)
      << v;
}

TEST(CompareVerdictTest, MeasuresThatDisagreeAreMixed) {
  const std::string v = CompareVerdict(WithErrors({{10.0, 0.3}, {20.0, 0.1}, {30.0, 0.5}}));
  EXPECT_THAT(v,
              testing::StartsWith("mixed (against the ground truth): pairwise best on RMS relative "
                                  "translation error"));
  EXPECT_NE(v.find("joint best on RMS relative rotation error"), std::string::npos) << v;
}

TEST(CompareVerdictTest, ARunNotAppliedIsLeftOutAndNamed) {
  CompareResult c = WithErrors({{1.0, 0.01}, {13.11, 0.107}, {9.0, 0.09}});
  c.runs[0].success = false;
  c.runs[0].message = "no accepted pair";
  std::string v = CompareVerdict(c);
  EXPECT_THAT(v, testing::StartsWith("surface_bundle is best"));
  EXPECT_NE(v.find("; not applied: pairwise (no accepted pair)"), std::string::npos) << v;
  EXPECT_EQ(v.find("(pairwise),"), std::string::npos) << v;  // its numbers left out
  c.runs[2].success = false;
  c.runs[2].message = "too few planes";
  v = CompareVerdict(c);
  EXPECT_THAT(v, testing::StartsWith("joint: the only run applied; not applied: pairwise"));
  c.runs[1].success = false;
  EXPECT_THAT(CompareVerdict(c), testing::StartsWith("no run refined the rig"));
}

TEST(CompareVerdictTest, WithoutTheTruthJudgesByTheFit) {
  CompareResult c;
  const double off_floor_mm[] = {12.0, 6.0, 5.9};
  for (int r = 0; r < 3; ++r) {
    CompareRun run;
    run.name = r == 0 ? "pairwise" : r == 1 ? "joint" : "surface_bundle";
    run.success = true;
    PairDiagnostics pair;
    pair.points = 1000;
    pair.correspondences = 500;
    pair.inlier_fraction = 0.5;
    pair.rmse_m = 0.010;
    pair.off_floor_correspondences = 100;
    pair.off_floor_rmse_m = off_floor_mm[r] * 1e-3;
    run.fit = {pair};
    c.runs.push_back(run);
  }
  const std::string v = CompareVerdict(c);
  EXPECT_THAT(
      v, testing::StartsWith("joint and surface_bundle are even (within 5%) and best (no ground "
                             "truth: judged by the fit of the pairs): RMS off-floor pair residual "
                             "12.00 mm (pairwise), 6.00 mm (joint), 5.90 mm (surface_bundle)"));
  EXPECT_NE(v.find("even: RMS pair residual"), std::string::npos) << v;
}

TEST(CompareInputTest, OneCameraOrAMissingTruthIsBadInput) {
  RigCapture capture;
  capture.cameras.resize(1);
  capture.cameras[0].serial = "a";
  EXPECT_THROW(CheckCompareInput(capture, nullptr, {}), InputError);
  capture.cameras.resize(2);
  capture.cameras[1].serial = "b";
  EXPECT_NO_THROW(CheckCompareInput(capture, nullptr, {}));
  const PoseMap gt = {{"a", Pose::Identity()}};
  try {
    CheckCompareInput(capture, &gt, {"c.h5", "i.json", "gt.json", ""});
    FAIL() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), "compare: gt.json has no pose for camera b of the capture");
  }
}

}  // namespace
}  // namespace rigfit
