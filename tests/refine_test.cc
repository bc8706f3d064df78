#include "rig/refine.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "core/errors.h"
#include "core/evaluate.h"
#include "core/geometry.h"
#include "core/pose.h"
#include "reference_test_util.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

/// Largest relative-pose errors (deg, m) and tilt (deg) of an estimate (EvaluateRig).
struct MaxErrors {
  double rotation_deg = 0.0;
  double translation_m = 0.0;
  double tilt_deg = 0.0;
};

MaxErrors Errors(const PoseMap& est, const PoseMap& gt) {
  const RigErrors e = EvaluateRig(est, gt);
  return {e.max_rotation_rad / kDegToRad, e.max_translation_m, e.max_tilt_rad / kDegToRad};
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
  for (const std::string& serial : {SimSerial(2), SimSerial(3)}) {
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

/// The worst-pair errors (deg, mm) measured at b97677b on PairRig, for the tolerances of
/// PairRecovery: twice these.
struct MeasuredError {
  double rotation_deg;
  double translation_mm;
};

/// PairRig(0.0, 1), started 0.216 deg and 26.0 mm off.
MeasuredError NoiseFreePairError(RegistrationMethod method) {
  return method == RegistrationMethod::kGicp ? MeasuredError{0.00028, 0.0072}
                                             : MeasuredError{0.00672, 0.3227};
}

/// PairRig(SimOptions{}.noise, 2), started 0.860 deg and 35.0 mm off.
MeasuredError DefaultNoisePairError(RegistrationMethod method) {
  return method == RegistrationMethod::kGicp ? MeasuredError{0.1536, 5.862}
                                             : MeasuredError{0.0900, 3.089};
}

class PairRecovery : public ::testing::TestWithParam<RegistrationMethod> {};

TEST_P(PairRecovery, NoiseFreeWithinTwiceTheMeasuredError) {
  const SimulatedRig rig = PairRig(0.0, 1);
  const RefineResult r = Refine(rig.capture, rig.init, PairwiseOptions(GetParam()), StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const MaxErrors before = Errors(rig.init, rig.gt);
  const MaxErrors after = Errors(r.refined, rig.gt);
  std::printf("noise-free: before %.3f deg %.1f mm, after %.5f deg %.4f mm, tilt %.4f deg\n",
              before.rotation_deg, before.translation_m * 1e3, after.rotation_deg,
              after.translation_m * 1e3, after.tilt_deg);
  const MeasuredError measured = NoiseFreePairError(GetParam());
  EXPECT_LT(after.rotation_deg, 2.0 * measured.rotation_deg);
  EXPECT_LT(after.translation_m * 1e3, 2.0 * measured.translation_mm);
}

TEST_P(PairRecovery, DefaultNoiseWithinTwiceTheMeasuredError) {
  const SimulatedRig rig = PairRig(SimOptions{}.noise, 2);
  const RefineResult r = Refine(rig.capture, rig.init, PairwiseOptions(GetParam()), StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const MaxErrors before = Errors(rig.init, rig.gt);
  const MaxErrors after = Errors(r.refined, rig.gt);
  std::printf("default noise: before %.3f deg %.1f mm, after %.4f deg %.3f mm, tilt %.4f deg\n",
              before.rotation_deg, before.translation_m * 1e3, after.rotation_deg,
              after.translation_m * 1e3, after.tilt_deg);
  const MeasuredError measured = DefaultNoisePairError(GetParam());
  EXPECT_LT(after.rotation_deg, 2.0 * measured.rotation_deg);
  EXPECT_LT(after.translation_m * 1e3, 2.0 * measured.translation_mm);
}

INSTANTIATE_TEST_SUITE_P(Methods, PairRecovery,
                         ::testing::Values(RegistrationMethod::kPointToPlane,
                                           RegistrationMethod::kGicp),
                         [](const auto& info) {
                           return info.param == RegistrationMethod::kGicp ? "Gicp" : "PointToPlane";
                         });

SimulatedRig Rig(int cameras, double noise, std::uint64_t seed) {
  SimOptions sim;
  sim.cameras = cameras;
  sim.noise = noise;
  sim.seed = seed;
  return SimulateRig(sim);
}

TEST(JointRefine, RecoversANoiseFreeThreeCameraRig) {
  const SimulatedRig rig = Rig(3, 0.0, 4);
  RefineOptions options;
  ASSERT_EQ(options.icp.mode, RefineMode::kJoint);  // the default
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_EQ(r.mode, RefineMode::kJoint);
  const MaxErrors after = Errors(r.refined, rig.gt);
  EXPECT_LT(after.rotation_deg, 0.01);
  EXPECT_LT(after.translation_m, 0.001);
  for (const CameraReport& c : r.cameras) {
    EXPECT_TRUE(c.accepted) << c.serial << ": " << c.message;
    if (c.reference) continue;
    ASSERT_TRUE(c.has_covariance) << c.serial;
    EXPECT_TRUE(c.covariance.allFinite());
    EXPECT_GT(c.covariance.diagonal().minCoeff(), 0.0);
  }
}

TEST(JointRefine, CovarianceShrinksWhenMorePointsAreUsed) {
  const SimulatedRig rig = Rig(3, SimOptions{}.noise, 9);
  // The joint registration's covariance: the surface bundle's rests on its own pixels, which
  // the region's stride does not thin.
  RefineOptions sparse;
  sparse.icp.surface_bundle = false;
  sparse.region.pixel_stride = 4;
  RefineOptions dense = sparse;
  dense.region.pixel_stride = 2;
  const RefineResult r_sparse = Refine(rig.capture, rig.init, sparse, StderrLog());
  const RefineResult r_dense = Refine(rig.capture, rig.init, dense, StderrLog());
  for (size_t i = 1; i < r_dense.cameras.size(); ++i) {
    ASSERT_TRUE(r_sparse.cameras[i].has_covariance && r_dense.cameras[i].has_covariance);
    // Four times the pixels: every variance smaller, the trace by a clear margin.
    const Mat6& c_sparse = r_sparse.cameras[i].covariance;
    const Mat6& c_dense = r_dense.cameras[i].covariance;
    EXPECT_LT(c_dense.trace(), 0.8 * c_sparse.trace()) << r_dense.cameras[i].serial;
    for (int k = 0; k < 6; ++k) EXPECT_LT(c_dense(k, k), c_sparse(k, k)) << k;
  }
}

/// Warnings of a joint refinement that name a weakly constrained direction.
std::vector<std::string> DegeneracyWarnings(const RefineResult& r) {
  std::vector<std::string> found;
  for (const std::string& w : r.warnings) {
    if (w.find("weakly constrained") != std::string::npos) found.push_back(w);
  }
  return found;
}

TEST(JointRefine, DegeneracyIsReportedOnABareRoomAndHeldOnRequest) {
  SimOptions sim;
  sim.width = 320;
  sim.height = 180;
  sim.bare = true;
  const SimulatedRig bare = SimulateRig(sim);
  RefineOptions options;
  options.icp.hold_weak_directions = true;
  // Floor and walls never settle (the rig wanders along its weak directions) and would run
  // every scale to its cap; the report and the hold are under test here, not convergence.
  options.icp.max_iterations = {10, 10, 5};
  // Every warning of the result also reaches the log (the CLI prints it on stderr).
  std::vector<std::string> logged;
  Log log;
  log.sink = [&logged](LogLevel level, const std::string& m) {
    if (level == LogLevel::kWarning) logged.push_back(m);
  };
  const RefineResult r = Refine(bare.capture, bare.init, options, log);
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_FALSE(DegeneracyWarnings(r).empty());
  for (const std::string& w : DegeneracyWarnings(r)) {
    EXPECT_NE(std::find(logged.begin(), logged.end(), w), logged.end()) << "not logged: " << w;
  }
  for (const CameraReport& c : r.cameras) {
    for (const WeakDirection& d : c.weak_directions) {
      // Held at the leveled pose: the refined pose does not move along the weak direction
      // (the hold's standard deviation is 0.1 mm; allow the rest of the rig's pull).
      const Vec6 change = PoseDifference(r.leveled.at(c.serial), r.refined.at(c.serial));
      EXPECT_LT(std::abs(d.constraint.dot(change)), 0.002) << c.serial << ": " << d.name;
    }
  }
}

TEST(JointRefine, NoDegeneracyInAFurnishedRoom) {
  // The default rig (640x360): at 320x180 the furniture's share of a camera's information
  // can fall to the threshold (docs/benchmarks.md).
  const SimulatedRig room = SimulateRig(SimOptions{});
  const RefineResult r = Refine(room.capture, room.init, RefineOptions(), StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  EXPECT_TRUE(DegeneracyWarnings(r).empty()) << DegeneracyWarnings(r).front();
}

class BothModes : public ::testing::TestWithParam<RefineMode> {};

TEST_P(BothModes, TheReferenceKeepsItsYawAndCentreOrItsWholeLeveledPose) {
  const SimulatedRig rig = Rig(3, SimOptions{}.noise, 5);
  RefineOptions options;
  options.icp.mode = GetParam();
  options.icp.reference = SimSerial(1);
  // The surface bundle (the default) levels the reference's tilt again on the floor the
  // cameras share: measured 0.0114 deg here (both modes).
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  EXPECT_EQ(r.reference, SimSerial(1));
  EXPECT_TRUE(r.cameras[1].surface_leveled);
  EXPECT_TRUE(YawAndCentreHeld(r.leveled.at(SimSerial(1)), r.refined.at(SimSerial(1)), 0.025));
  // Without it the reference is held whole.
  options.icp.surface_bundle = false;
  const RefineResult held = Refine(rig.capture, rig.init, options, StderrLog());
  EXPECT_FALSE(held.cameras[1].surface_leveled);
  EXPECT_TRUE(held.refined.at(SimSerial(1)).isApprox(held.leveled.at(SimSerial(1)), 1e-12));
}

TEST_P(BothModes, CameraWithoutOverlapIsReportedAndKeepsItsLeveledPose) {
  SimulatedRig rig = Rig(3, 0.0, 6);
  // Camera 2 believed 40 m away: its band overlaps no other camera's.
  rig.init.at(SimSerial(2)).translation() += Vec3(40.0, 0.0, 0.0);
  RefineOptions options;
  options.icp.mode = GetParam();
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const CameraReport& lonely = r.cameras[2];
  EXPECT_FALSE(lonely.connected);
  EXPECT_FALSE(lonely.accepted);
  EXPECT_TRUE(r.refined.at(SimSerial(2)).isApprox(r.leveled.at(SimSerial(2)), 1e-12));
  bool warned = false;
  for (const std::string& w : r.warnings) warned |= w.find(SimSerial(2)) != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST_P(BothModes, PairsBelowMinFitnessDoNotLink) {
  // No pair of a rig overlaps completely: at min_fitness 1 no pair links its cameras, in the
  // joint mode (gated at the start of each scale) as in the pairwise one (after its ICP).
  const SimulatedRig rig = Rig(3, 0.0, 6);
  RefineOptions options;
  options.icp.mode = GetParam();
  options.icp.min_fitness = 1.0;
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  ASSERT_FALSE(r.pairs.empty());
  for (const PairReport& p : r.pairs) {
    EXPECT_FALSE(p.accepted) << p.serial_a << " - " << p.serial_b;
    EXPECT_GT(p.fitness, 0.3) << p.serial_a << " - " << p.serial_b;  // they do overlap
  }
  for (const CameraReport& c : r.cameras) {
    if (c.reference) continue;
    EXPECT_FALSE(c.connected) << c.serial;
    EXPECT_TRUE(r.refined.at(c.serial).isApprox(r.leveled.at(c.serial), 1e-12)) << c.serial;
  }
}

TEST_P(BothModes, SafetyBoundsKeepTheLeveledPose) {
  const SimulatedRig rig = Rig(3, 0.0, 7);
  RefineOptions options;
  options.icp.mode = GetParam();
  options.icp.max_translation_m = 1e-4;  // far below the perturbation of the simulated rig
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  EXPECT_FALSE(r.success);
  for (const CameraReport& c : r.cameras) {
    EXPECT_TRUE(r.refined.at(c.serial).isApprox(r.leveled.at(c.serial), 1e-12)) << c.serial;
    if (c.reference) continue;
    EXPECT_FALSE(c.accepted);
    EXPECT_NE(c.message.find("max_translation_m"), std::string::npos) << c.message;
  }
}

TEST_P(BothModes, DefaultBoundsAdmitTheSupportedStartRange) {
  // The roughest start rigfit supports, +-3 deg of yaw and +-10 cm in x and z on every
  // camera, the reference too: on this seed (4 cameras, noise-free) one camera's correction
  // against the rig is 0.12 m, which a 0.1 m bound rejected. The default bounds must let
  // every camera be refined.
  SimOptions sim;
  sim.seed = 4;
  sim.noise = 0.0;
  sim.perturb_yaw_deg = 3.0;
  sim.perturb_xz_m = 0.1;
  const SimulatedRig rig = SimulateRig(sim);
  RefineOptions options;
  options.icp.mode = GetParam();
  const RefineResult r = Refine(rig.capture, rig.init, options, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  double largest = 0.0;
  for (const CameraReport& c : r.cameras) {
    EXPECT_TRUE(c.accepted) << c.serial << ": " << c.message;
    largest = std::max(largest, c.own_translation_m);
  }
  EXPECT_GT(largest, 0.1);
  const MaxErrors after = Errors(r.refined, rig.gt);
  EXPECT_LT(after.rotation_deg, 0.01);
  EXPECT_LT(after.translation_m, 0.001);
}

INSTANTIATE_TEST_SUITE_P(Modes, BothModes,
                         ::testing::Values(RefineMode::kJoint, RefineMode::kPairwise),
                         [](const auto& info) {
                           return info.param == RefineMode::kJoint ? "Joint" : "Pairwise";
                         });

/// Three scans of a 10 cm curved height field seen from 0.3 m above (points cameras, as
/// rigfit import-ply makes them: no depth noise model), 0.1 mm noise along z; the third one
/// bowed by up to `bow_m` along its depth (a scanner's calibration error), so that it fits
/// the other two only approximately. Its world poses in `gt`.
RigCapture ScanRig(double bow_m, PoseMap* gt) {
  const auto height = [](double x, double y) {
    return 0.01 * std::sin(40.0 * x) * std::cos(30.0 * y) + 0.005 * std::sin(70.0 * y + 1.0);
  };
  // Camera frames: z along -world z, from 0.3 m above, each tilted a little.
  const auto camera = [](double rx, double ry, const Vec3& t) {
    Pose T = Pose::Identity();
    T.linear() = (Eigen::AngleAxisd(rx, Vec3::UnitX()) * Eigen::AngleAxisd(ry, Vec3::UnitY()) *
                  Eigen::AngleAxisd(M_PI, Vec3::UnitX()))
                     .toRotationMatrix();
    T.translation() = t;
    return T;
  };
  const Pose poses[3] = {camera(0.0, 0.0, Vec3(0.0, 0.0, 0.3)),
                         camera(0.0, 0.3, Vec3(0.05, 0.0, 0.3)),
                         camera(-0.25, 0.0, Vec3(0.0, 0.04, 0.3))};
  const double x_range[3][2] = {{-0.06, 0.03}, {-0.03, 0.06}, {-0.05, 0.05}};
  const double y_range[3][2] = {{-0.05, 0.05}, {-0.05, 0.05}, {-0.02, 0.06}};
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 1e-4);
  RigCapture capture;
  for (int c = 0; c < 3; ++c) {
    CameraCapture& scan = capture.cameras.emplace_back();
    scan.serial = "scan" + std::to_string(c);
    (*gt)[scan.serial] = poses[c];
    const Pose T_camera_world = poses[c].inverse();
    for (double x = x_range[c][0]; x <= x_range[c][1]; x += 0.001) {
      for (double y = y_range[c][0]; y <= y_range[c][1]; y += 0.001) {
        Vec3 p = T_camera_world * Vec3(x, y, height(x, y));
        p.z() += noise(rng);
        if (c == 2) p.z() += bow_m * (p.x() * p.x() + p.y() * p.y()) / (0.05 * 0.05);
        scan.points.push_back(p);
      }
    }
  }
  return capture;
}

TEST(JointRefine, ScansWithoutANoiseModelAreWeightedByTheirFit) {
  // The bowed scan (1 mm) fits the others far beyond min_noise_m. Weighted by min_noise_m
  // alone its pairs pulled the two consistent scans apart by 0.40 deg, 0.61 mm; scaled by
  // their residual variance (as the pose graph scales its edges) by 0.17 deg, 0.25 mm (without
  // the bow 0.011 deg, 0.09 mm either way).
  PoseMap gt;
  const RigCapture capture = ScanRig(1e-3, &gt);
  RefineOptions options;
  options.ground.enabled = false;
  options.region.band_height = 0.0;
  options.icp.voxel_size = 0.002;
  options.icp.scales = {2.0, 1.0};
  options.icp.max_iterations = {20, 15};
  options.icp.min_noise_m = 2e-4;
  options.icp.gravity_weight = 0.0;
  options.icp.overlap_margin = 0.05;
  options.icp.min_overlap_area = 0.0;
  const RefineResult r = Refine(capture, gt, options, StderrLog());
  ASSERT_TRUE(r.success) << r.message;
  const RelativePoseError e =
      RelativeError(r.refined.at("scan0"), r.refined.at("scan1"), gt.at("scan0"), gt.at("scan1"));
  std::printf("scan0 - scan1: %.4f deg %.4f mm\n", e.rotation_rad / kDegToRad,
              e.translation_m * 1e3);
  EXPECT_LT(e.translation_m, 0.0004);
  EXPECT_LT(e.rotation_rad / kDegToRad, 0.28);
}

TEST(Refine, OneCameraIsLeveledAndReported) {
  const SimulatedRig rig = Rig(1, 0.0, 8);
  const RefineResult r = Refine(rig.capture, rig.init, RefineOptions{}, StderrLog());
  EXPECT_FALSE(r.success);
  EXPECT_NE(r.message.find("one camera"), std::string::npos) << r.message;
  const Pose& leveled = r.refined.at(SimSerial(0));
  EXPECT_LT(TiltErrorRad(leveled, rig.gt.at(SimSerial(0))) / kDegToRad, 0.05);
}

TEST(RefineInput, UnknownReferenceAndMissingPosesAreRefusedByTheLibrary) {
  SimOptions sim;
  sim.cameras = 2;
  sim.width = 64;
  sim.height = 36;
  const SimulatedRig rig = SimulateRig(sim);
  const auto message = [&](const PoseMap& initial, RefineOptions options) {
    options.threads = 1;
    try {
      Refine(rig.capture, initial, options);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no InputError");
  };
  RefineOptions unknown;
  unknown.icp.reference = "no-such-camera";
  EXPECT_EQ(message(rig.init, unknown),
            "refine: icp.reference 'no-such-camera' is not a camera of the capture (cameras: " +
                SimSerial(0) + ", " + SimSerial(1) + ")");
  PoseMap missing = rig.init;
  missing.erase(SimSerial(1));
  EXPECT_EQ(message(missing, RefineOptions{}),
            "refine: the initial extrinsics has no pose for camera(s) " + SimSerial(1) +
                " of the capture");
  PoseMap extra = rig.init;
  extra["stranger"] = Pose::Identity();
  EXPECT_EQ(message(extra, RefineOptions{}),
            "refine: the initial extrinsics has pose(s) for camera(s) stranger that the capture "
            "does not hold");
  // Named inputs, every problem in one message.
  EXPECT_THROW(CheckRefineInput(rig.capture, missing, unknown,
                                {"compare", "rig.h5", "init.json", "--reference"}),
               InputError);
  try {
    CheckRefineInput(rig.capture, missing, unknown, {"compare", "rig.h5", "init.json", "--ref"});
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()),
              "compare: init.json has no pose for camera(s) " + SimSerial(1) +
                  " of rig.h5; --ref 'no-such-camera' is not a camera of rig.h5 (cameras: " +
                  SimSerial(0) + ", " + SimSerial(1) + ")");
  }
  EXPECT_NO_THROW(CheckRefineInput(rig.capture, rig.init, RefineOptions{}));
}

}  // namespace
}  // namespace rigfit
