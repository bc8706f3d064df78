#include "rig/crlb.h"

#include <gtest/gtest.h>

#include "rig/refine.h"
#include "rig/region.h"
#include "sim/scene.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

SimulatedRig SmallNoiseFreeRig() {
  SimOptions sim;
  sim.cameras = 3;
  sim.width = 320;
  sim.height = 180;
  sim.noise = 0.0;
  sim.seed = 5;
  return SimulateRig(sim);
}

TEST(CramerRaoBound, ScalesWithTheNoiseAndMatchesItsCovariance) {
  const SimulatedRig rig = SmallNoiseFreeRig();
  RefineOptions options;
  // The sensor noise alone, no prior of fixed weight: the bound is linear in the noise.
  options.icp.gravity_weight = 0.0;
  options.ground.enabled = false;  // floor normals are snapped within a noise-sized band
  const CramerRaoBound k =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.002, 1e-7, 500, 1, 2);
  const CramerRaoBound k2 =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.004, 1e-7, 500, 1, 2);
  ASSERT_TRUE(k.ok) << k.message;
  ASSERT_TRUE(k2.ok) << k2.message;
  ASSERT_EQ(k.serials.size(), 2u);
  EXPECT_EQ(k.reference, rig.capture.cameras.front().serial);
  // Same draws, twice the noise: twice the errors (to the first order of the small motions).
  EXPECT_NEAR(k2.rms.rotation_rad / k.rms.rotation_rad, 2.0, 0.01);
  EXPECT_NEAR(k2.rms.translation_m / k.rms.translation_m, 2.0, 0.01);
  EXPECT_NEAR(k2.covariance(3, 3) / k.covariance(3, 3), 4.0, 1e-6);
  // The sampled tilt error of a camera is its covariance's tilt: sqrt(C_xx + C_zz).
  // RMS over the three cameras, the reference's tilt being exact.
  const double tilt_variance =
      (k.covariance(0, 0) + k.covariance(2, 2) + k.covariance(6, 6) + k.covariance(8, 8)) / 3.0;
  EXPECT_NEAR(k.rms.tilt_rad / std::sqrt(tilt_variance), 1.0, 0.1);
}

TEST(CramerRaoBound, SampledErrorsAreTheCovariancesErrors) {
  // Two cameras: the only pair holds the reference, whose pose is exact, so the relative
  // error is the free camera's tangent error itself: the translation error is |d| and the
  // rotation error |w| (core/pose.h), whose mean squares are the traces of its covariance.
  SimulatedRig rig = SmallNoiseFreeRig();
  const std::string dropped = rig.capture.cameras[1].serial;
  rig.capture.cameras.erase(rig.capture.cameras.begin() + 1);
  rig.gt.erase(dropped);
  RefineOptions options;
  options.icp.gravity_weight = 0.0;
  options.ground.enabled = false;
  constexpr int kSamples = 2000;
  const CramerRaoBound k =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.002, 1e-7, kSamples, 3, 2);
  ASSERT_TRUE(k.ok) << k.message;
  ASSERT_EQ(k.serials.size(), 1u);
  // A mean square of 2000 samples of a 3-dof quadratic form is within ~3% (1 sigma, less
  // with unequal eigenvalues): 10% is over three sigma.
  constexpr double kSamplingTolerance = 0.10;
  const double rotation_ms = k.covariance.topLeftCorner<3, 3>().trace();
  const double translation_ms = k.covariance.block<3, 3>(3, 3).trace();
  EXPECT_NEAR(k.rms.rotation_rad * k.rms.rotation_rad / rotation_ms, 1.0, kSamplingTolerance);
  EXPECT_NEAR(k.rms.translation_m * k.rms.translation_m / translation_ms, 1.0, kSamplingTolerance);
}

TEST(CramerRaoBound, CamerasThatShareNothingHaveNoBound) {
  SimulatedRig rig = SmallNoiseFreeRig();
  // Move the second camera's data 100 m away: nothing overlaps at the true poses.
  rig.gt[rig.capture.cameras[1].serial].translation() += Vec3(100.0, 0.0, 0.0);
  const CramerRaoBound b =
      ComputeCramerRaoBound(rig.capture, rig.gt, {}, 0.002, kCramerRaoNoiseFloorM, 10, 1, 2);
  EXPECT_FALSE(b.ok);
  EXPECT_FALSE(b.message.empty());
}

}  // namespace
}  // namespace rigfit

