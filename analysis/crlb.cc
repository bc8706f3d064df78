#include "analysis/crlb.h"

#include <ceres/crs_matrix.h>
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

#include "core/geometry.h"
#include "core/pose.h"
#include "prepare/correspondences.h"
#include "prepare/region.h"
#include "registration/joint.h"
#include "residuals/plane_cluster.h"
#include "rig/refine.h"
#include "uncertainty/covariance.h"

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
                                     double noise_floor_m, const BoundSampling& sampling) {
  const auto& [samples, seed, num_threads] = sampling;
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
  bound.covariance = InverseOrEmpty(information);
  if (bound.covariance.size() == 0) {
    bound.message = "the information is singular: some camera is not constrained";
    return bound;
  }
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

namespace {

/// The joint problem of the surface bound: every camera's pose at the truth (the reference
/// constant) and every used face's plane.
struct SurfaceBoundProblem {
  std::vector<std::array<double, kPoseAmbientSize>> poses;
  std::vector<Vec4> planes;
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold;
  ceres::SubsetManifold floor_manifold{4, {0, 1, 2}};
  std::unique_ptr<ceres::Problem> problem = NewProblem();
  std::vector<double*> free_blocks;
  std::vector<double*> plane_blocks;

  /// The serials of the free cameras go to `serials`.
  SurfaceBoundProblem(const std::vector<FacePixels>& cameras, const std::vector<PlanarFace>& faces,
                      const BoundFaces& counted, const PoseMap& T_true,
                      const std::string& reference, std::vector<std::string>* serials);
};

SurfaceBoundProblem::SurfaceBoundProblem(const std::vector<FacePixels>& cameras,
                                         const std::vector<PlanarFace>& faces,
                                         const BoundFaces& counted, const PoseMap& T_true,
                                         const std::string& reference,
                                         std::vector<std::string>* serials)
    : poses(cameras.size()), planes(faces.size()) {
  for (size_t f = 0; f < faces.size(); ++f) {
    planes[f] << faces[f].normal, faces[f].offset;
  }
  for (size_t c = 0; c < cameras.size(); ++c) {
    PoseToParameters(T_true.at(cameras[c].serial), poses[c].data());
    problem->AddParameterBlock(poses[c].data(), kPoseAmbientSize, SharedPoseManifold());
    if (cameras[c].serial == reference) {
      problem->SetParameterBlockConstant(poses[c].data());
    } else {
      serials->push_back(cameras[c].serial);
      free_blocks.push_back(poses[c].data());
    }
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    if (!counted.used[f]) continue;
    problem->AddParameterBlock(
        planes[f].data(), 4,
        faces[f].floor ? static_cast<ceres::Manifold*>(&floor_manifold) : &plane_manifold);
  }
  for (size_t f = 0; f < faces.size(); ++f) {
    if (counted.used[f]) plane_blocks.push_back(planes[f].data());
  }
}

/// What the correlated-noise covariance reads besides the problem.
struct CorrelatedBoundInputs {
  const std::vector<FacePixels>& cameras;
  const std::vector<PlanarFace>& faces;
  const BoundFaces& counted;
  const PoseMap& T_true;
  double depth_noise;
  const CorrelatedNoiseModel& correlated;
  int num_threads;
};

/// One camera's counted pixels: their rows and the faces they are on (`seen`, in order of
/// first appearance; slot[f] is face f's place in it).
struct CountedRows {
  std::vector<int> slot, seen, rows;
};

CountedRows CountedRowsOf(const FacePixels& camera, size_t c, size_t num_faces,
                          const BoundFaces& counted) {
  CountedRows out;
  out.slot.assign(num_faces, -1);
  for (size_t i = 0; i < camera.points.size(); ++i) {
    const int f = camera.faces[i];
    if (!counted.Counts(c, f)) continue;
    if (out.slot[f] < 0) {
      out.slot[f] = static_cast<int>(out.seen.size());
      out.seen.push_back(f);
    }
    out.rows.push_back(static_cast<int>(i));
  }
  return out;
}

/// Camera c's weight E G E^T / k^2 over its faces' residual blocks (added to the problem), or
/// empty with a message.
Eigen::MatrixXd CameraWeight(const CorrelatedBoundInputs& in, size_t c, const CountedRows& counted,
                             SurfaceBoundProblem* bound,
                             std::vector<ceres::ResidualBlockId>* residual_blocks,
                             std::string* message) {
  const FacePixels& camera = in.cameras[c];
  const std::vector<int>& rows = counted.rows;
  std::vector<Eigen::Vector2i> pixels(rows.size());
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(rows.size()),
                                            3 * static_cast<Eigen::Index>(counted.seen.size()));
  for (size_t k = 0; k < rows.size(); ++k) {
    const Vec3& p = camera.points[rows[k]];
    pixels[k] = camera.pixels[rows[k]];
    A.block<1, 3>(static_cast<Eigen::Index>(k), 3 * counted.slot[camera.faces[rows[k]]]) =
        (p / p.z()).transpose();
  }
  const Eigen::MatrixXd G = CorrelatedGram(pixels, A, in.correlated, in.num_threads);
  if (G.size() == 0) {
    *message = "the correlated noise's solve did not converge (camera " + camera.serial + ")";
    return {};
  }
  const Pose& T = in.T_true.at(camera.serial);
  Eigen::MatrixXd E = Eigen::MatrixXd::Zero(4 * G.rows() / 3, G.rows());
  for (size_t s = 0; s < counted.seen.size(); ++s) {
    const PlanarFace& face = in.faces[counted.seen[s]];
    const Vec3 n_c = T.linear().transpose() * face.normal;
    const double d_c = face.normal.dot(T.translation()) + face.offset;
    E.block<3, 3>(4 * s, 3 * s).setIdentity();
    E.block<1, 3>(4 * s + 3, 3 * s) = -n_c.transpose() / d_c;
    residual_blocks->push_back(bound->problem->AddResidualBlock(
        new PlaneClusterCost(Mat4::Identity(), true), nullptr, bound->poses[c].data(),
        bound->planes[counted.seen[s]].data()));
  }
  return E * G * E.transpose() / (in.depth_noise * in.depth_noise);
}

/// sum_c J_c^T W_c J_c over the cameras' stacked rows (dense).
Eigen::MatrixXd WeightedInformation(SurfaceBoundProblem* bound,
                                    const std::vector<ceres::ResidualBlockId>& residual_blocks,
                                    const std::vector<Eigen::MatrixXd>& weights) {
  std::vector<double*> blocks = bound->free_blocks;
  blocks.insert(blocks.end(), bound->plane_blocks.begin(), bound->plane_blocks.end());
  std::vector<double> residuals;
  ceres::CRSMatrix crs;
  EvaluateJacobian(bound->problem.get(), blocks, residual_blocks, &residuals, &crs);
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, crs.num_cols);
  for (int row = 0; row < crs.num_rows; ++row) {
    for (int a = crs.rows[row]; a < crs.rows[row + 1]; ++a) J(row, crs.cols[a]) = crs.values[a];
  }
  Eigen::MatrixXd information = Eigen::MatrixXd::Zero(J.cols(), J.cols());
  Eigen::Index row = 0;
  for (const Eigen::MatrixXd& W : weights) {
    const Eigen::MatrixXd Jc = J.middleRows(row, W.rows());
    information += Jc.transpose() * W * Jc;
    row += W.rows();
  }
  return information;
}

