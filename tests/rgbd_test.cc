// The dense RGB-D tracking: frame preprocessing, projective association, the two solve paths
// of the point-to-plane Gauss-Newton, coarse-to-fine tracking and odometry on rendered frames.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/errors.h"
#include "core/pose.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"
#include "rgbd_test_util.h"
#include "sim/random.h"
#include "sim/scene.h"

namespace rigfit {
namespace {

using namespace rgbd_test;  // NOLINT: TestRoom, LookAt, Render

double TranslationError(const Pose& a, const Pose& b) {
  return (a.translation() - b.translation()).norm();
}
double RotationErrorRad(const Pose& a, const Pose& b) {
  return LogSO3(a.linear().transpose() * b.linear()).norm();
}

TEST(RgbdFrame, PyramidScalesIntrinsicsAndKeepsSilhouettes) {
  RgbdFrame frame;
  frame.width = 8;
  frame.height = 4;
  frame.intrinsics = {100.0, 90.0, 3.5, 1.5};
  frame.source = "test";
  // Left half a wall at 1 m, right half at 3 m: the 2x2 block straddling the jump at u = 3..4
  // does not exist (blocks are 0-1, 2-3, 4-5, 6-7), so make one: column 3 at 3 m.
  frame.depth_m.assign(32, 1.0f);
  for (int v = 0; v < 4; ++v) {
    for (int u = 3; u < 8; ++u) frame.depth_m[v * 8 + u] = 3.0f;
  }
  FrameOptions options;
  options.levels = 2;
  const FramePyramid pyramid = BuildFramePyramid(frame, options);
  ASSERT_EQ(pyramid.levels.size(), 2u);
  const FrameLevel& coarse = pyramid.levels[1];
  EXPECT_EQ(coarse.width, 4);
  EXPECT_EQ(coarse.height, 2);
  EXPECT_DOUBLE_EQ(coarse.intrinsics.fx, 50.0);
  EXPECT_DOUBLE_EQ(coarse.intrinsics.fy, 45.0);
  EXPECT_DOUBLE_EQ(coarse.intrinsics.cx, 1.5);  // (3.5 + 0.5) / 2 - 0.5
  EXPECT_DOUBLE_EQ(coarse.intrinsics.cy, 0.5);
  // Block u = 2..3 holds 1 m and 3 m: the nearest (1 m) is kept, not the mean 2 m.
  EXPECT_FLOAT_EQ(coarse.depth_m[1], 1.0f);
  EXPECT_FLOAT_EQ(coarse.depth_m[2], 3.0f);
}

TEST(RgbdFrame, HalvingAveragesBlocksWithoutCrossingAJumpAndScalesTheIntrinsics) {
  RgbdFrame frame;
  frame.width = 4;
  frame.height = 2;
  frame.intrinsics = {100.0, 90.0, 1.5, 0.5};
  // Left block: 1.0, 1.02, 1.04 and an invalid pixel; right block: 1.0 next to 3.0 (a jump).
  frame.depth_m = {1.0f, 1.02f, 1.0f, 3.0f, 1.04f, kNaN, 3.0f, 3.0f};
  frame.color.assign(3 * 8, 0);
  frame.color[0] = 10;  // pixel (0, 0) red 10; (1, 0) red 20; (0, 1) red 31; (1, 1) red 0
  frame.color[3] = 20;
  frame.color[12] = 31;
  const RgbdFrame half = HalveFrame(frame, 0.05);
  ASSERT_EQ(half.width, 2);
  ASSERT_EQ(half.height, 1);
  EXPECT_DOUBLE_EQ(half.intrinsics.fx, 50.0);
  EXPECT_DOUBLE_EQ(half.intrinsics.fy, 45.0);
  EXPECT_DOUBLE_EQ(half.intrinsics.cx, 0.5);  // (1.5 + 0.5) / 2 - 0.5
  EXPECT_DOUBLE_EQ(half.intrinsics.cy, 0.0);
  EXPECT_NEAR(half.depth_m[0], 1.02f, 1e-6f);  // the mean of the three valid ones
  EXPECT_FLOAT_EQ(half.depth_m[1], 1.0f);      // the nearest, the far ones left out
  ASSERT_EQ(half.color.size(), 6u);
  EXPECT_EQ(half.color[0], 15);  // (10 + 20 + 31 + 0) / 4 rounded
  EXPECT_EQ(half.color[3], 0);
  frame.depth_m.pop_back();
  EXPECT_THROW(HalveFrame(frame, 0.05), InputError);
}

TEST(RgbdFrame, TruncationAndVertexAndNormalMapsOfATiltedPlane) {
  // The plane z = 2 + 0.5 x seen by a 32x24 camera: every interior normal is the plane's.
  RgbdFrame frame;
  frame.width = 32;
  frame.height = 24;
  frame.intrinsics = Intrinsics(32, 24);
  frame.source = "test";
  const PinholeIntrinsics& K = frame.intrinsics;
  for (int v = 0; v < 24; ++v) {
    for (int u = 0; u < 32; ++u) {
      const double a = (u - K.cx) / K.fx;  // x = a z on the ray
      frame.depth_m.push_back(static_cast<float>(2.0 / (1.0 - 0.5 * a)));
    }
  }
  frame.depth_m[5] = 10.0f;  // beyond max_depth_m: dropped
  FrameOptions options;
  options.levels = 1;
  options.bilateral = false;
  const FrameLevel level = BuildFramePyramid(frame, options).levels[0];
  EXPECT_TRUE(std::isnan(level.depth_m[5]));
  // The bilateral filter smooths the normals only: the vertices stay the measured points.
  options.bilateral = true;
  const FrameLevel filtered = BuildFramePyramid(frame, options).levels[0];
  for (int i = 0; i < 32 * 24; ++i) {
    if (level.Valid(i) && filtered.Valid(i)) {
      EXPECT_EQ(filtered.vertices[i], level.vertices[i]) << i;
    }
  }
  const Vec3 expected = Vec3(0.5, 0.0, -1.0).normalized();  // facing the camera
  int checked = 0;
  for (int v = 1; v < 23; ++v) {
    for (int u = 1; u < 31; ++u) {
      const int i = v * 32 + u;
      if (std::abs(i - 5) <= 1 || std::abs(i - 5 - 32) <= 0) continue;
      if (!level.Valid(i)) continue;
      const Vec3 p = level.vertices[i].cast<double>();
      EXPECT_NEAR(p.z(), 2.0 + 0.5 * p.x(), 1e-5);
      EXPECT_NEAR((u - K.cx) / K.fx * p.z(), p.x(), 1e-5);
      EXPECT_LT((level.normals[i].cast<double>() - expected).norm(), 1e-4);
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
  // No normal at the border or next to the dropped pixel.
  EXPECT_FALSE(level.Valid(0));
  EXPECT_FALSE(level.Valid(5 + 32));
}

TEST(RgbdFrame, BilateralFilterSmoothsAPlaneButNotAStep) {
  const int w = 20, h = 10;
  std::vector<float> depth(w * h);
  SimRng rng(3, 1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      depth[v * w + u] = static_cast<float>((u < 10 ? 1.0 : 2.0) + 0.005 * rng.Normal());
    }
  }
  const std::vector<float> filtered = BilateralFilter(depth, w, h, 2.0, 0.03);
  double before = 0.0, after = 0.0;
  for (int v = 2; v < h - 2; ++v) {
    for (int u = 2; u < 7; ++u) {
      before += std::pow(depth[v * w + u] - 1.0, 2);
      after += std::pow(filtered[v * w + u] - 1.0, 2);
    }
  }
  EXPECT_LT(after, 0.3 * before);  // a 5x5-pixel window cuts the variance ~10x
  for (int v = 0; v < h; ++v) {
    EXPECT_NEAR(filtered[v * w + 9], 1.0, 0.02);  // the step is 1 m, the range sigma 3 cm
    EXPECT_NEAR(filtered[v * w + 10], 2.0, 0.02);
  }
}

// With range_grows the range sigma grows as the depth noise does (z^2): at 3 m, noise 9 times
// that at 1 m is averaged as much as at 1 m, and a 1 m step (3.7 range sigmas there) is kept.
TEST(RgbdFrame, BilateralFilterWhoseRangeGrowsSmoothsFarDepthAsMuchAsNear) {
  const int w = 20, h = 10;
  const auto residual_variance = [&](double z0, double sigma, bool grows) {
    std::vector<float> depth(w * h);
    SimRng rng(3, 1);
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        depth[v * w + u] = static_cast<float>(z0 + (u < 10 ? 0.0 : 1.0) + sigma * rng.Normal());
      }
    }
    const std::vector<float> filtered = BilateralFilter(depth, w, h, 2.0, 0.03, grows);
    double before = 0.0, after = 0.0;
    for (int v = 2; v < h - 2; ++v) {
      for (int u = 2; u < 7; ++u) {
        before += std::pow(depth[v * w + u] - z0, 2);
        after += std::pow(filtered[v * w + u] - z0, 2);
      }
    }
    for (int v = 0; v < h; ++v) {
      EXPECT_NEAR(filtered[v * w + 9], z0, 3.0 * sigma) << z0;
      EXPECT_NEAR(filtered[v * w + 10], z0 + 1.0, 3.0 * sigma) << z0;
    }
    return after / before;
  };
  // Measured (variance after / before): 0.005 at 1 m and at 3 m; a fixed 3 cm range sigma
  // leaves 0.894 at 3 m.
  EXPECT_LT(residual_variance(1.0, 0.01, true), 0.05);
  EXPECT_LT(residual_variance(3.0, 0.09, true), 0.05);
  EXPECT_GT(residual_variance(3.0, 0.09, false), 0.5);
}

// FrameOptions::bilateral_range_grows reaches the level-0 normals: a wall 3 m away with 2 cm
// of depth noise (stereo's at that distance) gets normals near its own.
TEST(RgbdFrame, NormalsOfFarNoisyDepthWithTheRangeGrowing) {
  RgbdFrame frame;
  frame.width = 160;
  frame.height = 120;
  frame.intrinsics = Intrinsics(160, 120);
  SimRng rng(7, 1);
  for (int i = 0; i < 160 * 120; ++i) frame.depth_m.push_back(3.0f + 0.02f * rng.Normal());
  const auto rms_angle_deg = [&](bool grows) {
    FrameOptions options;
    options.bilateral_range_grows = grows;
    const FrameLevel level = BuildFramePyramid(frame, options).levels[0];
    double sum = 0.0;
    for (const int i : level.valid_pixels) {
      const double c = std::min(1.0f, -level.normals[i].z());
      sum += std::pow(std::acos(c) / kDegToRad, 2);
    }
    return std::sqrt(sum / level.valid_pixels.size());
  };
  // Measured RMS angle to the wall's normal: 9.65 deg with the fixed 3 cm, 3.56 growing.
  EXPECT_GT(rms_angle_deg(false), 7.0);
  EXPECT_LT(rms_angle_deg(true), 5.0);
}

// A depth image with noise, a step, invalid pixels and a pixel across a jump, for the filters'
// comparisons with their one-pixel loops.
std::vector<float> RoughDepth(int w, int h) {
  std::vector<float> depth(w * h);
  SimRng rng(5, 1);
  for (int i = 0; i < w * h; ++i) {
    depth[i] = static_cast<float>((i % w < w / 2 ? 1.0 : 1.04) + 0.01 * rng.Normal());
    if (rng.Uniform() < 0.1) depth[i] = std::numeric_limits<float>::quiet_NaN();
  }
  depth[w + 1] = 3.0f;
  return depth;
}

// BilateralFilter of RoughDepth(w, h) against the filter written pixel by pixel.
void ExpectBilateralBitsOfTheOnePixelWindowLoop(int w, int h, bool range_grows) {
  const double sigma_px = 2.0, sigma_m = 0.03;
  const std::vector<float> depth = RoughDepth(w, h);
  // The documented filter, pixel by pixel: the range weight tabulated every 64th of the range
  // sigma up to 4 of them (0 there and beyond), taps d = -4..4 in order, x then y.
  std::vector<float> range(4 * 64 + 1);
  for (std::size_t k = 0; k < range.size(); ++k) {
    range[k] = static_cast<float>(std::exp(-0.5 * (k / 64.0) * (k / 64.0)));
  }
  range.back() = 0.0f;
  const auto pass = [&](const std::vector<float>& in, bool along_x) {
    std::vector<float> out(in.size(), std::numeric_limits<float>::quiet_NaN());
    for (int v = 0; v < h; ++v) {
      for (int u = 0; u < w; ++u) {
        const float z = in[v * w + u];
        if (std::isnan(z)) continue;
        float sum = 0.0f, weight = 0.0f;
        for (int d = -4; d <= 4; ++d) {
          const int un = along_x ? u + d : u, vn = along_x ? v : v + d;
          if (un < 0 || vn < 0 || un >= w || vn >= h || std::isnan(in[vn * w + un])) continue;
          const float zn = in[vn * w + un];
          // With range_grows the range sigma grows as z^2 beyond 1 m (z the nearer depth).
          const float nearer = std::min(zn, z);
          const float scale = range_grows ? std::max(1.0f, nearer * nearer) : 1.0f;
          const float step =
              std::min(std::abs(zn - z) * static_cast<float>(64 / sigma_m) / scale, 256.0f);
          const float weight_d =
              static_cast<float>(std::exp(-d * d / (2.0 * sigma_px * sigma_px))) *
              range[static_cast<int>(step + 0.5f)];
          sum += weight_d * zn;
          weight += weight_d;
        }
        out[v * w + u] = sum / weight;
      }
    }
    return out;
  };
  const std::vector<float> expected = pass(pass(depth, true), false);
  const std::vector<float> filtered =
      BilateralFilter(depth, w, h, sigma_px, sigma_m, range_grows, 2);
  for (int i = 0; i < w * h; ++i) {
    if (std::isnan(expected[i])) {
      EXPECT_TRUE(std::isnan(filtered[i])) << i;
    } else {
      EXPECT_EQ(filtered[i], expected[i]) << w << "x" << h << ": " << i;  // same bits
    }
  }
}

TEST(RgbdFrame, BilateralFilterHasTheBitsOfTheOnePixelWindowLoop) {
  for (const bool range_grows : {false, true}) {
    ExpectBilateralBitsOfTheOnePixelWindowLoop(23, 17, range_grows);
    ExpectBilateralBitsOfTheOnePixelWindowLoop(3, 2, range_grows);  // narrower than the window
  }
}

TEST(RgbdFrame, HalvingHasTheBitsOfTheOneBlockLoop) {
  const int w = 24, h = 18;
  RgbdFrame frame;
  frame.width = w;
  frame.height = h;
  frame.intrinsics = {100.0, 100.0, 11.5, 8.5};
  frame.depth_m = RoughDepth(w, h);
  const double ratio = 0.03;
  const RgbdFrame half = HalveFrame(frame, ratio);
  for (int v = 0; v < h / 2; ++v) {
    for (int u = 0; u < w / 2; ++u) {
      // The valid samples of the block in row order; the mean of those within the ratio of the
      // nearest, summed in double.
      std::vector<float> samples;
      for (int k = 0; k < 4; ++k) {
        const float z = frame.depth_m[(2 * v + k / 2) * w + 2 * u + k % 2];
        if (!std::isnan(z)) samples.push_back(z);
      }
      const float z = half.depth_m[v * (w / 2) + u];
      if (samples.empty()) {
        EXPECT_TRUE(std::isnan(z));
        continue;
      }
      const float nearest = *std::min_element(samples.begin(), samples.end());
      double sum = 0.0;
      int count = 0;
      for (const float s : samples) {
        if (s - nearest <= ratio * nearest) {
          sum += s;
          ++count;
        }
      }
      EXPECT_EQ(z, static_cast<float>(sum / count)) << u << ", " << v;
    }
  }
}

TEST(RgbdAssociation, EachConditionIsTested) {
  const FrameLevel target = SinglePixelLevel(2.0f);
  AssociationOptions options;
  options.max_distance_m = 0.1;
  options.max_normal_angle_deg = 30.0;
  int j = -1;
  // Matched: the same pixel, 5 cm closer.
  FrameLevel source = SinglePixelLevel(1.95f);
  EXPECT_EQ(AssociatePixel(source, 12, target, Pose::Identity(), options, &j),
            AssociationOutcome::kMatched);
  EXPECT_EQ(j, 12);
  // No source point.
  EXPECT_EQ(AssociatePixel(source, 0, target, Pose::Identity(), options, &j),
            AssociationOutcome::kNoSourcePoint);
  // Behind the target camera.
  Pose behind = Pose::Identity();
  behind.translation() = Vec3(0, 0, -3.0);
  EXPECT_EQ(AssociatePixel(source, 12, target, behind, options, &j),
            AssociationOutcome::kBehindCamera);
  // Outside the image: 0.3 m sideways at 1.95 m is 1.5 px... at f = 10 px, 1.2 m is 6 px.
  Pose sideways = Pose::Identity();
  sideways.translation() = Vec3(1.2, 0, 0);
  EXPECT_EQ(AssociatePixel(source, 12, target, sideways, options, &j),
            AssociationOutcome::kOutsideImage);
  // Lands on an invalid target pixel: 0.2 m sideways is 1 px.
  sideways.translation() = Vec3(0.2, 0, 0);
  EXPECT_EQ(AssociatePixel(source, 12, target, sideways, options, &j),
            AssociationOutcome::kNoTargetPoint);
  // Too far: 15 cm in front of the target point.
  source = SinglePixelLevel(1.85f);
  EXPECT_EQ(AssociatePixel(source, 12, target, Pose::Identity(), options, &j),
            AssociationOutcome::kTooFar);
  // Normals 40 degrees apart.
  source = SinglePixelLevel(1.95f);
  source.normals[12] = ExpSO3(Vec3(40.0 * kDegToRad, 0, 0)).cast<float>() * Vec3f(0, 0, -1);
  EXPECT_EQ(AssociatePixel(source, 12, target, Pose::Identity(), options, &j),
            AssociationOutcome::kNormalsDisagree);
  source.normals[12] = ExpSO3(Vec3(20.0 * kDegToRad, 0, 0)).cast<float>() * Vec3f(0, 0, -1);
  EXPECT_EQ(AssociatePixel(source, 12, target, Pose::Identity(), options, &j),
            AssociationOutcome::kMatched);
}

// The overlap counts the pixels that land on the target's depth, matched or not.
TEST(RgbdAssociation, OverlapShareCountsThePixelsThatLandOnTheTarget) {
  const Scene room = TestRoom();
  const Pose T = LookAt(Vec3(0.0, 1.4, 0.0), Vec3(0.0, 1.0, -2.5));
  const FramePyramid frame = BuildFramePyramid(Render(room, T, 160, 120, 0.0015, 1), {});
  const FrameLevel& level = frame.levels[0];
  const AssociationOptions options;
  EXPECT_EQ(OverlapShare(level, level, Pose::Identity(), options), 1.0);
  // Turned 20 degrees about the camera's y axis: the pixels that land in the image on a
  // vertex, whatever the distance and normal gates say.
  const Pose turned = PosePlus(Pose::Identity(), (Vec6() << 0, 0.35, 0, 0, 0, 0).finished());
  int landed = 0;
  for (const int i : level.valid_pixels) {
    int j = -1;
    const AssociationOutcome outcome = AssociatePixel(level, i, level, turned, options, &j);
    landed += outcome == AssociationOutcome::kMatched || outcome == AssociationOutcome::kTooFar ||
              outcome == AssociationOutcome::kNormalsDisagree;
  }
  const double share = OverlapShare(level, level, turned, options);
  EXPECT_DOUBLE_EQ(share, static_cast<double>(landed) / level.valid_pixels.size());
  EXPECT_GT(share, 0.3);
  EXPECT_LT(share, 0.8);
  // Turned half a turn: everything behind the camera.
  const Pose behind = PosePlus(Pose::Identity(), (Vec6() << 0, M_PI, 0, 0, 0, 0).finished());
  EXPECT_EQ(OverlapShare(level, level, behind, options), 0.0);
  EXPECT_EQ(OverlapShare(FrameLevel{}, level, Pose::Identity(), options), 0.0);
}

TEST(RgbdAssociation, RoundsToTheNearestPixelUpToTheImageEdge) {
  // A target whose every pixel is valid at 2 m, f = 10 px, c = 2: a source point at
  // x = (u - 2) z / f lands on column u.
  FrameLevel target = SinglePixelLevel(2.0f);
  for (int i = 0; i < 25; ++i) {
    const float u = static_cast<float>(i % 5), v = static_cast<float>(i / 5);
    target.depth_m[i] = 2.0f;
    target.vertices[i] = Vec3f((u - 2) * 0.2f, (v - 2) * 0.2f, 2.0f);
    target.normals[i] = Vec3f(0, 0, -1);
  }
  FrameLevel source = SinglePixelLevel(2.0f);
  const AssociationOptions options{1.0, 30.0};
  const auto at_column = [&](double u, int* j) {
    Pose T = Pose::Identity();
    T.translation() = Vec3((u - 2.0) * 0.2, 0, 0);  // moves the centre point to column u
    return AssociatePixel(source, 12, target, T, options, j);
  };
  int j = -1;
  EXPECT_EQ(at_column(-0.5, &j), AssociationOutcome::kMatched);
  EXPECT_EQ(j, 10);  // row 2, column 0
  EXPECT_EQ(at_column(-0.5001, &j), AssociationOutcome::kOutsideImage);
  EXPECT_EQ(at_column(4.4999, &j), AssociationOutcome::kMatched);
  EXPECT_EQ(j, 14);
  EXPECT_EQ(at_column(4.5, &j), AssociationOutcome::kOutsideImage);
  EXPECT_EQ(at_column(1.49, &j), AssociationOutcome::kMatched);
  EXPECT_EQ(j, 11);
  EXPECT_EQ(at_column(1.51, &j), AssociationOutcome::kMatched);
  EXPECT_EQ(j, 12);
}

TEST(RgbdWeights, DepthNoiseWeightIsTheInverseVarianceOfZSquaredNoise) {
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(1.0, 1.0), 1.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(2.0, 2.0), 1.0 / 16.0);  // sigma ~ z^2: variance ~ z^4
  // With a floor at 1 m a nearer depth weighs as 1 m; a farther one is not changed.
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(0.5, 0.5), 16.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(0.5, 0.5, 1.0), 1.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(0.5, 2.0, 1.0), 2.0 / 17.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(2.0, 2.0, 1.0), 1.0 / 16.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(1.0, 2.0), 2.0 / 17.0);
  EXPECT_DOUBLE_EQ(DepthNoiseWeight(2.0, 1.0), DepthNoiseWeight(1.0, 2.0));
}

