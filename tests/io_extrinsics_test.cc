#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "io/extrinsics_json.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;
using Json = nlohmann::json;

class ExtrinsicsTest : public io_test::TempDirTest {
 protected:
  /// Writes text to a file and returns the message of the InputError that reading it throws.
  std::string ReadError(const std::string& text) {
    const std::string path = Path("extrinsics.json");
    io_test::WriteText(path, text);
    return io_test::InputErrorMessage([&] { ReadExtrinsics(path); });
  }
};

Pose RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  Vec6 delta;
  for (int i = 0; i < 6; ++i) delta[i] = u(rng);
  return PosePlus(Pose::Identity(), delta);
}

std::string MatrixText(const Eigen::Matrix4d& M) {
  std::string text = "[";
  for (int r = 0; r < 4; ++r) {
    text += r ? ",[" : "[";
    for (int c = 0; c < 4; ++c) text += (c ? "," : "") + Json(M(r, c)).dump();
    text += "]";
  }
  return text + "]";
}

TEST_F(ExtrinsicsTest, RoundTripIsBitExactAndPreservesUnknownKeys) {
  std::mt19937 rng(7);
  PoseMap poses = {{"31001117", RandomPose(rng)}, {"31002234", RandomPose(rng)}};
  const Json base = {
      {"31001117", {{"model", "ZED 2i"}, {"T_world_camera", PoseToJson(Pose::Identity())}}},
      {"99999999", {{"T_world_camera", PoseToJson(Pose::Identity())}, {"note", "not refined"}}},
      {"_meta", {{"site", "lab 3"}, {"ground_refined", "old"}}}};
  const Json meta = {{"ground_refined", {{"planes", 2}}}, {"icp_refined", {{"success", true}}}};
  const std::string path = Path("out.json");
  WriteExtrinsics(path, poses, base, meta);

  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  EXPECT_THAT(doc.warnings, IsEmpty());
  ASSERT_THAT(doc.poses, SizeIs(3));
  for (const auto& [serial, T] : poses) {
    EXPECT_EQ(doc.poses.at(serial).matrix(), T.matrix()) << serial;  // bit-exact
  }
  EXPECT_EQ(doc.poses.at("99999999").matrix(), Eigen::Matrix4d::Identity());
  EXPECT_EQ(doc.document["31001117"]["model"], "ZED 2i");
  EXPECT_EQ(doc.document["99999999"]["note"], "not refined");
  EXPECT_EQ(doc.document["_meta"]["site"], "lab 3");
  EXPECT_EQ(doc.document["_meta"]["ground_refined"]["planes"], 2);  // meta keys replace
  EXPECT_EQ(doc.document["_meta"]["icp_refined"]["success"], true);
  EXPECT_THAT(io_test::ReadText(path), HasSubstr("{\n  \"31001117\": {\n    "));  // indent 2
  EXPECT_THAT(Listing(), ElementsAre("out.json"));
}

TEST_F(ExtrinsicsTest, WritesWithoutBaseAndMeta) {
  const std::string path = Path("out.json");
  WriteExtrinsics(path, {{"a", Pose::Identity()}});
  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  EXPECT_EQ(doc.document, Json::parse(R"({"a": {"T_world_camera":
      [[1.0,0.0,0.0,0.0],[0.0,1.0,0.0,0.0],[0.0,0.0,1.0,0.0],[0.0,0.0,0.0,1.0]]}})"));
}

/// The extrinsics file of one camera whose rotation block is ExpSO3(0.3, -0.2, 0.1) with
/// `error` added to its entry (0, 1): ||R^T R - I|| (max norm) is then about `error`.
Eigen::Matrix4d PerturbedRotation(double error) {
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  M.topLeftCorner<3, 3>() = ExpSO3(Vec3(0.3, -0.2, 0.1));
  M(0, 1) += error;
  M(0, 3) = 1.5;
  return M;
}

