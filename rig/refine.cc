#include "rig/refine.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <optional>
#include <string>
#include <utility>

#include "core/errors.h"
#include "core/format.h"
#include "core/geometry.h"
#include "core/parallel.h"
#include "core/stopwatch.h"
#include "prepare/correspondences.h"
#include "prepare/preprocess.h"
#include "prepare/region.h"
#include "registration/joint.h"
#include "registration/pairwise.h"
#include "registration/pose_graph.h"
#include "registration/surface_bundle.h"
#include "residuals/relative_pose.h"

namespace rigfit {
namespace {

/// How far above the band the surface bundle takes its pixels: several sigmas of the vertical
/// depth noise at the band's range (k z^2 |ray_y|: about 2 cm at 4 m for k = 0.0025); with more
/// noise the surface bundle's window simply keeps fewer pixels at the band's top.
constexpr double kSurfaceBandExtensionM = 0.1;

/// A warning of the result, also logged (the CLI prints it on stderr).
void Warn(RefineResult* result, const Log& log, std::string message) {
  log.Warning(message);
  result->warnings.push_back(std::move(message));
}

/// The rigid motion G that best explains the change of the connected cameras,
/// refined_i ~ G leveled_i (Gauss-Newton on the tangent residuals PoseDifference(G
/// leveled_i, refined_i); a few steps suffice for the small motions of a refinement).
Pose CommonMotion(const std::vector<Pose>& leveled, const std::vector<Pose>& refined,
                  const std::vector<bool>& connected) {
  constexpr int kSteps = 5;
  Pose G = Pose::Identity();
  for (int step = 0; step < kSteps; ++step) {
    // Moving G by the left tangent step (w, d) about the world origin moves camera i by
    // w in rotation and by d + w x t_i in translation (t_i = its centre under G).
    Mat6 H = Mat6::Zero();
    Vec6 g = Vec6::Zero();
    for (size_t i = 0; i < leveled.size(); ++i) {
      if (!connected[i]) continue;
      const Pose moved = G * leveled[i];
      const Vec6 r = PoseDifference(moved, refined[i]);
      Eigen::Matrix<double, 6, 6> J = Mat6::Identity();
      J.block<3, 3>(3, 0) = -Hat(moved.translation());
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    if (H.isZero()) break;
    const Vec6 delta = H.ldlt().solve(g);
    G = PosePlus(Pose::Identity(), delta) * G;
  }
  return G;
}

/// Why a camera's own change against the rig (after the common motion) exceeds the safety
/// bounds (max_rotation_deg, max_translation_m); empty when it does not.
std::string BoundsViolation(const Vec6& own, const IcpOptions& options) {
  const double rotation_deg = own.head<3>().norm() * kRadToDeg;
  const double translation_m = own.tail<3>().norm();
  if (rotation_deg > options.max_rotation_deg) {
    return "rotation change against the rig " + Fixed(rotation_deg, 3) +
           " deg exceeds max_rotation_deg " + Fixed(options.max_rotation_deg, 3);
  }
  if (translation_m > options.max_translation_m) {
    return "translation change against the rig " + Fixed(translation_m, 4) +
           " m exceeds max_translation_m " + Fixed(options.max_translation_m, 4);
  }
  return "";
}

/// The index of camera `reference` (CheckRefineInput made sure it is there); empty: 0.
int ReferenceIndex(const RigCapture& capture, const std::string& reference) {
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    if (capture.cameras[i].serial == reference) return static_cast<int>(i);
  }
  return 0;
}

/// What the registration stages (joint or pairwise, then the surface bundle) work on.
struct RegistrationInputs {
  const std::vector<RegistrationCamera>& cameras;
  const std::vector<CandidatePair>& candidates;
  const std::vector<Pose>& leveled;
  int reference = 0;
  const IcpOptions& options;
  /// The surface bundle's cameras (icp.surface_bundle), empty without it.
  const std::vector<SurfaceCamera>& surfaces;
  int num_threads = 1;
  const Log& log;
};

/// Says whether a free depth camera's depth model was observable: warned when it was not
/// (held at scale 1, offset 0), logged when it was.
void WarnDepthModel(const CameraReport& camera, const SurfaceCamera& surface, const Log& log,
                    RefineResult* result) {
  if (!surface.free || !surface.ray_model) return;
  const DepthModelEstimate& e = camera.depth_model;
  const std::string name = "camera " + camera.serial + ": depth model ";
  if (e.solved) {
    log.Info(name + "scale " + Fixed(e.scale, 4) + " +- " + Fixed(e.scale_sigma, 4) + ", offset " +
             Fixed(e.offset * 1e3, 3) + " +- " + Fixed(e.offset_sigma * 1e3, 3) + " 1/km" +
             (e.offset_px != 0.0 ? " (" + Fixed(e.offset_px, 3) + " px)" : ""));
    return;
  }
  const std::string why =
      e.offset_prior_sigma == 0.0 || camera.surface_fallback
          ? "its planes do not fix its pose"
          : "its scene does not tell it apart from its pose (1-sigma " +
                (e.scale_prior_sigma > 0.0
                     ? Fixed(e.scale_sigma / e.scale_prior_sigma, 2) + " of the prior's in scale, "
                     : std::string()) +
                Fixed(e.offset_sigma / e.offset_prior_sigma, 2) +
                " in offset; correlation with the pose " + Fixed(e.pose_correlation, 2) + ")";
  Warn(result, log, name + "not observable: " + why + "; held at scale 1, offset 0");
}

/// The surface bundle's cameras at the registration's poses (`joint`), free where it linked
/// them, each with its start's covariance.
std::vector<SurfaceCamera> BundleCameras(const RegistrationInputs& in, const JointResult& joint) {
  std::vector<SurfaceCamera> surfaces = in.surfaces;
  for (size_t i = 0; i < surfaces.size(); ++i) {
    surfaces[i].T_world_camera = joint.poses[i];
    surfaces[i].free = joint.connected[i] && static_cast<int>(i) != in.reference;
    // The start's information is the noise model's: the inflation (uncertainty/inflation.h) and
    // the surfaces' offsets (surface_bias) widen the reported 1-sigma, not the prior that holds
    // the bundle at the joint pose.
    if (joint.covariance_ok) {
      const SigmaInflation& f = joint.sigma_inflation[i];
      surfaces[i].start_covariance =
          Inflated(joint.covariance[i], {1.0 / f.rotation, 1.0 / f.translation});
      surfaces[i].start_inflation = f;
    }
    // A camera the joint solve could not link keeps its leveled pose, which may be far off:
    // its pixels would pull the planes.
    if (!joint.connected[i]) surfaces[i].points.clear();
  }
  return surfaces;
}

/// The surface bundle after the registration (`joint`: the joint solve's result, or the pose
/// graph's poses without a covariance): joint's poses, covariance, inflation and surfaces are
/// replaced where it refined a camera.
void RefineSurfaces(const RegistrationInputs& in, JointResult* joint, RefineResult* result) {
  const IcpOptions& options = in.options;
  const Log& log = in.log;
  std::vector<SurfaceCamera> surfaces = BundleCameras(in, *joint);
  const SurfaceBundleResult bundle = RegisterSurfaceBundle(surfaces, options, in.num_threads, log);
  if (!bundle.usable) {
    Warn(result, log, bundle.message + "; the joint point-to-plane poses stand");
    return;
  }
  SurfaceBundleReport& report = result->surface;
  report.ran = true;
  report.planes = bundle.planes;
  report.pixels = bundle.pixels;
  report.rounds = bundle.rounds;
  report.noise_scale = bundle.noise_scale;
  log.Info("surface bundle: " + std::to_string(bundle.planes) + " planes, " +
           std::to_string(bundle.pixels) + " pixels, " + std::to_string(bundle.rounds) +
           " rounds, noise scale " + Fixed(bundle.noise_scale, 3));
  for (size_t i = 0; i < surfaces.size(); ++i) {
    CameraReport& camera = result->cameras[i];
    camera.surface_thickness_before = bundle.thickness_before[i];
    camera.surface_thickness_after = bundle.thickness_after[i];
    camera.surface_fallback = bundle.fallback[i];
    camera.surface_noise_correlation = bundle.noise_correlation[i];
    camera.depth_model = bundle.depth_model[i];
    if (options.depth_model != CameraDepthModel::kNone)
      WarnDepthModel(camera, surfaces[i], log, result);
    if (bundle.leveled[i]) {
      // The reference, leveled again on the bundle's floor (its yaw and centre held); taken
      // with the safety bounds when another camera is refined (ApplySafetyBounds).
      joint->poses[i] = bundle.poses[i];
      camera.surface_leveled = true;
      continue;
    }
    if (!surfaces[i].free) continue;
    if (bundle.fallback[i]) {
      Warn(result, log,
           "camera " + camera.serial +
               ": too few planes fix its pose for the surface bundle; it keeps its joint "
               "point-to-plane pose");
      continue;  // with the joint covariance
    }
    if (options.hold_weak_directions && i < joint->weak.size() && !joint->weak[i].empty()) {
      log.Info("camera " + camera.serial +
               ": weak directions held (icp.hold_weak_directions); it keeps its joint pose");
      continue;
    }
    // The bundle's change from the joint pose held to the safety bounds here (its gauge is
    // the reference's, which it moves by its leveling alone), so that a camera it moved too far
    // keeps its joint pose, not (as the bounds at the end would have it) its leveled one.
    const std::string violation =
        BoundsViolation(PoseDifference(joint->poses[i], bundle.poses[i]), options);
    if (!violation.empty()) {
      Warn(result, log,
           "camera " + camera.serial + ": surface bundle " + violation +
               "; it keeps its joint point-to-plane pose");
      continue;
    }
    joint->poses[i] = bundle.poses[i];
    joint->covariance[i] = bundle.covariance_ok ? bundle.covariance[i] : Mat6::Zero();
    joint->surface_bias[i] = Mat6::Zero();  // in the bundle's covariance
    joint->sigma_inflation[i] = bundle.sigma_inflation[i];
    joint->surfaces[i] = bundle.surfaces[i];
  }
  if (options.keep_surface_diagnostics) {
    report.plane_list = bundle.plane_list;
    report.terms = bundle.terms;
    for (SurfaceCamera& camera : surfaces) report.points.push_back(std::move(camera.points));
  }
}

/// The surface bundle after the pose graph (which gives no covariance: the bundle starts
/// without a prior); each camera it refined reports the bundle's covariance, inflation and
/// surfaces. Returns the poses.
std::vector<Pose> PairwiseSurfaces(const RegistrationInputs& in, const PoseGraphResult& graph,
                                   RefineResult* result) {
  const size_t n = graph.poses.size();
  JointResult start;
  start.poses = graph.poses;
  start.connected = graph.connected;
  start.covariance.assign(n, Mat6::Zero());
  start.surface_bias.assign(n, Mat6::Zero());
  start.covariance_ok = true;  // zero: none, for the start and for the cameras not refined
  start.sigma_inflation.assign(n, SigmaInflation{});
  start.surfaces.assign(n, 0);
  const auto started = std::chrono::steady_clock::now();
  RefineSurfaces(in, &start, result);
  result->times.registration_s += SecondsSince(started);
  for (size_t i = 0; i < n; ++i) {
    CameraReport& report = result->cameras[i];
    if (start.covariance[i].isZero(0.0)) continue;
    report.has_covariance = true;
    report.covariance = start.covariance[i];
    report.sigma_inflation = start.sigma_inflation[i];
    report.surfaces = start.surfaces[i];
    report.few_surfaces = start.surfaces[i] < kFewSurfaceOrientations;
  }
  return start.poses;
}

/// Pairwise mode: ICP per candidate pair, then the pose graph, then the surface bundle when
/// asked for. Returns refined poses.
std::optional<std::vector<Pose>> RegisterPairwise(const RegistrationInputs& in,
                                                  RefineResult* result) {
  const auto& [cameras, candidates, leveled, reference, options, surfaces, num_threads, log] = in;
  std::vector<PoseGraphEdge> edges;
  for (const CandidatePair& pair : candidates) {
    PairReport& report = result->pairs.emplace_back();
    report.serial_a = result->cameras[pair.a].serial;
    report.serial_b = result->cameras[pair.b].serial;
    report.overlap_area_m2 = pair.overlap_area_m2;
    log.Info("pair " + report.serial_a + " <- " + report.serial_b + ": ICP");
    const auto start = std::chrono::steady_clock::now();
    const PairwiseResult icp =
        RegisterPair(cameras[pair.b], cameras[pair.a], options, num_threads, log);
    result->times.registration_s += SecondsSince(start);
    report.fitness = icp.fitness;
    report.rmse_before_m = icp.rmse_before_m;
    report.rmse_after_m = icp.rmse_after_m;
    report.correspondences = icp.correspondences;
    report.iterations = icp.iterations;
    report.accepted = icp.accepted;
    report.message = icp.message;
    log.Info("pair " + report.serial_a + " <- " + report.serial_b + ": fitness " +
             Fixed(icp.fitness, 3) + ", RMSE " + Fixed(icp.rmse_before_m * 1e3, 2) + " -> " +
             Fixed(icp.rmse_after_m * 1e3, 2) + " mm, " + std::to_string(icp.iterations) +
             " iterations" + (icp.accepted ? "" : ", rejected: " + icp.message));
    if (!icp.accepted) continue;
    edges.push_back({pair.a, pair.b, icp.T_target_source,
                     EdgeInformationFromTangentInformation(icp.information, leveled[pair.a])});
  }
  const auto start = std::chrono::steady_clock::now();
  const PoseGraphResult graph = OptimizePoseGraph(leveled, edges, reference);
  result->times.pose_graph_s = SecondsSince(start);
  for (size_t i = 0; i < leveled.size(); ++i) result->cameras[i].connected = graph.connected[i];
  if (!graph.usable) {
    result->message = "pose graph: " + graph.message;
    return std::nullopt;
  }
  if (surfaces.empty()) return graph.poses;
  return PairwiseSurfaces(in, graph, result);
}

/// The joint solve's per-camera results into the report: connectivity, covariance and weak
/// directions (each warned).
void ReportJointCameras(const JointResult& joint, const IcpOptions& options, const Log& log,
                        RefineResult* result) {
  for (size_t i = 0; i < result->cameras.size(); ++i) {
    CameraReport& report = result->cameras[i];
    report.connected = joint.connected[i];
    report.has_covariance = joint.covariance_ok && joint.connected[i] && !report.reference &&
                            !joint.covariance[i].isZero(0.0);
    report.covariance = joint.covariance[i] + joint.surface_bias[i];
    if (report.reference) continue;
    report.sigma_inflation = joint.sigma_inflation[i];
    report.surfaces = joint.surfaces[i];
    // Shown in the summary ("few"), not warned: on simulated rigs a third of the cameras rest on
    // one orientation with errors no worse than the others' (docs/benchmarks.md).
    report.few_surfaces = joint.connected[i] && joint.surfaces[i] < kFewSurfaceOrientations;
    report.weak_directions = joint.weak[i];
    for (const WeakDirection& d : joint.weak[i]) {
      Warn(result, log,
           "camera " + report.serial + ": " + d.name + " weakly constrained (" +
               Fixed(100.0 * d.strength, 2) +
               "% against the best-constrained direction, threshold " +
               Fixed(100.0 * options.degeneracy_threshold, 2) + "%): " + d.reason +
               (options.hold_weak_directions ? "; held at its leveled pose" : ""));
    }
  }
}

/// Each pair's fit after the joint solve into the report, logged.
void ReportJointPairs(const std::vector<CandidatePair>& candidates, const JointResult& joint,
                      const std::vector<OverlapStats>& overlap, const Log& log,
                      RefineResult* result) {
  for (size_t k = 0; k < candidates.size(); ++k) {
    PairReport& report = result->pairs[k];
    const OverlapStats& after = overlap[k];
    report.fitness = after.fitness;
    report.rmse_after_m = after.rmse_m;
    report.correspondences = joint.pair_correspondences[k];
    report.iterations = joint.iterations;
    report.accepted = joint.connected[candidates[k].a] && joint.connected[candidates[k].b] &&
                      joint.pair_correspondences[k] > 0;
    log.Info("pair " + report.serial_a + " - " + report.serial_b + ": fitness " +
             Fixed(report.fitness, 3) + ", RMSE " + Fixed(report.rmse_before_m * 1e3, 2) + " -> " +
             Fixed(report.rmse_after_m * 1e3, 2) + " mm");
  }
}

std::optional<std::vector<Pose>> RegisterAllJointly(const RegistrationInputs& in,
                                                    RefineResult* result) {
  const auto& [cameras, candidates, leveled, reference, options, surfaces, num_threads, log] = in;
  const size_t finest = options.scales.size() - 1;
  const double coarsest_voxel = options.scales.front() * options.voxel_size;
  // The finest views of a pair at the given poses: (b, a), b the source.
  const auto views = [&](const CandidatePair& pair, const Pose& T_a, const Pose& T_b) {
    return std::make_pair(CameraView{&cameras[pair.b].pyramid->levels[finest], T_b, nullptr,
                                     cameras[pair.b].depth_noise},
                          CameraView{&cameras[pair.a].pyramid->levels[finest], T_a, nullptr,
                                     cameras[pair.a].depth_noise});
  };
  // Registration time includes the pairs' fit before and after, as in the pairwise mode.
  // The pairs in parallel, one search each.
  const int pair_count = static_cast<int>(candidates.size());
  const auto start = std::chrono::steady_clock::now();
  result->pairs.assign(candidates.size(), PairReport{});
  ParallelFor(
      pair_count, num_threads,
      [&](int k) {
        const CandidatePair& pair = candidates[k];
        PairReport& report = result->pairs[k];
        report.serial_a = result->cameras[pair.a].serial;
        report.serial_b = result->cameras[pair.b].serial;
        report.overlap_area_m2 = pair.overlap_area_m2;
        const auto [b, a] =
            views(pair, cameras[pair.a].T_world_camera, cameras[pair.b].T_world_camera);
        report.rmse_before_m = FitRmse(b, a, options, 1);
      },
      /*min_per_thread=*/1);
  log.Info("joint: " + std::to_string(cameras.size()) + " cameras, " +
           std::to_string(candidates.size()) + " pairs");
  JointResult joint = RegisterJoint(cameras, candidates, reference, options, num_threads, log);
  log.Info("joint: " + std::to_string(joint.iterations) + " iterations, correspondences " +
           Fixed(joint.correspondences_s, 3) + " s, solve " + Fixed(joint.solve_s, 3) +
           " s, covariance " + Fixed(joint.covariance_s, 3) + " s");
  if (!surfaces.empty() && joint.usable) RefineSurfaces(in, &joint, result);
  result->times.correspondences_s = joint.correspondences_s;
  result->times.solve_s = joint.solve_s;
  ReportJointCameras(joint, options, log, result);
  std::vector<OverlapStats> overlap(candidates.size());
  ParallelFor(
      pair_count, num_threads,
      [&](int k) {
        const auto [b, a] =
            views(candidates[k], joint.poses[candidates[k].a], joint.poses[candidates[k].b]);
        overlap[k] = MeasureOverlap(b, a, coarsest_voxel, options, 1);
      },
      /*min_per_thread=*/1);
  ReportJointPairs(candidates, joint, overlap, log, result);
  result->times.registration_s = SecondsSince(start);
  if (!joint.usable) {
    result->message = joint.message;
    return std::nullopt;
  }
  return joint.poses;
}

/// The rig after ground leveling, what the later stages of Refine start from (capture order).
struct LeveledRig {
  std::vector<PointCloud> points;   ///< each camera's registration points (camera frame)
  std::vector<Pose> leveled;        ///< each camera's leveled pose (initial where not leveled)
  std::vector<bool> floor_leveled;  ///< whether its floor leveled it (ground accepted)
  std::vector<double> depth_noise;  ///< its depth noise k (CameraDepthNoise)
};

/// Refine's first step, ground leveling: each camera's registration points and leveled pose
/// (the initial one where leveling is off or fails), whether its floor leveled it and its depth
/// noise; fills each camera's serial, reference flag, point count and ground result,
/// result->leveled and the leveling time, and warns of each camera not leveled.
LeveledRig LevelCameras(const RigCapture& capture, const PoseMap& initial,
                        const RefineOptions& options, int reference, const Log& log,
                        RefineResult* result) {
  const auto start = std::chrono::steady_clock::now();
  const size_t n = capture.cameras.size();
  LeveledRig rig;
  std::vector<PointCloud>& points = rig.points;
  std::vector<Pose>& leveled = rig.leveled;
  points.assign(n, PointCloud{});
  leveled.resize(n);
  result->cameras.resize(n);
  for (size_t i = 0; i < n; ++i) leveled[i] = initial.at(capture.cameras[i].serial);
  // The cameras in parallel (each RANSAC has its own seeded generator), then the log in
  // camera order.
  ParallelFor(
      static_cast<int>(n), options.threads,
      [&](int i) {
        const CameraCapture& camera = capture.cameras[i];
        CameraReport& report = result->cameras[i];
        points[i] = RegistrationPoints(camera, options.region);
        report.points = static_cast<int>(points[i].size());
        if (options.ground.enabled) {
          report.ground = LevelCamera(points[i], leveled[i], options.ground);
          leveled[i] = report.ground.T_world_camera;
        }
      },
      /*min_per_thread=*/1);
  for (size_t i = 0; i < n; ++i) {
    const CameraCapture& camera = capture.cameras[i];
    CameraReport& report = result->cameras[i];
    report.serial = camera.serial;
    report.reference = static_cast<int>(i) == reference;
    if (options.ground.enabled) {
      if (report.ground.accepted) {
        log.Info("camera " + camera.serial + ": floor leveled (" +
                 Fixed(report.ground.correction_rotation_deg, 3) + " deg, " +
                 Fixed(report.ground.correction_translation_m * 1e3, 1) + " mm, " +
                 std::to_string(report.ground.inliers) + " inliers)");
      } else {
        Warn(result, log,
             "camera " + camera.serial + ": ground leveling not applied: " + report.ground.message);
      }
    }
    result->leveled[camera.serial] = leveled[i];
    rig.floor_leveled.push_back(report.ground.accepted);
    rig.depth_noise.push_back(CameraDepthNoise(options.icp, camera, report.ground));
  }
  result->times.leveling_s = SecondsSince(start);
  return rig;
}

/// Refine's second step: the near-floor band, the voxel pyramids and the candidate pairs
/// (PrepareRegistration), logged; fills each camera's band point count and the time.
PreparedRig Preprocess(const RigCapture& capture, const LeveledRig& rig,
                       const RefineOptions& options, const Log& log, RefineResult* result) {
  const auto start = std::chrono::steady_clock::now();
  PreparedRig prepared = PrepareRegistration(rig.points, rig.leveled, rig.floor_leveled,
                                             rig.depth_noise, options, options.threads);
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    result->cameras[i].band_points = prepared.band_points[i];
    log.Info("camera " + capture.cameras[i].serial + ": " +
             std::to_string(prepared.band_points[i]) + " band points, " +
             std::to_string(prepared.pyramids[i].levels.back().points.size()) +
             " at the finest voxel");
  }
  result->times.preprocessing_s = SecondsSince(start);
  log.Info(std::to_string(prepared.candidates.size()) + " candidate pairs");
  return prepared;
}

/// A stereo camera's 1-sigma of each surface's inverse-depth offset (CameraView::surface_bias):
/// icp.surface_bias_px of disparity through fx and its baseline (w = d / (fx B)); 0 for a camera
/// without a baseline or depth.
double SurfaceBias(const CameraCapture& camera, const IcpOptions& options) {
  if (!camera.HasDepth() || !(camera.baseline_m > 0.0)) return 0.0;
  return options.surface_bias_px / (camera.intrinsics.fx * camera.baseline_m);
}

/// The surface bundle's cameras: every valid pixel of the band once (pixel stride 1), at
/// the leveled poses.
std::vector<SurfaceCamera> SurfaceCameras(const RigCapture& capture, const LeveledRig& rig,
                                          const RefineOptions& options, int num_threads) {
  const RegionOptions& region = options.region;
  const size_t n = capture.cameras.size();
  std::vector<SurfaceCamera> surfaces(n);
  RegionOptions every_pixel = region;
  every_pixel.pixel_stride = 1;
  // Up to kSurfaceBandExtensionM over the band: the surface bundle keeps the pixels that
  // its planes put inside the band, whatever their noise (SurfaceCamera::points_top).
  RegionOptions band = region;
  if (band.band_height > 0.0) band.band_height += kSurfaceBandExtensionM;
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int i) {
        const CameraCapture& camera = capture.cameras[i];
        surfaces[i].points =
            NearFloorBand(RegistrationPoints(camera, every_pixel), rig.leveled[i], band);
        surfaces[i].T_world_leveled = rig.leveled[i];
        surfaces[i].depth_noise = rig.depth_noise[i];
        surfaces[i].ray_model = camera.HasDepth();
        if (camera.HasDepth()) {
          surfaces[i].pixel_angle = 1.0 / camera.intrinsics.fx;
          surfaces[i].intrinsics = camera.intrinsics;
          surfaces[i].width = camera.width;
          surfaces[i].height = camera.height;
        }
        surfaces[i].baseline_m = camera.baseline_m;
        surfaces[i].surface_bias = SurfaceBias(camera, options.icp);
        surfaces[i].floor_leveled = rig.floor_leveled[i];
        if (band.band_height > 0.0) {
          surfaces[i].band_bottom = -band.band_below;
          surfaces[i].band_top = region.band_height;
          surfaces[i].points_top = band.band_height;
        }
      },
      /*min_per_thread=*/1);
  return surfaces;
}

