#include "solver/crlb.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

#include "core/pose.h"
#include "solver/joint.h"
#include "solver/refine.h"

namespace rigfit {

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
  const auto draw = [&](const Eigen::MatrixXd& covariance) {
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
      for (size_t k = 0; k < bound.serials.size(); ++k) {
        const std::string& serial = bound.serials[k];
        drawn[serial] = PosePlus(T_true.at(serial), delta.segment<6>(6 * k));
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
  };
  bound.rms = draw(bound.covariance);
  // The estimator's own weights and noise model (options.icp) at the points.
  bound.estimator_covariance =
      JointSharedNoiseCovariance(cameras, rig.candidates, reference, options.icp, num_threads);
  bound.estimator_ok = bound.estimator_covariance.size() == bound.covariance.size();
  if (bound.estimator_ok) bound.estimator_rms = draw(bound.estimator_covariance);
  bound.samples = samples;
  bound.ok = true;
  return bound;
}

}  // namespace rigfit
