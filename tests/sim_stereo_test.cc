// The stereo depth model of the simulator (sim/stereo_depth.h) and the miscalibration options:
// block-matched depth close to the ray-cast truth on textured surfaces, holes on a textureless
// one, a disparity offset and a depth scale applied as documented, the options checked.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <functional>
#include <vector>

#include "core/errors.h"
#include "sim/random.h"
#include "sim/scene.h"
#include "sim/simulate_rig.h"
#include "sim/stereo_depth.h"

namespace rigfit {
namespace {

using ::testing::HasSubstr;
using ::testing::StrEq;

SimOptions SmallRig() {
  SimOptions o;
  o.cameras = 2;
  o.seed = 5;
  o.width = 320;
  o.height = 180;
  return o;
}

SimOptions Truth(SimOptions o) {
  o.depth_model = DepthModel::kGaussian;
  o.noise = 0.0;
  o.dropout = 0.0;
  o.disparity_offset_px = 0.0;
  o.depth_scale = 1.0;
  return o;
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double ValidShare(const std::vector<float>& depth) {
  return static_cast<double>(
             std::count_if(depth.begin(), depth.end(), [](float z) { return std::isfinite(z); })) /
         depth.size();
}

/// Disparity differences f B (1 / z - 1 / z_truth), pixels, where both are valid.
std::vector<double> DisparityErrors(const CameraCapture& measured, const CameraCapture& truth,
                                    double baseline_m) {
  const double f_b = measured.intrinsics.fx * baseline_m;
  std::vector<double> errors;
  for (size_t i = 0; i < truth.depth_m.size(); ++i) {
    if (std::isfinite(measured.depth_m[i]) && std::isfinite(truth.depth_m[i])) {
      errors.push_back(f_b / measured.depth_m[i] - f_b / truth.depth_m[i]);
    }
  }
  return errors;
}

TEST(StereoDepth, MatchesTheRayCastTruthAndRecordsTheBaseline) {
  SimOptions o = SmallRig();
  o.depth_model = DepthModel::kStereo;
  o.stereo_upsample = 2;
  const SimulatedRig stereo = SimulateRig(o);
  const SimulatedRig truth = SimulateRig(Truth(o));
  for (size_t c = 0; c < truth.capture.cameras.size(); ++c) {
    const CameraCapture& camera = stereo.capture.cameras[c];
    SCOPED_TRACE(camera.serial);
    EXPECT_EQ(camera.baseline_m, o.stereo_baseline_m);
    EXPECT_EQ(truth.capture.cameras[c].baseline_m, 0.0);  // the Gaussian model records none
    std::vector<double> errors = DisparityErrors(camera, truth.capture.cameras[c], 0.12);
    // Measured (seed 5, 320x180): 79% and 83% of the pixels matched; median |disparity error|
    // 0.05 px; 7% of the matched pixels off by more than 1 px (edges fattened, mismatches).
    EXPECT_GT(ValidShare(camera.depth_m), 0.6);
    for (double& e : errors) e = std::abs(e);
    EXPECT_LT(Median(errors), 0.1);
    const double outliers =
        std::count_if(errors.begin(), errors.end(), [](double e) { return e > 1.0; });
    EXPECT_LT(outliers / errors.size(), 0.15);
  }
}

TEST(StereoDepth, LeavesHolesOnATexturelessSurfaceAndMatchesATexturedOne) {
  // A wall 3 m in front of a camera looking along world +Z.
  Scene scene;
  OrientedBox wall;
  wall.center = Vec3(0.0, 1.0, 3.05);
  wall.half_extents = Vec3(5.0, 5.0, 0.05);
  wall.kind = SurfaceKind::kWall;
  scene.boxes = {wall};
  const Pose T_world_camera = CameraLookingAlong(Vec3(0.0, 1.0, 0.0), Vec3::UnitZ(), 0.0);
  const PinholeIntrinsics K = SimIntrinsics(160, 90);
  StereoOptions options;
  options.upsample = 2;
  const auto share = [&](double contrast) {
    SurfaceTexture texture;
    texture.contrast = contrast;
    SimRng rng(1, 2);
    return ValidShare(StereoDepth(scene, {texture}, {T_world_camera, K, 160, 90}, options, rng));
  };
  // Measured: 6.0% matched without texture (noise matched by chance), 99.5% with a contrast
  // of 0.3.
  EXPECT_LT(share(0.0), 0.12);
  EXPECT_GT(share(0.3), 0.9);
}

TEST(StereoDepth, DisparityOffsetShiftsInverseDepthOnTheListedCameraOnly) {
  SimOptions o = SmallRig();
  o.depth_model = DepthModel::kStereo;
  const SimulatedRig plain = SimulateRig(o);
  o.disparity_offset_px = 0.25;
  o.miscalibrated_cameras = {1};
  const SimulatedRig shifted = SimulateRig(o);
  const std::vector<float>& reference = plain.capture.cameras[0].depth_m;
  const std::vector<float>& reference_again = shifted.capture.cameras[0].depth_m;
  ASSERT_EQ(reference.size(), reference_again.size());
  EXPECT_EQ(std::memcmp(reference.data(), reference_again.data(), reference.size() * 4), 0);
  // The same images and matches: f B (1 / z' - 1 / z) is the offset up to float32 rounding
  // (measured: within 2e-5 px).
  const std::vector<double> errors =
      DisparityErrors(shifted.capture.cameras[1], plain.capture.cameras[1], 0.12);
  ASSERT_GT(errors.size(), 1000u);
  for (const double e : errors) ASSERT_NEAR(e, 0.25, 1e-4);
}

TEST(SimulateRig, MiscalibrationOfTheGaussianModel) {
  SimOptions o = Truth(SmallRig());
  o.cameras = 3;
  const SimulatedRig truth = SimulateRig(o);
  o.disparity_offset_px = -0.1;
  o.depth_scale = 1.01;
  const SimulatedRig miscalibrated = SimulateRig(o);  // every camera but 0 by default
  const double f_b = truth.capture.cameras[0].intrinsics.fx * o.stereo_baseline_m;
  for (int c = 0; c < 3; ++c) {
    const std::vector<float>& z = truth.capture.cameras[c].depth_m;
    const std::vector<float>& z2 = miscalibrated.capture.cameras[c].depth_m;
    for (size_t i = 0; i < z.size(); i += 7) {
      if (!std::isfinite(z[i])) continue;
      const double expected = c == 0 ? z[i] : 1.01 * f_b / (f_b / z[i] - 0.1);
      ASSERT_NEAR(z2[i], expected, 1e-5 * expected) << c << " " << i;  // float32
    }
  }
}

TEST(SimulateRig, ChecksTheStereoAndMiscalibrationOptions) {
  const auto message = [](const std::function<void(SimOptions&)>& change) {
    SimOptions o;
    change(o);
    try {
      CheckSimOptions(o);
    } catch (const SettingError& e) {
      return e.Spelled(SettingError::Flag);
    }
    return std::string("no error");
  };
  EXPECT_THAT(message([](SimOptions& o) { o.stereo_upsample = 0; }),
              StrEq("--stereo-upsample must be in [1, 4], got 0"));
  EXPECT_THAT(message([](SimOptions& o) { o.stereo_baseline_m = 0.0; }),
              HasSubstr("--stereo-baseline-m must be a finite number > 0"));
  EXPECT_THAT(message([](SimOptions& o) { o.depth_scale = 0.0; }),
              HasSubstr("--depth-scale must be in [0.5, 2]"));
  EXPECT_THAT(message([](SimOptions& o) { o.disparity_offset_px = NAN; }),
              HasSubstr("--disparity-offset-px must be finite"));
  EXPECT_THAT(message([](SimOptions& o) {
                o.miscalibrated_cameras = {0, 4};
              }),
              HasSubstr("--miscalibrated-cameras must be camera indices in [0, 3], got 4"));
  EXPECT_THAT(message([](SimOptions& o) {
                o.depth_model = DepthModel::kStereo;
                o.disparity_quant_px = 0.125;
              }),
              HasSubstr("--disparity-quant-px must be 0 with --depth-model stereo"));
  EXPECT_THAT(message([](SimOptions& o) {
                o.depth_model = DepthModel::kStereo;
                o.noise_corr_px = 2.0;
                o.noise_corr_share = 0.5;
              }),
              HasSubstr("--noise-corr-share must be 0 with --depth-model stereo"));
  EXPECT_EQ(message([](SimOptions& o) { o.depth_model = DepthModel::kStereo; }), "no error");
}

}  // namespace
}  // namespace rigfit