class RgbdTracking : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new Scene(TestRoom());
    T_world_target_ = LookAt(Vec3(0.4, 1.5, 1.6), Vec3(0.0, 0.5, -1.5));
    // A hand-held step: 2 cm and 1.5 degrees.
    T_world_source_ =
        PosePlus(T_world_target_, (Vec6() << 0.01, -0.02, 0.008, 0.015, -0.01, 0.012).finished());
  }
  static void TearDownTestSuite() { delete scene_; }
  static Pose TrueMotion() { return T_world_target_.inverse() * T_world_source_; }
  /// The full-resolution level of the camera at T_world_camera (depth noise k z^2 when k > 0).
  static FrameLevel FineLevel(const Pose& T_world_camera, int width, int height, double noise = 0.0,
                              std::uint64_t seed = 0) {
    FrameOptions options;
    options.levels = 1;
    return BuildFramePyramid(Render(*scene_, T_world_camera, width, height, noise, seed), options)
        .levels[0];
  }

  static Scene* scene_;
  static Pose T_world_target_;
  static Pose T_world_source_;
};
Scene* RgbdTracking::scene_ = nullptr;
Pose RgbdTracking::T_world_target_;
Pose RgbdTracking::T_world_source_;

TEST_F(RgbdTracking, ListAndFusedNormalEquationsAreTheSame) {
  const FrameLevel target = FineLevel(T_world_target_, 160, 120);
  const FrameLevel source = FineLevel(T_world_source_, 160, 120);
  const AssociationOptions options;
  const std::vector<ProjectiveCorrespondence> pairs =
      FindCorrespondences(source, target, Pose::Identity(), options);
  for (const PairWeighting weighting :
       {PairWeighting{}, PairWeighting{0.005, false}, PairWeighting{0.005, true}}) {
    const NormalEquations list = BuildNormalEquations(pairs, Pose::Identity(), weighting, 1);
    const NormalEquations fused =
        AccumulateProjective(source, target, Pose::Identity(), options, weighting, 2);
    ASSERT_GT(list.count, 5000);
    EXPECT_EQ(list.count, fused.count);
    EXPECT_LT((list.H - fused.H).norm(), 1e-9 * list.H.norm());
    EXPECT_LT((list.g - fused.g).norm(), 1e-9 * list.g.norm());
  }
}

