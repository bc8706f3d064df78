// `rigfit simulate`: writes an example rig (capture, true and perturbed extrinsics) to try
// rigfit without hardware and to benchmark it against ground truth.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <iterator>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "analysis/crlb.h"
#include "cli/commands.h"
#include "cli/simulate_common.h"
#include "core/errors.h"
#include "core/evaluate.h"
#include "core/format.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/text_table.h"
#include "sim/simulate_rig.h"

namespace rigfit::cli {
namespace {

namespace fs = std::filesystem;

constexpr const char* kOutputFiles[] = {"capture.h5", "gt.json", "init.json"};

struct SimulateArgs {
  std::string out_dir;
  bool force = false;
  bool crlb = false;
  std::string config_path;  ///< refine options of the bound (defaults when empty)
  SimOptions sim;
};

/// Draws of the poses for the bound's benchmark errors.
constexpr int kBoundSamples = 2000;

/// Prints `what` and the benchmark errors of a bound: "<what>: RMS relative rotation ...".
void PrintSampled(const std::string& what, const SampledErrors& e) {
  std::printf(
      "%s: RMS relative rotation %.4f deg, RMS relative translation %.2f mm, RMS tilt "
      "%.4f deg\n",
      what.c_str(), e.rotation_rad * kRadToDeg, e.translation_m * 1e3, e.tilt_rad * kRadToDeg);
}

/// Prints the Cramer-Rao bounds of the simulated rig (analysis/crlb.h), measured like
/// `rigfit evaluate`: the surface model's (the physical limit), then the point-to-plane
/// information bound of the joint problem and the joint estimator's own prediction.
void PrintBound(const SimulateArgs& a) {
  if (a.sim.noise <= 0.0) {
    std::printf("Cramer-Rao bound: 0 (noise-free capture)\n");
    return;
  }
  const RefineOptions options = a.config_path.empty() ? RefineOptions() : LoadConfig(a.config_path);
  SimOptions clean = a.sim;
  clean.noise = 0.0;
  const SimulatedRig truth = SimulateRig(clean);
  // The band's pixels and faces, labelled once for the white and the correlated bounds.
  std::vector<PlanarFace> faces;
  const std::vector<FacePixels> pixels = RigFacePixels(
      truth.capture, truth.gt, options.region,
      [&](const Pose& T, const PointCloud& p, std::vector<PlanarFace>* f, std::vector<int>* l) {
        LabelFaces(truth.scene, T, p, f, l);
      },
      &faces);
  const std::string reference = RigReference(truth.capture, options);
  const CramerRaoBound s = ComputeSurfaceCramerRaoBound(pixels, faces, truth.gt, reference,
                                                        {a.sim.noise}, {kBoundSamples, a.sim.seed});
  const std::string noise =
      "noise " + Fixed(a.sim.noise, 4) + ", " + std::to_string(kBoundSamples) + " draws";
  if (s.ok) {
    PrintSampled(
        "Cramer-Rao bound of the surface model (every pixel of the band once, inverse "
        "depth, the true faces as nuisance planes, floor normal known; " +
            noise + (a.sim.noise_corr_share > 0.0 ? "; white noise of that sigma" : "") + ")",
        s.rms);
  } else {
    std::printf("Cramer-Rao bound of the surface model: not available: %s\n", s.message.c_str());
  }
  if (a.sim.noise_corr_share > 0.0) {
    // The bound above is white noise's of the same sigma; this one knows the correlation.
    std::fprintf(stderr,
                 "computing the bound under the correlated noise (conjugate gradients over the "
                 "faces' pixels: about a minute per 640x360 camera)...\n");
    const CramerRaoBound c =
        ComputeSurfaceCramerRaoBound(pixels, faces, truth.gt, reference,
                                     {a.sim.noise, {a.sim.noise_corr_px, a.sim.noise_corr_share}},
                                     {kBoundSamples, a.sim.seed, 2});
    const std::string what = "Cramer-Rao bound of the surface model under the correlated noise (" +
                             Fixed(a.sim.noise_corr_px, 2) + " px, share " +
                             Fixed(a.sim.noise_corr_share, 2) + "; " + noise + ")";
    if (c.ok) {
      PrintSampled(what, c.rms);
    } else {
      std::printf("%s: not available: %s\n", what.c_str(), c.message.c_str());
    }
  }
  const CramerRaoBound b =
      ComputeCramerRaoBound(truth.capture, truth.gt, options, a.sim.noise, kCramerRaoNoiseFloorM,
                            {kBoundSamples, a.sim.seed, 2});
  if (!b.ok) {
    std::printf("Point-to-plane information bound: not available: %s\n", b.message.c_str());
    return;
  }
  PrintSampled(
      "Point-to-plane information bound (issue 5's: the joint problem's correspondences "
      "at the true poses, normals known, a point counted once per term; " +
          noise + ")",
      b.rms);
  // The first column as wide as its heading, which names the reference camera.
  const std::string heading = "  1-sigma against reference " + b.reference + ":";
  TextTable sigmas(
      {{std::max<size_t>(32, heading.size()), Align::kLeft, ""}, {9}, {9}, {8}, {8}, {8}});
  sigmas.AddRow({heading, "yaw deg", "tilt deg", "x mm", "y mm", "z mm"});
  for (size_t k = 0; k < b.serials.size(); ++k) {
    const PoseSigma sigma = SigmaOf(b.covariance.block<6, 6>(6 * k, 6 * k));
    sigmas.AddRow({"  " + b.serials[k], Fixed(sigma.yaw_deg, 4), Fixed(sigma.tilt_deg, 4),
                   Fixed(sigma.x_mm, 2), Fixed(sigma.y_mm, 2), Fixed(sigma.z_mm, 2)});
  }
  std::fputs(sigmas.text().c_str(), stdout);
  if (b.estimator_ok) {
    PrintSampled(
        "rigfit's joint estimator under its own noise model (depth noise plus "
        "plane_noise_share), each point's noise shared by all its terms (what its errors "
        "should be; not a bound)",
        b.estimator_rms);
  }
}

/// The simulation settings, recorded in the extrinsics files' _meta.
nlohmann::json SimulationMeta(const SimOptions& o, const std::string& poses) {
  nlohmann::json meta = {{"simulated",
                          {{"poses", poses},
                           {"cameras", o.cameras},
                           {"seed", o.seed},
                           {"width", o.width},
                           {"height", o.height},
                           {"noise", o.noise},
                           {"dropout", o.dropout},
                           {"perturb_yaw_deg", o.perturb_yaw_deg},
                           {"perturb_xz_m", o.perturb_xz_m},
                           {"perturb_tilt_deg", o.perturb_tilt_deg},
                           {"bare", o.bare}}}};
  // The realistic-noise settings only when used: earlier files stay as they were.
  nlohmann::json& simulated = meta["simulated"];
  if (o.noise_corr_share > 0.0) {
    simulated["noise_corr_px"] = o.noise_corr_px;
    simulated["noise_corr_share"] = o.noise_corr_share;
  }
  if (o.disparity_quant_px > 0.0 || o.depth_model == DepthModel::kStereo) {
    if (o.disparity_quant_px > 0.0) simulated["disparity_quant_px"] = o.disparity_quant_px;
    simulated["stereo_baseline_m"] = o.stereo_baseline_m;
  }
  if (o.depth_model == DepthModel::kStereo) {
    simulated["depth_model"] = DepthModelName(o.depth_model);
    simulated["stereo_upsample"] = o.stereo_upsample;
  }
  if (o.disparity_offset_px != 0.0 || o.depth_scale != 1.0) {
    simulated["stereo_baseline_m"] = o.stereo_baseline_m;
    simulated["disparity_offset_px"] = o.disparity_offset_px;
    simulated["depth_scale"] = o.depth_scale;
    nlohmann::json cameras = nlohmann::json::array();
    for (int i = 0; i < o.cameras; ++i) {
      const bool listed = std::find(o.miscalibrated_cameras.begin(), o.miscalibrated_cameras.end(),
                                    i) != o.miscalibrated_cameras.end();
      if (o.miscalibrated_cameras.empty() ? i != 0 : listed) cameras.push_back(SimSerial(i));
    }
    simulated["miscalibrated_cameras"] = cameras;
  }
  return meta;
}

int RunSimulate(const SimulateArgs& a) {
  CheckSimOptions(a.sim);
  if (!a.config_path.empty()) LoadConfig(a.config_path);  // bad config: exit 2 before writing
  PrepareOutputDir("simulate", a.out_dir, a.force,
                   std::vector<std::string>(std::begin(kOutputFiles), std::end(kOutputFiles)));
  const SimulatedRig rig = SimulateRig(a.sim);
  const fs::path dir(a.out_dir);
  WriteCapture((dir / "capture.h5").string(), rig.capture);
  WriteExtrinsics((dir / "gt.json").string(), rig.gt, nlohmann::json::object(),
                  SimulationMeta(a.sim, "ground truth"));
  WriteExtrinsics((dir / "init.json").string(), rig.init, nlohmann::json::object(),
                  SimulationMeta(a.sim, "perturbed ground truth"));
  std::printf("simulate: %d cameras, %dx%d, seed %llu%s -> %s\n", a.sim.cameras, a.sim.width,
              a.sim.height, static_cast<unsigned long long>(a.sim.seed),
              a.sim.bare ? ", bare room" : "", a.out_dir.c_str());
  for (const CameraCapture& camera : rig.capture.cameras) {
    const Vec3 p = rig.gt.at(camera.serial).translation();
    size_t valid = 0;
    for (float z : camera.depth_m) valid += std::isfinite(z) ? 1 : 0;
    std::printf("  %s  position (%6.3f, %6.3f, %6.3f) m  %zu points\n", camera.serial.c_str(),
                p.x(), p.y(), p.z(), valid);
  }
  if (a.crlb) PrintBound(a);
  return kExitOk;
}

/// The depth model's and the miscalibration's flags (docs/commands/simulate.md), rigfit.simulate's
/// keywords of the same names (python/tests/test_simulate.py holds the two to the same shown
/// defaults).
void AddStereoOptions(CLI::App* sub, SimOptions* o) {
  sub->add_option_function<std::string>(
         "--depth-model",
         [o](const std::string& model) { o->depth_model = DepthModelNamed(model); },
         "gaussian: ray-cast depth plus --noise; stereo: block matching (OpenCV "
         "StereoSGBM) of a rendered, textured left/right pair (--noise, --dropout and the "
         "correlated noise not used)")
      ->check(CLI::IsMember({"gaussian", "stereo"}))
      ->default_str(DepthModelName(o->depth_model));
  sub->add_option("--stereo-baseline-m", o->stereo_baseline_m,
                  "Stereo baseline, metres: the stereo model's, --disparity-quant-px's and the "
                  "miscalibration's (disparity = fx x baseline / z)")
      ->capture_default_str();
  sub->add_option("--stereo-upsample", o->stereo_upsample,
                  "Stereo model: render and match at this many times the resolution, then "
                  "average the disparity down (as ZED HD modes do), 1 to 4")
      ->capture_default_str();
  sub->add_option("--disparity-offset-px", o->disparity_offset_px,
                  "Miscalibration: add this to the disparity of the miscalibrated cameras, "
                  "pixels, either depth model")
      ->capture_default_str();
  sub->add_option("--depth-scale", o->depth_scale,
                  "Miscalibration: multiply the depth of the miscalibrated cameras by this, "
                  "in [0.5, 2]")
      ->capture_default_str();
  sub->add_option("--miscalibrated-cameras", o->miscalibrated_cameras,
                  "Indices (0 = the reference) of the cameras --disparity-offset-px and "
                  "--depth-scale apply to, comma-separated; default every camera but 0")
      ->delimiter(',');
}

}  // namespace

Command AddSimulateCommand(CLI::App& app) {
  auto args = std::make_shared<SimulateArgs>();
  SimOptions& o = args->sim;
  CLI::App* sub = app.add_subcommand(
      "simulate",
      "Write an example rig: DIR/capture.h5 (ray-cast depth of a furnished room, ZED-like "
      "cameras at 1.8-2.5 m looking down at the floor, stereo-like noise sigma = noise * z^2, "
      "dropped pixels, no depth beyond 10 m), DIR/gt.json (true extrinsics) and DIR/init.json "
      "(every camera perturbed about its centre: yaw about world +Y, tilt about a random "
      "horizontal axis, horizontal offset and a vertical one of a fifth of it). Deterministic "
      "for a given seed.");
  sub->add_option("--out", args->out_dir, "Output directory (created if missing)")->required();
  sub->add_option("--cameras", o.cameras, "Number of cameras")->capture_default_str();
  AddSeedOption(sub, &o.seed, "Random seed (0 to 2^64 - 1)");
  sub->add_option("--width", o.width, "Image width, pixels")->capture_default_str();
  sub->add_option("--height", o.height, "Image height, pixels")->capture_default_str();
  sub->add_option("--noise", o.noise, "Depth noise: sigma = noise * z^2 (1/m)")
      ->capture_default_str();
  sub->add_option("--noise-corr-px", o.noise_corr_px,
                  "Correlated depth noise: correlation length in pixels of its smooth share "
                  "(stereo block matching correlates over a few pixels)")
      ->capture_default_str();
  sub->add_option("--noise-corr-share", o.noise_corr_share,
                  "Share of the depth noise variance that is correlated over --noise-corr-px, "
                  "in [0, 1]; the rest is per pixel")
      ->capture_default_str();
  sub->add_option("--disparity-quant-px", o.disparity_quant_px,
                  "Round the disparity (f x 0.12 m / z) to multiples of this many pixels, "
                  "e.g. 0.125; 0 keeps depth continuous")
      ->capture_default_str();
  sub->add_option("--dropout", o.dropout, "Fraction of depth pixels dropped at random")
      ->capture_default_str();
  AddStereoOptions(sub, &o);
  sub->add_option("--perturb-yaw-deg", o.perturb_yaw_deg,
                  "init: yaw about world +Y, uniform in +-this, degrees")
      ->capture_default_str();
  sub->add_option("--perturb-xz-m", o.perturb_xz_m,
                  "init: x and z offsets uniform in +-this, y in +-this/5, metres")
      ->capture_default_str();
  sub->add_option("--perturb-tilt-deg", o.perturb_tilt_deg,
                  "init: tilt about a random horizontal axis, up to this, degrees")
      ->capture_default_str();
  sub->add_flag("--bare", o.bare, "Floor and walls only (the planar-degenerate case)");
  sub->add_flag("--force", args->force, "Overwrite capture.h5, gt.json, init.json in DIR");
  sub->add_flag("--crlb", args->crlb,
                "Also print the Cramer-Rao bound of the rig: the errors an efficient estimator "
                "of the joint problem would show at this noise (docs/residuals.md)");
  sub->add_option("--config", args->config_path,
                  "With --crlb: refine options (YAML) of the bound's joint problem");
  return {sub, [args] { return RunSimulate(*args); }};
}

}  // namespace rigfit::cli