/// The cameras the registration moves, from their leveled poses; each one's depth noise
/// logged with where it comes from.
std::vector<RegistrationCamera> RegistrationCameras(const RigCapture& capture,
                                                    const std::vector<CloudPyramid>& pyramids,
                                                    const LeveledRig& rig,
                                                    const IcpOptions& options, const Log& log,
                                                    const RefineResult& result) {
  std::vector<RegistrationCamera> cameras(capture.cameras.size());
  for (size_t i = 0; i < cameras.size(); ++i) {
    const GroundResult& ground = result.cameras[i].ground;
    cameras[i] = {&pyramids[i], rig.leveled[i], rig.depth_noise[i],
                  SurfaceBias(capture.cameras[i], options)};
    log.Info("camera " + capture.cameras[i].serial +
             ": depth noise k = " + Fixed(cameras[i].depth_noise, 5) + " /m" +
             (!capture.cameras[i].HasDepth() ? " (points camera: noise floor only)"
              : options.depth_noise > 0.0    ? " (configured)"
              : ground.found                 ? " (measured on the floor)"
                                             : " (no floor: noise floor only)"));
  }
  return cameras;
}

/// Refine's last step, the safety bounds, measured after removing the motion common to the
/// whole rig: a wrong reference pose moves every other camera by its lever arm, which is no
/// reason to distrust them; one camera moving against the others is. Fills each camera's
/// change, acceptance and message, takes the accepted poses into result->refined and warns of
/// each camera kept at its leveled pose; returns how many non-reference cameras moved.
int ApplySafetyBounds(const std::vector<Pose>& leveled, const std::vector<Pose>& refined,
                      const IcpOptions& options, const Log& log, RefineResult* result) {
  const size_t n = leveled.size();
  std::vector<bool> connected(n);
  for (size_t i = 0; i < n; ++i) connected[i] = result->cameras[i].connected;
  const Pose common = CommonMotion(leveled, refined, connected);
  int moved = 0;
  for (size_t i = 0; i < n; ++i) {
    CameraReport& report = result->cameras[i];
    const Vec6 delta = PoseDifference(leveled[i], refined[i]);
    report.delta_rotation_deg = delta.head<3>().norm() * kRadToDeg;
    report.delta_translation_m = delta.tail<3>().norm();
    const Vec6 own = PoseDifference(common * leveled[i], refined[i]);
    report.own_rotation_deg = own.head<3>().norm() * kRadToDeg;
    report.own_translation_m = own.tail<3>().norm();
    if (report.reference) {
      report.accepted = true;
      continue;  // its pose: below
    }
    if (!report.connected) {
      report.message = "not connected to the reference camera by an accepted pair";
    } else if (!refined[i].matrix().allFinite()) {
      report.message = "registration produced a non-finite pose";
    } else if (const std::string violation = BoundsViolation(own, options); !violation.empty()) {
      report.message = violation;
    } else {
      report.accepted = true;
      ++moved;
      result->refined[report.serial] = refined[i];
      continue;
    }
    Warn(result, log, "camera " + report.serial + " keeps its leveled pose: " + report.message);
  }
  // The reference moves only where the surface bundle leveled it again on its floor, and only
  // with a refined camera: when nothing is refined, every camera keeps its leveled pose.
  for (size_t i = 0; i < n; ++i) {
    CameraReport& report = result->cameras[i];
    if (!report.reference || !report.surface_leveled) continue;
    if (moved > 0) {
      result->refined[report.serial] = refined[i];
    } else {
      report.surface_leveled = false;
      report.delta_rotation_deg = 0.0;
      report.delta_translation_m = 0.0;
    }
  }
  return moved;
}

