// Joint mode: every camera pose in ONE Ceres problem with the reference camera held
// constant. Coarse to fine, correspondences of every candidate pair are re-found (in both
// directions) at the current poses, then the joint problem is solved for a few
// iterations, until the poses stop moving. Terms: noise-whitened point-to-plane or GICP
// correspondences (robust loss; floor points carry the leveled floor's normal, see
// SnapFloorNormals) and the gravity prior of every non-reference camera. A separate floor
// term (each camera's floor points on y = 0) was measured and did not help: the floor
// correspondences between cameras already carry that information (docs/benchmarks.md).
#pragma once

#include <string>
#include <vector>

#include "core/log.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "prepare/region.h"
#include "registration/pairwise.h"
#include "uncertainty/degeneracy.h"
#include "uncertainty/inflation.h"

namespace rigfit {

struct JointResult {
  std::vector<Pose> poses;                ///< refined poses; unconnected cameras as given
  std::vector<bool> connected;            ///< linked to the reference by pairs with correspondences
  std::vector<int> pair_correspondences;  ///< per candidate pair, at the end (both ways)
  bool usable = false;                    ///< Ceres' last solution is usable
  std::string message;
  int iterations = 0;  ///< outer iterations (correspondence searches) over all scales
  /// Per camera: 6x6 covariance of the pose in the PoseManifold tangent (world rotation
  /// vector, world translation), gauge fixed by the reference (whose covariance is 0),
  /// scaled by the measured variance of the whitened residuals. Zero when unavailable.
  /// Raised by `sigma_inflation`. The reported covariance is covariance + surface_bias.
  std::vector<Mat6> covariance;
  bool covariance_ok = false;
  /// Per camera: the covariance its surfaces' offsets of inverse depth give it
  /// (RegistrationCamera::surface_bias; SharedNoiseCovariance); zero without one.
  std::vector<Mat6> surface_bias;
  /// Per camera: how much the residuals' own scatter raised the noise model's 1-sigma (at least 1;
  /// 1 without a covariance): the design effect of its terms' realised residuals in cells of
  /// kCovarianceCellM against single points (uncertainty/covariance.h, ClusterSandwiches), the
  /// noise's correlation and the surfaces' bias that the model takes as independent (not
  /// surface_bias).
  std::vector<SigmaInflation> sigma_inflation;
  /// Per camera: the distinct orientations of the surfaces its correspondences lie on, each
  /// holding a share of its information (StabilityAccumulator::Orientations; 0 when not connected).
  std::vector<int> surfaces;
  /// Per camera, the directions its correspondences barely constrain at the end
  /// (uncertainty/degeneracy.h); with options.hold_weak_directions a non-reference camera's
  /// are held at its start pose.
  std::vector<std::vector<WeakDirection>> weak;
  double correspondences_s = 0.0;  ///< time spent searching correspondences
  double solve_s = 0.0;            ///< time spent building and solving problems
  double covariance_s = 0.0;       ///< time spent on the covariance and the weak directions
};

/// Refines every camera connected to `reference` jointly. Never throws on bad geometry.
JointResult RegisterJoint(const std::vector<RegistrationCamera>& cameras,
                          const std::vector<CandidatePair>& pairs, int reference,
                          const IcpOptions& options, int num_threads, const Log& log);

/// The information of the joint problem at the cameras' poses (PoseManifold tangents of
/// every camera but the reference, in camera order, 6 each): correspondences of every
/// pair in both directions at the finest scale, whitened by the depth noise model and not
/// rescaled by the residuals, no robust loss, plus the gravity prior. With noise-free
/// clouds at the true poses this is the Fisher information of the estimator's model, whose
/// inverse is the Cramer-Rao bound (analysis/crlb.h).
Eigen::MatrixXd JointInformation(const std::vector<RegistrationCamera>& cameras,
                                 const std::vector<CandidatePair>& pairs, int reference,
                                 const IcpOptions& options, int num_threads);

/// The covariance of the joint estimator at the cameras' poses (same tangents, terms and
/// priors as JointInformation) when each point's depth noise enters every term it takes part
/// in (SharedNoiseCovariance): what the estimator's errors are under the noise model, where
/// the inverse of JointInformation counts a point once per term.
Eigen::MatrixXd JointSharedNoiseCovariance(const std::vector<RegistrationCamera>& cameras,
                                           const std::vector<CandidatePair>& pairs, int reference,
                                           const IcpOptions& options, int num_threads);

}  // namespace rigfit
