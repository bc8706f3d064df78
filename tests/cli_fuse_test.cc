// End-to-end tests of `rigfit fuse`: the built executable (RIGFIT_CLI_PATH) on a small
// noise-free rig written by `rigfit simulate`; the map it writes is read back and checked
// against the simulated room.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "io/extrinsics_json.h"
#include "io/ply.h"
#include "io/png.h"
#include "report/image.h"
#include "report/map_view.h"
#include "report/palette.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;
using namespace cli_test;  // NOLINT: RunRigfit and friends

constexpr int kSeed = 5;

class CliFuseTest : public SimulatedRigSuite<CliFuseTest> {
 protected:
  static void SetUpTestSuite() {
    SimulateRig("rigfit_cli_fuse_test", {"--cameras", "3", "--width", "160", "--height", "90",
                                         "--noise", "0", "--seed", std::to_string(kSeed)});
  }

  /// `rigfit fuse` of the rig's capture at the extrinsics file `extrinsics` into the map file
  /// `map` (paths).
  static RunResult Fuse(const std::string& extrinsics, const std::string& map,
                        std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {
        "fuse", "--capture", Rig("capture.h5"), "--extrinsics", extrinsics, "--map", map};
    args.insert(args.end(), extra.begin(), extra.end());
    return RunRigfit(args, root_);
  }

  /// The summary's "<N> points in -> <M> map points".
  static void ParseSummary(const std::string& out, long long* in, long long* map) {
    const size_t at = out.find("cameras, ");
    ASSERT_NE(at, std::string::npos) << out;
    ASSERT_EQ(std::sscanf(out.c_str() + at, "cameras, %lld points in -> %lld map points", in, map),
              2)
        << out;
  }
};

TEST_F(CliFuseTest, TrueExtrinsicsGiveOneSurfaceWithNormalsAndColours) {
  const RunResult r = Fuse(Rig("gt.json"), Scratch("gt.ply"));
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  long long in = 0;
  long long map = 0;
  ParseSummary(r.out, &in, &map);
  EXPECT_LT(map, in);
  const PlyCloud cloud = ReadPly(Scratch("gt.ply"));
  ASSERT_EQ(static_cast<long long>(cloud.points.size()), map);
  ASSERT_EQ(cloud.normals.size(), cloud.points.size());
  EXPECT_EQ(cloud.colors.size(), cloud.points.size());
  const Scene scene = SimulateRoom(kSeed, false);
  int far = 0;
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    ASSERT_NEAR(cloud.normals[i].norm(), 1.0, 1e-5) << i;
    if (scene.DistanceToSurface(cloud.points[i]) > 1e-3) ++far;
  }
  // Noise-free depth: off the surfaces only where a crease's normal let faces merge.
  EXPECT_LT(far, static_cast<int>(cloud.points.size()) / 100) << far;
}

TEST_F(CliFuseTest, PerturbedExtrinsicsDoubleTheSurfaces) {
  const RunResult gt = Fuse(Rig("gt.json"), Scratch("gt2.ply"));
  const RunResult init = Fuse(Rig("init.json"), Scratch("init.ply"));
  ASSERT_EQ(gt.exit_code, 0) << Describe(gt);
  ASSERT_EQ(init.exit_code, 0) << Describe(init);
  long long in_gt = 0, map_gt = 0, in_init = 0, map_init = 0;
  ParseSummary(gt.out, &in_gt, &map_gt);
  ParseSummary(init.out, &in_init, &map_init);
  EXPECT_EQ(in_gt, in_init);
  EXPECT_GT(map_init, map_gt);
}

// --report: the map from above (report/map_view.h), +Y up, the cameras in their colours.
TEST_F(CliFuseTest, ReportDrawsTheMapFromAboveWithTheCameras) {
  const RunResult r = Fuse(Rig("gt.json"), Scratch("report.ply"), {"--report", Scratch("report")});
  ASSERT_EQ(r.exit_code, 0) << Describe(r);
  EXPECT_NE(r.out.find("report: " + Scratch("report/map_top.png")), std::string::npos) << r.out;
  const Image image = ReadPng(Scratch("report/map_top.png"));
  ASSERT_EQ(image.width, kMapViewWidth);
  ASSERT_EQ(image.height, kMapViewHeight);
  // Each camera is a disc of its colour; the map fills a tenth of the plot at least.
  std::vector<int> camera_pixels(3, 0);
  int drawn = 0;
  for (int y = kMapPlotTop; y < kMapPlotBottom; ++y) {
    for (int x = kMapPlotLeft; x < kMapPlotRight; ++x) {
      const Rgb c = image.At(x, y);
      drawn += c != kWhite ? 1 : 0;
      for (int k = 0; k < 3; ++k) camera_pixels[k] += c == CameraColor(k) ? 1 : 0;
    }
  }
  for (int k = 0; k < 3; ++k) EXPECT_GT(camera_pixels[k], 50) << k;
  EXPECT_GT(drawn, (kMapPlotRight - kMapPlotLeft) * (kMapPlotBottom - kMapPlotTop) / 10);
  const std::string page = ReadText(Scratch("report/index.html"));
  EXPECT_NE(page.find("map points (compression"), std::string::npos);  // the summary
  EXPECT_NE(page.find("world +Y, the extrinsics&#39; up axis"), std::string::npos);
  // A report directory whose parent is missing: refused before anything is written.
  const RunResult bad =
      Fuse(Rig("gt.json"), Scratch("bad_report.ply"), {"--report", Scratch("missing/report")});
  EXPECT_EQ(bad.exit_code, 2) << Describe(bad);
  EXPECT_NE(bad.err.find("fuse: --report"), std::string::npos) << bad.err;
  EXPECT_FALSE(fs::exists(Scratch("bad_report.ply")));
}

TEST_F(CliFuseTest, BadInputExitsTwoAndWritesNothing) {
  // A camera without a pose.
  ExtrinsicsDocument gt = ReadExtrinsics(Rig("gt.json"));
  gt.poses.erase(gt.poses.begin());
  WriteExtrinsics(Scratch("two.json"), gt.poses);
  RunResult r = Fuse(Scratch("two.json"), Scratch("missing.ply"));
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("has no pose for camera"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(Scratch("missing.ply")));
  r = Fuse(Rig("gt.json"), Scratch("depth.ply"), {"--min-depth", "3", "--max-depth", "2"});
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_FALSE(fs::exists(Scratch("depth.ply")));
  // An existing map only with --force.
  ASSERT_EQ(Fuse(Rig("gt.json"), Scratch("once.ply")).exit_code, 0);
  r = Fuse(Rig("gt.json"), Scratch("once.ply"));
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_NE(r.err.find("use --force"), std::string::npos) << r.err;
  EXPECT_EQ(Fuse(Rig("gt.json"), Scratch("once.ply"), {"--force"}).exit_code, 0);
  // An input never (a copy of gt.json: the rig is shared, read only).
  fs::copy_file(Rig("gt.json"), Scratch("input.json"));
  r = Fuse(Scratch("input.json"), Scratch("input.json"), {"--force"});
  EXPECT_EQ(r.exit_code, 2) << Describe(r);
  EXPECT_EQ(ReadText(Scratch("input.json")), ReadText(Rig("gt.json")));
}

}  // namespace
}  // namespace rigfit
