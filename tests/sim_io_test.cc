// The simulated rig survives the file contract: what `rigfit simulate` writes reads back
// bit-exactly (depth with its NaNs, intrinsics, colour, true and perturbed poses). Built as a
// library user would: the entry header alone, linked to rigfit_library (rigfit::rigfit).
#include <gtest/gtest.h>
#include <rigfit/rigfit.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <string>

namespace rigfit {
namespace {

/// A fresh directory of this process (other build trees may run the same test at once).
std::filesystem::path TempDir(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("rigfit_sim_io_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

void ExpectSamePoses(const PoseMap& read, const PoseMap& written) {
  ASSERT_EQ(read.size(), written.size());
  for (const auto& [serial, T] : written) {
    ASSERT_EQ(read.count(serial), 1u) << serial;
    EXPECT_TRUE(read.at(serial).isApprox(T, 0.0)) << serial;
  }
}

TEST(SimulatedRigFiles, RoundTripBitExactly) {
  SimOptions options;
  options.width = 160;
  options.height = 90;
  options.cameras = 3;
  const SimulatedRig rig = SimulateRig(options);
  const std::filesystem::path dir = TempDir("round_trip");
  WriteCapture((dir / "capture.h5").string(), rig.capture);
  WriteExtrinsics((dir / "gt.json").string(), rig.gt);
  WriteExtrinsics((dir / "init.json").string(), rig.init);

  const RigCapture capture = ReadCapture((dir / "capture.h5").string());
  ASSERT_EQ(capture.cameras.size(), rig.capture.cameras.size());
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    const CameraCapture& read = capture.cameras[i];
    const CameraCapture& written = rig.capture.cameras[i];
    EXPECT_EQ(read.serial, written.serial);
    ASSERT_EQ(read.width, written.width);
    ASSERT_EQ(read.height, written.height);
    ASSERT_EQ(read.depth_m.size(), written.depth_m.size());
    EXPECT_EQ(std::memcmp(read.depth_m.data(), written.depth_m.data(),
                          read.depth_m.size() * sizeof(float)),
              0)
        << read.serial;
    EXPECT_EQ(read.intrinsics.fx, written.intrinsics.fx);
    EXPECT_EQ(read.intrinsics.fy, written.intrinsics.fy);
    EXPECT_EQ(read.intrinsics.cx, written.intrinsics.cx);
    EXPECT_EQ(read.intrinsics.cy, written.intrinsics.cy);
    EXPECT_EQ(read.color, written.color);
  }
  ExpectSamePoses(ReadExtrinsics((dir / "gt.json").string()).poses, rig.gt);
  ExpectSamePoses(ReadExtrinsics((dir / "init.json").string()).poses, rig.init);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace rigfit
