// The rule every pose file read by rigfit follows for a 4x4 matrix printed as numbers
// (extrinsics JSON, 7-Scenes pose.txt): how far from a rigid transform it may be, and what
// is done about the rounding of limited-precision files (docs/formats.md).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "core/pose.h"

namespace rigfit {

/// A 4x4 matrix [R t; 0 0 0 1] of finite numbers as a Pose. Throws InputError("<field>: ...")
/// for a last row other than [0, 0, 0, 1] (to 1e-9) and a rotation block R with
/// ||R^T R - I|| (max norm) > 1e-3 or det(R) <= 0. Smaller deviations are removed by
/// projecting R onto SO(3) (SVD; kept bit for bit up to double round-off, 1e-12); those above
/// 1e-6 (limited-precision files, e.g. 7-Scenes' pose.txt at ~3e-4) add a line naming `field`
/// and the deviation to `warnings`.
Pose PoseFromMatrix(const Eigen::Matrix4d& M, const std::string& field,
                    std::vector<std::string>* warnings);

}  // namespace rigfit
