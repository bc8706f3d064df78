#include "rig/diagnostics.h"

#include <cmath>
#include <limits>

#include "prepare/correspondences.h"

namespace rigfit {
namespace {

/// |n_y| below this: the surface's normal is more than 45 deg from vertical (off the floor).
const double kOffFloorMaxVertical = std::sqrt(0.5);

/// One correspondence's signed residual r = (R_t n_q) . (T_s p - T_t q) and its target's
/// world normal.
struct MatchResidual {
  int source = 0;  ///< index of p in the source band
  double r = 0.0;
  Vec3 n_world;
};

/// The correspondences of band s to band t at `poses`, as the registration finds them at its
/// finest scale, with their residuals.
std::vector<MatchResidual> MatchResiduals(const DiagnosticRig& rig, int s, int t,
                                          const PoseMap& poses, const IcpOptions& options,
                                          int num_threads) {
  const ScaleLevel& source = rig.bands[s].levels.front();
  const ScaleLevel& target = rig.bands[t].levels.front();
  const CameraView source_view{&source, poses.at(rig.serials[s])};
  const CameraView target_view{&target, poses.at(rig.serials[t])};
  std::vector<MatchResidual> out;
  for (const Correspondence& c : FindCorrespondences(
           source_view, target_view, options.max_correspondence_distance_factor * source.voxel_size,
           options.max_normal_angle_deg, num_threads)) {
    const Vec3 n_world = target_view.T_world_camera.linear() * target.geometry.normals[c.target];
    const double r = n_world.dot(source_view.T_world_camera * source.points[c.source] -
                                 target_view.T_world_camera * target.points[c.target]);
    out.push_back({c.source, r, n_world});
  }
  return out;
}

}  // namespace

DiagnosticRig PrepareDiagnostics(const RigCapture& capture, const RefineResult& leveling,
                                 const RefineOptions& options, int num_threads) {
  // The registration's own preparation (rig/refine.h), at the finest voxel only.
  const size_t n = capture.cameras.size();
  std::vector<PointCloud> points(n);
  std::vector<Pose> leveled(n);
  std::vector<bool> floor_leveled(n, false);
  std::vector<double> depth_noise(n, 0.0);
  for (size_t i = 0; i < n; ++i) {
    const CameraCapture& camera = capture.cameras[i];
    points[i] = RegistrationPoints(camera, options.region);
    leveled[i] = leveling.leveled.at(camera.serial);
    if (i < leveling.cameras.size()) {
      floor_leveled[i] = leveling.cameras[i].ground.accepted;
      depth_noise[i] = CameraDepthNoise(options.icp, camera, leveling.cameras[i].ground);
    }
  }
  RefineOptions finest = options;
  finest.icp.scales = {options.icp.scales.back()};
  PreparedRig prepared =
      PrepareRegistration(points, leveled, floor_leveled, depth_noise, finest, num_threads);
  DiagnosticRig rig;
  for (const CameraCapture& camera : capture.cameras) rig.serials.push_back(camera.serial);
  rig.bands = std::move(prepared.pyramids);
  rig.pairs = std::move(prepared.candidates);
  return rig;
}

std::vector<PairDiagnostics> Diagnose(const DiagnosticRig& rig, const PoseMap& poses,
                                      const IcpOptions& options, int num_threads) {
  std::vector<PairDiagnostics> out;
  for (const CandidatePair& pair : rig.pairs) {
    PairDiagnostics& d = out.emplace_back();
    d.a = pair.a;
    d.b = pair.b;
    double sum_squares = 0.0, off_floor_sum_squares = 0.0;
    for (const auto& [s, t] : {std::pair{pair.a, pair.b}, std::pair{pair.b, pair.a}}) {
      const ScaleLevel& source = rig.bands[s].levels.front();
      for (size_t i = 0; i < source.points.size(); ++i) d.points += source.geometry.IsValid(i);
      for (const MatchResidual& m : MatchResiduals(rig, s, t, poses, options, num_threads)) {
        d.residuals_m.push_back(m.r);
        sum_squares += m.r * m.r;
        if (std::abs(m.n_world.y()) < kOffFloorMaxVertical) {
          ++d.off_floor_correspondences;
          off_floor_sum_squares += m.r * m.r;
        }
      }
    }
    d.correspondences = static_cast<int>(d.residuals_m.size());
    if (d.points > 0) d.inlier_fraction = static_cast<double>(d.correspondences) / d.points;
    if (d.correspondences > 0) d.rmse_m = std::sqrt(sum_squares / d.correspondences);
    if (d.off_floor_correspondences > 0) {
      d.off_floor_rmse_m = std::sqrt(off_floor_sum_squares / d.off_floor_correspondences);
    }
  }
  return out;
}

std::vector<std::vector<float>> PointResiduals(const DiagnosticRig& rig, const PoseMap& poses,
                                               const IcpOptions& options, int num_threads) {
  std::vector<std::vector<float>> out;
  for (const CloudPyramid& band : rig.bands) {
    out.emplace_back(band.levels.front().points.size(), std::numeric_limits<float>::quiet_NaN());
  }
  for (const CandidatePair& pair : rig.pairs) {
    for (const auto& [s, t] : {std::pair{pair.a, pair.b}, std::pair{pair.b, pair.a}}) {
      for (const MatchResidual& m : MatchResiduals(rig, s, t, poses, options, num_threads)) {
        float& r = out[s][m.source];
        if (!(std::abs(r) <= std::abs(m.r))) r = static_cast<float>(m.r);
      }
    }
  }
  return out;
}

}  // namespace rigfit