/// Whether pixel (u, v) of a depth image (row-major, w x h, NaN invalid) marks an edge or a hole
/// rim for RegionOptions::edge_margin_px: a valid 4-neighbour farther by more than jump x its
/// depth, or an invalid 4-neighbour that is no isolated dropout (4 or more invalid pixels in
/// that neighbour's 3 x 3).
bool EdgeOrRim(const std::vector<float>& z, int w, int h, int u, int v, double jump) {
  const auto at = [&](int x, int y) { return z[static_cast<size_t>(y) * w + x]; };
  const float here = at(u, v);
  if (!std::isfinite(here)) return false;
  constexpr int kDu[] = {1, -1, 0, 0};
  constexpr int kDv[] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    const int x = u + kDu[k];
    const int y = v + kDv[k];
    if (x < 0 || y < 0 || x >= w || y >= h) continue;
    const float there = at(x, y);
    if (std::isfinite(there)) {
      if (there - here > jump * here) return true;  // the near side of a jump
      continue;
    }
    int invalid = 0;
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx;
        const int yy = y + dy;
        invalid += xx >= 0 && yy >= 0 && xx < w && yy < h && !std::isfinite(at(xx, yy)) ? 1 : 0;
      }
    }
    if (invalid >= 4) return true;
  }
  return false;
}

