// The example-rig simulator behind `rigfit simulate`: a furnished room seen by a rig of
// ZED-like depth cameras, with true and perturbed extrinsics. Deterministic for a seed.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/setting_error.h"
#include "core/types.h"
#include "sim/random.h"
#include "sim/scene.h"

namespace rigfit {

/// Horizontal field of view of the simulated pinhole cameras (ZED-like), degrees.
inline constexpr double kSimHorizontalFovDeg = 85.0;

/// How a simulated camera's depth is made.
enum class DepthModel {
  /// The ray-cast depth plus Gaussian noise (SimOptions::noise and its correlated share).
  kGaussian,
  /// Semi-global block matching of a rendered, textured left/right pair (sim/stereo_depth.h).
  kStereo,
};

/// "gaussian" or "stereo" (`--depth-model`, rigfit.simulate's depth_model).
const char* DepthModelName(DepthModel model);
/// The model of that name; SettingError "{depth_model} must be gaussian or stereo, got ..."
/// for another.
DepthModel DepthModelNamed(const std::string& name);

/// What to simulate. Defaults are those of `rigfit simulate`.
struct SimOptions {
  int cameras = 4;
  std::uint64_t seed = 0;
  int width = 640;   ///< pixels
  int height = 360;  ///< pixels
  /// Depth noise: z_measured = z + N(0, sigma^2) with sigma = noise * z^2 (1/m), the
  /// quadratic growth of stereo depth error with range.
  double noise = 0.0025;
  /// Perturbation of `init` from `gt`, per camera (see SimulateRig).
  double perturb_yaw_deg = 2.0;
  double perturb_xz_m = 0.05;
  double perturb_tilt_deg = 0.3;
  /// Floor and walls only: the planar-degenerate case.
  bool bare = false;
  /// Fraction of pixels dropped (NaN) at random.
  double dropout = 0.03;
  /// Measured depths beyond this are invalid (NaN).
  double max_depth_m = 10.0;
  /// Which draw of the pixel noise and dropout: 0 is the seed's own; another value draws
  /// them anew for the same scene, cameras and perturbation (bias against variance).
  std::uint64_t noise_draw = 0;
  /// Spatially correlated depth noise, as stereo block matching produces: a share
  /// noise_corr_share of the noise VARIANCE comes from a smooth Gaussian field (white noise
  /// blurred by a Gaussian of noise_corr_px pixels, GaussianNoiseField), the rest is per
  /// pixel; the total sigma stays noise * z^2. 0 and 0: white noise only, as before.
  double noise_corr_px = 0.0;
  double noise_corr_share = 0.0;
  /// Disparity quantisation of a stereo camera with baseline stereo_baseline_m: the noisy
  /// depth's disparity f B / z is rounded to a multiple of disparity_quant_px pixels (e.g.
  /// 1/8 for sub-pixel block matching); 0 keeps depth continuous.
  double disparity_quant_px = 0.0;
  /// The stereo baseline of disparity_quant_px, of the miscalibration below and of the
  /// stereo depth model.
  double stereo_baseline_m = 0.12;  ///< ZED-like
  /// kStereo: depth by block matching (noise, its correlated share and dropout are not used;
  /// disparity_quant_px must be 0, the matcher quantises by itself).
  DepthModel depth_model = DepthModel::kGaussian;
  /// kStereo: the pair rendered and matched at this many times the resolution, the disparity
  /// averaged down (ZED HD modes); 1 to 4.
  int stereo_upsample = 1;
  /// Miscalibrated cameras (either depth model): their disparity f B / z gains
  /// disparity_offset_px, then their depth is multiplied by depth_scale.
  double disparity_offset_px = 0.0;
  double depth_scale = 1.0;
  /// Indices of the miscalibrated cameras; empty: every camera but the reference (index 0).
  std::vector<int> miscalibrated_cameras;
};

/// Limits of the simulators' options (`rigfit simulate`, `rigfit simulate-sequence`,
/// rigfit.simulate): cameras of a rig, and pixels on either side of an image.
inline constexpr int kMaxSimCameras = 64;
inline constexpr int kMinSimImageSize = 16;
inline constexpr int kMaxSimImageSize = 8192;

/// Throws SettingError ("{width} must be in [16, 8192] pixels, got ...") unless both sides are
/// within [kMinSimImageSize, kMaxSimImageSize].
void CheckSimImageSize(int width, int height);

/// The checks of the options `rigfit simulate` takes as flags and rigfit.simulate as keywords:
/// cameras in [1, kMaxSimCameras], the image size (CheckSimImageSize), noise, noise_corr_px,
/// disparity_quant_px and perturb_xz_m finite and >= 0, dropout in [0, 1), perturb_yaw_deg in
/// [0, 180], perturb_tilt_deg in [0, 90], noise_corr_share in [0, 1] and > 0 only with
/// noise_corr_px > 0; stereo_baseline_m finite and > 0, stereo_upsample in [1, 4],
/// disparity_offset_px finite, depth_scale in [0.5, 2], miscalibrated_cameras indices of
/// cameras; with the stereo model, disparity_quant_px and noise_corr_share 0. Throws SettingError
/// (core/setting_error.h) on the first problem. (SimulateRig's own check is a programmer's
/// guard with looser bounds.)
void CheckSimOptions(const SimOptions& options);

/// A zero-mean Gaussian field of width x height pixels with unit variance at every pixel,
/// correlated over about corr_px pixels: white N(0, 1) noise on a canvas padded by 3 corr_px,
/// blurred by a normalised Gaussian kernel of standard deviation corr_px (separable), divided
/// by the kernel's norm. Its correlation at a distance of d pixels is exp(-d^2 / (4 corr_px^2)).
/// Row-major; corr_px > 0.
std::vector<double> GaussianNoiseField(int width, int height, double corr_px, SimRng& rng);

/// A simulated rig: the capture, the true and the perturbed extrinsics, and the scene.
struct SimulatedRig {
  RigCapture capture;
  PoseMap gt;    ///< true T_world_camera per serial
  PoseMap init;  ///< perturbed T_world_camera per serial: a refinement's starting point
  Scene scene;
};

/// Serial of simulated camera `index`: 8 digits like a ZED serial, 31000000 + 1117 index,
/// so string order is camera order and camera 0 is the reference.
std::string SimSerial(int index);

/// Pinhole intrinsics of a simulated camera: square pixels, kSimHorizontalFovDeg across the
/// width, principal point at the image centre ((width - 1) / 2, (height - 1) / 2).
PinholeIntrinsics SimIntrinsics(int width, int height);

/// The room SimulateRig simulates for a seed (its `scene`): about 6 x 5 m with 2.5 m walls;
/// unless bare, baseboards, boxes at random yaw, tables with thin legs and a chair, all resting
/// on the floor. Deterministic for a seed (its own random stream).
Scene SimulateRoom(std::uint64_t seed, bool bare);

/// T_world_camera of a camera at centre looking along `forward` (world, not vertical), level
/// (its x axis horizontal, OpenCV axes: x right, y down, z forward, world +Y up), then rolled
/// by `roll` radians about its z axis.
Pose CameraLookingAlong(const Vec3& centre, const Vec3& forward, double roll);

/// The colour of a ray's hit at p_world as the simulator renders it: the box's albedo,
/// Lambertian-like shading lit from above and a little to the side, and a 0.5 m
/// checkerboard on the floor (enough for a person to read the colour images).
std::array<std::uint8_t, 3> ShadeHit(const Scene& scene, const RayHit& hit, const Vec3& p_world);

/// Simulates a rig. The scene is a room of about 6 x 5 m with 2.5 m walls; unless bare, it
/// holds baseboards, boxes at random yaw, tables with thin legs and a chair, all resting on
/// the floor. Cameras stand around the room at 1.8-2.5 m height looking down at the floor
/// near the room centre, with a little roll. Each depth pixel is the z of the first
/// surface hit, plus N(0, (noise z^2)^2), dropped with probability `dropout`, and NaN
/// beyond max_depth_m or where the ray leaves the room. `color` is shaded per surface.
///
/// init = PosePlus(gt, [w, d]) per camera (core/pose.h tangent: world-frame rotation
/// about the camera centre, then a world translation), with w_y (yaw) uniform in
/// +-perturb_yaw_deg, (w_x, w_z) a tilt of uniform magnitude in [0, perturb_tilt_deg]
/// about a random horizontal axis, d_x and d_z uniform in +-perturb_xz_m and d_y uniform
/// in +-perturb_xz_m / 5. Every camera is perturbed, the reference too.
///
/// The same options give bit-identical results on every platform up to the last bit of
/// libm's log, sin and cos (std::mt19937_64 with portable variates, sim/random.h).
/// The room, the cameras, the perturbations and each camera's pixel noise use separate
/// random streams, so e.g. `bare` or `noise` leave the cameras and poses unchanged.
/// Throws std::invalid_argument for options out of range (cameras < 1, width or
/// height < 2, negative or non-finite noise, dropout outside [0, 1), ...).
SimulatedRig SimulateRig(const SimOptions& options);

}  // namespace rigfit
