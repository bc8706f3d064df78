// Where the joint mode's error comes from: single camera pairs of simulated rigs,
// registered from the true poses with the depth noise on one side, the other, both or
// neither. Each run is a two-camera capture: camera b (the reference, held fixed) and
// camera a, both at their true poses; the error is a's refined pose against the truth.
// With --same-view, b is a's own noise-free image (same pose, same pixels): how far a
// camera's noisy cloud sits from its own noise-free cloud. Usage: view_bias --help.
#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>

#include "bench_util.h"
#include "core/geometry.h"
#include "io/config_yaml.h"
#include "rig/refine.h"
#include "sim/simulate_rig.h"

int main(int argc, char** argv) {
  using namespace rigfit;
  CLI::App app{"Single camera pairs of simulated rigs registered from the true poses"};
  SimOptions sim;
  int first_seed = 0, seeds = 3;
  std::string noisy = "source", config;
  bool same_view = false, verbose = false;
  app.add_option("--first-seed", first_seed);
  app.add_option("--seeds", seeds, "number of seeds");
  app.add_option("--noise", sim.noise, "depth noise of the noisy side (sigma = noise z^2)");
  app.add_option("--width", sim.width, "image width, pixels");
  app.add_option("--height", sim.height, "image height, pixels");
  app.add_option("--noisy", noisy, "which side has the depth noise")
      ->check(CLI::IsMember({"source", "target", "both", "none"}));
  app.add_flag("--same-view", same_view, "register each camera to its own noise-free image");
  app.add_option("--config", config, "refine options (YAML)");
  app.add_flag("--verbose", verbose, "every pair's error");
  CLI11_PARSE(app, argc, argv);
  const RefineOptions base = config.empty() ? RefineOptions() : LoadConfig(config);
  if (same_view) noisy = "source";  // the target is the camera's own noise-free image

  const std::string kReference = "00000000";  // sorts first: the reference of every run
  double sum_t2 = 0.0, sum_r2 = 0.0, worst_t = 0.0;
  Vec3 sum_in_camera = Vec3::Zero();  // position errors in camera a's frame, summed
  int runs = 0, failures = 0;
  for (int seed = first_seed; seed < first_seed + seeds; ++seed) {
    sim.seed = static_cast<std::uint64_t>(seed);
    SimOptions clean_options = sim;
    clean_options.noise = 0.0;
    const SimulatedRig with_noise = SimulateRig(sim);
    const SimulatedRig clean = SimulateRig(clean_options);
    const auto image = [&](bool noisy_side, size_t i) {
      return (noisy_side ? with_noise : clean).capture.cameras[i];
    };
    const size_t n = with_noise.capture.cameras.size();
    for (size_t a = 0; a < n; ++a) {
      for (size_t b = 0; b < n; ++b) {
        if ((a == b) != same_view) continue;
        const std::string serial = with_noise.capture.cameras[a].serial;
        const Pose truth = with_noise.gt.at(serial);
        RigCapture capture;
        capture.cameras = {image(noisy == "target" || noisy == "both", b),
                           image(noisy == "source" || noisy == "both", a)};
        capture.cameras[0].serial = kReference;
        const PoseMap start = {{kReference, with_noise.gt.at(with_noise.capture.cameras[b].serial)},
                               {serial, truth}};
        RefineOptions options = base;
        options.icp.reference = kReference;
        options.threads = 1;
        const RefineResult r = Refine(capture, start, options);
        const bool refined = r.success && r.cameras[1].accepted;
        if (!refined) {
          ++failures;
          if (verbose)
            std::printf("seed %d %zu <- %zu: not refined: %s\n", seed, b, a, r.message.c_str());
          continue;
        }
        const Vec6 d = PoseDifference(truth, r.refined.at(serial));
        const double t = d.tail<3>().norm();
        sum_t2 += t * t;
        sum_r2 += d.head<3>().squaredNorm();
        worst_t = std::max(worst_t, t);
        ++runs;
        // The position error in camera a's own frame (z along its optical axis).
        const Vec3 in_camera =
            truth.linear().transpose() * (r.refined.at(serial).translation() - truth.translation());
        sum_in_camera += in_camera;
        if (verbose) {
          std::printf(
              "seed %d %zu <- %zu: %.4f deg (yaw %.4f), %.2f mm (world x %.2f y %.2f z %.2f; "
              "camera x %.2f y %.2f z %.2f)\n",
              seed, b, a, d.head<3>().norm() * kRadToDeg, d(1) * kRadToDeg, t * 1e3, d(3) * 1e3,
              d(4) * 1e3, d(5) * 1e3, in_camera.x() * 1e3, in_camera.y() * 1e3,
              in_camera.z() * 1e3);
        }
      }
    }
  }
  std::printf(
      "noise %g on %s%s, seeds %d..%d: %d pairs refined (%d not), RMS error %.4f deg, "
      "%.2f mm (worst %.2f mm)\n",
      sim.noise, noisy.c_str(), same_view ? " (same view)" : "", first_seed, first_seed + seeds - 1,
      runs, failures, runs ? std::sqrt(sum_r2 / runs) * kRadToDeg : 0.0,
      runs ? std::sqrt(sum_t2 / runs) * 1e3 : 0.0, worst_t * 1e3);
  if (runs > 0) {
    const Vec3 mean = sum_in_camera / runs * 1e3;
    std::printf(
        "mean position error in camera a's frame (z optical axis): x %.2f y %.2f z %.2f mm\n",
        mean.x(), mean.y(), mean.z());
  }
  return 0;
}
