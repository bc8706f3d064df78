#include "core/geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace rigfit {
namespace {

constexpr double kTolerance = 1e-12;

CameraCapture FlatDepthCamera(int width, int height, float z) {
  CameraCapture c;
  c.serial = "cam";
  c.width = width;
  c.height = height;
  c.intrinsics = {100.0, 110.0, 3.5, 2.5};
  c.depth_m.assign(static_cast<size_t>(width) * height, z);
  return c;
}

TEST(UnprojectDepth, PinholeModelAndInvalidPixels) {
  CameraCapture c = FlatDepthCamera(8, 6, 2.0f);
  c.depth_m[0] = std::numeric_limits<float>::quiet_NaN();
  c.depth_m[1] = 0.0f;
  c.depth_m[2] = 50.0f;  // beyond max range
  const PointCloud pts = UnprojectDepth(c, UnprojectOptions{});
  ASSERT_EQ(pts.size(), 8u * 6u - 3u);
  // First kept pixel is (u=3, v=0).
  EXPECT_NEAR(pts[0].x(), 2.0 * (3 - 3.5) / 100.0, kTolerance);
  EXPECT_NEAR(pts[0].y(), 2.0 * (0 - 2.5) / 110.0, kTolerance);
  EXPECT_NEAR(pts[0].z(), 2.0, kTolerance);
}

TEST(UnprojectDepth, StrideKeepsEveryNthPixel) {
  const CameraCapture c = FlatDepthCamera(8, 6, 1.0f);
  UnprojectOptions options;
  options.pixel_stride = 3;
  EXPECT_EQ(UnprojectDepth(c, options).size(), 3u * 2u);  // u in {0,3,6}, v in {0,3}
}

TEST(RelativeError, IsGaugeFree) {
  const Pose a = PosePlus(Pose::Identity(), (Vec6() << 0.1, 0.2, 0.3, 1, 2, 3).finished());
  const Pose b = PosePlus(Pose::Identity(), (Vec6() << -0.3, 0.5, 0.1, -1, 0, 2).finished());
  const Pose gauge = PosePlus(Pose::Identity(), (Vec6() << 0.7, -0.1, 0.4, 5, 6, 7).finished());
  const RelativePoseError e = RelativeError(gauge * a, gauge * b, a, b);
  EXPECT_NEAR(e.rotation_rad, 0.0, 1e-9);
  EXPECT_NEAR(e.translation_m, 0.0, 1e-9);
  Pose b_moved = b;
  b_moved.translation() += Vec3(0.003, 0.0, 0.004);
  EXPECT_NEAR(RelativeError(a, b_moved, a, b).translation_m, 0.005, 1e-12);
}

TEST(TiltError, BlindToYawAndTranslationSensitiveToTilt) {
  const Pose gt = PosePlus(Pose::Identity(), (Vec6() << 2.0, 0.3, 0.1, 1, 2, 3).finished());
  const Pose yawed = PosePlus(gt, (Vec6() << 0, 0.5, 0, 4, 5, 6).finished());
  EXPECT_NEAR(TiltErrorRad(yawed, gt), 0.0, 1e-12);
  const Pose tilted = PosePlus(gt, (Vec6() << 0.01, 0, 0, 0, 0, 0).finished());
  EXPECT_NEAR(TiltErrorRad(tilted, gt), 0.01, 1e-9);
}

TEST(RotationAngle, AccurateForTinyAndLargeAngles) {
  for (double angle : {1e-9, 1e-5, 1.0, M_PI - 1e-6}) {
    EXPECT_NEAR(RotationAngle(ExpSO3(angle * Vec3(0.6, 0.0, 0.8))), angle, 1e-12 + 1e-9 * angle);
  }
}

}  // namespace
}  // namespace rigfit