TEST_F(RgbdTracking, OneGaussNewtonStepRecoversASmallMotion) {
  // With the true pairs (each source pixel's own surface point), one linearised step from
  // the identity leaves only the second-order error of the small-angle model.
  const FrameLevel source = FineLevel(T_world_source_, 160, 120);
  const FrameLevel target = FineLevel(T_world_target_, 160, 120);
  std::vector<ProjectiveCorrespondence> pairs;
  const Pose motion = TrueMotion();
  for (int i = 0; i < source.width * source.height; ++i) {
    int j = -1;
    if (AssociatePixel(source, i, target, motion, AssociationOptions{}, &j) !=
        AssociationOutcome::kMatched) {
      continue;
    }
    // q: the source point itself in the target frame (on the surface), n: the target normal.
    pairs.push_back({source.vertices[i].cast<double>(), motion * source.vertices[i].cast<double>(),
                     target.normals[j].cast<double>()});
  }
  ASSERT_GT(pairs.size(), 5000u);
  const NormalEquations equations = BuildNormalEquations(pairs, Pose::Identity(), {});
  const Pose stepped = ApplyLeftUpdate(SolveStep(equations, 2.0, 1e-12).x, Pose::Identity());
  // 1.4 degrees and 2 cm: second-order terms ~ (0.024 rad)^2 x 3 m ~ 2 mm.
  EXPECT_LT(TranslationError(stepped, motion), 3e-3);
  EXPECT_LT(RotationErrorRad(stepped, motion), 1e-3);
  const Pose converged = SolvePairsGaussNewton(pairs, Pose::Identity(), {}, 20);
  EXPECT_LT(TranslationError(converged, motion), 1e-6);
  EXPECT_LT(RotationErrorRad(converged, motion), 1e-6);
}