namespace rigfit {
namespace {

/// The predicted inverse depth of the pixel with ray a on the world plane (n, d) seen from T.
double PredictedInverseDepth(const Pose& T, const Vec3& n, double d, const Vec3& a) {
  const Vec3 n_c = T.linear().transpose() * n;
  const double d_c = n.dot(T.translation()) + d;
  return -n_c.dot(a) / d_c;
}

TEST(SurfaceCramerRaoBound, PoseBlockOfTheSchurComplementEqualsTheDenseInverse) {
  // A small rig; the Fisher information built here by central differences of the predicted
  // inverse depth, the planes parameterised differently (two normal directions of our own and
  // the offset): the poses' block of its dense inverse must equal the bound's covariance, which
  // Ceres computes with the planes eliminated.
  SimOptions sim;
  sim.cameras = 3;
  sim.width = 64;
  sim.height = 36;
  sim.noise = 0.0;
  sim.dropout = 0.0;
  const SimulatedRig rig = SimulateRig(sim);
  constexpr double kNoise = 0.0025;
  RegionOptions every_pixel;
  every_pixel.pixel_stride = 1;
  std::vector<FacePixels> cameras;
  std::vector<PlanarFace> faces;
  for (const CameraCapture& camera : rig.capture.cameras) {
    FacePixels& c = cameras.emplace_back();
    c.serial = camera.serial;
    const Pose& T = rig.gt.at(camera.serial);
    c.points = NearFloorBand(RegistrationPoints(camera, every_pixel), T, RegionOptions{});
    LabelFaces(rig.scene, T, c.points, &faces, &c.faces);
  }
  const CramerRaoBound bound =
      ComputeSurfaceCramerRaoBound(cameras, faces, rig.gt, cameras.front().serial, kNoise, 10, 1);
  ASSERT_TRUE(bound.ok) << bound.message;

  // The faces the bound uses: at least 3 pixels in each of at least two cameras.
  const size_t n = cameras.size();
  std::vector<std::vector<int>> count(faces.size(), std::vector<int>(n, 0));
  for (size_t c = 0; c < n; ++c) {
    for (const int f : cameras[c].faces) {
      if (f >= 0) ++count[f][c];
    }
  }
  std::vector<int> column(faces.size(), -1);  // first parameter of each used face
  int params = 6 * static_cast<int>(n - 1);
  for (size_t f = 0; f < faces.size(); ++f) {
    int seen = 0;
    for (size_t c = 0; c < n; ++c) seen += count[f][c] >= 3 ? 1 : 0;
    if (seen < 2) continue;
    column[f] = params;
    params += faces[f].floor ? 1 : 3;
  }
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(params, params);
  constexpr double kStep = 1e-6;
  for (size_t c = 0; c < n; ++c) {
    const Pose& T = rig.gt.at(cameras[c].serial);
    for (size_t i = 0; i < cameras[c].points.size(); ++i) {
      const int f = cameras[c].faces[i];
      if (f < 0 || column[f] < 0 || count[f][c] < 3) continue;
      const Vec3 a = cameras[c].points[i] / cameras[c].points[i].z();
      const Vec3& nf = faces[f].normal;
      const double df = faces[f].offset;
      // Two directions orthogonal to the normal.
      const Vec3 u = nf.unitOrthogonal();
      const Vec3 v = nf.cross(u);
      Eigen::VectorXd g = Eigen::VectorXd::Zero(params);
      const auto h = [&](const Pose& Tc, const Vec3& nn, double dd) {
        return PredictedInverseDepth(Tc, nn.normalized(), dd, a);
      };
      if (c > 0) {
        for (int k = 0; k < 6; ++k) {
          Vec6 delta = Vec6::Zero();
          delta[k] = kStep;
          g[6 * (c - 1) + k] =
              (h(PosePlus(T, delta), nf, df) - h(PosePlus(T, -delta), nf, df)) / (2 * kStep);
        }
      }
      int col = column[f];
      if (!faces[f].floor) {
        g[col++] = (h(T, nf + kStep * u, df) - h(T, nf - kStep * u, df)) / (2 * kStep);
        g[col++] = (h(T, nf + kStep * v, df) - h(T, nf - kStep * v, df)) / (2 * kStep);
      }
      g[col] = (h(T, nf, df + kStep) - h(T, nf, df - kStep)) / (2 * kStep);
      H.noalias() += g * g.transpose() / (kNoise * kNoise);
    }
  }
  const Eigen::MatrixXd dense = H.inverse().topLeftCorner(6 * (n - 1), 6 * (n - 1));
  ASSERT_EQ(bound.covariance.rows(), dense.rows());
  EXPECT_LT((bound.covariance - dense).cwiseAbs().maxCoeff(), 1e-5 * dense.cwiseAbs().maxCoeff())
      << "bound\n"
      << bound.covariance << "\ndense\n"
      << dense;
}

}  // namespace
}  // namespace rigfit
