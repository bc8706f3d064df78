// End-to-end tests of `rigfit import-ply`: the built executable (RIGFIT_CLI_PATH) imports PLY
// clouds written here into a rig capture (points layout), which must read back as the clouds;
// bad arguments give exit code 2, a one-line message naming the argument or file, and no
// output; and `rigfit refine` on an imported capture (points cameras, ground leveling
// included) recovers a known perturbation of a simulated rig.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/evaluate.h"
#include "io/capture_h5.h"
#include "io/extrinsics_json.h"
#include "io/ply.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using namespace cli_test;  // NOLINT: RunRigfit and friends
using ::testing::HasSubstr;
using ::testing::Not;

/// Coordinates are stored as float32: relative round-off 6e-8, 2e-7 m at a few metres.
constexpr double kFloat32Tolerance = 1e-6;

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

/// A small cloud: a tilted grid, with normals when asked.
PlyCloud Grid(int n, double offset, bool with_normals) {
  PlyCloud cloud;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      cloud.points.emplace_back(offset + 0.01 * i, -0.5 + 0.013 * j, 2.0 + 0.002 * (i - j));
      if (with_normals) cloud.normals.push_back(Vec3(0.2, -0.2, -1.0).normalized());
    }
  }
  return cloud;
}

class CliImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("rigfit_cli_import_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Out() const { return Path("capture.h5"); }

  /// Expects exit code 2, one line on stderr containing `message`, and no capture written.
  void ExpectBadInput(const RunResult& r, const std::string& message) const {
    EXPECT_EQ(r.exit_code, 2) << Describe(r);
    EXPECT_THAT(r.err, HasSubstr(message)) << Describe(r);
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << Describe(r);
    EXPECT_FALSE(fs::exists(Out()));
  }

  fs::path dir_;
};

void ExpectNear(const PointCloud& got, const PointCloud& want) {
  ASSERT_EQ(got.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_LT((got[i] - want[i]).norm(), kFloat32Tolerance) << "point " << i;
  }
}

TEST_F(CliImportTest, RoundTripGivesTheCloudsInSerialOrder) {
  const PlyCloud b = Grid(7, 0.0, true);
  const PlyCloud a = Grid(5, 1.0, false);
  WritePly(Path("b.ply"), b);
  WritePly(Path("a.ply"), a);
  const RunResult r = RunRigfit(
      {"import-ply", "--out", Out(), "scanB=" + Path("b.ply"), "scanA=" + Path("a.ply")}, dir_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_THAT(r.out, HasSubstr("wrote 2 cameras"));

  const RigCapture capture = ReadCapture(Out());
  ASSERT_EQ(capture.cameras.size(), 2u);
  const CameraCapture& first = capture.cameras[0];
  const CameraCapture& second = capture.cameras[1];
  EXPECT_EQ(first.serial, "scanA");
  EXPECT_EQ(second.serial, "scanB");
  EXPECT_FALSE(first.HasDepth());
  ExpectNear(first.points, a.points);
  EXPECT_TRUE(first.normals.empty());
  ExpectNear(second.points, b.points);
  ExpectNear(second.normals, b.normals);
}

TEST_F(CliImportTest, BadSerialsAreRefused) {
  WritePly(Path("a.ply"), Grid(3, 0.0, false));
  const std::string a = Path("a.ply");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "=" + a}, dir_), "empty serial");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "x/y=" + a}, dir_),
                 "serial 'x/y' contains '/'");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), a}, dir_), "expected SERIAL=cloud.ply");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "s1=" + a, "s1=" + a}, dir_),
                 "serial 's1' given twice");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "s1="}, dir_), "empty file name");
}

TEST_F(CliImportTest, MissingOrBrokenFileIsNamed) {
  WritePly(Path("a.ply"), Grid(3, 0.0, false));
  const std::string missing = Path("missing.ply");
  ExpectBadInput(
      RunRigfit({"import-ply", "--out", Out(), "s1=" + Path("a.ply"), "s2=" + missing}, dir_),
      missing);
  const std::string broken = Path("broken.ply");
  WriteText(broken,
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nend_header\n1\n2\n");
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "s1=" + broken}, dir_), broken);
  const std::string empty = Path("empty.ply");
  WritePly(empty, PlyCloud{});
  ExpectBadInput(RunRigfit({"import-ply", "--out", Out(), "s1=" + empty}, dir_),
                 empty + ": no points");
}