TEST_F(RgbdTracking, ClosedFormAndCeresAgreeOnTheSamePairs) {
  const FrameLevel source = FineLevel(T_world_source_, 80, 60, 0.0025, 1);
  const FrameLevel target = FineLevel(T_world_target_, 80, 60, 0.0025, 2);
  const std::vector<ProjectiveCorrespondence> pairs =
      FindCorrespondences(source, target, Pose::Identity(), AssociationOptions{});
  ASSERT_GT(pairs.size(), 1000u);
  for (const PairWeighting weighting : {PairWeighting{}, PairWeighting{0.01, false},
                                        PairWeighting{0.0, true}, PairWeighting{0.01, true}}) {
    const Pose closed = SolvePairsGaussNewton(pairs, Pose::Identity(), weighting, 100);
    const Pose ceres = SolvePairsCeres(pairs, Pose::Identity(), weighting);
    const std::string what = "huber " + std::to_string(weighting.huber_delta_m) +
                             (weighting.depth_noise ? ", depth noise" : "");
    EXPECT_LT(TranslationError(closed, ceres), 1e-9) << what;
    EXPECT_LT(RotationErrorRad(closed, ceres), 1e-9) << what;
    // And the solution moved: it is not the start.
    EXPECT_GT(TranslationError(closed, Pose::Identity()), 5e-3);
  }
}

