// `rigfit fuse`: every depth camera of a rig capture fused into one surfel map
// (rgbd/surfel_map.h) at the given extrinsics, written as a PLY with normals (and colours when
// every camera has them) and, with --report, as a picture from above (report/map_view.h).
// Well-aligned cameras merge their overlap into one surface; a misaligned rig shows doubled
// surfaces (and a larger map).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/map_ply.h"
#include "core/errors.h"
#include "core/format.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/extrinsics_json.h"
#include "io/ply.h"
#include "io/text_table.h"
#include "report/map_view.h"
#include "report/palette.h"
#include "report/refine_report.h"
#include "rgbd/frame.h"
#include "rgbd/surfel_map.h"
#include "rig/refine.h"

namespace rigfit::cli {
namespace {

struct FuseArgs {
  std::string capture_path;
  std::string extrinsics_path;
  std::string map_path;
  std::string report_dir;  ///< empty: no report
  bool force = false;
  FrameOptions frame;
  FusionOptions fusion;
};

int RunFuse(FuseArgs a) {
  CheckOutputFile(a.map_path, {a.capture_path, a.extrinsics_path}, a.force, "fuse: --map");
  if (!a.report_dir.empty()) CheckReportDirectory(a.report_dir, "fuse: --report");
  if (!(a.frame.min_depth_m >= 0.0 && a.frame.max_depth_m > a.frame.min_depth_m)) {
    throw InputError("fuse: need 0 <= --min-depth < --max-depth");
  }
  if (!(a.fusion.max_distance_m > 0.0) ||
      !(a.fusion.max_normal_angle_deg > 0.0 && a.fusion.max_normal_angle_deg <= 180.0)) {
    throw InputError("fuse: --max-distance must be > 0 and --max-angle in (0, 180]");
  }
  const RigCapture capture = ReadCaptureGuarded(a.capture_path);
  const ExtrinsicsDocument extrinsics = ReadExtrinsics(a.extrinsics_path);
  std::vector<std::string> warnings = CaptureWarnings(capture, a.capture_path);
  warnings.insert(warnings.end(), extrinsics.warnings.begin(), extrinsics.warnings.end());
  for (const std::string& warning : warnings) {
    std::fprintf(stderr, "fuse: warning: %s\n", warning.c_str());
  }
  CheckRefineInput(capture, extrinsics.poses, RefineOptions{},
                   {"fuse", a.capture_path, a.extrinsics_path, "icp.reference"});
  bool all_color = true;
  for (const CameraCapture& camera : capture.cameras) {
    if (!camera.HasDepth()) {
      throw InputError("fuse: camera " + camera.serial + " of " + a.capture_path +
                       " has no depth image (points layout); fuse needs depth images");
    }
    all_color = all_color && !camera.color.empty();
  }

  // A rig's cameras are one instant: nothing is dormant, and no pixel is left out as covered
  // (a rule against a sequence's growth, rgbd/surfel_map.h: each camera is seen once).
  a.fusion.dormant_frames = 0;
  a.fusion.cover_radius_scale = 0.0;
  a.frame.levels = 1;
  SurfelMap map;
  std::vector<MapOverlay> cameras;
  TextTable table({{16, Align::kLeft, ""}, {10}, {10}, {10}});
  table.AddRow({"camera", "points", "merged", "added"});
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    const CameraCapture& camera = capture.cameras[i];
    RgbdFrame frame;
    frame.index = static_cast<int>(i);
    frame.source = camera.serial;
    frame.width = camera.width;
    frame.height = camera.height;
    frame.intrinsics = camera.intrinsics;
    frame.depth_m = camera.depth_m;
    const FramePyramid pyramid = BuildFramePyramid(frame, a.frame);
    const Pose& T_world_camera = extrinsics.poses.at(camera.serial);
    const FusionStats stats =
        map.FuseFrame(pyramid.levels[0], T_world_camera, frame.index, a.fusion,
                      all_color ? camera.color : std::vector<std::uint8_t>{});
    table.AddRow({camera.serial, std::to_string(stats.input_points), std::to_string(stats.merged),
                  std::to_string(stats.added)});
    cameras.push_back({camera.serial, CameraColor(static_cast<int>(i)), 3, {T_world_camera}, true});
  }
  WritePly(a.map_path, SurfelMapToPly(map));
  std::string summary = table.text();
  Appendf(&summary, "%zu cameras, %lld points in -> %d map points (compression %.2f%s) -> %s\n",
          capture.cameras.size(), static_cast<long long>(map.input_points()), map.size(),
          map.CompressionRatio(), map.has_color() ? ", with colours" : "", a.map_path.c_str());
  std::fputs(summary.c_str(), stdout);
  if (!a.report_dir.empty()) {
    const MapPoints points{map.positions(), map.normals(), map.colors(), map.radii()};
    for (const std::string& file : WriteMapReport(
             a.report_dir, "rigfit fuse report", points, cameras,
             MapViewAxesFor(Vec3::UnitY(), Vec3::UnitX(), "world +Y, the extrinsics' up axis"),
             summary)) {
      std::printf("report: %s\n", file.c_str());
    }
  }
  return kExitOk;
}

}  // namespace

Command AddFuseCommand(CLI::App& app) {
  auto args = std::make_shared<FuseArgs>();
  FuseArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "fuse",
      "Fuse every depth camera of a rig capture into one surfel map (point-based fusion, "
      "docs/rgbd.md) at the given extrinsics and write it as a PLY with normals (and colours "
      "when every camera has them): aligned cameras merge into one surface, a misaligned rig "
      "shows doubled surfaces. Exit codes: 0 done; 2 bad input or usage (nothing written); 1 "
      "internal error.");
  sub->add_option("--capture", a.capture_path, "Rig capture (HDF5) with depth images")->required();
  sub->add_option("--extrinsics", a.extrinsics_path,
                  "Extrinsics (JSON): a pose for every camera of the capture")
      ->required();
  sub->add_option("--map", a.map_path,
                  "Output surfel map (PLY); its directory must exist, and it must not be an "
                  "input file")
      ->required();
  sub->add_flag("--force", a.force, "Replace --map if it exists");
  sub->add_option("--report", a.report_dir,
                  "Also write the map seen from above with the cameras (map_top.png) and a page "
                  "showing it with the summary (index.html), and an interactive 3-D view of the "
                  "map and cameras (view3d.html, opens offline) into this directory (created; "
                  "its parent must exist)");
  sub->add_option("--min-depth", a.frame.min_depth_m, "Drop depth below this (metres)")
      ->capture_default_str();
  sub->add_option("--max-depth", a.frame.max_depth_m, "Drop depth beyond this (metres)")
      ->capture_default_str();
  sub->add_option("--max-distance", a.fusion.max_distance_m,
                  "Merge a pixel into a map point only within this distance (metres)")
      ->capture_default_str();
  sub->add_option("--max-angle", a.fusion.max_normal_angle_deg,
                  "... and when their normals are within this angle (degrees)")
      ->capture_default_str();
  return {sub, [args] { return RunFuse(*args); }};
}

}  // namespace rigfit::cli