TEST_F(CliImportTest, CloudsInMillimetresAreRefused) {
  // A cloud in millimetres: its points lie kilometres away, which no capture may hold.
  PlyCloud millimetres = Grid(3, 0.0, false);
  for (Vec3& p : millimetres.points) p *= 1000.0;
  WritePly(Path("mm.ply"), millimetres);
  WritePly(Path("a.ply"), Grid(3, 0.0, false));
  ExpectBadInput(
      RunRigfit({"import-ply", "--out", Out(), "s1=" + Path("a.ply"), "s2=" + Path("mm.ply")},
                dir_),
      "camera s2: points: row 0 has length 2061.55, beyond 1000 m from the camera");
}

TEST_F(CliImportTest, ExistingOutputIsReplacedOnlyWithForce) {
  WritePly(Path("a.ply"), Grid(3, 0.0, false));
  WriteText(Out(), "previous");
  const std::vector<std::string> args = {"import-ply", "--out", Out(), "s1=" + Path("a.ply")};
  const RunResult refused = RunRigfit(args, dir_);
  EXPECT_EQ(refused.exit_code, 2) << Describe(refused);
  EXPECT_THAT(refused.err, HasSubstr("use --force"));
  EXPECT_EQ(ReadText(Out()), "previous");

  std::vector<std::string> forced = args;
  forced.push_back("--force");
  const RunResult replaced = RunRigfit(forced, dir_);
  ASSERT_EQ(replaced.exit_code, 0) << Describe(replaced);
  EXPECT_EQ(ReadCapture(Out()).cameras.size(), 1u);

  // An input is never replaced, --force or not.
  const RunResult input =
      RunRigfit({"import-ply", "--force", "--out", Path("a.ply"), "s1=" + Path("a.ply")}, dir_);
  EXPECT_EQ(input.exit_code, 2) << Describe(input);
  EXPECT_THAT(input.err, HasSubstr("it is an input file"));
  EXPECT_EQ(ReadPly(Path("a.ply")).points.size(), 9u);
}

// A noise-free simulated rig whose depth images are turned into camera-frame clouds: refine
// of the imported capture (points cameras: leveling and joint registration) must land as
// close to the truth as the noise-free depth rig does (docs/benchmarks.md: 0.11 mm, 0.002 deg
// for 4 cameras at 640x360; bounds here leave room for the smaller images).
TEST_F(CliImportTest, RefineOnImportedCloudsRecoversThePerturbation) {
  constexpr double kMaxRotationDeg = 0.02;
  constexpr double kMaxTranslationMm = 1.0;
  SimOptions sim;
  sim.cameras = 3;
  sim.width = 320;
  sim.height = 180;
  sim.noise = 0.0;
  const SimulatedRig rig = SimulateRig(sim);
  std::vector<std::string> args = {"import-ply", "--out", Out()};
  for (const CameraCapture& camera : rig.capture.cameras) {
    PlyCloud cloud;
    cloud.points = CameraPoints(camera, UnprojectOptions{});
    const std::string ply = Path(camera.serial + ".ply");
    WritePly(ply, cloud);
    args.push_back(camera.serial + "=" + ply);
  }
  const RunResult imported = RunRigfit(args, dir_);
  ASSERT_EQ(imported.exit_code, 0) << Describe(imported);
  WriteExtrinsics(Path("init.json"), rig.init);

  const RunResult refined = RunRigfit({"refine", "--capture", Out(), "--extrinsics",
                                       Path("init.json"), "--out", Path("out.json"), "--quiet"},
                                      dir_);
  ASSERT_EQ(refined.exit_code, 0) << Describe(refined);
  EXPECT_THAT(refined.err, Not(HasSubstr("warning"))) << Describe(refined);
  const RigErrors before = EvaluateRig(rig.init, rig.gt);
  const RigErrors after = EvaluateRig(ReadExtrinsics(Path("out.json")).poses, rig.gt);
  EXPECT_GT(before.max_translation_m * 1e3, 20.0 * kMaxTranslationMm);
  EXPECT_LT(after.max_rotation_rad * kRadToDeg, kMaxRotationDeg);
  EXPECT_LT(after.max_translation_m * 1e3, kMaxTranslationMm);
  EXPECT_LT(after.max_tilt_rad * kRadToDeg, kMaxRotationDeg);
}

}  // namespace
}  // namespace rigfit