TEST_F(RgbdTracking, CoarseToFineTrackingRecoversTheMotion) {
  const FrameOptions frame_options;
  const FramePyramid source =
      BuildFramePyramid(Render(*scene_, T_world_source_, 320, 240), frame_options);
  const FramePyramid target =
      BuildFramePyramid(Render(*scene_, T_world_target_, 320, 240), frame_options);
  const TrackResult result =
      TrackProjective(source, target, Pose::Identity(), ProjectiveIcpOptions{});
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_EQ(result.weak_directions, 0);
  EXPECT_GT(result.matched_ratio, 0.8);
  // Noise-free: the projective pairs are exact to the pixel footprint at convergence.
  EXPECT_LT(TranslationError(result.T_target_source, TrueMotion()), 5e-4);
  EXPECT_LT(RotationErrorRad(result.T_target_source, TrueMotion()), 2e-4);
  EXPECT_LT(result.rmse_m, 1e-3);
}

TEST_F(RgbdTracking, AFlatWallHoldsWhatItCannotFix) {
  // A camera facing the +Z wall from 1.5 m sees nothing but the wall: the translations along
  // it and the rotation about its normal are unobservable and must not move.
  Scene wall;
  wall.size_x_m = 20.0;
  wall.size_z_m = 20.0;
  wall.wall_height_m = 20.0;
  OrientedBox box;
  box.center = Vec3(0, 0, -3.0);
  box.half_extents = Vec3(10, 10, 0.1);
  wall.boxes.push_back(box);
  const Pose T_world_target = LookAt(Vec3(0, 0, -1.5), Vec3(0, 0, -3));
  Pose T_world_source = T_world_target;
  T_world_source.translation() += Vec3(0, 0, 0.01);  // 1 cm away from the wall
  const FrameOptions frame_options;
  const FramePyramid source =
      BuildFramePyramid(Render(wall, T_world_source, 160, 120), frame_options);
  const FramePyramid target =
      BuildFramePyramid(Render(wall, T_world_target, 160, 120), frame_options);
  // Start 3 cm off along the wall: that offset must stay, the 1 cm across must be found.
  Pose start = Pose::Identity();
  start.translation() = Vec3(0.03, 0.0, 0.0);
  const TrackResult result = TrackProjective(source, target, start, ProjectiveIcpOptions{});
  ASSERT_TRUE(result.success) << result.message;
  EXPECT_EQ(result.weak_directions, 3);
  const Pose motion = T_world_target.inverse() * T_world_source;
  EXPECT_NEAR(result.T_target_source.translation().z(), motion.translation().z(), 1e-4);
  EXPECT_NEAR(result.T_target_source.translation().x(), 0.03, 1e-6);
  EXPECT_NEAR(result.T_target_source.translation().y(), 0.0, 1e-6);
}

