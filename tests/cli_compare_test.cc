// End-to-end tests of `rigfit compare`: the built executable (RIGFIT_CLI_PATH) on a small
// rig written by `rigfit simulate`. Three runs (pairwise, joint, surface_bundle); the joint
// errors must be those `rigfit evaluate` gives for the output of `rigfit refine` (joint is
// the default mode) on the same input.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iterator>
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

/// The runs of `rigfit compare`, in the order it prints them.
const char* const kRuns[] = {"pairwise", "joint", "surface_bundle"};

TEST_F(CliCompareTest, ThreeRunsSideBySideAndTheDefaultAgreesWithEvaluate) {
  const RunResult r =
      RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics", Rig("init.json"),
                 "--gt", Rig("gt.json"), "--json", Scratch("compare.json"), "--quiet"},
                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  for (const char* text :
       {"pairwise", "joint", "surface_bundle", "change", "error vs gt", "joint 1-sigma",
        "plane thickness (sigma)", "surface bundle: ", "all pairs", "peak RSS MB",
        "verdict: ", "pairwise (pairwise ICP + pose graph, point_to_plane)"}) {
    EXPECT_NE(r.out.find(text), std::string::npos) << text << "\n" << r.out;
  }
  // The errors table has a row per run.
  for (const char* run : kRuns) {
    EXPECT_NE(
        r.out.find("\n" + std::string(run) + std::string(36 - std::string(run).size(), ' ') + "|"),
        std::string::npos)
        << run << "\n"
        << r.out;
  }
  const Json compare = Json::parse(ReadText(Scratch("compare.json")));
  EXPECT_EQ(compare["runs"], Json(std::vector<std::string>(std::begin(kRuns), std::end(kRuns))));
  EXPECT_EQ(compare["modes"].size(), 3u);
  EXPECT_EQ(compare["method"], "point_to_plane");
  for (const char* run : kRuns) {
    SCOPED_TRACE(run);
    const Json& m = compare["modes"][run];
    EXPECT_EQ(m["success"], true) << m["message"];
    EXPECT_EQ(m["mode"], run == std::string("pairwise") ? "pairwise" : "joint");
    EXPECT_EQ(m["method"], "point_to_plane");
    EXPECT_EQ(m["surface_bundle"], run == std::string("surface_bundle"));
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
  // The surface bundle reports its planes and every camera's plane thickness before and after
  // (in sigmas of the noise model); the other runs do not.
  const Json& bundle = compare["modes"]["surface_bundle"];
  EXPECT_EQ(bundle["surface"]["ran"], true);
  EXPECT_GT(bundle["surface"]["planes"].get<int>(), 0);
  for (const auto& [serial, camera] : bundle["cameras"].items()) {
    SCOPED_TRACE(serial);
    ASSERT_TRUE(camera.contains("surface"));
    EXPECT_GT(camera["surface"]["thickness_before"].get<double>(), 0.0);
    EXPECT_GT(camera["surface"]["thickness_after"].get<double>(), 0.0);
    EXPECT_TRUE(camera["surface"]["fallback"].is_boolean());
    char cell[64];
    std::snprintf(cell, sizeof(cell), "%.2f -> %.2f",
                  camera["surface"]["thickness_before"].get<double>(),
                  camera["surface"]["thickness_after"].get<double>());
    EXPECT_NE(r.out.find(cell), std::string::npos) << cell << "\n" << r.out;
  }
  EXPECT_FALSE(compare["modes"]["joint"].contains("surface"));
  EXPECT_FALSE(compare["modes"]["joint"]["cameras"].begin()->contains("surface"));

  // `rigfit refine` with its defaults (joint, then the surface bundle) + `rigfit evaluate` on
  // its output give the surface_bundle run's errors.
  const RunResult refine =
      RunRigfit({"refine", "--capture", Rig("capture.h5"), "--extrinsics", Rig("init.json"),
                 "--out", Scratch("default.json"), "--quiet"},
                root_);
  ASSERT_EQ(refine.exit_code, 0) << Describe(refine);
  const RunResult evaluate = RunRigfit(
      {"evaluate", Scratch("default.json"), Rig("gt.json"), "--json", Scratch("eval.json")}, root_);
  ASSERT_EQ(evaluate.exit_code, 0) << Describe(evaluate);
  const Json summary = Json::parse(ReadText(Scratch("eval.json")))["summary"];
  const Json& joint = compare["modes"]["surface_bundle"]["errors"];
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
  for (const char* run : kRuns) EXPECT_TRUE(compare["modes"][run]["errors"].is_null()) << run;
}

// --report writes the page with the printed comparison and the 3-D view with one pose set a
// run, after the initial and the leveled poses; a report inside a missing folder is bad input.
TEST_F(CliCompareTest, ReportHoldsTheComparisonAndA3dViewOfEveryRun) {
  const std::string dir = Scratch("report");
  const RunResult r = RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("init.json"), "--report", dir, "--quiet"},
                                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.out.find("report: " + dir + "/index.html"), std::string::npos) << r.out;
  EXPECT_NE(ReadText(dir + "/index.html").find("view3d.html"), std::string::npos);
  const std::string data = ReadText(dir + "/view3d_data.js");
  for (const char* set :
       {"\"initial\"", "\"before (leveled)\"", "\"pairwise\"", "\"joint\"", "\"surface_bundle\""}) {
    EXPECT_NE(data.find(set), std::string::npos) << set;
  }
  const RunResult bad = RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics",
                                   Rig("init.json"), "--report", Scratch("no/such/dir")},
                                  root_);
  EXPECT_EQ(bad.exit_code, 2) << Describe(bad);
  EXPECT_NE(bad.err.find("--report"), std::string::npos) << bad.err;
}

TEST_F(CliCompareTest, TheRunsSetTheSurfaceBundleWhateverTheConfigSays) {
  // The surface bundle was once icp.method surface_bundle: such a config is refused, saying where
  // it went.
  std::ofstream(Scratch("old.yaml")) << "icp:\n  method: surface_bundle\n";
  const RunResult old = RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics",
                                   Rig("init.json"), "--config", Scratch("old.yaml"), "--quiet"},
                                  root_);
  EXPECT_EQ(old.exit_code, 2) << Describe(old);
  EXPECT_NE(old.err.find("set icp.surface_bundle: true"), std::string::npos) << old.err;
  // icp.surface_bundle on: the pairwise and joint runs still run without it.
  std::ofstream(Scratch("surface.yaml")) << "icp:\n  surface_bundle: true\n";
  const RunResult r =
      RunRigfit({"compare", "--capture", Rig("capture.h5"), "--extrinsics", Rig("init.json"),
                 "--config", Scratch("surface.yaml"), "--json", Scratch("surface.json"), "--quiet"},
                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.out.find("joint (joint registration, point_to_plane)"), std::string::npos) << r.out;
  const Json compare = Json::parse(ReadText(Scratch("surface.json")));
  EXPECT_EQ(compare["method"], "point_to_plane");
  EXPECT_EQ(compare["config"], Scratch("surface.yaml"));
  for (const char* run : kRuns) {
    EXPECT_EQ(compare["modes"][run]["success"], true) << run << compare["modes"][run]["message"];
  }
  for (const char* run : kRuns) {
    EXPECT_EQ(compare["modes"][run]["method"], "point_to_plane") << run;
    EXPECT_EQ(compare["modes"][run]["surface_bundle"], run == std::string("surface_bundle")) << run;
  }
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
