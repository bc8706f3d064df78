// Gauge-free errors of estimated extrinsics against ground truth: the errors of every
// relative pose T_i^-1 T_j (i < j) and the tilt of every camera. Used by the tests, the
// benchmarks and `rigfit evaluate`.
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

}  // namespace rigfit
