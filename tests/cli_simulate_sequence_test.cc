// `rigfit simulate-sequence`: the TUM RGB-D layout written and read back (depth PNG values,
// colour, file lists, ground truth), the output folder guarded, bad flags refused (the 16-bit
// PNG writer it uses is tested in io_png_test.cc).
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/errors.h"
#include "io/png.h"
#include "io/trajectory_tum.h"
#include "sim/simulate_sequence.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

constexpr double kTumDepthScale = 5000.0;

class CliSimulateSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("rigfit_cli_simseq_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

/// The non-comment lines of a text file, split at spaces.
std::vector<std::vector<std::string>> DataLines(const fs::path& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> lines;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    lines.emplace_back();
    for (std::string f; fields >> f;) lines.back().push_back(f);
  }
  return lines;
}

// Noise-free frames: the depth PNGs hold round(z x 5000) of the sequence's own frames, so
// they give back the ray-cast depth to 1/10000 m; the lists and the ground truth name the
// same timestamps.
TEST_F(CliSimulateSequence, WritesTheTumLayoutAndItReadsBack) {
  constexpr int kFrames = 3, kWidth = 64, kHeight = 48;
  const cli_test::RunResult r =
      cli_test::RunRigfit({"simulate-sequence", "--out", (dir_ / "seq").string(), "--frames",
                           std::to_string(kFrames), "--width", std::to_string(kWidth), "--height",
                           std::to_string(kHeight), "--noise", "none", "--seed", "2"},
                          dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.err.find("frame 3 of 3"), std::string::npos) << r.err;

  SimSequenceOptions o;
  o.frames = kFrames;
  o.width = kWidth;
  o.height = kHeight;
  o.noise = SequenceNoise::kNone;
  o.seed = 2;
  const SimulatedSequence sequence(o);
  const fs::path seq = dir_ / "seq";
  const auto depth_lines = DataLines(seq / "depth.txt");
  const auto rgb_lines = DataLines(seq / "rgb.txt");
  ASSERT_EQ(depth_lines.size(), static_cast<size_t>(kFrames));
  ASSERT_EQ(rgb_lines.size(), static_cast<size_t>(kFrames));
  const Trajectory gt = ReadTumTrajectory((seq / "groundtruth.txt").string());
  const Trajectory expected = sequence.GroundTruth();
  ASSERT_EQ(gt.poses.size(), static_cast<size_t>(kFrames));
  for (int i = 0; i < kFrames; ++i) {
    const RgbdFrame frame = sequence.Frame(i);
    const std::vector<std::string> stamps = {"0.000000", "0.033333", "0.066667"};
    ASSERT_EQ(depth_lines[i].size(), 2u);
    EXPECT_EQ(depth_lines[i][0], stamps[i]);
    EXPECT_EQ(depth_lines[i][1], "depth/" + stamps[i] + ".png");
    EXPECT_EQ(rgb_lines[i][1], "rgb/" + stamps[i] + ".png");
    EXPECT_DOUBLE_EQ(gt.timestamps[i], std::stod(stamps[i]));
    EXPECT_TRUE(gt.poses[i].isApprox(expected.poses[i], 1e-12)) << i;

    const Grey16Raster png = ReadPngGrey16((seq / depth_lines[i][1]).string());
    ASSERT_EQ(png.width, kWidth);
    ASSERT_EQ(png.height, kHeight);
    const std::vector<std::uint16_t>& depth = png.values;
    int valid = 0;
    for (size_t p = 0; p < depth.size(); ++p) {
      const float z = frame.depth_m[p];
      if (!std::isfinite(z)) {
        EXPECT_EQ(depth[p], 0) << p;
        continue;
      }
      ++valid;
      EXPECT_EQ(depth[p], std::lround(z * kTumDepthScale)) << p;
      EXPECT_LE(std::abs(depth[p] / kTumDepthScale - z), 0.5 / kTumDepthScale + 1e-7) << p;
    }
    EXPECT_GT(valid, kWidth * kHeight / 2);
    const RgbRaster rgb = ReadPng((seq / rgb_lines[i][1]).string());
    EXPECT_EQ(rgb.width, kWidth);
    EXPECT_EQ(rgb.rgb, frame.color);
  }

  // An earlier result is kept unless --force.
  const cli_test::RunResult again =
      cli_test::RunRigfit({"simulate-sequence", "--out", seq.string(), "--frames", "1", "--width",
                           "32", "--height", "24", "--no-color"},
                          dir_);
  EXPECT_EQ(again.exit_code, 2) << cli_test::Describe(again);
  EXPECT_NE(again.err.find("--force"), std::string::npos) << again.err;
  const cli_test::RunResult forced =
      cli_test::RunRigfit({"simulate-sequence", "--out", seq.string(), "--frames", "1", "--width",
                           "32", "--height", "24", "--no-color", "--force"},
                          dir_);
  EXPECT_EQ(forced.exit_code, 0) << cli_test::Describe(forced);
  EXPECT_EQ(DataLines(seq / "depth.txt").size(), 1u);
}

// --noise stereo: the depth the sequence's block matching gives, written and said so.
TEST_F(CliSimulateSequence, WritesStereoDepth) {
  const fs::path seq = dir_ / "stereo";
  const cli_test::RunResult r = cli_test::RunRigfit(
      {"simulate-sequence", "--out", seq.string(), "--frames", "2", "--width", "160", "--height",
       "120", "--noise", "stereo", "--seed", "3", "--no-color"},
      dir_);
  ASSERT_EQ(r.exit_code, 0) << cli_test::Describe(r);
  EXPECT_NE(r.out.find("noise stereo"), std::string::npos) << r.out;
  SimSequenceOptions o;
  o.frames = 2;
  o.width = 160;
  o.height = 120;
  o.seed = 3;
  o.color = false;
  o.noise = SequenceNoise::kStereo;
  const RgbdFrame frame = SimulatedSequence(o).Frame(1);
  const std::vector<std::string> line = DataLines(seq / "depth.txt")[1];
  const std::vector<std::uint16_t> depth = ReadPngGrey16((seq / line[1]).string()).values;
  ASSERT_EQ(depth.size(), frame.depth_m.size());
  int valid = 0;
  for (std::size_t p = 0; p < depth.size(); ++p) {
    const float z = frame.depth_m[p];
    EXPECT_EQ(depth[p], std::isfinite(z) ? std::lround(z * kTumDepthScale) : 0L) << p;
    valid += depth[p] > 0 ? 1 : 0;
  }
  EXPECT_GT(valid, static_cast<int>(depth.size()) / 2);
}

TEST_F(CliSimulateSequence, RefusesBadFlagsNamingThem) {
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"--frames", "0"}, "--frames"},
      {{"--width", "8"}, "--width"},
      {{"--rate", "0"}, "--rate"},
      {{"--speed", "-1"}, "--speed"},
      {{"--noise", "gaussian"}, "--noise"},
      {{"--noise", "stereo", "--stereo-baseline-m", "0"}, "--stereo-baseline-m"},
      {{"--noise", "stereo", "--stereo-upsample", "0"}, "--stereo-upsample"},
  };
  for (const auto& [flags, name] : cases) {
    std::vector<std::string> args = {"simulate-sequence", "--out", (dir_ / "bad").string()};
    args.insert(args.end(), flags.begin(), flags.end());
    const cli_test::RunResult r = cli_test::RunRigfit(args, dir_);
    EXPECT_EQ(r.exit_code, 2) << name << "\n" << cli_test::Describe(r);
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
  }
}

}  // namespace
}  // namespace rigfit
