// Real data nobody on the team made: frames of an RGB-D sequence with ground-truth poses
// (io/rgbd_sequence.h: TUM RGB-D fr1/xyz with motion capture by default, 7-Scenes with
// KinectFusion's poses, ...) taken as the fixed cameras of a rig (real Kinect v1 depth),
// refined from a perturbed start without ground leveling, with the whole cloud (band_height
// 0) and no gravity prior (the sequences' worlds are not gravity-aligned). Prints the
// gauge-free errors against the ground truth before and after, per mode. Usage:
// sequence_rig --help.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>

#include "bench/bench_util.h"
#include "core/evaluate.h"
#include "core/stopwatch.h"
#include "io/config_yaml.h"
#include "io/rgbd_sequence.h"
#include "rig/refine.h"

using namespace rigfit;

int main(int argc, char** argv) {
  CLI::App app{"Frames of a sequence as a fixed rig: joint and pairwise against its ground truth"};
  std::string dir = std::string(RIGFIT_SHARED_DATA_DIR) + "/tum_fr1_xyz_subset";
  std::vector<int> frames = {0, 9, 18, 27, 36};
  double rotation_deg = 1.0, translation_m = 0.03, depth_noise = 0.0;
  int seeds = 5;
  std::string method = "point_to_plane";
  std::vector<double> intrinsics;
  app.add_option("--intrinsics", intrinsics, "fx fy cx cy (default: the sequence's)")->expected(4);
  app.add_option("--dir", dir, "the sequence (rigfit track's formats, docs/sequences.md)");
  app.add_option("--frames", frames, "depth frame indices used as cameras");
  app.add_option("--perturb-deg", rotation_deg, "rotation of each start pose, degrees");
  app.add_option("--perturb-m", translation_m, "translation of each start pose, metres");
  app.add_option("--seeds", seeds, "perturbations tried");
  app.add_option("--method", method, "icp.method of the joint mode (pairwise: point_to_plane)")
      ->check(CLI::IsMember({"point_to_plane", "gicp", "surface_bundle"}));
  app.add_option("--depth-noise", depth_noise, "icp.depth_noise (k of sigma_z = k z^2); 0: none");
  std::string surface_faces = "rays";
  app.add_option("--surface-faces", surface_faces, "icp.surface_faces (with surface_bundle)")
      ->check(CLI::IsMember({"rays", "image"}));
  CLI11_PARSE(app, argc, argv);

  SequenceOptions sequence_options;
  if (!intrinsics.empty()) {
    sequence_options.intrinsics =
        PinholeIntrinsics{intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]};
  }
  const std::unique_ptr<RgbdSequence> sequence = OpenRgbdSequence(dir, sequence_options);
  RigCapture capture;
  PoseMap gt;
  for (int f : frames) {
    RgbdFrame frame = sequence->Frame(f);
    if (!frame.T_world_camera_gt) {
      std::fprintf(stderr, "frame %d has no ground-truth pose\n", f);
      return 1;
    }
    CameraCapture camera;
    char serial[16];
    std::snprintf(serial, sizeof(serial), "frame%02d", f);
    camera.serial = serial;
    camera.width = frame.width;
    camera.height = frame.height;
    camera.intrinsics = frame.intrinsics;
    camera.depth_m = std::move(frame.depth_m);
    gt[camera.serial] = *frame.T_world_camera_gt;
    capture.cameras.push_back(std::move(camera));
  }

  RefineOptions options;
  options.ground.enabled = false;
  options.region.band_height = 0.0;
  options.icp.gravity_weight = 0.0;
  options.icp.depth_noise = depth_noise;
  options.icp.surface_faces = surface_faces == "image" ? SurfaceFaces::kImage : SurfaceFaces::kRays;
  std::printf("%s: %zu frames as cameras, start perturbed by %.2f deg and %.3f m, method %s\n\n",
              sequence->Describe().c_str(), frames.size(), rotation_deg, translation_m,
              method.c_str());
  std::printf(
      "| seed | start deg | start mm | start max mm | joint deg | joint mm | joint max mm | "
      "pairwise deg | pairwise mm | pairwise max mm |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  bench::ErrorSummary summary[3];
  for (int seed = 0; seed < seeds; ++seed) {
    const PoseMap init = bench::PerturbRig(gt, rotation_deg, translation_m, seed);
    RigErrors errors[3] = {EvaluateRig(init, gt)};
    for (int m = 0; m < 2; ++m) {
      options.icp.mode = m == 0 ? RefineMode::kJoint : RefineMode::kPairwise;
      bench::SetMethod(m == 0 || method != "surface_bundle" ? method : "point_to_plane",
                       &options.icp);
      const auto start = std::chrono::steady_clock::now();
      const RefineResult result = Refine(capture, init, options);
      // The wall time on stderr, so that the tables stay as they are.
      std::fprintf(stderr, "seed %d, %s: refine %.2f s\n", seed, m == 0 ? "joint" : "pairwise",
                   SecondsSince(start));
      for (const std::string& warning : result.warnings) {
        std::fprintf(stderr, "seed %d, %s: %s\n", seed, m == 0 ? "joint" : "pairwise",
                     warning.c_str());
      }
      errors[m + 1] = EvaluateRig(result.refined, gt);
    }
    for (int k = 0; k < 3; ++k) summary[k].Add(errors[k]);
    std::printf("| %d | %s | %s | %s |\n", seed, bench::ErrorCells(errors[0]).c_str(),
                bench::ErrorCells(errors[1]).c_str(), bench::ErrorCells(errors[2]).c_str());
  }
  std::printf("| RMS (max) | %s | %s | %s |\n", summary[0].Cells().c_str(),
              summary[1].Cells().c_str(), summary[2].Cells().c_str());
  return 0;
}
