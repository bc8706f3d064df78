// End-to-end tests of `rigfit evaluate`: the built executable (RIGFIT_CLI_PATH) runs as a
// subprocess on extrinsics files written here with known errors, and the tests check its
// table, its JSON output and its exit codes. Also SigmaOf (core/evaluate.h), whose numbers
// `rigfit refine` reports.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

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

/// Errors of exactly equal relative poses are round-off: far below what the table prints.
constexpr double kRoundOff = 1e-9;

/// The whitespace-separated cells of the first table row of `text` that starts with `label`
/// followed by two spaces, without the label; empty if there is none.
std::vector<std::string> RowCells(const std::string& text, const std::string& label) {
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(label + "  ", 0) != 0) continue;
    std::istringstream cells(line.substr(label.size()));
    std::vector<std::string> row;
    for (std::string cell; cells >> cell;) row.push_back(cell);
    return row;
  }
  return {};
}

/// Four cameras about 2 m above the floor, looking down and inwards at different yaws.
PoseMap TrueRig() {
  const std::vector<std::pair<std::string, Vec3>> centres = {{"31000000", {1.7, 2.5, -1.6}},
                                                             {"31001117", {1.9, 1.9, 1.3}},
                                                             {"31002234", {-0.9, 2.0, 1.9}},
                                                             {"31003351", {-2.2, 2.4, -0.8}}};
  PoseMap rig;
  double yaw_deg = 20.0;
  for (const auto& [serial, centre] : centres) {
    // Camera z forward, pitched 35 deg down below the horizon, then yawed about world +Y.
    const Mat3 R = ExpSO3(Vec3(0.0, yaw_deg * kDegToRad, 0.0)) *
                   ExpSO3(Vec3((180.0 - 35.0) * kDegToRad, 0.0, 0.0));
    Pose T = Pose::Identity();
    T.linear() = R;
    T.translation() = centre;
    rig[serial] = T;
    yaw_deg += 85.0;
  }
  return rig;
}

/// `motion` * T for every pose: the whole rig moved rigidly.
PoseMap Moved(const PoseMap& rig, const Pose& motion) {
  PoseMap moved;
  for (const auto& [serial, T] : rig) moved[serial] = motion * T;
  return moved;
}

class CliEvaluateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("rigfit_cli_evaluate_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    WriteExtrinsics(Gt(), TrueRig());
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Gt() const { return (dir_ / "gt.json").string(); }
  std::string Est() const { return (dir_ / "est.json").string(); }
  std::string Report() const { return (dir_ / "report.json").string(); }

  /// Writes `est` and evaluates it against the true rig, with a JSON report.
  RunResult Evaluate(const PoseMap& est) const {
    WriteExtrinsics(Est(), est);
    return RunRigfit({"evaluate", Est(), Gt(), "--json", Report()}, dir_);
  }

  /// Expects exit code 2 with `message` on stderr, and no report written.
  void ExpectBadInput(const RunResult& r, const std::string& message) const {
    EXPECT_EQ(r.exit_code, 2) << Describe(r);
    EXPECT_NE(r.err.find(message), std::string::npos) << Describe(r);
    EXPECT_FALSE(fs::exists(Report()));
  }

  /// Every error in the report is below `tolerance` (degrees and millimetres).
  void ExpectAllZero(const Json& report, double tolerance) const {
    for (const Json& pair : report["pairs"]) {
      EXPECT_LT(pair["rotation_deg"].get<double>(), tolerance) << pair.dump();
      EXPECT_LT(pair["translation_mm"].get<double>(), tolerance) << pair.dump();
    }
    for (const Json& camera : report["cameras"]) {
      EXPECT_LT(camera["tilt_deg"].get<double>(), tolerance) << camera.dump();
    }
    for (const char* metric : {"rotation_deg", "translation_mm", "tilt_deg"}) {
      EXPECT_LT(report["summary"][metric]["rms"].get<double>(), tolerance) << metric;
      EXPECT_LT(report["summary"][metric]["max"].get<double>(), tolerance) << metric;
    }
  }

  fs::path dir_;
};

TEST_F(CliEvaluateTest, IdenticalFilesHaveNoError) {
  const RunResult r = RunRigfit({"evaluate", Gt(), Gt(), "--json", Report()}, dir_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const Json report = Json::parse(ReadText(Report()));
  ASSERT_EQ(report["pairs"].size(), 6u);
  ASSERT_EQ(report["cameras"].size(), 4u);
  ExpectAllZero(report, kRoundOff);
  EXPECT_EQ(RowCells(r.out, "RMS"), (std::vector<std::string>{"0.000", "0.00"})) << r.out;
  EXPECT_EQ(RowCells(r.out, "31000000 - 31001117"), (std::vector<std::string>{"0.000", "0.00"}))
      << r.out;
}

TEST_F(CliEvaluateTest, OneCameraMovedTenMillimetresShowsInItsPairs) {
  const std::string moved = "31002234";
  PoseMap est = TrueRig();
  est[moved].translation() += Vec3(0.010, 0.0, 0.0);
  const RunResult r = Evaluate(est);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);

  // A pure translation d of camera j changes the error of T_i^-1 T_j by R_i^T d (and of
  // T_j^-1 T_k by -R_j^T d): |d| = 10 mm in every pair of the moved camera, 0 elsewhere.
  const Json report = Json::parse(ReadText(Report()));
  ASSERT_EQ(report["pairs"].size(), 6u);
  for (const Json& pair : report["pairs"]) {
    const bool involved = pair["serial_i"] == moved || pair["serial_j"] == moved;
    EXPECT_NEAR(pair["translation_mm"].get<double>(), involved ? 10.0 : 0.0, kRoundOff)
        << pair.dump();
    EXPECT_NEAR(pair["rotation_deg"].get<double>(), 0.0, kRoundOff) << pair.dump();
    const std::string label =
        pair["serial_i"].get<std::string>() + " - " + pair["serial_j"].get<std::string>();
    EXPECT_EQ(RowCells(r.out, label),
              (std::vector<std::string>{"0.000", involved ? "10.00" : "0.00"}))
        << r.out;
  }
  // 3 of the 6 pairs hold the moved camera: RMS = sqrt(3 * 10^2 / 6) mm.
  EXPECT_NEAR(report["summary"]["translation_mm"]["rms"].get<double>(), std::sqrt(50.0), kRoundOff);
  EXPECT_NEAR(report["summary"]["translation_mm"]["max"].get<double>(), 10.0, kRoundOff);
  EXPECT_EQ(RowCells(r.out, "max"), (std::vector<std::string>{"0.000", "10.00"})) << r.out;
  EXPECT_NEAR(report["summary"]["tilt_deg"]["max"].get<double>(), 0.0, kRoundOff);
}