/// The camera with its depth pixels within `m` pixels of edges and hole rims invalid.
CameraCapture WithoutEdges(const CameraCapture& camera, const RegionOptions& region, int m) {
  const int w = camera.width;
  const int h = camera.height;
  // Marks, then their dilation by m pixels: along rows, then along columns.
  std::vector<char> marked(camera.depth_m.size(), 0), rows(camera.depth_m.size(), 0);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      marked[static_cast<size_t>(v) * w + u] =
          EdgeOrRim(camera.depth_m, w, h, u, v, region.edge_jump);
    }
  }
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      for (int x = std::max(0, u - m); x <= std::min(w - 1, u + m); ++x) {
        if (marked[static_cast<size_t>(v) * w + x]) rows[static_cast<size_t>(v) * w + u] = 1;
      }
    }
  }
  CameraCapture kept = camera;
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      for (int y = std::max(0, v - m); y <= std::min(h - 1, v + m); ++y) {
        if (rows[static_cast<size_t>(y) * w + u]) {
          kept.depth_m[static_cast<size_t>(v) * w + u] = std::numeric_limits<float>::quiet_NaN();
          break;
        }
      }
    }
  }
  return kept;
}

}  // namespace

double CameraDepthNoise(const IcpOptions& options, const CameraCapture& camera,
                        const GroundResult& ground) {
  if (!camera.HasDepth()) return 0.0;
  if (options.depth_noise > 0.0) return options.depth_noise;
  return ground.found ? ground.depth_noise : 0.0;
}

