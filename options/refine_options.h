// Options of every refine stage: plain structs whose in-class defaults are the single
// source of truth (configs/default.yaml and docs/config.md list the same values).
// Sections map one to one to the YAML config: ground:, region:, icp:.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace rigfit {

enum class RefineMode { kJoint, kPairwise };
/// The residual of the registration (joint or pairwise): point-to-plane or GICP.
enum class RegistrationMethod { kPointToPlane, kGicp };
/// How a depth camera's noise behaves (the surface bundle's inverse-depth residual): Gaussian
/// in depth (rigfit's simulator, many SDK depth maps) or Gaussian in disparity (raw stereo).
enum class DepthNoiseModel { kGaussianDepth, kDisparity };
/// Surface bundle: the per-camera depth model estimated with the poses (docs/residuals.md,
/// "Depth model"): none, an offset in inverse depth, or a scale and an offset.
enum class CameraDepthModel { kNone, kOffset, kScaleOffset };
/// Surface bundle: where its last round's non-floor faces come from: the segmentation's planes
/// with each pixel assigned by its ray (registration/ray_membership.h), or the faces found in
/// each depth camera's image (registration/image_faces.h).
enum class SurfaceFaces { kRays, kImage };
enum class RobustLoss { kHuber, kCauchy, kTukey, kNone };

/// Ground leveling: RANSAC floor per camera, pose corrected so the floor is y = 0, +Y up.
struct GroundOptions {
  bool enabled = true;
  /// Only planes whose normal is within this angle of world +Y (at the initial pose) count.
  double max_normal_angle_deg = 20.0;
  /// RANSAC inlier distance to the plane.
  double ransac_distance_m = 0.02;
  int ransac_iterations = 500;
  /// The floor is searched among the points at most this far above the lowest ones.
  double search_height_m = 0.5;
  /// A floor needs at least this many inlier points.
  int min_inliers = 500;
  /// Corrections beyond these are rejected for that camera (pose kept, warning).
  double max_rotation_deg = 10.0;
  double max_translation_m = 0.5;
  std::uint64_t seed = 0;
};

/// Which points take part in registration.
struct RegionOptions {
  /// The near-floor band: from band_below under the floor to band_height above it.
  /// band_height 0 means the whole cloud (scenes without a floor).
  double band_below = 0.05;
  double band_height = 0.3;
  /// Depth pixels used: every pixel_stride-th in u and v, within [min_depth_m, max_depth_m].
  int pixel_stride = 2;
  double min_depth_m = 0.2;
  double max_depth_m = 10.0;
  /// Depth pixels within edge_margin_px pixels of a depth jump (a 4-neighbour farther by more
  /// than edge_jump x its depth) or of the rim of a hole (an invalid neighbour with at least 4
  /// invalid pixels around it: not an isolated dropout) are left out; 0 keeps them all.
  /// Block-matched depth fattens edges and leaves unreliable rims around its holes.
  int edge_margin_px = 0;
  /// The margin of a stereo camera (one whose capture gives its baseline_m: its depth is
  /// matched disparity) at least stereo_edge_min_width_px wide, when larger than
  /// edge_margin_px. Block matching's windows carry the near surface's disparity past its edge
  /// (edge fattening), which biases the faces beside the jump; other depth cameras, and
  /// narrower stereo images, keep edge_margin_px (their thin faces, a few pixels wide, are
  /// worth more than their edge pixels cost). Measured: docs/benchmarks.md, "Four families".
  int stereo_edge_margin_px = 2;
  int stereo_edge_min_width_px = 640;
  double edge_jump = 0.05;
};