// TrackResult::converged: judged at the finest level that runs steps, so that a pyramid whose
// finest level is skipped (its iterations 0) can converge; one step there cannot.
TEST(ProjectiveIcp, ConvergedAtTheFinestLevelThatRuns) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(2), 160, 120, 0.0);
  const FramePyramid target = BuildFramePyramid(sequence.Frame(0), FrameOptions{});
  const FramePyramid source = BuildFramePyramid(sequence.Frame(1), FrameOptions{});
  ProjectiveIcpOptions options;
  EXPECT_TRUE(TrackProjective(source, target, Pose::Identity(), options).converged);
  options.iterations = {0, 10, 10};
  const TrackResult skipped = TrackProjective(source, target, Pose::Identity(), options);
  ASSERT_TRUE(skipped.success) << skipped.message;
  EXPECT_TRUE(skipped.converged);
  options.iterations = {1, 0, 0};
  EXPECT_FALSE(TrackProjective(source, target, Pose::Identity(), options).converged);
}

TEST(RgbdOdometry, NoiseFreeWalkDriftsLessThanAMillimetrePerMetre) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(30), 320, 240, 0.0);
  OdometryOptions options;
  options.icp.converged_rotation_rad = 1e-7;
  options.icp.converged_translation_m = 1e-7;
  const OdometryResult result = RunOdometry(sequence, options);
  ASSERT_EQ(result.trajectory.poses.size(), 30u);
  EXPECT_EQ(result.failures, 0);
  const Trajectory gt = sequence.GroundTruth();
  double travelled = 0.0;
  for (int i = 1; i < 30; ++i) {
    travelled += (gt.poses[i].translation() - gt.poses[i - 1].translation()).norm();
  }
  ASSERT_GT(travelled, 0.3);
  // The first pose is the ground truth's; the last one's error is the drift.
  EXPECT_LT(TranslationError(result.trajectory.poses[0], gt.poses[0]), 1e-12);
  const double drift = TranslationError(result.trajectory.poses.back(), gt.poses.back());
  EXPECT_LT(drift / travelled, 1e-3) << "drift " << drift << " m over " << travelled << " m";
}