PointCloud RegistrationPoints(const CameraCapture& camera, const RegionOptions& region) {
  // The depth range is a depth sensor's; a points camera's frame may have its origin inside
  // the object (e.g. the Stanford bunny's scans), so it keeps every finite point.
  const UnprojectOptions unproject =
      camera.HasDepth()
          ? UnprojectOptions{region.pixel_stride, region.min_depth_m, region.max_depth_m}
          : UnprojectOptions{1, -std::numeric_limits<double>::infinity(),
                             std::numeric_limits<double>::infinity()};
  const bool stereo = camera.baseline_m > 0.0 && camera.width >= region.stereo_edge_min_width_px;
  const int margin = stereo ? std::max(region.edge_margin_px, region.stereo_edge_margin_px)
                            : region.edge_margin_px;
  if (camera.HasDepth() && margin > 0) {
    return CameraPoints(WithoutEdges(camera, region, margin), unproject);
  }
  return CameraPoints(camera, unproject);
}

PreparedRig PrepareRegistration(const std::vector<PointCloud>& points,
                                const std::vector<Pose>& leveled,
                                const std::vector<bool>& floor_leveled,
                                const std::vector<double>& depth_noise,
                                const RefineOptions& options, int num_threads) {
  const size_t n = points.size();
  std::vector<double> voxel_sizes;
  for (double s : options.icp.scales) voxel_sizes.push_back(s * options.icp.voxel_size);
  PreparedRig rig;
  rig.pyramids.resize(n);
  rig.band_points.resize(n);
  std::vector<GroundBox> boxes(n);
  // The cameras in parallel, the threads left over within each camera: downsampling and
  // tree building run on one thread per camera.
  const int camera_threads = std::max(1, std::min(static_cast<int>(n), num_threads));
  const int threads_per_camera = std::max(1, num_threads / camera_threads);
  ParallelFor(
      static_cast<int>(n), camera_threads,
      [&](int i) {
        const PointCloud band = NearFloorBand(points[i], leveled[i], options.region);
        rig.band_points[i] = static_cast<int>(band.size());
        boxes[i] = RobustGroundBox(Transform(leveled[i], band));
        rig.pyramids[i] =
            BuildPyramid(band, voxel_sizes, options.icp.normal_neighbors, Vec3::Zero(),
                         options.icp.max_correspondence_distance_factor, threads_per_camera);
        if (floor_leveled[i]) {
          SnapFloorNormals(&rig.pyramids[i], FloorModel{leveled[i], depth_noise[i],
                                                        options.ground.ransac_distance_m});
        }
      },
      /*min_per_thread=*/1);
  rig.candidates =
      FindCandidatePairs(boxes, options.icp.overlap_margin, options.icp.min_overlap_area);
  return rig;
}

