// `rigfit refine`: load-independent pipeline from a rig capture and initial extrinsics to
// refined extrinsics: ground leveling, near-floor band, preprocessing, candidate pairs,
// then pairwise (ICP + pose graph) or joint registration, and the safety bounds.
#pragma once

#include <string>
#include <vector>

#include "core/log.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/ground.h"
#include "prepare/preprocess.h"
#include "prepare/region.h"
#include "registration/surface_bundle.h"
#include "uncertainty/degeneracy.h"
#include "uncertainty/inflation.h"

namespace rigfit {

struct CameraReport {
  std::string serial;
  bool reference = false;
  GroundResult ground;              ///< leveling of this camera (found = false when disabled)
  int points = 0;                   ///< valid points used for leveling
  int band_points = 0;              ///< points of the near-floor band
  bool connected = false;           ///< linked to the reference by accepted pairs
  bool accepted = false;            ///< registration change applied
  double delta_rotation_deg = 0.0;  ///< registration change (refined vs leveled)
  double delta_translation_m = 0.0;
  /// The change after removing the motion common to the whole rig (what the safety
  /// bounds max_rotation_deg and max_translation_m apply to).
  double own_rotation_deg = 0.0;
  double own_translation_m = 0.0;
  std::string message;  ///< why the change was not applied
  /// Joint mode: covariance of the refined pose in the PoseManifold tangent (world
  /// rotation vector, world translation), gauge fixed by the reference.
  bool has_covariance = false;
  Mat6 covariance = Mat6::Zero();
  /// Joint mode: how much what the residuals show (correlated noise, surfaces' bias) raised the
  /// noise model's 1-sigma in `covariance` (docs/uncertainty.md, "Inflation"; the surface
  /// bundle's cameras: its pixels' design effect and its start's inflation, at least its planes'
  /// cluster-robust covariance; docs/uncertainty.md section 10), 1 without a covariance.
  SigmaInflation sigma_inflation;
  /// Joint mode: the distinct orientations of the surfaces the pose rests on (the surface
  /// bundle's planes for the cameras it refined), and whether they are fewer than
  /// kFewSurfaceOrientations: one surface's bias then moves the pose whole, and the 1-sigma
  /// cannot show it (warned).
  int surfaces = 0;
  bool few_surfaces = false;
  /// Joint mode: directions the correspondences barely constrain (reported as a warning;
  /// held at the leveled pose with icp.hold_weak_directions).
  std::vector<WeakDirection> weak_directions;
  /// Surface bundle: RMS whitened residual of the camera's pixels on the planes, at the joint
  /// start and at the end (0 when it did not run), and whether the camera kept its joint
  /// pose because its planes did not fix it.
  double surface_thickness_before = 0.0;
  double surface_thickness_after = 0.0;
  bool surface_fallback = false;
  /// Surface bundle: the noise's spatial correlation measured on the camera's residuals, the
  /// variance of a 32 x 32 pixel tile's sum against independent pixels' (1: independent;
  /// stereo depth: tens). Its pixels were weighted down by it (SurfaceBundleResult).
  double surface_noise_correlation = 0.0;
  /// Surface bundle, the reference: its tilt leveled again on the bundle's floor (its yaw and
  /// centre held).
  bool surface_leveled = false;
  /// Surface bundle with icp.depth_model: the camera's depth model and whether its scene could
  /// tell it apart from its pose (not solved: scale 1, offset 0).
  DepthModelEstimate depth_model;
};

/// What the surface bundle did (icp.surface_bundle).
struct SurfaceBundleReport {
  bool ran = false;
  int planes = 0;
  int pixels = 0;
  int rounds = 0;
  /// sqrt(cost / (N - p)): the residuals' spread against the noise model; near 1 when the
  /// model's k is right. k measured = noise_scale * k of the model.
  double noise_scale = 0.0;
  /// Only with icp.keep_surface_diagnostics (empty otherwise): the last round's planes, per
  /// (camera, plane) the indices into that camera's `points` of the pixels it used
  /// (SurfaceBundleResult::plane_list, terms), and per camera (capture order) the band pixels
  /// the bundle was given (camera frame; none for a camera the joint solve did not link).
  std::vector<PlanarFace> plane_list;
  std::vector<SurfaceTerm> terms;
  std::vector<PointCloud> points;
};

struct PairReport {
  std::string serial_a;  ///< target (held still in pairwise ICP)
  std::string serial_b;  ///< source
  double overlap_area_m2 = 0.0;
  double fitness = 0.0;
  double rmse_before_m = 0.0;
  double rmse_after_m = 0.0;
  int correspondences = 0;
  int iterations = 0;
  bool accepted = false;
  std::string message;
};

struct StageTimes {
  double leveling_s = 0.0;
  double preprocessing_s = 0.0;
  double registration_s = 0.0;     ///< correspondences, solves and the pairs' fit metrics
  double correspondences_s = 0.0;  ///< of which correspondence search (joint mode)
  double solve_s = 0.0;            ///< of which building and solving the problem (joint)
  double pose_graph_s = 0.0;
};

struct RefineResult {
  PoseMap leveled;  ///< after ground leveling
  PoseMap refined;  ///< the output extrinsics
  std::string reference;
  RefineMode mode = RefineMode::kJoint;  ///< the registration mode that ran
  RegistrationMethod method = RegistrationMethod::kPointToPlane;
  bool icp_ran = false;  ///< false: leveling only (run_icp false or a single camera)
  bool success = false;  ///< false: the refinement was not applied (refined == leveled)
  std::string message;
  std::vector<std::string> warnings;
  std::vector<CameraReport> cameras;  ///< in capture order (by serial)
  std::vector<PairReport> pairs;
  SurfaceBundleReport surface;
  StageTimes times;
};

/// The depth noise k of a camera: configured, or measured on its floor, or 0. The stereo
/// model sigma_z = k z^2 along the ray assumes the frame's origin is the sensor and z its
/// depth, which a points camera (scanner frames, fused fragments) does not promise: its
/// correspondences use icp.min_noise_m alone (k = 0).
double CameraDepthNoise(const IcpOptions& options, const CameraCapture& camera,
                        const GroundResult& ground);

/// The camera-frame points the pipeline uses: a depth camera's valid pixels at the region's
/// stride and within its depth range, away from edges and hole rims when the region says so
/// (RegionOptions::edge_margin_px); every finite point of a points camera.
PointCloud RegistrationPoints(const CameraCapture& camera, const RegionOptions& region);

/// The registration inputs of a rig at its leveled poses: each camera's near-floor band
/// (NearFloorBand), its voxel pyramid (floor normals snapped to the leveled floor where
/// floor_leveled, SnapFloorNormals) and the candidate pairs (FindCandidatePairs).
struct PreparedRig {
  std::vector<CloudPyramid> pyramids;
  std::vector<int> band_points;
  std::vector<CandidatePair> candidates;
};
PreparedRig PrepareRegistration(const std::vector<PointCloud>& points,
                                const std::vector<Pose>& leveled,
                                const std::vector<bool>& floor_leveled,
                                const std::vector<double>& depth_noise,
                                const RefineOptions& options, int num_threads);

/// How CheckRefineInput names the inputs in its messages: the CLI passes file names and the
/// option that set the reference; a library caller may keep the defaults.
struct RefineInputNames {
  std::string command = "refine";
  std::string capture = "the capture";
  std::string extrinsics = "the initial extrinsics";
  std::string reference = "icp.reference";
};

/// Throws InputError (one message listing every problem, prefixed "<command>: ") when a camera
/// of the capture has no pose in `initial`, a pose names no camera of the capture, or
/// options.icp.reference is set and is not a camera of the capture.
void CheckRefineInput(const RigCapture& capture, const PoseMap& initial,
                      const RefineOptions& options, const RefineInputNames& names = {});

/// Runs the pipeline. Calls CheckRefineInput first (InputError on inputs that do not match).
/// options.run_registration false stops after leveling; options.threads threads. Progress and
/// warnings go to `log` (none by default). Never throws on bad geometry: the result says what
/// was and was not applied.
RefineResult Refine(const RigCapture& capture, const PoseMap& initial, const RefineOptions& options,
                    const Log& log = Log{});

}  // namespace rigfit