/// Registration refinement (joint or pairwise).
struct IcpOptions {
  RefineMode mode = RefineMode::kJoint;
  RegistrationMethod method = RegistrationMethod::kPointToPlane;
  /// The stage after the registration (joint or pairwise): the surface bundle refines every
  /// camera and the planar surfaces they see in one problem, starting from the registered
  /// poses (registration/surface_bundle.h, docs/residuals.md "Surface bundle"). It levels the
  /// reference's tilt again on the floor the cameras share (its yaw and centre held).
  bool surface_bundle = true;
  /// Finest voxel size; the scales multiply it, coarse to fine.
  double voxel_size = 0.02;
  std::vector<double> scales = {4.0, 2.0, 1.0};
  /// Iteration cap per scale (same length as scales). The finest is low on purpose: on noisy
  /// depth its correspondences creep away from the truth a little at every outer iteration
  /// (docs/benchmarks.md, "finest-scale iterations"); noise-free rigs converge before it.
  std::vector<int> max_iterations = {50, 30, 5};
  /// Correspondences farther than factor x voxel size (at the current scale) are dropped.
  double max_correspondence_distance_factor = 1.4;
  /// Correspondences whose two normals differ by more than this, plus the expected error of
  /// both normals under the depth noise (up to 60 degrees in all; a larger angle is not
  /// widened), are dropped.
  double max_normal_angle_deg = 30.0;
  /// Neighbours used for normals and covariances.
  int normal_neighbors = 20;
  /// Depth noise k of the stereo model sigma_z = k z^2 (1/m) used to weight every
  /// correspondence; 0 measures it per camera on its floor (cameras without a floor then
  /// use min_noise_m alone).
  double depth_noise = 0.0;
  /// Noise floor of every correspondence residual (m): model error of the local plane.
  double min_noise_m = 0.001;
  /// Share of each point's depth noise k z^2 that enters its residual's sigma whatever the
  /// surface's orientation: the error of a local plane fitted to noisy neighbours (normal,
  /// offset along the surface). With 0, points seen at grazing angles (no depth noise along
  /// their normal) get weights far above what they deserve; 0 for noise-free depth changes
  /// nothing. docs/residuals.md section 8, docs/benchmarks.md.
  double plane_noise_share = 0.5;
  /// Weight of the pitch/roll gravity prior, 1 / sigma_tilt in 1/rad against residuals
  /// whitened by the noise model; 0 disables it. 1500: sigma_tilt = 0.04 deg, how far a
  /// plane fitted to a few metres of real floor (flat to about 3 mm over 4 m) can tilt.
  double gravity_weight = 1500.0;
  /// Joint mode: a direction of a camera's pose whose information is below this fraction
  /// of the best-constrained direction's (eigenvalues of the noise-weighted constraint
  /// matrix, uncertainty/degeneracy.h) is reported as weakly constrained; 0 turns the analysis
  /// off.
  double degeneracy_threshold = 0.002;
  /// Joint mode: hold weakly constrained directions at the leveled pose (a 0.1 mm prior)
  /// instead of letting the weak data move them. Off by default: on the bare simulated
  /// room it kept more of the start error than it prevented (docs/benchmarks.md).
  bool hold_weak_directions = false;
  /// Surface bundle (surface_bundle true): the depth cameras' noise model. With noise
  /// Gaussian in depth the inverse depth 1/z is biased by k^2 z, which the residual removes;
  /// with disparity noise it is not (docs/residuals.md, "Surface bundle").
  DepthNoiseModel depth_noise_model = DepthNoiseModel::kGaussianDepth;
  /// Surface bundle: rounds of segmentation and solve after the joint point-to-plane start.
  int surface_rounds = 3;
  /// Surface bundle: the last round's faces other than the floor: the segmentation's planes,
  /// pixels by their rays (kRays), or the faces grown in each depth camera's image up to their
  /// creases and associated across cameras (kImage; the floor's pixels stay by their rays). A
  /// rig with a camera without a depth image keeps kRays (docs/uncertainty.md section 10).
  SurfaceFaces surface_faces = SurfaceFaces::kRays;
  /// Surface bundle: each free depth camera's measured inverse depth read as alpha w + beta,
  /// alpha and beta estimated with the poses (the reference's held at 1 and 0), with priors of
  /// 1-sigma depth_scale_sigma (alpha about 1) and depth_offset_sigma_px of disparity (beta
  /// about 0; through fx and the camera's baseline_m, without one the scale prior's effect at
  /// the camera's mean inverse depth). A camera whose scene cannot tell its model apart from
  /// its pose keeps 1 and 0 (reported). Off by default: it measured worse on stereo rigs
  /// (docs/benchmarks.md).
  CameraDepthModel depth_model = CameraDepthModel::kNone;
  double depth_scale_sigma = 0.01;
  double depth_offset_sigma_px = 0.2;
  /// Stereo cameras (a baseline_m in the capture): the 1-sigma (px) of the disparity offset
  /// each surface has, the same over the surface (block matching's bias on slanted and
  /// differently textured surfaces), which no number of pixels averages away and a camera on
  /// few surfaces absorbs into its pose. It widens the reported 1-sigma (joint and surface
  /// bundle covariances), not the poses; 0: none (docs/uncertainty.md, "Surface bias").
  double surface_bias_px = 0.1;
  /// Surface bundle: keep its last round's planes and pixels in RefineResult::surface
  /// (SurfaceBundleReport::plane_list, terms, points) for a caller that looks inside it
  /// (bench/rig_accuracy --segmentation, the reports' 3-D view of the planes). The refinement is
  /// the same either way; off, no pixel is copied. Asked for in code, not a config key.
  bool keep_surface_diagnostics = false;
  RobustLoss robust_loss = RobustLoss::kHuber;
  /// Scale of the robust loss on whitened residuals, in standard deviations.
  double robust_loss_scale = 2.0;
  /// A pair needs this overlap (OverlapStats::fitness) to link its cameras: pairwise ICP, and
  /// the joint mode at the start of its first and of its finest scale.
  double min_fitness = 0.3;
  /// Candidate pairs: world XZ boxes inflated by overlap_margin must intersect by at least
  /// min_overlap_area.
  double overlap_margin = 0.5;
  double min_overlap_area = 1.0;
  /// Camera held constant (gauge); empty means the first serial.
  std::string reference;
  /// A camera whose change against the rig (after removing the motion common to all
  /// connected cameras) exceeds these keeps its leveled pose (warning). They must admit
  /// the corrections of the rough starts rigfit supports, +-3 deg of yaw and +-10 cm in x
  /// and z on every camera. A camera's change against the rig includes its share of the
  /// others' errors (the common motion is fitted to all of them): 0.2 m covers the
  /// benchmarked starts (largest 0.12 m), not every corner of that range on every rig.
  double max_rotation_deg = 5.0;
  double max_translation_m = 0.2;
};

struct RefineOptions {
  GroundOptions ground;
  RegionOptions region;
  IcpOptions icp;
  /// The stages: false stops after leveling (`rigfit refine --no-icp`).
  bool run_registration = true;
  /// Threads of the solve (`--threads`), 1 to kMaxRefineThreads; a run's result does not
  /// depend on it.
  int threads = 2;
};

constexpr int kMaxRefineThreads = 256;

/// Every out-of-range or inconsistent value, one human-readable line each naming the key
/// as in the config file (e.g. "icp.voxel_size must be > 0, got -1"). Empty when valid.
std::vector<std::string> OptionProblems(const RefineOptions& options);

}  // namespace rigfit
