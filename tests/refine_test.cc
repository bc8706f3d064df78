#include "solver/refine.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/geometry.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

constexpr double kDeg = M_PI / 180.0;

struct RigErrors {
  double max_rotation_deg = 0.0;
  double max_translation_m = 0.0;
  double max_tilt_deg = 0.0;
};

RigErrors Errors(const PoseMap& est, const PoseMap& gt) {
  RigErrors e;
  for (auto i = gt.begin(); i != gt.end(); ++i) {
    e.max_tilt_deg = std::max(e.max_tilt_deg, TiltErrorRad(est.at(i->first), i->second) / kDeg);
    for (auto j = std::next(i); j != gt.end(); ++j) {
      const RelativePoseError r =
          RelativeError(est.at(i->first), est.at(j->first), i->second, j->second);
      e.max_rotation_deg = std::max(e.max_rotation_deg, r.rotation_rad / kDeg);
      e.max_translation_m = std::max(e.max_translation_m, r.translation_m);
    }
  }
  return e;
}

/// Two neighbouring cameras of a simulated 4-camera rig (two cameras alone would face each
/// other across the room and share little but the floor), the first exact, the second
/// started from its perturbed pose.
SimulatedRig PairRig(double noise, std::uint64_t seed) {
  SimOptions sim;
  sim.seed = seed;
  sim.noise = noise;
  SimulatedRig rig = SimulateRig(sim);
  rig.capture.cameras.resize(2);
  for (const std::string serial : {SimSerial(2), SimSerial(3)}) {
    rig.gt.erase(serial);
    rig.init.erase(serial);
  }
  rig.init.begin()->second = rig.gt.begin()->second;
  return rig;
}

Log StderrLog() {
  Log log;
  if (std::getenv("RIGFIT_TEST_VERBOSE") != nullptr) {
    log.sink = [](LogLevel, const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); };
  }
  return log;
}

RefineOptions PairwiseOptions(RegistrationMethod method) {
  RefineOptions options;
  options.icp.mode = RefineMode::kPairwise;
  options.icp.method = method;
  return options;
}

class PairRecovery : public ::testing::TestWithParam<RegistrationMethod> {};

TEST_P(PairRecovery, NoiseFreeToAMillimetre) {
  const SimulatedRig rig = PairRig(0.0, 1);
  const RefineResult r =
      Refine(rig.capture, rig.init, PairwiseOptions(GetParam()), true, 2, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const RigErrors before = Errors(rig.init, rig.gt);
  const RigErrors after = Errors(r.refined, rig.gt);
  std::printf("noise-free: before %.3f deg %.1f mm, after %.4f deg %.3f mm, tilt %.4f deg\n",
              before.max_rotation_deg, before.max_translation_m * 1e3, after.max_rotation_deg,
              after.max_translation_m * 1e3, after.max_tilt_deg);
  EXPECT_LT(after.max_rotation_deg, 0.02);
  EXPECT_LT(after.max_translation_m, 0.001);
}

TEST_P(PairRecovery, DefaultNoiseToACentimetre) {
  const SimulatedRig rig = PairRig(SimOptions{}.noise, 2);
  const RefineResult r =
      Refine(rig.capture, rig.init, PairwiseOptions(GetParam()), true, 2, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const RigErrors after = Errors(r.refined, rig.gt);
  std::printf("default noise: after %.4f deg %.3f mm, tilt %.4f deg\n", after.max_rotation_deg,
              after.max_translation_m * 1e3, after.max_tilt_deg);
  EXPECT_LT(after.max_rotation_deg, 0.2);
  EXPECT_LT(after.max_translation_m, 0.01);
}

INSTANTIATE_TEST_SUITE_P(Methods, PairRecovery,
                         ::testing::Values(RegistrationMethod::kPointToPlane,
                                           RegistrationMethod::kGicp),
                         [](const auto& info) {
                           return info.param == RegistrationMethod::kGicp ? "Gicp" : "PointToPlane";
                         });

}  // namespace
}  // namespace rigfit
