#include "rig/crlb.h"

#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <ceres/sphere_manifold.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>

#include "core/pose.h"
#include "residuals/plane_cluster.h"
#include "rig/correspondences.h"
#include "rig/covariance.h"
#include "rig/joint.h"
#include "rig/refine.h"
#include "rig/region.h"

namespace rigfit {

namespace {

/// RMS over `samples` draws of the poses from N(T_true, covariance) (free cameras `serials`,
/// 6 each) of the benchmark errors.
SampledErrors SampleErrors(const Eigen::MatrixXd& covariance,
                           const std::vector<std::string>& serials, const PoseMap& T_true,
                           int samples, std::uint64_t seed) {
  // Draws delta = L z, L L^T = covariance, z ~ N(0, I): poses Exp(delta_i) T_i.
  const Eigen::MatrixXd L = Eigen::LLT<Eigen::MatrixXd>(covariance).matrixL();
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> normal;
  double sum_r2 = 0.0, sum_t2 = 0.0, sum_tilt2 = 0.0;
  for (int s = 0; s < samples; ++s) {
    Eigen::VectorXd z(L.cols());
    for (int k = 0; k < z.size(); ++k) z(k) = normal(rng);
    const Eigen::VectorXd delta = L * z;
    PoseMap drawn = T_true;
    for (size_t k = 0; k < serials.size(); ++k) {
      drawn[serials[k]] = PosePlus(T_true.at(serials[k]), delta.segment<6>(6 * k));
    }
    const RigErrors e = EvaluateRig(drawn, T_true);
    sum_r2 += e.rms_rotation_rad * e.rms_rotation_rad;
    sum_t2 += e.rms_translation_m * e.rms_translation_m;
    sum_tilt2 += e.rms_tilt_rad * e.rms_tilt_rad;
  }
  SampledErrors rms;
  if (samples > 0) {
    rms.rotation_rad = std::sqrt(sum_r2 / samples);
    rms.translation_m = std::sqrt(sum_t2 / samples);
    rms.tilt_rad = std::sqrt(sum_tilt2 / samples);
  }
  return rms;
}

}  // namespace

CramerRaoBound ComputeCramerRaoBound(const RigCapture& noise_free, const PoseMap& T_true,
                                     const RefineOptions& options, double depth_noise,
                                     double noise_floor_m, int samples, std::uint64_t seed,
                                     int num_threads) {
  CramerRaoBound bound;
  const size_t n = noise_free.cameras.size();
  if (n < 2) {
    bound.message = "the capture has fewer than two cameras";
    return bound;
  }
  bound.reference =
      options.icp.reference.empty() ? noise_free.cameras.front().serial : options.icp.reference;
  int reference = 0;
  std::vector<PointCloud> points(n);
  std::vector<Pose> poses(n);
  for (size_t i = 0; i < n; ++i) {
    const CameraCapture& camera = noise_free.cameras[i];
    if (camera.serial == bound.reference) reference = static_cast<int>(i);
    points[i] = RegistrationPoints(camera, options.region);
    poses[i] = T_true.at(camera.serial);
  }
  // At the true poses every floor is exactly y = 0: the estimator snaps floor normals there.
  const PreparedRig rig =
      PrepareRegistration(points, poses, std::vector<bool>(n, options.ground.enabled),
                          std::vector<double>(n, depth_noise), options, num_threads);
  std::vector<RegistrationCamera> cameras(n);
  for (size_t i = 0; i < n; ++i) cameras[i] = {&rig.pyramids[i], poses[i], depth_noise};
  // The sensor's noise, not the estimator's weighting choices.
  IcpOptions sensor = options.icp;
  sensor.min_noise_m = noise_floor_m;
  sensor.plane_noise_share = 0.0;
  const Eigen::MatrixXd information =
      JointInformation(cameras, rig.candidates, reference, sensor, num_threads);
  if (information.size() == 0 || !information.allFinite()) {
    bound.message = "no correspondences between the cameras at the true poses";
    return bound;
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(information);
  if (!(eig.eigenvalues().minCoeff() > 1e-12 * eig.eigenvalues().maxCoeff())) {
    bound.message = "the information is singular: some camera is not constrained";
    return bound;
  }
  bound.covariance = eig.eigenvectors() * eig.eigenvalues().cwiseInverse().asDiagonal() *
                     eig.eigenvectors().transpose();
  for (size_t i = 0; i < n; ++i) {
    if (static_cast<int>(i) != reference) bound.serials.push_back(noise_free.cameras[i].serial);
  }
  bound.rms = SampleErrors(bound.covariance, bound.serials, T_true, samples, seed);
  // The estimator's own weights and noise model (options.icp) at the points.
  bound.estimator_covariance =
      JointSharedNoiseCovariance(cameras, rig.candidates, reference, options.icp, num_threads);
  bound.estimator_ok = bound.estimator_covariance.size() == bound.covariance.size();
  if (bound.estimator_ok) {
    bound.estimator_rms =
        SampleErrors(bound.estimator_covariance, bound.serials, T_true, samples, seed);
  }
  bound.samples = samples;
  bound.ok = true;
  return bound;
}

BoundFaces::BoundFaces(const std::vector<FacePixels>& cameras, size_t num_faces)
    : count(num_faces, std::vector<int>(cameras.size(), 0)), used(num_faces, false) {
  for (size_t c = 0; c < cameras.size(); ++c) {
    for (const int f : cameras[c].faces) {
      if (f >= 0) ++count[f][c];
    }
  }
  for (size_t f = 0; f < num_faces; ++f) {
    used[f] =
        std::count_if(count[f].begin(), count[f].end(), [](int k) { return k >= kMinPixels; }) >= 2;
  }
}

CramerRaoBound ComputeSurfaceCramerRaoBound(const std::vector<FacePixels>& cameras,
                                            const std::vector<PlanarFace>& faces,
                                            const PoseMap& T_true, const std::string& reference,
                                            double depth_noise, int samples, std::uint64_t seed) {
  CramerRaoBound bound;
  bound.reference = reference;
  const size_t n = cameras.size();
  if (n < 2 || !(depth_noise > 0.0)) {
    bound.message = "needs two cameras or more and depth noise > 0";
    return bound;
  }
  const BoundFaces counted(cameras, faces.size());
  const std::vector<bool>& used = counted.used;
  std::vector<std::array<double, kPoseAmbientSize>> poses(n);
  std::vector<Vec4> planes(faces.size());
  for (size_t f = 0; f < faces.size(); ++f) {
    planes[f] << faces[f].normal, faces[f].offset;
  }
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold;
  ceres::SubsetManifold floor_manifold(4, {0, 1, 2});
  std::unique_ptr<ceres::Problem> problem = NewProblem();
  std::vector<double*> free_blocks;
  for (size_t c = 0; c < n; ++c) {
    PoseToParameters(T_true.at(cameras[c].serial), poses[c].data());
    problem->AddParameterBlock(poses[c].data(), kPoseAmbientSize, SharedPoseManifold());
    if (cameras[c].serial == reference) {
      problem->SetParameterBlockConstant(poses[c].data());
    } else {
      bound.serials.push_back(cameras[c].serial);
      free_blocks.push_back(poses[c].data());
    }
  }
  if (bound.serials.size() + 1 != n) {
    bound.message = "the reference '" + reference + "' is not one of the cameras";
    return bound;
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    if (!used[f]) continue;
    problem->AddParameterBlock(
        planes[f].data(), 4,
        faces[f].floor ? static_cast<ceres::Manifold*>(&floor_manifold) : &plane_manifold);
  }
  for (size_t c = 0; c < n; ++c) {
    std::vector<PlaneCluster> clusters(faces.size());
    for (size_t i = 0; i < cameras[c].points.size(); ++i) {
      const int f = cameras[c].faces[i];
      if (!counted.Counts(c, f)) continue;
      const Vec3& p = cameras[c].points[i];
      clusters[f].AddRay(p, 1.0 / p.z(), depth_noise);
    }
    for (size_t f = 0; f < faces.size(); ++f) {
      if (clusters[f].Count() == 0) continue;
      problem->AddResidualBlock(PlaneClusterCost::Create(clusters[f], true), nullptr,
                                poses[c].data(), planes[f].data());
    }
  }
  std::vector<double*> plane_blocks;
  for (size_t f = 0; f < faces.size(); ++f) {
    if (used[f]) plane_blocks.push_back(planes[f].data());
  }
  bound.covariance = MarginalPoseCovariance(problem.get(), free_blocks, plane_blocks);
  if (bound.covariance.size() == 0) {
    bound.message = "the information is singular: some camera or face is not constrained";
    return bound;
  }
  bound.rms = SampleErrors(bound.covariance, bound.serials, T_true, samples, seed);
  bound.samples = samples;
  bound.ok = true;
  return bound;
}

CramerRaoBound ComputeRigSurfaceBound(const RigCapture& noise_free, const PoseMap& T_true,
                                      const RefineOptions& options, double depth_noise,
                                      const FaceLabeler& label, int samples, std::uint64_t seed) {
  RegionOptions every_pixel = options.region;
  every_pixel.pixel_stride = 1;
  std::vector<FacePixels> cameras;
  std::vector<PlanarFace> faces;
  for (const CameraCapture& camera : noise_free.cameras) {
    FacePixels& pixels = cameras.emplace_back();
    const Pose& T = T_true.at(camera.serial);
    pixels.serial = camera.serial;
    pixels.points = NearFloorBand(RegistrationPoints(camera, every_pixel), T, options.region);
    label(T, pixels.points, &faces, &pixels.faces);
  }
  const std::string reference = options.icp.reference.empty() && !noise_free.cameras.empty()
                                    ? noise_free.cameras.front().serial
                                    : options.icp.reference;
  return ComputeSurfaceCramerRaoBound(cameras, faces, T_true, reference, depth_noise, samples,
                                      seed);
}

}  // namespace rigfit
