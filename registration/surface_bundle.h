// The surface bundle (icp.surface_bundle): the poses of every camera AND the planar
// surfaces they see are the unknowns of one Ceres problem, every valid pixel of the band
// entering once through a residual exact for noise along the viewing ray
// (residuals/plane_cluster.h, docs/residuals.md "Surface bundle"). It starts from the joint
// point-to-plane solve (within about a centimetre), then for a few rounds: segments the merged
// world cloud into planes (registration/plane_segmentation.h) at the current poses, with a model
// error that shrinks from round to round, and solves poses and planes together, the planes
// eliminated by the Schur complement. Each non-floor plane keeps the pixels that its plane
// puts inside the band (not those whose measured height is inside: the noise would tilt the
// plane). The floor is one plane with its normal held at +Y; the gravity prior stays for
// every camera. Along the directions where the planes know a camera's pose less well than
// the start does (planes do not see their boundaries), the start holds it as a prior with its
// covariance. A camera whose planes do not fix all six directions (fewer than three planes,
// or normals that do not span space) keeps its start pose. The reference keeps its yaw and
// centre (the gauge); after each round its tilt is leveled again on the bundle's floor.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "uncertainty/inflation.h"

namespace rigfit {

struct SurfaceCamera {
  PointCloud points;                        ///< band points, camera frame, every valid pixel once
  Pose T_world_camera = Pose::Identity();   ///< start (the joint solve's result)
  Pose T_world_leveled = Pose::Identity();  ///< for the gravity prior
  double depth_noise = 0.0;                 ///< k of sigma_z = k z^2 (0: icp.min_noise_m alone)
  bool ray_model = true;                    ///< a depth camera; false: a points camera
  /// The angle of one pixel (1 / fx, radians) for the noise's spatial correlation
  /// (SurfaceBundleResult::noise_correlation); 0: not measured (each pixel independent).
  double pixel_angle = 0.0;
  /// A depth camera's image, for the faces found in it (IcpOptions::surface_faces; width 0:
  /// none, the rig keeps the faces by rays).
  PinholeIntrinsics intrinsics;
  int width = 0;
  int height = 0;
  /// A stereo camera's baseline (m; 0: unknown): its depth model's offset prior is in pixels of
  /// disparity through it and pixel_angle (IcpOptions::depth_offset_sigma_px).
  double baseline_m = 0.0;
  /// The 1-sigma of each surface's offset in its inverse depth (1/m; CameraView::surface_bias):
  /// in the reported covariance, not the weights.
  double surface_bias = 0.0;
  bool floor_leveled = false;  ///< its floor was leveled to y = 0 (the floor is then known)
  bool free = false;           ///< estimated (connected, not the reference)
  /// The near-floor band (world heights at the leveled pose, region.band_below and
  /// region.band_height; infinite: no band), and the top up to which `points` were taken
  /// (above band_top, so that the pixels whose plane puts them inside the band are there
  /// whatever their noise: registration/surface_bundle.cc, PredictedHeightWindow).
  double band_bottom = -std::numeric_limits<double>::infinity();
  double band_top = std::numeric_limits<double>::infinity();
  double points_top = std::numeric_limits<double>::infinity();
  /// The start's covariance (PoseManifold tangent; zero: none): the start enters as a prior
  /// with it (RegisterSurfaceBundle).
  Mat6 start_covariance = Mat6::Zero();
  /// How much larger the start's errors are than start_covariance says (the joint solve's
  /// sigma_inflation): the reported covariance counts the start's prior with it, the prior
  /// itself does not (its weight stays the noise model's).
  SigmaInflation start_inflation;
};

/// A camera's depth model (IcpOptions::depth_model): its measured inverse depth w read as
/// scale * w + offset.
struct DepthModelEstimate {
  /// Solved for with the poses (a free depth camera that its planes fix, icp.depth_model on).
  bool solved = false;
  /// Its scene tells the model apart from its pose: each estimated parameter's 1-sigma (planes
  /// and poses marginalised) at most kDepthObservableSigmaRatio of its prior's. Otherwise it
  /// was held at scale 1, offset 0 and the poses solved again.
  bool observable = false;
  double scale = 1.0;
  double offset = 0.0;     ///< in inverse depth, 1/m
  double offset_px = 0.0;  ///< offset * fx * baseline_m: the disparity offset (0: no baseline)
  /// The 1-sigma of scale and offset from the data and the prior (0: held), and the prior's.
  double scale_sigma = 0.0;
  double offset_sigma = 0.0;
  double scale_prior_sigma = 0.0;
  double offset_prior_sigma = 0.0;
  /// The largest |correlation| of the estimated parameters with the camera's six pose
  /// directions.
  double pose_correlation = 0.0;
};

/// The largest ratio of a depth model parameter's 1-sigma to its prior's for the model to count
/// as observable: the data hold at least 3 times the prior's information about it.
constexpr double kDepthObservableSigmaRatio = 0.5;

/// One camera's pixels (indices into SurfaceCamera::points) on one plane.
struct SurfaceTerm {
  int camera = 0;
  int plane = 0;
  std::vector<int> pixels;
};

struct SurfaceBundleResult {
  /// Refined; cameras that are not free or fell back as given, but the reference's tilt, leveled
  /// again on the bundle's floor when it sees it (its yaw and centre as given).
  std::vector<Pose> poses;
  bool usable = false;
  std::string message;
  /// Per camera: held at its start pose because its planes do not fix its pose.
  std::vector<bool> fallback;
  /// Per camera: not free (the reference) and its tilt leveled again on the bundle's floor.
  std::vector<bool> leveled;
  /// Per camera: 6x6 covariance (PoseManifold tangent, planes marginalised, scaled by
  /// noise_scale^2); zero when unavailable.
  std::vector<Mat6> covariance;
  bool covariance_ok = false;
  /// Per free camera: how much the reported covariance raised the noise model's 1-sigma (the
  /// pixels' design effect, the start's inflation, at least the planes' cluster-robust
  /// covariance: docs/uncertainty.md section 10; uncertainty/inflation.h; 1 elsewhere), and the
  /// distinct orientations of the planes its pixels are on, weighted by its pixels
  /// (SurfaceOrientations; 0 for a camera on none).
  std::vector<SigmaInflation> sigma_inflation;
  std::vector<int> surfaces;
  /// Per camera: RMS whitened residual of its pixels on the planes at the start and at the
  /// end ("plane thickness" in standard deviations; near 1 when the noise model holds).
  std::vector<double> thickness_before;
  std::vector<double> thickness_after;
  /// sqrt(cost / (N - p)) at the end: the measured noise against the model's (N pixels,
  /// p parameters); the depth noise the data show is noise_scale * k.
  double noise_scale = 0.0;
  /// Per camera: how many pixels' worth of variance the noise of a tile of 32 x 32
  /// pixels on one plane has per pixel (1: independent pixels; stereo
  /// block matching, whose errors are correlated over a few pixels, gives tens). Measured on
  /// the residuals of each round; the next round's pixels of that camera each count as
  /// 1 / noise_correlation of a pixel, so that the covariance is not that many times too
  /// optimistic and a camera with correlated noise weighs what its data are worth.
  std::vector<double> noise_correlation;
  /// Per camera: its depth model (scale 1, offset 0 and not solved when icp.depth_model is none,
  /// for the reference, points cameras and cameras that fell back).
  std::vector<DepthModelEstimate> depth_model;
  int planes = 0;  ///< in the last round
  /// The last round's planes (world, n^T x + d = 0) and, per (camera, plane), the indices
  /// into that camera's SurfaceCamera::points of the pixels it used: for diagnostics
  /// (bench/rig_accuracy --segmentation compares them with the simulator's faces). Filled
  /// only with options.keep_surface_diagnostics: no refinement needs the copy of every pixel
  /// index.
  using Term = SurfaceTerm;
  std::vector<PlanarFace> plane_list;
  std::vector<Term> terms;
  int pixels = 0;  ///< in the last round's clusters
  int rounds = 0;
};

/// Refines the free cameras. Never throws on bad geometry. The solve is single-threaded, so
/// that its digits do not depend on the threads (Ceres' multi-threaded Schur elimination sums
/// in the order its threads finish; the problem it solves is small); num_threads share out the
/// cameras and planes of the last round's assignment by rays (registration/ray_membership.h), whose
/// result does not depend on them.
SurfaceBundleResult RegisterSurfaceBundle(const std::vector<SurfaceCamera>& cameras,
                                          const IcpOptions& options, int num_threads,
                                          const Log& log);

}  // namespace rigfit
