// `rigfit import-ply`: a rig capture from one point cloud per camera, so that scanners,
// LiDARs and fused fragments can be refined too. Each PLY file's points (and normals, if it
// has them) become the `points` (and `normals`) of one camera, in that camera's own frame, as
// the file holds them (../shared/docs/formats.md, points layout; docs/usage.md).
#include <algorithm>
#include <cstdio>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "cli/commands.h"
#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/ply.h"

namespace rigfit::cli {
namespace {

struct ImportPlyArgs {
  std::vector<std::string> cameras;  ///< SERIAL=cloud.ply
  std::string out_path;
  bool force = false;
};

/// One camera to import: its serial and its PLY file.
struct PlySource {
  std::string serial;
  std::string path;
};

/// Splits every SERIAL=cloud.ply at its first '=' and checks the serials: non-empty, no '/'
/// (an HDF5 path separator), no duplicates. Throws InputError naming the argument.
std::vector<PlySource> ParseSources(const std::vector<std::string>& arguments) {
  std::vector<PlySource> sources;
  std::set<std::string> serials;
  for (const std::string& argument : arguments) {
    const size_t eq = argument.find('=');
    if (eq == std::string::npos) {
      throw InputError("import-ply: '" + argument + "': expected SERIAL=cloud.ply");
    }
    PlySource source{argument.substr(0, eq), argument.substr(eq + 1)};
    if (source.serial.empty()) {
      throw InputError("import-ply: '" + argument + "': empty serial");
    }
    if (source.serial.find('/') != std::string::npos) {
      throw InputError("import-ply: '" + argument + "': serial '" + source.serial +
                       "' contains '/'");
    }
    if (source.path.empty()) {
      throw InputError("import-ply: '" + argument + "': empty file name");
    }
    if (!serials.insert(source.serial).second) {
      throw InputError("import-ply: '" + argument + "': serial '" + source.serial +
                       "' given twice");
    }
    sources.push_back(std::move(source));
  }
  return sources;
}

/// --out must not replace an input, an existing file only with --force, and its directory
/// must exist.
void CheckOutputPath(const ImportPlyArgs& a, const std::vector<PlySource>& sources) {
  std::vector<std::string> inputs;
  for (const PlySource& source : sources) inputs.push_back(source.path);
  CheckOutputFile(a.out_path, inputs, a.force, "import-ply: --out");
}

int RunImportPly(const ImportPlyArgs& a) {
  std::vector<PlySource> sources = ParseSources(a.cameras);
  CheckOutputPath(a, sources);
  // The contract orders cameras by serial.
  std::sort(sources.begin(), sources.end(),
            [](const PlySource& x, const PlySource& y) { return x.serial < y.serial; });
  RigCapture capture;
  for (const PlySource& source : sources) {
    PlyCloud cloud = ReadPly(source.path);
    if (cloud.skipped_non_finite > 0) {
      std::fprintf(stderr,
                   "import-ply: warning: %s: %lld vertices with non-finite coordinates or "
                   "normals left out (camera %s)\n",
                   source.path.c_str(), static_cast<long long>(cloud.skipped_non_finite),
                   source.serial.c_str());
    }
    if (cloud.points.empty()) {
      throw InputError("import-ply: " + source.path + ": no points (camera " + source.serial + ")");
    }
    CameraCapture& camera = capture.cameras.emplace_back();
    camera.serial = source.serial;
    camera.points = std::move(cloud.points);
    camera.normals = std::move(cloud.normals);
  }
  WriteCapture(a.out_path, capture);
  for (size_t i = 0; i < sources.size(); ++i) {
    const CameraCapture& camera = capture.cameras[i];
    std::printf("%-16s %9zu points%s <- %s\n", camera.serial.c_str(), camera.points.size(),
                camera.normals.empty() ? "" : " with normals", sources[i].path.c_str());
  }
  std::printf("wrote %zu cameras -> %s\n", capture.cameras.size(), a.out_path.c_str());
  return kExitOk;
}

}  // namespace

Command AddImportPlyCommand(CLI::App& app) {
  auto args = std::make_shared<ImportPlyArgs>();
  CLI::App* sub = app.add_subcommand(
      "import-ply",
      "Build a rig capture (HDF5, points layout) from one PLY point cloud per camera: "
      "SERIAL=cloud.ply, points (and normals, if the file has them) in that camera's own "
      "frame, metres. Refine it with extrinsics that map each camera's frame to the world. "
      "Exit codes: 0 done; 2 bad input or usage (nothing written).");
  sub->add_option("SERIAL=PLY", args->cameras, "One camera per argument: its serial and its cloud")
      ->required();
  sub->add_option("--out", args->out_path, "Rig capture to write (HDF5)")->required();
  sub->add_flag("--force", args->force, "Replace --out if it exists");
  return {sub, [args] { return RunImportPly(*args); }};
}

}  // namespace rigfit::cli