double MaxDeviation(const Eigen::Matrix4d& M) {
  const Mat3 R = M.topLeftCorner<3, 3>();
  return (R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff();
}

TEST_F(ExtrinsicsTest, NearlyRigidRotationIsReorthonormalisedAndReported) {
  // 7-Scenes' pose files are orthonormal to ~3e-4: the contract accepts up to 1e-3.
  for (const double error : {3e-4, 0.999e-3}) {
    const Eigen::Matrix4d M = PerturbedRotation(error);
    ASSERT_GT(MaxDeviation(M), 1e-6);
    ASSERT_LE(MaxDeviation(M), 1e-3);
    const std::string path = Path("in.json");
    io_test::WriteText(path, "{\"cam7\": {\"T_world_camera\": " + MatrixText(M) + "}}");
    const ExtrinsicsDocument doc = ReadExtrinsics(path);
    ASSERT_THAT(doc.warnings, SizeIs(1)) << error;
    EXPECT_THAT(doc.warnings[0], HasSubstr(path + ": camera cam7: T_world_camera"));
    EXPECT_THAT(doc.warnings[0], HasSubstr("re-orthonormalised"));
    const Mat3 R = doc.poses.at("cam7").linear();
    EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-14);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-14);
    EXPECT_LT((R - M.topLeftCorner<3, 3>()).norm(), error);  // the nearest rotation
    EXPECT_EQ(doc.poses.at("cam7").translation().x(), 1.5);
  }
}

TEST_F(ExtrinsicsTest, PrintingPrecisionRotationIsProjectedSilently) {
  const Eigen::Matrix4d M = PerturbedRotation(5e-7);
  ASSERT_LT(MaxDeviation(M), 1e-6);
  ASSERT_GT(MaxDeviation(M), 1e-12);
  const std::string path = Path("in.json");
  io_test::WriteText(path, "{\"cam7\": {\"T_world_camera\": " + MatrixText(M) + "}}");
  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  EXPECT_THAT(doc.warnings, SizeIs(0));
  const Mat3 R = doc.poses.at("cam7").linear();
  EXPECT_LT((R.transpose() * R - Mat3::Identity()).norm(), 1e-14);
}

TEST_F(ExtrinsicsTest, RotationBeyondTheToleranceIsRefused) {
  const Eigen::Matrix4d M = PerturbedRotation(1.1e-3);
  ASSERT_GT(MaxDeviation(M), 1e-3);
  const std::string path = Path("in.json");
  io_test::WriteText(path, "{\"cam7\": {\"T_world_camera\": " + MatrixText(M) + "}}");
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadExtrinsics(path); }),
              AllOf(HasSubstr(path + ": camera cam7: T_world_camera: rotation block is not a "
                                     "rotation"),
                    HasSubstr("tolerance 1e-3")));
}

TEST_F(ExtrinsicsTest, RealSevenScenesPoseIsAcceptedWithAWarning) {
  const std::string pose_file =
      io_test::SharedDataPath("sevenscenes_kitchen/frames/frame-000200.pose.txt");
  std::ifstream in(pose_file);
  RIGFIT_NEED_SHARED_DATA(pose_file);
  Eigen::Matrix4d M;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) in >> M(r, c);
  }
  ASSERT_TRUE(in);
  ASSERT_GT(MaxDeviation(M), 1e-6);  // printed with limited precision
  const std::string path = Path("in.json");
  io_test::WriteText(path, "{\"frame200\": {\"T_world_camera\": " + MatrixText(M) + "}}");
  const ExtrinsicsDocument doc = ReadExtrinsics(path);
  EXPECT_THAT(doc.warnings, SizeIs(1));
  EXPECT_LT((doc.poses.at("frame200").matrix() - M).cwiseAbs().maxCoeff(), 1e-3);
}