/// ComputeSurfaceCramerRaoBound's covariance under correlated noise: per camera, the rays a_i
/// of its counted pixels, three columns per face (the face's indicator times each component),
/// give G = A^T S^-1 A (CorrelatedGram); since w_i = e_f^T a_i on face f (e_f = -n_c / d_c),
/// b_i = E_f a_i with E_f = [I; e_f^T], and the information of the stacked per-face
/// residual vectors pi_c / d_c (PlaneClusterCost with L = I: w_i - h_i = b_i^T pi_c / d_c) is
/// E G E^T / k^2. The faces are eliminated densely. Empty with a message on failure.
Eigen::MatrixXd CorrelatedPoseCovariance(const CorrelatedBoundInputs& in,
                                         SurfaceBoundProblem* bound, std::string* message) {
  std::vector<ceres::ResidualBlockId> residual_blocks;
  std::vector<Eigen::MatrixXd> weights;  // per camera: 4 F_c x 4 F_c
  for (size_t c = 0; c < in.cameras.size(); ++c) {
    const FacePixels& camera = in.cameras[c];
    if (camera.pixels.size() != camera.points.size()) {
      *message = "correlated noise needs every point's pixel (camera " + camera.serial + ")";
      return {};
    }
    const CountedRows counted = CountedRowsOf(camera, c, in.faces.size(), in.counted);
    if (counted.seen.empty()) continue;
    Eigen::MatrixXd W = CameraWeight(in, c, counted, bound, &residual_blocks, message);
    if (W.size() == 0) return {};
    weights.push_back(std::move(W));
  }
  const Eigen::MatrixXd information = WeightedInformation(bound, residual_blocks, weights);
  const Eigen::Index p = 6 * static_cast<Eigen::Index>(bound->free_blocks.size());
  const Eigen::Index q = information.rows() - p;
  if (q == 0) {
    *message = "no face is seen by two cameras";
    return {};
  }
  const Eigen::MatrixXd faces_inverse = InverseOrEmpty(information.bottomRightCorner(q, q));
  if (faces_inverse.size() == 0) {
    *message = "the information is singular: some face is not constrained";
    return {};
  }
  const Eigen::MatrixXd schur =
      information.topLeftCorner(p, p) -
      information.topRightCorner(p, q) * faces_inverse * information.bottomLeftCorner(q, p);
  Eigen::MatrixXd covariance = InverseOrEmpty(0.5 * (schur + schur.transpose()));
  if (covariance.size() == 0) {
    *message = "the information is singular: some camera is not constrained";
  }
  return covariance;
}

