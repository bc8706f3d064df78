// What the capture reader and writer (io/capture_h5.h) share: the contract's root attributes
// and range, and the checks both apply, so that nothing is written that would not read back.
// Internal to io/ (not installed).
#pragma once

#include <string>
#include <vector>

#include "core/types.h"
#include "io/hdf5_internal.h"

namespace rigfit::h5 {

inline constexpr const char* kFormat = "rig-capture";
inline constexpr long long kVersion = 1;
/// Depths and point distances beyond this are no measurement of a depth camera but a unit
/// mistake (millimetres as metres, a wrong depth_scale) or a damaged file.
inline constexpr double kMaxRangeM = 1000.0;

/// "" if K is a pinhole matrix of a width x height image, else what is wrong with it.
std::string IntrinsicsProblem(const Mat3& K, int width, int height);

/// Fails when the valid (finite) depth as a whole looks like another unit: its median is
/// beyond 100 m (no depth camera sees a room from that far). Every sample of a burst counts.
void CheckDepthUnit(const std::vector<float>& metres, const Context& where);

/// Fails on the first vector (row of points, normals) that is not finite or is longer than
/// max_norm.
void CheckVectors(const PointCloud& vectors, const std::string& name, double max_norm,
                  const Context& where);

}  // namespace rigfit::h5