TEST(RgbdOdometry, ALongLossRestartsTheTrackAndKeepsRotations) {
  // 40 frames of sky (nothing to track) between good ones: the chain of predictions stays a
  // rotation, the track restarts after 5 failures in a row, and tracks again afterwards.
  const Scene scene = TestRoom();
  std::vector<Pose> poses = Walk(50);
  for (int i = 3; i < 43; ++i) {
    poses[i] = LookAt(poses[i].translation(), poses[i].translation() + Vec3(0, 10, 0.01));
  }
  const RenderedSequence sequence(scene, poses, 80, 60, 0.0);
  const OdometryResult result = RunOdometry(sequence, OdometryOptions{});
  // The sky frames fail and are no reference (nothing to track against); frame 43 tracks
  // against frame 2 from 41 frames of constant-velocity prediction, or fails and restarts.
  EXPECT_GE(result.failures, 40);
  EXPECT_LE(result.failures, 41);
  EXPECT_EQ(result.restarts, result.failures - 40);
  for (const Pose& T : result.trajectory.poses) {
    EXPECT_LT((T.linear().transpose() * T.linear() - Mat3::Identity()).norm(), 1e-12);
  }
  for (int i = 44; i < 50; ++i) EXPECT_TRUE(result.frames[i].track.success) << i;
}

