// End-to-end tests of `rigfit refine`: the built executable (RIGFIT_CLI_PATH) runs as a
// subprocess on a small rig written by `rigfit simulate`, and the tests check its exit codes,
// its output file and what it leaves untouched.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/evaluate.h"
#include "io/extrinsics_json.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using namespace cli_test;  // NOLINT: RunRigfit and friends

constexpr int kCameras = 3;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

Json ReadJson(const fs::path& path) { return Json::parse(ReadText(path)); }

void WriteJson(const fs::path& path, const Json& json) { WriteText(path, json.dump(2)); }

double MaxTiltErrorDeg(const PoseMap& est, const PoseMap& gt) {
  double worst = 0.0;
  for (const auto& [serial, T] : gt) {
    worst = std::max(worst, TiltErrorRad(est.at(serial), T) * kRadToDeg);
  }
  return worst;
}

double MaxPoseDifference(const PoseMap& a, const PoseMap& b) {
  double worst = 0.0;
  for (const auto& [serial, T] : a) {
    worst = std::max(worst, (T.matrix() - b.at(serial).matrix()).cwiseAbs().maxCoeff());
  }
  return worst;
}

class CliRefineTest : public SimulatedRigSuite<CliRefineTest> {
 protected:
  /// One small simulated rig shared by every test: 3 cameras, 320 x 180, noise-free depth (the
  /// solver's accuracy under noise is tests/refine_test.cc's job), and a perturbation small
  /// enough that the true change of every camera, reference shift included, is within the
  /// default safety bounds (icp.max_translation_m 0.2: a 4 deg yaw of the reference would
  /// already move a camera 3 m away by 0.2 m).
  static void SetUpTestSuite() {
    SimulateRig("rigfit_cli_refine_test",
                {"--cameras", std::to_string(kCameras), "--width", "320", "--height", "180",
                 "--noise", "0", "--perturb-yaw-deg", "0.5", "--perturb-xz-m", "0.02"});
  }

  void SetUp() override {
    SimulatedRigSuite::SetUp();
    dir_ = root_ / ::testing::UnitTest::GetInstance()->current_test_info()->name();
    fs::create_directories(dir_);
  }

  static std::string Capture() { return Rig("capture.h5"); }
  static std::string Init() { return Rig("init.json"); }
  static std::string Gt() { return Rig("gt.json"); }
  std::string Out() const { return (dir_ / "out.json").string(); }

  RunResult Refine(std::vector<std::string> extra) const {
    return Refine(Init(), Out(), std::move(extra));
  }
  RunResult Refine(const std::string& extrinsics, const std::string& out,
                   std::vector<std::string> extra) const {
    std::vector<std::string> args = {"refine",   "--capture", Capture(), "--extrinsics",
                                     extrinsics, "--out",     out,       "--threads",
                                     "2"};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunRigfit(args, root_);
  }

  /// Expects exit code 2, a message containing `message` and an untouched output directory.
  void ExpectBadInput(const RunResult& r, const std::string& message) const {
    EXPECT_EQ(r.exit_code, 2) << Describe(r);
    EXPECT_NE(r.err.find(message), std::string::npos) << Describe(r);
    EXPECT_FALSE(fs::exists(Out()));
    for (const auto& entry : fs::directory_iterator(dir_)) {
      ADD_FAILURE() << "unexpected file " << entry.path();
    }
  }

  /// The leveled poses: a --no-icp run into its own file.
  PoseMap LeveledPoses() const {
    const std::string out = (dir_ / "leveled.json").string();
    const RunResult r = Refine(Init(), out, {"--no-icp"});
    EXPECT_EQ(r.exit_code, 0) << Describe(r);
    return ReadExtrinsics(out).poses;
  }

  fs::path dir_;
};

