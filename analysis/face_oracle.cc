#include "analysis/face_oracle.h"

#include <ceres/manifold.h>
#include <ceres/problem.h>
#include <ceres/product_manifold.h>
#include <ceres/solver.h>
#include <ceres/sphere_manifold.h>

#include <array>
#include <cmath>
#include <map>
#include <memory>

#include "residuals/camera_planes.h"
#include "residuals/plane_cluster.h"

namespace rigfit {
namespace {

/// Smallest sigma_w a pixel is weighted with (noise-free captures), 1/m.
constexpr double kMinSigmaW = 1e-6;

/// One camera's measured pixels on the counted faces.
struct OraclePixels {
  std::vector<int> faces;              ///< per slot, the face
  std::vector<FacePixelRow> rows;      ///< b_i / sigma_i, face: the slot
  std::vector<PlaneCluster> clusters;  ///< per slot
  int gated = 0;
};

/// Camera c's labelled pixels on the faces `counted` keeps, read from its noisy depth: those
/// with a valid depth within `gate` sigma_w of their face's (the noise-free point's).
OraclePixels MeasuredPixels(const CameraCapture& camera, const FacePixels& labelled,
                            const BoundFaces& counted, size_t c, double sigma_w, double gate) {
  OraclePixels out;
  std::map<int, int> slot_of;
  const PinholeIntrinsics& K = camera.intrinsics;
  for (size_t k = 0; k < labelled.faces.size(); ++k) {
    const int f = labelled.faces[k];
    if (!counted.Counts(c, f)) continue;
    const Eigen::Vector2i& px = labelled.pixels[k];
    const double z = camera.depth_m[static_cast<size_t>(px.y()) * camera.width + px.x()];
    if (!std::isfinite(z) || z <= 0.0) continue;
    if (std::abs(1.0 / z - 1.0 / labelled.points[k].z()) > gate * sigma_w) {
      ++out.gated;
      continue;
    }
    const Vec3 a((px.x() - K.cx) / K.fx, (px.y() - K.cy) / K.fy, 1.0);
    auto [it, added] = slot_of.emplace(f, static_cast<int>(out.faces.size()));
    if (added) {
      out.faces.push_back(f);
      out.clusters.emplace_back();
    }
    out.clusters[it->second].AddRay(z * a, 1.0 / z, sigma_w);
    FacePixelRow& row = out.rows.emplace_back();
    row.pixel = px;
    row.face = it->second;
    row.row << a, 1.0 / z;
    row.row /= sigma_w;
  }
  return out;
}

}  // namespace

FaceOracleResult SolveWithTrueFaces(const RigCapture& noisy,
                                    const std::vector<FacePixels>& labelled,
                                    const std::vector<PlanarFace>& faces, const PoseMap& start,
                                    const std::string& reference,
                                    const FaceOracleOptions& options) {
  FaceOracleResult result;
  const BoundFaces counted(labelled, faces.size());
  const double sigma_w = std::max(options.depth_noise, kMinSigmaW);
  std::vector<Eigen::Vector4d> planes(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) planes[f] << faces[f].normal, faces[f].offset;
  std::map<std::string, std::array<double, kPoseAmbientSize>> poses;
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold pose_manifold;
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold;
  ceres::SubsetManifold floor_manifold(4, {0, 1, 2});
  const bool whitened = options.correlated.share > 0.0;
  const WhiteningFilter filter =
      whitened ? FitWhiteningFilter(options.correlated) : WhiteningFilter{};
  for (size_t c = 0; c < labelled.size(); ++c) {
    const CameraCapture* camera = nullptr;
    for (const CameraCapture& k : noisy.cameras) {
      if (k.serial == labelled[c].serial) camera = &k;
    }
    if (camera == nullptr || !camera->HasDepth() || !start.count(labelled[c].serial)) continue;
    OraclePixels pixels =
        MeasuredPixels(*camera, labelled[c], counted, c, sigma_w, options.gate_sigmas);
    result.gated += pixels.gated;
    if (pixels.faces.empty()) continue;
    auto& pose = poses[labelled[c].serial];
    PoseToParameters(start.at(labelled[c].serial), pose.data());
    problem.AddParameterBlock(pose.data(), kPoseAmbientSize, &pose_manifold);
    if (labelled[c].serial == reference) problem.SetParameterBlockConstant(pose.data());
    std::vector<double*> blocks = {pose.data()};
    for (const int f : pixels.faces) {
      if (!problem.HasParameterBlock(planes[f].data())) {
        problem.AddParameterBlock(
            planes[f].data(), 4,
            faces[f].floor ? static_cast<ceres::Manifold*>(&floor_manifold) : &plane_manifold);
      }
      blocks.push_back(planes[f].data());
    }
    result.pixels += static_cast<int>(pixels.rows.size());
    if (whitened) {
      const Eigen::MatrixXd M =
          WhitenedGram(pixels.rows, static_cast<int>(pixels.faces.size()), filter);
      problem.AddResidualBlock(new CameraPlanesCost(CameraPlanesCost::SquareRoot(M), true), nullptr,
                               blocks);
    } else {
      for (size_t s = 0; s < pixels.faces.size(); ++s) {
        problem.AddResidualBlock(PlaneClusterCost::Create(pixels.clusters[s], true), nullptr,
                                 pose.data(), blocks[1 + s]);
      }
    }
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = 100;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  result.ok = summary.IsSolutionUsable();
  result.message = summary.BriefReport();
  result.poses = start;
  for (const auto& [serial, pose] : poses) result.poses[serial] = PoseFromParameters(pose.data());
  return result;
}

}  // namespace rigfit
