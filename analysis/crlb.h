// The Cramer-Rao bound of a rig: the covariance of the best unbiased estimate of the camera
// poses that the joint problem's data could give, and the errors such an estimator would
// show when measured like the benchmarks measure rigfit (core/evaluate.h).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "analysis/correlated_noise.h"
#include "core/evaluate.h"
#include "core/types.h"
#include "options/refine_options.h"

namespace rigfit {

/// The residual noise floor of the bounds that `rigfit simulate --crlb` and the benchmarks
/// report (m): the simulator's depth noise has none, 1 mm keeps grazing points finite.
inline constexpr double kCramerRaoNoiseFloorM = 1e-3;

/// RMS over pose samples of the benchmark errors (core/evaluate.h): of the RMS over camera
/// pairs of the relative rotation and translation errors, and of the RMS tilt.
struct SampledErrors {
  double rotation_rad = 0.0;
  double translation_m = 0.0;
  double tilt_rad = 0.0;
};

struct CramerRaoBound {
  bool ok = false;
  std::string message;  ///< why there is no bound
  std::string reference;
  /// Serials of the free cameras (every camera but the reference), in capture order.
  std::vector<std::string> serials;
  /// Joint covariance of the free cameras' poses (PoseManifold tangents, 6 each, in the
  /// order of serials): the inverse of the Fisher information.
  Eigen::MatrixXd covariance;
  /// The errors of poses drawn from the bound.
  SampledErrors rms;
  int samples = 0;

  /// The same for the joint estimator as rigfit runs it (options.icp: method, weights and
  /// noise model) when each point's depth noise enters every term it takes part in
  /// (JointSharedNoiseCovariance): what rigfit's errors should be under the noise model. The
  /// bound above treats the terms as independent, as the joint problem does, and so counts a
  /// point once per term it is in: in both directions and with every overlapping camera. Not
  /// a lower bound; estimator_ok false when it is not available.
  bool estimator_ok = false;
  Eigen::MatrixXd estimator_covariance;
  SampledErrors estimator_rms;
};

/// How a bound's errors are sampled (draws of the poses from it), and the threads that compute
/// it.
struct BoundSampling {
  int samples = 0;         ///< draws of the poses from N(T_true, covariance)
  std::uint64_t seed = 0;  ///< the draws' generator seed (deterministic)
  int num_threads = 1;     ///< threads computing the bound's information
};

/// The bound for a capture of noise-free depth taken at the true poses T_true, sensor noise
/// sigma_z = depth_noise z^2 along each ray and noise_floor_m on every residual (> 0: it keeps
/// grazing points, n . p near 0, finite; kCramerRaoNoiseFloorM for the benchmarks): the information
/// of the joint problem (JointInformation: the estimator's near-floor band, finest voxel scale,
/// correspondences in both directions, gravity prior; every residual weighted by that sensor noise,
/// not by the estimator's icp.min_noise_m and icp.plane_noise_share) at the true poses, inverted,
/// then `sampling.samples` draws of the poses from N(T_true, covariance) (seeded, deterministic)
/// measured with EvaluateRig. The reference is options.icp.reference or the first serial. Never
/// throws on bad geometry: ok false with a message.
CramerRaoBound ComputeCramerRaoBound(const RigCapture& noise_free, const PoseMap& T_true,
                                     const RefineOptions& options, double depth_noise,
                                     double noise_floor_m, const BoundSampling& sampling);

/// The pixels of one camera with the face each one sees (noise-free, at the true pose).
struct FacePixels {
  std::string serial;
  PointCloud points;       ///< camera frame; every valid pixel of the band once
  std::vector<int> faces;  ///< per point, the index of its face in the faces list (-1: none)
  /// Per point, its pixel (u, v): needed by a bound with correlated noise only (may be empty).
  std::vector<Eigen::Vector2i> pixels;
};

/// The faces and pixels the surface-model bound counts: a face seen by one camera alone
/// carries nothing about the poses (its plane absorbs any motion), so a face counts where two
/// cameras or more have kMinPixels or more on it, and a camera's pixels on it where it has
/// that many.
struct BoundFaces {
  static constexpr int kMinPixels = 3;
  std::vector<std::vector<int>> count;  ///< [face][camera]: the camera's pixels on the face
  std::vector<bool> used;               ///< per face

  BoundFaces(const std::vector<FacePixels>& cameras, size_t num_faces);
  /// Whether camera c's pixels on face f count (f < 0: no face).
  bool Counts(size_t c, int f) const { return f >= 0 && used[f] && count[f][c] >= kMinPixels; }
};

/// The depth noise a surface-model bound assumes.
struct SurfaceBoundNoise {
  double depth_noise = 0.0;              ///< k of sigma_z = k z^2 (sigma of the inverse depth)
  CorrelatedNoiseModel correlated = {};  ///< its spatially correlated share (share 0: white)
};

/// The physical bound of the rig (issue 18): the measurements are the inverse depths of every
/// pixel once, w = 1/z with sigma_w = depth_noise (noise Gaussian in depth with sigma_z = k z^2
/// gives sigma_w = k to first order), the unknowns the poses of every camera but `reference`
/// AND every face seen by two cameras or more (3 parameters each: the normal on the sphere and
/// the offset; the floor's offset only: its normal +Y is known, leveling defines up), the faces
/// eliminated: the poses' block of the inverse
/// Fisher information, from the plane-cluster Jacobians (residuals/plane_cluster.h) at the
/// truth, the faces eliminated by Schur complement (MarginalPoseCovariance,
/// uncertainty/covariance.h). No gravity prior (it is no measurement). Errors sampled like
/// ComputeCramerRaoBound's. Never throws on bad geometry: ok false with a message. With
/// `noise.correlated` share > 0 the noise is CorrelatedNoiseModel's (every camera's `pixels`
/// needed; share < 1 and corr_px > 0, else ok false): the information of camera c is J_c^T B_c^T
/// S_c^-1 B_c J_c / k^2 over all its faces together (B_c: the rows b_i^T of its counted pixels,
/// each in its face's columns; CorrelatedGram), no longer a sum over (camera, face) clusters: an
/// estimator that knows the correlation can difference it away where faces meet. Only the counted
/// pixels enter: the others (faces one camera sees, clutter) would also tell of the smooth field
/// next to them, so the true bound of the band is at most this one.
CramerRaoBound ComputeSurfaceCramerRaoBound(const std::vector<FacePixels>& cameras,
                                            const std::vector<PlanarFace>& faces,
                                            const PoseMap& T_true, const std::string& reference,
                                            const SurfaceBoundNoise& noise,
                                            const BoundSampling& sampling);

/// Labels points (camera frame, at T_world_camera) with the faces they lie on, appending new
/// faces to `faces` (e.g. the simulator's LabelFaces, sim/scene.h).
using FaceLabeler = std::function<void(const Pose& T_world_camera, const PointCloud& points,
                                       std::vector<PlanarFace>* faces, std::vector<int>* labels)>;

/// Every valid pixel of each camera's near-floor band (`region`, pixel stride 1) of a noise-free
/// capture at its true poses, labelled by `label` (its faces appended to `faces`), with its
/// pixel for a depth camera.
std::vector<FacePixels> RigFacePixels(const RigCapture& noise_free, const PoseMap& T_true,
                                      const RegionOptions& region, const FaceLabeler& label,
                                      std::vector<PlanarFace>* faces);

/// The reference camera of a bound: options.icp.reference, or the capture's first serial.
std::string RigReference(const RigCapture& capture, const RefineOptions& options);

}  // namespace rigfit
