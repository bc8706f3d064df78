// `rigfit simulate --crlb`: both bounds, the surface model's below the point-to-plane one; with
// correlated noise also the surface model's under that noise.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <regex>
#include <string>

#include "cli_test_util.h"

namespace rigfit {
namespace {

/// The three numbers after "RMS relative rotation" on the line starting with `prefix`.
std::vector<double> BoundOf(const std::string& out, const std::string& prefix) {
  const std::regex line("(^|\n)" + prefix +
                        "[^\n]*RMS relative rotation ([0-9.]+) deg, RMS relative translation "
                        "([0-9.]+) mm, RMS tilt ([0-9.]+) deg");
  std::smatch m;
  if (!std::regex_search(out, m, line)) return {};
  return {std::stod(m[2]), std::stod(m[3]), std::stod(m[4])};
}

TEST(CliSimulate, CrlbPrintsBothBoundsTheSurfaceModelsLower) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rigfit_cli_simulate_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const cli_test::RunResult r = cli_test::RunRigfit(
      {"simulate", "--out", dir.string(), "--width", "160", "--height", "90", "--crlb"}, dir);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<double> surface = BoundOf(r.out, "Cramer-Rao bound of the surface model");
  const std::vector<double> point = BoundOf(r.out, "Point-to-plane information bound");
  ASSERT_EQ(surface.size(), 3u) << r.out;
  ASSERT_EQ(point.size(), 3u) << r.out;
  for (int k = 0; k < 3; ++k) {
    EXPECT_GT(surface[k], 0.0) << k;
    // Every pixel once with the faces estimated still informs more than the voxel-level
    // correspondences: the built-in rig gives about half (0.0166 / 0.0383 deg at 640x360).
    EXPECT_LT(surface[k], point[k]) << k;
  }
}

TEST(CliSimulate, CrlbWithCorrelatedNoisePrintsItsOwnBoundToo) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("rigfit_cli_simulate_corr_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const cli_test::RunResult r = cli_test::RunRigfit(
      {"simulate", "--out", dir.string(), "--cameras", "3", "--width", "160", "--height", "90",
       "--noise-corr-px", "2", "--noise-corr-share", "0.8", "--crlb"},
      dir);
  std::filesystem::remove_all(dir);
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::vector<double> white =
      BoundOf(r.out, "Cramer-Rao bound of the surface model \\(every pixel of the band once");
  const std::vector<double> correlated =
      BoundOf(r.out, "Cramer-Rao bound of the surface model under the correlated noise");
  ASSERT_EQ(white.size(), 3u) << r.out;
  ASSERT_EQ(correlated.size(), 3u) << r.out;
  EXPECT_THAT(r.out, ::testing::HasSubstr("(2.00 px, share 0.80;"));
  // Not the white line again: on this rig the correlation costs about a factor 2 (9.7 against
  // 5.6 mm); its exact value is tests/crlb_test.cc's (against the dense inverse).
  EXPECT_GT(correlated[1], 1.3 * white[1]);
  EXPECT_THAT(r.err, ::testing::HasSubstr("computing the bound under the correlated noise"));
}

TEST(CliSimulate, StereoDepthModelAndMiscalibrationFlags) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("rigfit_cli_simulate_stereo_" + std::to_string(getpid()));
  std::filesystem::create_directories(dir);
  const std::vector<std::string> rig = {"simulate", "--out", dir.string(), "--cameras", "2",
                                        "--width",  "160",   "--height",   "90"};
  const auto run = [&](std::vector<std::string> flags) {
    flags.insert(flags.begin(), rig.begin(), rig.end());
    return cli_test::RunRigfit(flags, dir);
  };
  const cli_test::RunResult ok = run(
      {"--depth-model", "stereo", "--disparity-offset-px", "0.1", "--miscalibrated-cameras", "1"});
  ASSERT_EQ(ok.exit_code, 0) << ok.err;
  const nlohmann::json meta =
      nlohmann::json::parse(cli_test::ReadText(dir / "gt.json"))["_meta"]["simulated"];
  EXPECT_EQ(meta["depth_model"], "stereo");
  EXPECT_EQ(meta["stereo_baseline_m"], 0.12);
  EXPECT_EQ(meta["disparity_offset_px"], 0.1);
  EXPECT_EQ(meta["miscalibrated_cameras"], nlohmann::json::array({"31001117"}));
  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{"--depth-model", "lidar"}, "--depth-model"},
      {{"--stereo-upsample", "0"}, "--stereo-upsample must be in [1, 4], got 0"},
      {{"--depth-scale", "0"}, "--depth-scale must be in [0.5, 2]"},
      {{"--stereo-baseline-m", "-1"}, "--stereo-baseline-m must be a finite number > 0"},
      {{"--miscalibrated-cameras", "0,2"},
       "--miscalibrated-cameras must be camera indices in [0, "
       "1], got 2"},
      {{"--depth-model", "stereo", "--disparity-quant-px", "0.125"},
       "--disparity-quant-px must be 0 with --depth-model stereo"},
  };
  for (const auto& [flags, message] : bad) {
    std::vector<std::string> args = flags;
    args.push_back("--force");
    const cli_test::RunResult r = run(args);
    EXPECT_NE(r.exit_code, 0) << flags[0];
    EXPECT_THAT(r.err, ::testing::HasSubstr(message)) << flags[0];
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rigfit
