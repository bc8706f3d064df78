// A surfel map (rgbd/surfel_map.h) as a PLY cloud with normals (and colours when the map has
// them), shared by `rigfit fuse` and `rigfit slam`.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "io/ply.h"
#include "rgbd/surfel_map.h"

namespace rigfit::cli {

inline PlyCloud SurfelMapToPly(const SurfelMap& map) {
  const auto to_byte = [](float value) {
    return static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0f, 255.0f)));
  };
  PlyCloud cloud;
  cloud.points.reserve(map.size());
  cloud.normals.reserve(map.size());
  for (int i = 0; i < map.size(); ++i) {
    cloud.points.push_back(map.positions()[i].cast<double>());
    cloud.normals.push_back(map.normals()[i].cast<double>());
    if (map.has_color()) {
      const Vec3f& c = map.colors()[i];
      cloud.colors.push_back({to_byte(c.x()), to_byte(c.y()), to_byte(c.z())});
    }
  }
  return cloud;
}

}  // namespace rigfit::cli
