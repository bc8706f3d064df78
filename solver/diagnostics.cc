#include "solver/diagnostics.h"

#include <cmath>

#include "core/geometry.h"
#include "solver/correspondences.h"

namespace rigfit {

DiagnosticRig PrepareDiagnostics(const RigCapture& capture, const RefineResult& leveling,
                                 const RefineOptions& options, int num_threads) {
  DiagnosticRig rig;
  const UnprojectOptions unproject{options.region.pixel_stride, options.region.min_depth_m,
                                   options.region.max_depth_m};
  const double finest_voxel = options.icp.scales.back() * options.icp.voxel_size;
  std::vector<GroundBox> boxes;
  for (size_t i = 0; i < capture.cameras.size(); ++i) {
    const CameraCapture& camera = capture.cameras[i];
    const Pose& T_world_camera = leveling.leveled.at(camera.serial);
    const PointCloud band =
        NearFloorBand(CameraPoints(camera, unproject), T_world_camera, options.region);
    boxes.push_back(RobustGroundBox(Transform(T_world_camera, band)));
    CloudPyramid pyramid =
        BuildPyramid(band, {finest_voxel}, options.icp.normal_neighbors, Vec3::Zero(), num_threads);
    // The floor model of the registration (solver/refine.cc): the configured depth noise,
    // else the one measured on the camera's floor.
    const GroundResult* ground =
        i < leveling.cameras.size() ? &leveling.cameras[i].ground : nullptr;
    if (ground != nullptr && ground->accepted) {
      const double depth_noise =
          options.icp.depth_noise > 0.0 ? options.icp.depth_noise : ground->depth_noise;
      SnapFloorNormals(&pyramid,
                       FloorModel{T_world_camera, depth_noise, options.ground.ransac_distance_m});
    }
    rig.serials.push_back(camera.serial);
    rig.bands.push_back(std::move(pyramid));
  }
  rig.pairs = FindCandidatePairs(boxes, options.icp.overlap_margin, options.icp.min_overlap_area);
  return rig;
}

std::vector<PairDiagnostics> Diagnose(const DiagnosticRig& rig, const PoseMap& poses,
                                      const IcpOptions& options, int num_threads) {
  std::vector<PairDiagnostics> out;
  for (const CandidatePair& pair : rig.pairs) {
    PairDiagnostics& d = out.emplace_back();
    d.a = pair.a;
    d.b = pair.b;
    double sum_squares = 0.0;
    for (const auto& [s, t] : {std::pair{pair.a, pair.b}, std::pair{pair.b, pair.a}}) {
      const ScaleLevel& source = rig.bands[s].levels.front();
      const ScaleLevel& target = rig.bands[t].levels.front();
      const CameraView source_view{&source, poses.at(rig.serials[s])};
      const CameraView target_view{&target, poses.at(rig.serials[t])};
      for (size_t i = 0; i < source.points.size(); ++i) d.points += source.geometry.IsValid(i);
      const std::vector<Correspondence> matches = FindCorrespondences(
          source_view, target_view, options.max_correspondence_distance_factor * source.voxel_size,
          options.max_normal_angle_deg, num_threads);
      for (const Correspondence& c : matches) {
        const Vec3 n_world =
            target_view.T_world_camera.linear() * target.geometry.normals[c.target];
        const double r = n_world.dot(source_view.T_world_camera * source.points[c.source] -
                                     target_view.T_world_camera * target.points[c.target]);
        d.residuals_m.push_back(r);
        sum_squares += r * r;
      }
    }
    d.correspondences = static_cast<int>(d.residuals_m.size());
    if (d.points > 0) d.inlier_fraction = static_cast<double>(d.correspondences) / d.points;
    if (d.correspondences > 0) d.rmse_m = std::sqrt(sum_squares / d.correspondences);
  }
  return out;
}

}  // namespace rigfit