TEST_F(ExtrinsicsTest, MalformedInputsNameFileSerialAndField) {
  const std::string path = Path("extrinsics.json");
  EXPECT_THAT(ReadError("{\"a\": {\"T_world_camera\": [[1,0,0,0],"),
              HasSubstr(path + ": malformed JSON: parse error at line 1, column"));
  EXPECT_THAT(ReadError("[1, 2]"), HasSubstr(path + ": expected a JSON object"));
  EXPECT_THAT(ReadError("{\"\": {\"T_world_camera\": []}}"), HasSubstr("empty camera serial"));
  EXPECT_THAT(ReadError("{\"cam1\": 3}"),
              HasSubstr(path + ": camera cam1: expected an object with T_world_camera"));
  EXPECT_THAT(ReadError("{\"cam1\": {\"pose\": 3}}"),
              HasSubstr(path + ": camera cam1: missing T_world_camera"));
  EXPECT_THAT(ReadError(R"({"cam1": {"T_world_camera": [[1,0,0,0],[0,1,0,0],[0,0,0,1]]}})"),
              HasSubstr(path + ": camera cam1: T_world_camera: expected a 4x4"));
  EXPECT_THAT(ReadError(R"({"cam1": {"T_world_camera": [[1,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}})"),
              HasSubstr("camera cam1: T_world_camera: row 0 is not an array of 4 numbers"));
  EXPECT_THAT(
      ReadError(R"({"cam1": {"T_world_camera": [[1,0,0,"x"],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}})"),
      HasSubstr("camera cam1: T_world_camera: entry [0][3] is not a number"));
  EXPECT_THAT(
      ReadError(R"({"cam1": {"T_world_camera": [[1,0,0,1e999],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}})"),
      HasSubstr(path + ": malformed JSON: number overflow parsing '1e999'"));
  EXPECT_THAT(
      ReadError(R"({"cam1": {"T_world_camera": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}})"),
      HasSubstr("camera cam1: T_world_camera: last row must be [0, 0, 0, 1]"));
  // Scaled by 1.01: not rigid.
  EXPECT_THAT(
      ReadError(R"({"cam1": {"T_world_camera": [[1.01,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}})"),
      HasSubstr(path + ": camera cam1: T_world_camera: rotation block is not a rotation"));
  // A reflection is orthonormal but has det -1.
  EXPECT_THAT(
      ReadError(R"({"cam1": {"T_world_camera": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}})"),
      HasSubstr("det = -1"));
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadExtrinsics(Path("missing.json")); }),
              HasSubstr(Path("missing.json") + ": cannot open"));
}

TEST_F(ExtrinsicsTest, RefusesToOverwriteAnInputAndLeavesItUnchanged) {
  const std::string input = Path("in.json");
  WriteExtrinsics(input, {{"a", Pose::Identity()}});
  const std::string before = io_test::ReadText(input);
  const ExtrinsicsDocument doc = ReadExtrinsics(input);
  Pose moved = Pose::Identity();
  moved.translation() = Vec3(1, 2, 3);
  const std::string message = io_test::InputErrorMessage([&] {
    WriteExtrinsics(input, {{"a", moved}}, doc.document, {}, {input});
  });
  EXPECT_THAT(message, HasSubstr("refusing to write " + input + ": it is an input file"));
  EXPECT_EQ(io_test::ReadText(input), before);
  EXPECT_THAT(Listing(), ElementsAre("in.json"));
}

TEST_F(ExtrinsicsTest, MissingOutputDirectoryAndBadPosesAreInputErrors) {
  EXPECT_THAT(io_test::InputErrorMessage([&] {
                WriteExtrinsics(Path("nope/out.json"), {{"a", Pose::Identity()}});
              }),
              HasSubstr("does not exist"));
  Pose bad = Pose::Identity();
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THAT(io_test::InputErrorMessage([&] {
                WriteExtrinsics(Path("o.json"), {{"a", bad}});
              }),
              HasSubstr("camera a: T_world_camera is not finite"));
  EXPECT_THAT(Listing(), IsEmpty());
}

}  // namespace
}  // namespace rigfit