TEST_F(CliEvaluateTest, YawAndShiftOfTheWholeRigIsNoError) {
  // The gauge of a leveled rig: a yaw about world +Y and any translation.
  Pose motion = Pose::Identity();
  motion.linear() = ExpSO3(Vec3(0.0, 30.0 * kDegToRad, 0.0));
  motion.translation() = Vec3(1.0, 0.5, -2.0);
  const RunResult r = Evaluate(Moved(TrueRig(), motion));
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  ExpectAllZero(Json::parse(ReadText(Report())), kRoundOff);
}

TEST_F(CliEvaluateTest, TiltOfTheWholeRigIsATiltErrorOnly) {
  // Relative poses do not see a rigid motion; the tilt error does see a tilt of the rig.
  const double tilt_deg = 5.0;
  Pose motion = Pose::Identity();
  motion.linear() = ExpSO3(Vec3(tilt_deg * kDegToRad, 0.0, 0.0));
  const RunResult r = Evaluate(Moved(TrueRig(), motion));
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const Json report = Json::parse(ReadText(Report()));
  for (const Json& pair : report["pairs"]) {
    EXPECT_LT(pair["rotation_deg"].get<double>(), kRoundOff) << pair.dump();
    EXPECT_LT(pair["translation_mm"].get<double>(), kRoundOff) << pair.dump();
  }
  for (const Json& camera : report["cameras"]) {
    EXPECT_NEAR(camera["tilt_deg"].get<double>(), tilt_deg, kRoundOff) << camera.dump();
  }
}

TEST_F(CliEvaluateTest, CameraMissingFromTheEstimateIsBadInput) {
  PoseMap est = TrueRig();
  est.erase("31001117");
  ExpectBadInput(Evaluate(est), "no pose for camera(s) 31001117");
}

TEST_F(CliEvaluateTest, ExtraCameraInTheEstimateIsIgnoredWithANote) {
  PoseMap est = TrueRig();
  est["99999999"] = Pose::Identity();
  const RunResult r = Evaluate(est);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.err.find("99999999"), std::string::npos) << Describe(r);
  const Json report = Json::parse(ReadText(Report()));
  EXPECT_EQ(report["ignored_cameras"], Json::array({"99999999"}));
  EXPECT_EQ(report["pairs"].size(), 6u);
  ExpectAllZero(report, kRoundOff);
}

TEST_F(CliEvaluateTest, MalformedFileIsBadInput) {
  std::ofstream(Est()) << "{\"31000000\": {\"T_world_camera\": [[1, 0, 0, 0],";
  ExpectBadInput(RunRigfit({"evaluate", Est(), Gt(), "--json", Report()}, dir_), Est());
}

TEST_F(CliEvaluateTest, MissingFileIsBadInput) {
  const std::string none = (dir_ / "none.json").string();
  ExpectBadInput(RunRigfit({"evaluate", Gt(), none, "--json", Report()}, dir_), none);
}

TEST_F(CliEvaluateTest, JsonOntoAnInputIsRefused) {
  const std::string before = ReadText(Gt());
  const RunResult r = RunRigfit({"evaluate", Gt(), Gt(), "--json", Gt()}, dir_);
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("it is an input file"), std::string::npos) << Describe(r);
  EXPECT_EQ(ReadText(Gt()), before);
}

TEST(SigmaOfTest, ReadsDegreesAndMillimetresOffTheTangentCovariance) {
  constexpr double kTolerance = 1e-12;
  // Tangent [wx, wy, wz, dx, dy, dz]: standard deviations 0.3, 0.2, 0.4 deg and 1, 2, 3 mm,
  // with correlations that SigmaOf must ignore.
  const Vec6 sd =
      (Vec6() << 0.3 * kDegToRad, 0.2 * kDegToRad, 0.4 * kDegToRad, 1e-3, 2e-3, 3e-3).finished();
  Mat6 C = sd.asDiagonal() * Mat6::Constant(0.5) * sd.asDiagonal();
  C.diagonal() = sd.cwiseAbs2();
  const PoseSigma s = SigmaOf(C);
  EXPECT_NEAR(s.yaw_deg, 0.2, kTolerance);
  EXPECT_NEAR(s.tilt_deg, 0.5, kTolerance);  // sqrt(0.3^2 + 0.4^2)
  EXPECT_NEAR(s.x_mm, 1.0, kTolerance);
  EXPECT_NEAR(s.y_mm, 2.0, kTolerance);
  EXPECT_NEAR(s.z_mm, 3.0, kTolerance);
}

}  // namespace
}  // namespace rigfit