/// The white-noise covariance: each camera's counted pixels of a face as one plane cluster.
Eigen::MatrixXd WhitePoseCovariance(const std::vector<FacePixels>& cameras, size_t num_faces,
                                    const BoundFaces& counted, double depth_noise,
                                    SurfaceBoundProblem* bound) {
  for (size_t c = 0; c < cameras.size(); ++c) {
    std::vector<PlaneCluster> clusters(num_faces);
    for (size_t i = 0; i < cameras[c].points.size(); ++i) {
      const int f = cameras[c].faces[i];
      if (!counted.Counts(c, f)) continue;
      const Vec3& p = cameras[c].points[i];
      clusters[f].AddRay(p, 1.0 / p.z(), depth_noise);
    }
    for (size_t f = 0; f < num_faces; ++f) {
      if (clusters[f].Count() == 0) continue;
      bound->problem->AddResidualBlock(PlaneClusterCost::Create(clusters[f], true), nullptr,
                                       bound->poses[c].data(), bound->planes[f].data());
    }
  }
  return MarginalPoseCovariance(bound->problem.get(), bound->free_blocks, bound->plane_blocks);
}

}  // namespace

CramerRaoBound ComputeSurfaceCramerRaoBound(const std::vector<FacePixels>& cameras,
                                            const std::vector<PlanarFace>& faces,
                                            const PoseMap& T_true, const std::string& reference,
                                            const SurfaceBoundNoise& noise,
                                            const BoundSampling& sampling) {
  const auto& [depth_noise, correlated] = noise;
  const auto& [samples, seed, num_threads] = sampling;
  CramerRaoBound bound;
  bound.reference = reference;
  const size_t n = cameras.size();
  if (n < 2 || !(depth_noise > 0.0)) {
    bound.message = "needs two cameras or more and depth noise > 0";
    return bound;
  }
  const BoundFaces counted(cameras, faces.size());
  SurfaceBoundProblem problem(cameras, faces, counted, T_true, reference, &bound.serials);
  if (bound.serials.size() + 1 != n) {
    bound.message = "the reference '" + reference + "' is not one of the cameras";
    return bound;
  }
  if (correlated.share > 0.0) {
    if (!(correlated.share < 1.0) || !(correlated.corr_px > 0.0)) {
      bound.message = "correlated noise needs a white share (share < 1) and corr_px > 0";
      return bound;
    }
    const CorrelatedBoundInputs in{cameras,     faces,      counted,    T_true,
                                   depth_noise, correlated, num_threads};
    bound.covariance = CorrelatedPoseCovariance(in, &problem, &bound.message);
    if (bound.covariance.size() == 0) return bound;
  } else {
    bound.covariance = WhitePoseCovariance(cameras, faces.size(), counted, depth_noise, &problem);
  }
  if (bound.covariance.size() == 0) {
    bound.message = "the information is singular: some camera or face is not constrained";
    return bound;
  }
  bound.rms = SampleErrors(bound.covariance, bound.serials, T_true, samples, seed);
  bound.samples = samples;
  bound.ok = true;
  return bound;
}

std::vector<FacePixels> RigFacePixels(const RigCapture& noise_free, const PoseMap& T_true,
                                      const RegionOptions& region, const FaceLabeler& label,
                                      std::vector<PlanarFace>* faces) {
  RegionOptions every_pixel = region;
  every_pixel.pixel_stride = 1;
  std::vector<FacePixels> cameras;
  for (const CameraCapture& camera : noise_free.cameras) {
    FacePixels& pixels = cameras.emplace_back();
    const Pose& T = T_true.at(camera.serial);
    pixels.serial = camera.serial;
    pixels.points = NearFloorBand(RegistrationPoints(camera, every_pixel), T, region);
    label(T, pixels.points, faces, &pixels.faces);
    if (camera.HasDepth()) {
      for (const Vec3& p : pixels.points) pixels.pixels.push_back(PixelOf(camera.intrinsics, p));
    }
  }
  return cameras;
}

std::string RigReference(const RigCapture& capture, const RefineOptions& options) {
  return options.icp.reference.empty() && !capture.cameras.empty() ? capture.cameras.front().serial
                                                                   : options.icp.reference;
}

}  // namespace rigfit