TEST(RgbdOdometry, FramesFacingAFlatWallReportTheirWeakDirections) {
  Scene wall;
  wall.size_x_m = wall.size_z_m = wall.wall_height_m = 20.0;
  OrientedBox box;
  box.center = Vec3(0, 0, -3.0);
  box.half_extents = Vec3(10, 10, 0.1);
  wall.boxes.push_back(box);
  std::vector<Pose> poses;
  for (int i = 0; i < 3; ++i) poses.push_back(LookAt(Vec3(0, 0, -1.5 + 0.01 * i), Vec3(0, 0, -3)));
  const RenderedSequence sequence(wall, poses, 160, 120, 0.0);
  const OdometryResult result = RunOdometry(sequence, OdometryOptions{});
  ASSERT_EQ(result.frames.size(), 3u);
  EXPECT_EQ(result.failures, 0);
  EXPECT_EQ(result.frames[1].track.weak_directions, 3);
  EXPECT_EQ(result.frames[2].track.weak_directions, 3);
  // The motion across the wall is found; nothing moves along it.
  EXPECT_NEAR(result.trajectory.poses[2].translation().z(), poses[2].translation().z(), 1e-4);
  EXPECT_NEAR(result.trajectory.poses[2].translation().x(), 0.0, 1e-6);
}

// A keyframe is renewed when half of the pixels its first tracked frame matched are lost, not
// half of all pixels: on noisy depth, where the angle gate drops many pixels from the start,
// the absolute share renewed it every frame (frame-to-frame drift).
TEST(RgbdOdometry, AKeyframeIsKeptWhileFewPixelsMatchFromTheStart) {
  const Scene scene = TestRoom();
  const RenderedSequence sequence(scene, Walk(12), 160, 120, 0.003);
  OdometryOptions options;
  options.icp.association.max_normal_angle_deg = 20.0;
  const OdometryResult result = RunOdometry(sequence, options);
  int keyframes = 0;
  double matched = 0.0;
  for (const OdometryFrame& frame : result.frames) {
    keyframes += frame.keyframe ? 1 : 0;
    matched += frame.track.matched_ratio;
  }
  // Measured: 0.39 of the pixels matched on average; 2 keyframes (the first and one renewed
  // by distance), 12 of 12 by the absolute share.
  EXPECT_EQ(result.failures, 0);
  EXPECT_LT(matched / 11, 0.5);
  EXPECT_LE(keyframes, 3);
}

TEST(RgbdOdometry, KeyframesAndStrideAndFailuresAreReported) {
  const Scene scene = TestRoom();
  std::vector<Pose> poses = Walk(12);
  // Frame 6 looks at the ceiling-less sky: nothing to track.
  poses[6] = LookAt(poses[6].translation(), poses[6].translation() + Vec3(0, 10, 0.01));
  const RenderedSequence sequence(scene, poses, 160, 120, 0.0);
  OdometryOptions options;
  options.keyframes = true;
  options.stride = 2;
  const OdometryResult result = RunOdometry(sequence, options);
  ASSERT_EQ(result.frames.size(), 6u);
  EXPECT_EQ(result.frames[3].index, 6);
  EXPECT_FALSE(result.frames[3].track.success);
  EXPECT_EQ(result.failures, 1);
  EXPECT_EQ(result.restarts, 0);
  // The failed frame is no reference; its pose is the constant-velocity prediction.
  EXPECT_FALSE(result.frames[3].keyframe);
  const Trajectory& t = result.trajectory;
  const Pose predicted = t.poses[2] * (t.poses[1].inverse() * t.poses[2]);
  EXPECT_TRUE(t.poses[3].isApprox(predicted, 1e-9));
  // Frame 8 tracks against the last good reference and is back on the truth.
  EXPECT_TRUE(result.frames[4].track.success);
  EXPECT_LT(TranslationError(t.poses[4], poses[8]), 1e-3);
  EXPECT_THROW(
      {
        OdometryOptions bad;
        bad.first_frame = 12;
        RunOdometry(sequence, bad);
      },
      InputError);
}

}  // namespace
}  // namespace rigfit
