// Helpers shared by the benchmark programs (sequence_rig, bunny_rig, view_bias): seeded start
// perturbations and the markdown rows they print.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <random>
#include <string>

#include "core/evaluate.h"
#include "io/config_yaml.h"
#include "options/refine_options.h"

namespace rigfit::bench {

/// Every pose of `gt` moved by PosePlus (core/pose.h: a world rotation about the camera
/// centre, then a world translation) of exactly rotation_deg about a random axis and
/// translation_m along a random direction, both uniform on the sphere (normalised Gaussian
/// vectors of std::mt19937_64(seed)), drawn in serial order: the same seed gives the same
/// start.
inline PoseMap PerturbRig(const PoseMap& gt, double rotation_deg, double translation_m,
                          std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  PoseMap init;
  for (const auto& [serial, T] : gt) {
    const Vec3 axis = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
    const Vec3 direction = Vec3(normal(rng), normal(rng), normal(rng)).normalized();
    Vec6 delta;
    delta << rotation_deg / kRadToDeg * axis, translation_m * direction;
    init[serial] = PosePlus(T, delta);
  }
  return init;
}

/// "rms deg | rms mm | max mm" of the relative-pose errors, for a markdown row.
inline std::string ErrorCells(const RigErrors& e) {
  char cells[96];
  std::snprintf(cells, sizeof(cells), "%.3f | %.2f | %.2f", e.rms_rotation_rad * kRadToDeg,
                e.rms_translation_m * 1e3, e.max_translation_m * 1e3);
  return cells;
}

/// RMS over runs of each run's RMS relative rotation and translation, and the worst pair of
/// all runs: the summary row of a table of ErrorCells.
struct ErrorSummary {
  double sum_rotation_deg2 = 0.0;
  double sum_translation_mm2 = 0.0;
  double worst_translation_mm = 0.0;
  int runs = 0;

  void Add(const RigErrors& e) {
    sum_rotation_deg2 += std::pow(e.rms_rotation_rad * kRadToDeg, 2);
    sum_translation_mm2 += std::pow(e.rms_translation_m * 1e3, 2);
    worst_translation_mm = std::max(worst_translation_mm, e.max_translation_m * 1e3);
    ++runs;
  }
  /// "rms deg | rms mm | max mm", as ErrorCells.
  std::string Cells() const {
    char cells[96];
    std::snprintf(cells, sizeof(cells), "%.3f | %.2f | %.2f", std::sqrt(sum_rotation_deg2 / runs),
                  std::sqrt(sum_translation_mm2 / runs), worst_translation_mm);
    return cells;
  }
};

/// The benchmarks' --method: point_to_plane or gicp (icp.method, the surface bundle off), or
/// surface_bundle (point_to_plane, then the surface bundle: icp.surface_bundle on).
inline void SetMethod(const std::string& method, IcpOptions* icp) {
  icp->surface_bundle = method == "surface_bundle";
  icp->method =
      icp->surface_bundle ? RegistrationMethod::kPointToPlane : RegistrationMethodNamed(method);
}

}  // namespace rigfit::bench