void CheckRefineInput(const RigCapture& capture, const PoseMap& initial,
                      const RefineOptions& options, const RefineInputNames& names) {
  std::vector<std::string> serials;
  std::vector<std::string> missing;
  for (const CameraCapture& camera : capture.cameras) {
    serials.push_back(camera.serial);
    if (initial.count(camera.serial) == 0) missing.push_back(camera.serial);
  }
  std::vector<std::string> extra;
  for (const auto& [serial, pose] : initial) {
    if (std::find(serials.begin(), serials.end(), serial) == serials.end()) {
      extra.push_back(serial);
    }
  }
  std::vector<std::string> problems;
  if (!missing.empty()) {
    problems.push_back(names.extrinsics + " has no pose for camera(s) " + Join(missing) + " of " +
                       names.capture);
  }
  if (!extra.empty()) {
    problems.push_back(names.extrinsics + " has pose(s) for camera(s) " + Join(extra) + " that " +
                       names.capture + " does not hold");
  }
  const std::string& reference = options.icp.reference;
  if (!reference.empty() && std::find(serials.begin(), serials.end(), reference) == serials.end()) {
    problems.push_back(names.reference + " '" + reference + "' is not a camera of " +
                       names.capture + " (cameras: " + Join(serials) + ")");
  }
  if (!problems.empty()) throw InputError(names.command + ": " + Join(problems, "; "));
}