TEST_F(CliRefineTest, RefinesTheRigAndPreservesUnknownKeys) {
  Json init = ReadJson(Init());
  const std::string first = init.begin().key();
  init[first]["model"] = "ZED 2i";
  init["_meta"]["site"] = "lab 3";
  const std::string extrinsics = (dir_ / "init.json").string();
  WriteJson(extrinsics, init);

  const RunResult r = Refine(extrinsics, Out(), {});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const Json out = ReadJson(Out());
  const PoseMap gt = ReadExtrinsics(Gt()).poses;
  const PoseMap refined = ReadExtrinsics(Out()).poses;
  ASSERT_EQ(refined.size(), gt.size());
  for (const auto& [serial, T] : gt) EXPECT_EQ(refined.count(serial), 1u) << serial;
  EXPECT_EQ(out[first]["model"], "ZED 2i");
  EXPECT_EQ(out["_meta"]["site"], "lab 3");
  EXPECT_TRUE(out["_meta"].contains("simulated"));  // written by simulate, kept

  const Json& icp = out["_meta"]["icp_refined"];
  EXPECT_EQ(icp["success"], true) << icp["message"];
  EXPECT_EQ(icp["skipped"], false);
  EXPECT_EQ(icp["reference"], first);
  EXPECT_EQ(icp["config"]["icp"]["voxel_size"], 0.02);
  EXPECT_EQ(icp["mode"], "joint");
  EXPECT_EQ(icp["method"], "point_to_plane");
  EXPECT_EQ(icp["cameras"].size(), static_cast<size_t>(kCameras));
  EXPECT_FALSE(icp["pairs"].empty());
  // Every camera reports its change against the rig; the joint covariance gives a 1-sigma
  // uncertainty to every connected camera but the reference (whose pose fixes the gauge).
  int with_sigma = 0;
  for (const auto& [serial, camera] : icp["cameras"].items()) {
    EXPECT_GE(camera["own_rotation_deg"].get<double>(), 0.0) << serial;
    EXPECT_GE(camera["own_translation_m"].get<double>(), 0.0) << serial;
    const bool expect_sigma = camera["connected"] == true && camera["reference"] == false;
    ASSERT_EQ(camera.contains("sigma"), expect_sigma) << serial << ": " << camera.dump();
    if (!expect_sigma) continue;
    ++with_sigma;
    for (const char* key : {"yaw_deg", "tilt_deg", "x_mm", "y_mm", "z_mm"}) {
      ASSERT_TRUE(camera["sigma"][key].is_number()) << serial << " " << key;
      const double sigma = camera["sigma"][key].get<double>();
      EXPECT_TRUE(std::isfinite(sigma) && sigma > 0.0) << serial << " " << key << " " << sigma;
    }
  }
  EXPECT_GT(with_sigma, 0);
  for (const char* stage :
       {"load", "leveling", "preprocessing", "registration", "pose_graph", "output", "total"}) {
    EXPECT_TRUE(icp["timings_s"].contains(stage)) << stage;
  }
  EXPECT_EQ(out["_meta"]["ground_refined"]["cameras"].size(), static_cast<size_t>(kCameras));
  EXPECT_TRUE(AllNumbersFinite(out));

  // End to end, the noise-free rig ends near the truth: measured worst pair 0.0047 deg and
  // 0.133 mm (from 0.93 deg and 39.3 mm at the start); the bounds leave a factor of 2.
  const RigErrors after = EvaluateRig(refined, gt);
  EXPECT_LT(after.max_rotation_rad * kRadToDeg, 0.01);
  EXPECT_LT(after.max_translation_m, 0.27e-3);
  EXPECT_NE(r.out.find("refined "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find(Out()), std::string::npos) << r.out;
}

TEST_F(CliRefineTest, TheReferenceIsHeldOrLeveledOnTheBundlesFloor) {
  // Without the surface bundle the reference is held at its leveled pose; the bundle (the
  // default) levels it again on its floor (yaw and centre held), and the summary says which.
  const PoseMap leveled = LeveledPoses();
  const std::string reference = leveled.begin()->first;  // the first serial
  const RunResult held = Refine({"--no-surface-bundle"});
  ASSERT_EQ(held.exit_code, 0) << Describe(held);
  EXPECT_NE(held.out.find("reference (held fixed)"), std::string::npos) << held.out;
  EXPECT_EQ(ReadExtrinsics(Out()).poses.at(reference).matrix(), leveled.at(reference).matrix());

  const RunResult bundle = Refine({});
  ASSERT_EQ(bundle.exit_code, 0) << Describe(bundle);
  EXPECT_NE(bundle.out.find("reference (yaw and centre held, tilt from the floor)"),
            std::string::npos)
      << bundle.out;
  const Pose moved = ReadExtrinsics(Out()).poses.at(reference);
  EXPECT_LT((moved.translation() - leveled.at(reference).translation()).norm(), 1e-9);
}

TEST_F(CliRefineTest, NoTimingsMakesTheOutputByteIdentical) {
  const std::string second = (dir_ / "second.json").string();
  const RunResult a = Refine(Init(), Out(), {"--no-timings", "--quiet"});
  const RunResult b = Refine(Init(), second, {"--no-timings", "--quiet"});
  ASSERT_EQ(a.exit_code, b.exit_code) << Describe(a) << Describe(b);
  const std::string text = ReadText(Out());
  EXPECT_FALSE(text.empty());
  EXPECT_EQ(text, ReadText(second));
  EXPECT_FALSE(ReadJson(Out())["_meta"]["icp_refined"].contains("timings_s"));
}

TEST_F(CliRefineTest, NoIcpLevelsTheFloor) {
  const RunResult r = Refine({"--no-icp"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const Json out = ReadJson(Out());
  const Json& icp = out["_meta"]["icp_refined"];
  EXPECT_EQ(icp["skipped"], true);
  EXPECT_EQ(icp["success"], true);
  // Registration did not run: no mode or method ran, although the config names both.
  EXPECT_TRUE(icp["mode"].is_null()) << icp["mode"];
  EXPECT_TRUE(icp["method"].is_null()) << icp["method"];
  EXPECT_EQ(icp["config"]["icp"]["mode"], "joint");
  const PoseMap init = ReadExtrinsics(Init()).poses;
  const PoseMap leveled = ReadExtrinsics(Out()).poses;
  const PoseMap gt = ReadExtrinsics(Gt()).poses;
  EXPECT_GT(MaxPoseDifference(leveled, init), 1e-6);
  // Noise-free floors level every camera: measured worst tilt 2.3e-5 deg (0.26 deg at the
  // start); the bound leaves a factor of 2.
  EXPECT_LT(MaxTiltErrorDeg(leveled, gt), 5e-5);

  // The floor found in each camera frame lies on y = 0, normal +Y, at the written pose.
  const double kFloorTolerance = 1e-9;
  for (const auto& [serial, ground] : out["_meta"]["ground_refined"]["cameras"].items()) {
    ASSERT_EQ(ground["accepted"], true) << serial << ": " << ground["message"];
    const Json& plane = ground["plane_camera"];
    const Pose& T = leveled.at(serial);
    const Vec3 normal_world = T.linear() * Vec3(plane[0], plane[1], plane[2]);
    const double d_world = plane[3].get<double>() - normal_world.dot(T.translation());
    EXPECT_NEAR(std::abs(normal_world.y()), 1.0, kFloorTolerance) << serial;
    EXPECT_NEAR(d_world, 0.0, kFloorTolerance) << serial;
  }
}

TEST_F(CliRefineTest, NoGroundNoIcpWritesTheInputPoses) {
  const RunResult r = Refine({"--no-ground", "--no-icp"});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const Json out = ReadJson(Out());
  const Json init = ReadJson(Init());
  for (const auto& [serial, camera] : init.items()) {
    if (serial != "_meta") {
      EXPECT_EQ(out[serial]["T_world_camera"], camera["T_world_camera"]) << serial;
    }
  }
  EXPECT_EQ(out["_meta"]["ground_refined"]["skipped"], true);
  EXPECT_EQ(out["_meta"]["icp_refined"]["skipped"], true);
}

TEST_F(CliRefineTest, AllPairsFailingExitsThreeWithTheLeveledPoses) {
  const fs::path config = dir_.parent_path() / "strict_fitness.yaml";
  WriteText(config, "icp:\n  mode: pairwise\n  min_fitness: 1.0\n");
  const PoseMap leveled = LeveledPoses();
  fs::remove(dir_ / "leveled.json");

  const RunResult r = Refine({"--config", config.string()});
  ASSERT_EQ(r.exit_code, 3) << Describe(r);
  EXPECT_EQ(MaxPoseDifference(ReadExtrinsics(Out()).poses, leveled), 0.0);
  const Json out = ReadJson(Out());
  const Json& icp = out["_meta"]["icp_refined"];
  EXPECT_EQ(icp["success"], false);
  EXPECT_FALSE(icp["message"].get<std::string>().empty());
  EXPECT_EQ(icp["config"]["icp"]["min_fitness"], 1.0);
  EXPECT_EQ(icp["mode"], "pairwise");
  ASSERT_FALSE(icp["pairs"].empty());
  for (const Json& pair : icp["pairs"]) EXPECT_EQ(pair["accepted"], false) << pair.dump();
  for (const auto& [serial, camera] : icp["cameras"].items()) {
    EXPECT_FALSE(camera.contains("sigma")) << serial;  // pairwise mode has no covariance
    if (camera["reference"] == true) continue;
    EXPECT_EQ(camera["accepted"], false) << serial;
    EXPECT_FALSE(camera["message"].get<std::string>().empty()) << serial;  // says why
  }
  EXPECT_TRUE(out["_meta"].contains("ground_refined"));
  EXPECT_NE(r.out.find("refinement not applied"), std::string::npos) << r.out;
}

TEST_F(CliRefineTest, MissingCaptureIsBadInput) {
  ExpectBadInput(RunRigfit({"refine", "--capture", (dir_ / "none.h5").string(), "--extrinsics",
                            Init(), "--out", Out()},
                           root_),
                 "none.h5");
}

TEST_F(CliRefineTest, MalformedExtrinsicsIsBadInput) {
  const fs::path extrinsics = dir_.parent_path() / "malformed.json";
  WriteText(extrinsics, "{\"31000000\": {\"T_world_camera\": [[1, 0, 0, 0],");
  ExpectBadInput(Refine(extrinsics.string(), Out(), {}), "malformed JSON");
}

TEST_F(CliRefineTest, CameraMissingFromExtrinsicsIsBadInput) {
  Json init = ReadJson(Init());
  const std::string dropped = std::prev(init.end(), 2).key();  // the last camera before _meta
  init.erase(dropped);
  const fs::path extrinsics = dir_.parent_path() / "missing_camera.json";
  WriteJson(extrinsics, init);
  ExpectBadInput(Refine(extrinsics.string(), Out(), {}), "no pose for camera(s) " + dropped);
}

TEST_F(CliRefineTest, ExtraCameraInExtrinsicsIsBadInput) {
  Json init = ReadJson(Init());
  init["99999999"] = init.begin().value();
  const fs::path extrinsics = dir_.parent_path() / "extra_camera.json";
  WriteJson(extrinsics, init);
  ExpectBadInput(Refine(extrinsics.string(), Out(), {}), "camera(s) 99999999");
}

TEST_F(CliRefineTest, OutputOntoTheExtrinsicsIsRefused) {
  const fs::path extrinsics = dir_.parent_path() / "own_input.json";
  fs::copy_file(Init(), extrinsics, fs::copy_options::overwrite_existing);
  const std::string before = ReadText(extrinsics);
  const RunResult r = Refine(extrinsics.string(), extrinsics.string(), {});
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("it is an input file"), std::string::npos) << Describe(r);
  EXPECT_EQ(ReadText(extrinsics), before);
}

TEST_F(CliRefineTest, OutputDirectoryMustExist) {
  const RunResult r = Refine(Init(), (dir_ / "no_such_dir" / "out.json").string(), {});
  ExpectBadInput(r, "does not exist");
}

TEST_F(CliRefineTest, NegativeVoxelSizeIsBadInput) {
  ExpectBadInput(Refine({"--voxel-size=-0.01"}), "--voxel-size must be");
}

TEST_F(CliRefineTest, UnknownConfigKeyIsBadInput) {
  const fs::path config = dir_.parent_path() / "unknown_key.yaml";
  WriteText(config, "icp:\n  voxl_size: 0.05\n");
  ExpectBadInput(Refine({"--config", config.string()}), "voxl_size");
}

TEST_F(CliRefineTest, UnknownReferenceIsBadInput) {
  ExpectBadInput(Refine({"--reference", "12345678"}), "'12345678' is not a camera");
}

TEST_F(CliRefineTest, UnknownMethodIsAUsageError) {
  ExpectBadInput(Refine({"--method", "icp"}), "--method");
}

TEST_F(CliRefineTest, TheSurfaceBundleAsAMethodSaysWhereItWent) {
  // It was --method surface_bundle until the residual and the stage became two settings.
  ExpectBadInput(Refine({"--method", "surface_bundle"}), "--surface-bundle");
}

TEST_F(CliRefineTest, QuietAndVerboseExcludeEachOther) {
  ExpectBadInput(Refine({"--quiet", "--verbose"}), "excludes");
}

}  // namespace
}  // namespace rigfit
