// End-to-end tests of `rigfit compare`: the built executable (RIGFIT_CLI_PATH) on a small
// rig written by `rigfit simulate`. Its joint errors must be those `rigfit evaluate` gives
// for the output of `rigfit refine` (joint is the default mode) on the same input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_test_util.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace cli_test;  // NOLINT: RunRigfit and friends

class CliCompareTest : public SimulatedRigSuite<CliCompareTest> {
 protected:
  /// 3 cameras, 320 x 180, noise-free, a perturbation within the default safety bounds
  /// (as tests/cli_refine_test.cc).
  static void SetUpTestSuite() {
    SimulateRig("rigfit_cli_compare_test",
                {"--cameras", "3", "--width", "320", "--height", "180", "--noise", "0",
                 "--perturb-yaw-deg", "0.5", "--perturb-xz-m", "0.02"});
  }
};

TEST_F(CliCompareTest, BothModesSideBySideAndJointAgreesWithEvaluate) {
  const RunResult r =
      RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics", Rig("init.json"),
                 "--gt", Rig("gt.json"), "--json", Scratch("compare.json"), "--quiet"},
                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  for (const char* text : {"pairwise", "joint", "change", "error vs gt", "joint 1-sigma",
                           "all pairs", "peak RSS MB", "verdict: "}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
  const Json compare = Json::parse(ReadText(Scratch("compare.json")));
  for (const char* mode : {"pairwise", "joint"}) {
    SCOPED_TRACE(mode);
    const Json& m = compare["modes"][mode];
    EXPECT_EQ(m["success"], true) << m["message"];
    EXPECT_EQ(m["cameras"].size(), 3u);
    EXPECT_GT(m["wall_s"].get<double>(), 0.0);
    EXPECT_GT(m["peak_rss_mb"].get<double>(), 0.0);
    // The mark is reset per mode (core/peak_memory.h); the process holds the capture.
    EXPECT_EQ(m["peak_rss_per_mode"], true);
    EXPECT_GE(m["peak_rss_mb"].get<double>(), 0.5 * compare["baseline_rss_mb"].get<double>());
    for (const char* error : {"rotation_deg", "translation_mm", "tilt_deg"}) {
      EXPECT_TRUE(m["errors"][error]["rms"].is_number()) << error;
      EXPECT_TRUE(m["errors"][error]["max"].is_number()) << error;
    }
    ASSERT_FALSE(m["fit"]["pairs"].empty());
    EXPECT_GT(m["fit"]["all_pairs"]["correspondences"].get<int>(), 0);
    // Walls and boxes, doubled at the perturbed start, line up: their residuals shrink.
    EXPECT_LT(m["fit"]["all_pairs"]["off_floor_rmse_mm"].get<double>(),
              0.7 * compare["before"]["fit"]["all_pairs"]["off_floor_rmse_mm"].get<double>());
  }
  EXPECT_EQ(compare["before"]["fit"]["pairs"].size(),
            compare["modes"]["joint"]["fit"]["pairs"].size());
  EXPECT_FALSE(compare["verdict"].get<std::string>().empty());
  // The joint mode reports a 1-sigma for every camera but the reference.
  int with_sigma = 0;
  for (const auto& [serial, camera] : compare["modes"]["joint"]["cameras"].items()) {
    with_sigma += camera.contains("sigma") ? 1 : 0;
  }
  EXPECT_EQ(with_sigma, 2);

  // `rigfit refine` (joint) + `rigfit evaluate` on its output give the same errors.
  const RunResult refine = RunRigfit({"refine", "--capture", Rig("capture.h5"), "--extrinsics",
                                      Rig("init.json"), "--out", Scratch("joint.json"), "--quiet"},
                                     root_);
  ASSERT_EQ(refine.exit_code, 0) << Describe(refine);
  const RunResult evaluate = RunRigfit(
      {"evaluate", Scratch("joint.json"), Rig("gt.json"), "--json", Scratch("eval.json")}, root_);
  ASSERT_EQ(evaluate.exit_code, 0) << Describe(evaluate);
  const Json summary = Json::parse(ReadText(Scratch("eval.json")))["summary"];
  const Json& joint = compare["modes"]["joint"]["errors"];
  for (const char* error : {"rotation_deg", "translation_mm", "tilt_deg"}) {
    for (const char* stat : {"rms", "max"}) {
      EXPECT_NEAR(joint[error][stat].get<double>(), summary[error][stat].get<double>(), 1e-9)
          << error << " " << stat;
    }
  }
}

TEST_F(CliCompareTest, WithoutGroundTruthJudgesByTheFit) {
  const RunResult r = RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("init.json"), "--json", Scratch("nogt.json"), "--quiet"},
                                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_EQ(r.out.find("error vs gt"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("no ground truth"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("RMS off-floor pair residual"), std::string::npos) << r.out;
  const Json compare = Json::parse(ReadText(Scratch("nogt.json")));
  EXPECT_TRUE(compare["ground_truth"].is_null());
  EXPECT_TRUE(compare["modes"]["joint"]["errors"].is_null());
}

TEST_F(CliCompareTest, JsonOntoAnInputIsRefused) {
  // A copy of init.json: the rig is shared, read only.
  const std::string init = Scratch("init.json");
  fs::copy_file(Rig("init.json"), init);
  const RunResult r = RunRigfit(
      {"compare", "--capture", Rig("capture.h5"), "--extrinsics", init, "--json", init}, root_);
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("input file"), std::string::npos) << r.err;
  EXPECT_EQ(ReadText(init), ReadText(Rig("init.json")));
}

TEST_F(CliCompareTest, MissingGroundTruthCameraIsBadInput) {
  const Json gt = Json::parse(ReadText(Rig("gt.json")));
  Json partial = Json::object();
  partial[gt.begin().key()] = gt.begin().value();
  std::ofstream(Scratch("partial_gt.json")) << partial.dump();
  const RunResult r = RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("init.json"), "--gt", Scratch("partial_gt.json")},
                                root_);
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("partial_gt.json has no pose for camera"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace rigfit
