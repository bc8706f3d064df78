// PLY point clouds: debug output of rigfit and input of scanner data (Stanford bunny, LiDAR).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// A point cloud with optional per-point normals and RGB colors (each empty or one per point).
struct PlyCloud {
  PointCloud points;
  PointCloud normals;
  std::vector<std::array<std::uint8_t, 3>> colors;
  /// Vertices read but left out: x y z or nx ny nz not finite (the invalid pixels of an
  /// organised cloud, e.g. PCL's savePLYFile writes them as nan).
  std::int64_t skipped_non_finite = 0;
};

/// Writes binary_little_endian 1.0: element vertex with float x y z, then float nx ny nz if
/// normals are given, then uchar red green blue if colors are given. Coordinates are stored
/// as float32. Atomic (temporary file + rename). Throws InputError naming the file if normals
/// or colors are neither empty nor one per point, or the file cannot be written.
void WritePly(const std::string& path, const PlyCloud& cloud);

/// Reads ascii 1.0 and binary_little_endian 1.0 files: element vertex with x y z (any numeric
/// type), optional nx ny nz, optional uchar red green blue; other vertex properties are
/// ignored, other elements (faces, range grids, lists included) are skipped. Throws InputError
/// naming the file and the element/property at fault for a malformed or truncated file,
/// binary_big_endian, or a missing vertex element or x/y/z property. A vertex whose x y z or
/// nx ny nz are not finite is skipped and counted (PlyCloud::skipped_non_finite).
PlyCloud ReadPly(const std::string& path);

}  // namespace rigfit