RefineResult Refine(const RigCapture& capture, const PoseMap& initial, const RefineOptions& options,
                    const Log& log) {
  CheckRefineInput(capture, initial, options);
  const int num_threads = options.threads;
  RefineResult result;
  const size_t n = capture.cameras.size();
  result.reference = options.icp.reference.empty() && n > 0 ? capture.cameras.front().serial
                                                            : options.icp.reference;
  const int reference = ReferenceIndex(capture, result.reference);

  const LeveledRig rig = LevelCameras(capture, initial, options, reference, log, &result);
  const std::vector<Pose>& leveled = rig.leveled;
  result.refined = result.leveled;
  if (!options.run_registration) {
    result.success = true;
    result.message = "leveling only";
    return result;
  }
  if (n < 2) {
    result.message = "nothing to register: the capture has one camera";
    Warn(&result, log, result.message);
    return result;
  }

  result.icp_ran = true;
  result.mode = options.icp.mode;
  result.method = options.icp.method;
  const PreparedRig prepared = Preprocess(capture, rig, options, log, &result);
  const std::vector<SurfaceCamera> surfaces =
      options.icp.surface_bundle ? SurfaceCameras(capture, rig, options, num_threads)
                                 : std::vector<SurfaceCamera>{};
  const std::vector<RegistrationCamera> cameras =
      RegistrationCameras(capture, prepared.pyramids, rig, options.icp, log, result);
  const RegistrationInputs inputs{cameras,  prepared.candidates, leveled, reference, options.icp,
                                  surfaces, num_threads,         log};
  const std::optional<std::vector<Pose>> registered = options.icp.mode == RefineMode::kJoint
                                                          ? RegisterAllJointly(inputs, &result)
                                                          : RegisterPairwise(inputs, &result);
  if (!registered) {
    for (CameraReport& report : result.cameras) {
      if (!report.reference) report.message = "registration failed: " + result.message;
    }
    Warn(&result, log,
         "registration failed, every camera keeps its leveled pose: " + result.message);
    return result;
  }
  const int moved = ApplySafetyBounds(leveled, *registered, options.icp, log, &result);
  result.success = moved > 0;
  if (result.message.empty()) {
    result.message = result.success ? "refined " + std::to_string(moved) + " of " +
                                          std::to_string(n - 1) + " non-reference cameras"
                                    : "no camera could be refined";
  }
  return result;
}

}  // namespace rigfit
