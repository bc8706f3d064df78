// `rigfit export-ply`: every camera's points in the world at the given extrinsics, one colour
// per camera (report/palette.h, the colours of the refine report), as a binary PLY that
// MeshLab or CloudCompare opens, so that a person can see how well the cameras align.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "core/errors.h"
#include "core/geometry.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/ply.h"
#include "io/text_table.h"
#include "prepare/region.h"
#include "report/palette.h"
#include "rig/refine.h"

namespace rigfit::cli {
namespace {

struct ExportArgs {
  std::string capture_path;
  std::string extrinsics_path;
  std::string out_path;
  std::string config_path;
  bool band = false;
  int stride = 0;  ///< 0: region.pixel_stride of the config
  CLI::Option* stride_option = nullptr;
};

int RunExport(const ExportArgs& a) {
  std::vector<std::string> inputs = {a.capture_path, a.extrinsics_path};
  if (!a.config_path.empty()) inputs.push_back(a.config_path);
  RefuseToOverwriteInputs(a.out_path, inputs, "export-ply: --out");
  if (a.stride_option->count() > 0 && a.stride < 1) {
    throw InputError("export-ply: --stride must be >= 1, got " + std::to_string(a.stride));
  }
  const RefineOptions options = a.config_path.empty() ? RefineOptions{} : LoadConfig(a.config_path);
  const RigCapture capture = ReadCaptureGuarded(a.capture_path);
  const ExtrinsicsDocument extrinsics = ReadExtrinsics(a.extrinsics_path);
  std::vector<std::string> warnings = CaptureWarnings(capture, a.capture_path);
  warnings.insert(warnings.end(), extrinsics.warnings.begin(), extrinsics.warnings.end());
  for (const std::string& warning : warnings) {
    std::fprintf(stderr, "export-ply: warning: %s\n", warning.c_str());
  }
  for (const CameraCapture& camera : capture.cameras) {
    if (extrinsics.poses.count(camera.serial) == 0) {
      throw InputError("export-ply: " + a.extrinsics_path + " has no pose for camera " +
                       camera.serial + " of " + a.capture_path);
    }
  }
  RegionOptions region = options.region;
  if (a.stride_option->count() > 0) region.pixel_stride = a.stride;
  PlyCloud cloud;
  TextTable table({{16, Align::kLeft, ""}, {8}, {10}});
  table.AddRow({"camera", "colour", "points"});
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    const CameraCapture& camera = capture.cameras[i];
    const Pose& T_world_camera = extrinsics.poses.at(camera.serial);
    PointCloud points = RegistrationPoints(camera, region);
    if (a.band) points = NearFloorBand(points, T_world_camera, options.region);
    const Rgb color = CameraColor(static_cast<int>(i));
    for (const Vec3& p : points) {
      cloud.points.push_back(T_world_camera * p);
      cloud.colors.push_back({color.r, color.g, color.b});
    }
    table.AddRow({camera.serial, HexColor(color), std::to_string(points.size())});
  }
  std::fputs(table.text().c_str(), stdout);
  WritePly(a.out_path, cloud);
  std::printf("%zu points (%s) -> %s\n", cloud.points.size(),
              a.band ? "near-floor band" : "whole clouds", a.out_path.c_str());
  return kExitOk;
}

}  // namespace

Command AddExportPlyCommand(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  ExportArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "export-ply",
      "Write every camera's points in the world (at the given extrinsics) to one binary PLY, "
      "coloured per camera (the colours of the refine report), to inspect the alignment in "
      "MeshLab or CloudCompare. Exit codes: 0 done; 2 bad input or usage (nothing written); 1 "
      "internal error.");
  sub->add_option("--capture", a.capture_path, "Rig capture (HDF5)")->required();
  sub->add_option("--extrinsics", a.extrinsics_path,
                  "Extrinsics (JSON): a pose for every camera of the capture")
      ->required();
  sub->add_option("--out", a.out_path,
                  "Output point cloud (PLY); its directory must exist, and it must not be an "
                  "input file")
      ->required();
  sub->add_option("--config", a.config_path,
                  "Options (YAML, docs/config.md): region.pixel_stride, the depth range and the "
                  "band (region.band_below, region.band_height) come from it");
  sub->add_flag("--band", a.band,
                "Only the near-floor band (the points registration uses): world height in "
                "[-region.band_below, region.band_height] at the given extrinsics, whose floor "
                "must be y = 0 (leveled or refined extrinsics)");
  a.stride_option = sub->add_option(
      "--stride", a.stride,
      "Use every N-th depth pixel in u and v (default: region.pixel_stride, 2 unless "
      "configured); point-cloud cameras are exported whole");
  return {sub, [args] { return RunExport(*args); }};
}

}  // namespace rigfit::cli
