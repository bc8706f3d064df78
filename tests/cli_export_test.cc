// End-to-end tests of `rigfit export-ply`: the built executable (RIGFIT_CLI_PATH) on a small
// rig written by `rigfit simulate`; the PLY it writes is read back and checked against the
// capture's points moved by the extrinsics.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "core/geometry.h"
#include "io/capture_h5.h"
#include "io/extrinsics_json.h"
#include "io/ply.h"
#include "options/refine_options.h"
#include "report/palette.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using namespace cli_test;  // NOLINT: RunRigfit and friends

/// Coordinates are stored as float32: metres-sized values round within 1e-6.
constexpr double kFloatTolerance = 1e-6;

class CliExportTest : public SimulatedRigSuite<CliExportTest> {
 protected:
  static void SetUpTestSuite() {
    SimulateRig("rigfit_cli_export_test", {"--cameras", "3", "--width", "160", "--height", "90"});
  }

  /// Checks `cloud` holds, camera after camera, the given camera-frame points of every
  /// camera moved by its pose, in that camera's colour.
  static void ExpectCameraPoints(const PlyCloud& cloud, const RigCapture& capture,
                                 const PoseMap& poses, const std::vector<PointCloud>& points) {
    size_t expected = 0;
    for (const PointCloud& p : points) expected += p.size();
    ASSERT_EQ(cloud.points.size(), expected);
    ASSERT_EQ(cloud.colors.size(), expected);
    size_t k = 0;
    for (size_t i = 0; i < capture.cameras.size(); ++i) {
      const Rgb color = CameraColor(static_cast<int>(i));
      const Pose& T = poses.at(capture.cameras[i].serial);
      for (const Vec3& p : points[i]) {
        ASSERT_LT((cloud.points[k] - T * p).cwiseAbs().maxCoeff(), kFloatTolerance) << k;
        ASSERT_EQ(cloud.colors[k][0], color.r) << k;
        ASSERT_EQ(cloud.colors[k][1], color.g) << k;
        ASSERT_EQ(cloud.colors[k][2], color.b) << k;
        ++k;
      }
    }
  }
};

TEST_F(CliExportTest, EveryCameraInTheWorldInItsColour) {
  const RunResult r = RunRigfit({"export-ply", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("gt.json"), "--out", Scratch("all.ply"), "--stride", "3"},
                                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const RigCapture capture = ReadCapture(Rig("capture.h5"));
  const PoseMap poses = ReadExtrinsics(Rig("gt.json")).poses;
  const RegionOptions region;
  std::vector<PointCloud> points;
  for (const CameraCapture& camera : capture.cameras) {
    points.push_back(CameraPoints(camera, {3, region.min_depth_m, region.max_depth_m}));
  }
  ExpectCameraPoints(ReadPly(Scratch("all.ply")), capture, poses, points);
  EXPECT_NE(r.out.find(HexColor(CameraColor(2))), std::string::npos) << r.out;
}

TEST_F(CliExportTest, BandKeepsTheNearFloorPointsAtTheDefaultStride) {
  const RunResult r = RunRigfit({"export-ply", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("gt.json"), "--out", Scratch("band.ply"), "--band"},
                                root_);
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  const RigCapture capture = ReadCapture(Rig("capture.h5"));
  const PoseMap poses = ReadExtrinsics(Rig("gt.json")).poses;
  const RegionOptions region;
  std::vector<PointCloud> points;
  for (const CameraCapture& camera : capture.cameras) {
    const PointCloud all =
        CameraPoints(camera, {region.pixel_stride, region.min_depth_m, region.max_depth_m});
    PointCloud band;
    for (const Vec3& p : all) {
      const double y = (poses.at(camera.serial) * p).y();
      if (y >= -region.band_below && y <= region.band_height) band.push_back(p);
    }
    ASSERT_LT(band.size(), all.size());
    points.push_back(band);
  }
  ExpectCameraPoints(ReadPly(Scratch("band.ply")), capture, poses, points);
}

TEST_F(CliExportTest, OutputOntoAnInputIsRefused) {
  // A copy of gt.json: the rig is shared, read only.
  const std::string gt = Scratch("gt.json");
  fs::copy_file(Rig("gt.json"), gt);
  const RunResult r = RunRigfit(
      {"export-ply", "--capture", Rig("capture.h5"), "--extrinsics", gt, "--out", gt}, root_);
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("input file"), std::string::npos) << r.err;
  EXPECT_EQ(ReadText(gt), ReadText(Rig("gt.json")));
}

TEST_F(CliExportTest, ZeroStrideIsBadInput) {
  const RunResult r = RunRigfit({"export-ply", "--capture", Rig("capture.h5"), "--extrinsics",
                                 Rig("gt.json"), "--out", Scratch("zero.ply"), "--stride", "0"},
                                root_);
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("--stride"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(Scratch("zero.ply")));
}

}  // namespace
}  // namespace rigfit
