// Gauge-free errors of estimated extrinsics against ground truth: the errors of every
// relative pose T_i^-1 T_j (i < j) and the tilt of every camera. Used by the tests, the
// benchmarks and `rigfit evaluate`. Also the 1-sigma uncertainties of a pose read from its
// covariance, reported by `rigfit refine`.
#pragma once

#include <string>
#include <vector>

#include "core/geometry.h"

namespace rigfit {

struct PairError {
  std::string serial_i;
  std::string serial_j;
  RelativePoseError error;
};

struct RigErrors {
  std::vector<PairError> pairs;
  std::vector<std::pair<std::string, double>> tilt_rad;  ///< per camera
  double rms_rotation_rad = 0.0;
  double max_rotation_rad = 0.0;
  double rms_translation_m = 0.0;
  double max_translation_m = 0.0;
  double rms_tilt_rad = 0.0;
  double max_tilt_rad = 0.0;
};

/// Errors over the cameras of `gt`, every one of which must be in `est` (throws
/// std::invalid_argument naming the first that is not).
RigErrors EvaluateRig(const PoseMap& est, const PoseMap& gt);

/// The serials of `est` that `gt` lacks (EvaluateRig ignores them). Throws InputError
/// "<what>: <gt_name> holds no camera" when `gt` is empty and "<what>: <est_name> has no pose
/// for camera(s) A, B of <gt_name>" when `est` lacks cameras of `gt` (`rigfit evaluate`,
/// `rigfit.evaluate`).
std::vector<std::string> CheckEvaluationCameras(const PoseMap& est, const PoseMap& gt,
                                                const std::string& what,
                                                const std::string& est_name,
                                                const std::string& gt_name);

/// 1-sigma uncertainties of a pose, in the human-facing units of the reports.
struct PoseSigma {
  double yaw_deg = 0.0;   ///< rotation about world +Y
  double tilt_deg = 0.0;  ///< RMS magnitude of the rotation about a horizontal axis
  double x_mm = 0.0;      ///< camera centre along world x, y, z
  double y_mm = 0.0;
  double z_mm = 0.0;
};

/// Reads the 1-sigma uncertainties off a 6x6 pose covariance C in the PoseManifold tangent
/// [wx, wy, wz, dx, dy, dz] (core/pose.h: world rotation vector in rad, world translation
/// in m):
///   yaw  = sqrt(C(1,1)),
///   tilt = sqrt(C(0,0) + C(2,2)) = sqrt(E[wx^2 + wz^2]), the RMS of the tilt angle,
///   x, y, z = sqrt(C(3,3)), sqrt(C(4,4)), sqrt(C(5,5)).
/// Correlations are ignored. A negative diagonal entry (a covariance that is not positive
/// semi-definite) gives NaN, so that it is not reported as a number.
PoseSigma SigmaOf(const Mat6& covariance);

}  // namespace rigfit
