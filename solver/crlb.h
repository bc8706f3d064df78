// The Cramer-Rao bound of a rig: the covariance of the best unbiased estimate of the camera
// poses that the joint problem's data could give, and the errors such an estimator would
// show when measured like the benchmarks measure rigfit (core/evaluate.h).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/evaluate.h"
#include "core/types.h"
#include "solver/options.h"

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

/// The bound for a capture of noise-free depth taken at the true poses T_true, sensor noise
/// sigma_z = depth_noise z^2 along each ray and noise_floor_m on every residual (> 0: it keeps
/// grazing points, n . p near 0, finite; kCramerRaoNoiseFloorM for the benchmarks): the information
/// of the joint problem (JointInformation: the estimator's near-floor band, finest voxel scale,
/// correspondences in both directions, gravity prior; every residual weighted by that sensor noise,
/// not by the estimator's icp.min_noise_m and icp.plane_noise_share) at the true poses, inverted,
/// then `samples` draws of the poses from N(T_true, covariance) (seeded, deterministic) measured
/// with EvaluateRig. The reference is options.icp.reference or the first serial. Never throws on
/// bad geometry: ok false with a message.
CramerRaoBound ComputeCramerRaoBound(const RigCapture& noise_free, const PoseMap& T_true,
                                     const RefineOptions& options, double depth_noise,
                                     double noise_floor_m, int samples, std::uint64_t seed,
                                     int num_threads);

}  // namespace rigfit
