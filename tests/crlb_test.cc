#include "solver/crlb.h"

#include <gtest/gtest.h>

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
