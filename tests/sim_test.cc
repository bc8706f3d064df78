#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <set>
#include <stdexcept>
#include <tuple>

#include "core/geometry.h"
#include "sim/noise_field.h"
#include "sim/random.h"
#include "sim/scene.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

/// Noise-free points must lie on the scene surface to well under a millimetre (the depth
/// is stored as float32: 1 ulp at 8 m is 1e-6 m).
constexpr double kOnSurfaceTolerance = 1e-4;

SimOptions NoiseFree(std::uint64_t seed) {
  SimOptions o;
  o.seed = seed;
  o.noise = 0.0;
  o.dropout = 0.0;
  return o;
}

SimOptions Small(SimOptions o) {
  o.width = 320;
  o.height = 180;
  return o;
}

PointCloud WorldPoints(const SimulatedRig& rig, const CameraCapture& camera, int stride = 1) {
  UnprojectOptions u;
  u.pixel_stride = stride;
  return Transform(rig.gt.at(camera.serial), UnprojectDepth(camera, u));
}

size_t CountValid(const CameraCapture& camera) {
  return std::count_if(camera.depth_m.begin(), camera.depth_m.end(),
                       [](float z) { return std::isfinite(z); });
}

bool SameBits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

TEST(SimRng, UniformAndNormalMoments) {
  SimRng rng(7, 3);
  constexpr int kSamples = 200000;
  double sum_u = 0.0, sum_n = 0.0, sum_n2 = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    const double u = rng.Uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum_u += u;
    const double n = rng.Normal();
    sum_n += n;
    sum_n2 += n * n;
  }
  // Standard errors: 0.29 / sqrt(N) = 6e-4 for the uniform mean, 2.2e-3 and 3.2e-3 for the
  // normal mean and second moment; the tolerances are about 5 of them.
  EXPECT_NEAR(sum_u / kSamples, 0.5, 3e-3);
  EXPECT_NEAR(sum_n / kSamples, 0.0, 1e-2);
  EXPECT_NEAR(sum_n2 / kSamples, 1.0, 1.5e-2);
  SimRng a(7, 3), b(7, 4), c(8, 3);
  EXPECT_NE(a.Uniform(), b.Uniform());
  EXPECT_NE(SimRng(7, 3).Uniform(), c.Uniform());
}

TEST(Scene, RaycastBoxEntryFaceAndMisses) {
  OrientedBox box;
  box.center = Vec3(1.0, 2.0, 3.0);
  box.R_world_box = ExpSO3(Vec3(0.0, 0.3, 0.0));
  box.half_extents = Vec3(0.5, 0.25, 1.0);
  // Straight down onto the top face (local +y = world +y for a yawed box), direction of
  // length 2: t is in units of the direction.
  const std::optional<RayHit> top = RaycastBox(box, Vec3(1.1, 5.0, 3.1), Vec3(0.0, -2.0, 0.0), 0.0);
  ASSERT_TRUE(top);
  EXPECT_NEAR(top->t, (5.0 - 2.25) / 2.0, 1e-12);
  EXPECT_NEAR((top->normal_world - Vec3::UnitY()).norm(), 0.0, 1e-12);
  // Along the box's local x axis onto its -x face.
  const Vec3 x_axis = box.R_world_box.col(0);
  const std::optional<RayHit> side = RaycastBox(box, box.center - 3.0 * x_axis, x_axis, 0.0);
  ASSERT_TRUE(side);
  EXPECT_NEAR(side->t, 2.5, 1e-12);
  EXPECT_NEAR((side->normal_world + x_axis).norm(), 0.0, 1e-12);
  EXPECT_FALSE(RaycastBox(box, box.center - 3.0 * x_axis, -x_axis, 0.0));  // points away
  EXPECT_FALSE(RaycastBox(box, Vec3(1.0, 5.0, 3.0) + 2.0 * x_axis, -Vec3::UnitY(), 0.0));
  EXPECT_FALSE(RaycastBox(box, box.center, x_axis, 0.0));  // starts inside
}

TEST(Scene, SignedDistanceOutsideInsideAndCorner) {
  OrientedBox box;
  box.half_extents = Vec3(1.0, 1.0, 1.0);
  EXPECT_NEAR(SignedDistance(box, Vec3(3.0, 0.0, 0.0)), 2.0, 1e-12);
  EXPECT_NEAR(SignedDistance(box, Vec3(0.0, 0.25, 0.0)), -0.75, 1e-12);
  EXPECT_NEAR(SignedDistance(box, Vec3(2.0, 2.0, 1.0)), std::sqrt(2.0), 1e-12);
  Scene scene;
  scene.boxes = {box};
  EXPECT_NEAR(scene.DistanceToSurface(Vec3(0.0, 0.25, 0.0)), 0.75, 1e-12);
}

TEST(SimulateRig, NoiseFreePointsLieOnTheTrueSurface) {
  const SimulatedRig rig = SimulateRig(NoiseFree(0));
  ASSERT_EQ(rig.capture.cameras.size(), 4u);
  for (const CameraCapture& camera : rig.capture.cameras) {
    const PointCloud points = WorldPoints(rig, camera);
    ASSERT_EQ(points.size(), CountValid(camera));  // every depth lies in [0.1, 10] m
    ASSERT_GT(points.size(), camera.depth_m.size() / 2) << camera.serial;
    double worst = 0.0;
    for (const Vec3& p : points) worst = std::max(worst, rig.scene.DistanceToSurface(p));
    EXPECT_LT(worst, kOnSurfaceTolerance) << camera.serial;
  }
}

TEST(SimulateRig, PixelConventionMatchesRaycastThroughPixel) {
  const SimulatedRig rig = SimulateRig(Small(NoiseFree(1)));
  const CameraCapture& camera = rig.capture.cameras[1];
  const Pose& T = rig.gt.at(camera.serial);
  const PinholeIntrinsics& K = camera.intrinsics;
  int checked = 0;
  for (int v = 0; v < camera.height; v += 7) {
    for (int u = 0; u < camera.width; u += 7) {
      const float z = camera.depth_m[static_cast<size_t>(v) * camera.width + u];
      const Vec3 ray = T.linear() * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const std::optional<RayHit> hit = rig.scene.Raycast(T.translation(), ray);
      ASSERT_EQ(std::isfinite(z), hit.has_value()) << u << "," << v;
      if (!hit) continue;
      EXPECT_NEAR(z, hit->t, 1e-6 * hit->t) << u << "," << v;
      ++checked;
    }
  }
  EXPECT_GT(checked, 1000);
}

TEST(SimulateRig, IntrinsicsAreZedLike) {
  const PinholeIntrinsics K = SimIntrinsics(640, 360);
  EXPECT_NEAR(2.0 * std::atan(320.0 / K.fx), 85.0 * kDegToRad, 1e-12);
  EXPECT_EQ(K.fx, K.fy);
  EXPECT_EQ(K.cx, 319.5);
  EXPECT_EQ(K.cy, 179.5);
}

TEST(SimulateRig, DepthNoiseFollowsTheStereoModel) {
  SimOptions options = Small(NoiseFree(2));
  options.noise = 0.0025;
  const SimulatedRig rig = SimulateRig(options);
  // Normalised error e = (z_measured - z) / (noise z^2) must be N(0, 1). Only z < 6 m is
  // used, where the 10 m cut cannot truncate the distribution.
  double sum = 0.0, sum2 = 0.0;
  size_t n = 0;
  for (const CameraCapture& camera : rig.capture.cameras) {
    const Pose& T = rig.gt.at(camera.serial);
    const PinholeIntrinsics& K = camera.intrinsics;
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const float z = camera.depth_m[static_cast<size_t>(v) * camera.width + u];
        if (!std::isfinite(z)) continue;
        const Vec3 ray = T.linear() * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const double z_true = rig.scene.Raycast(T.translation(), ray)->t;
        if (z_true > 6.0) continue;
        const double e = (z - z_true) / (options.noise * z_true * z_true);
        sum += e;
        sum2 += e * e;
        ++n;
      }
    }
  }
  ASSERT_GT(n, 100000u);
  const double mean = sum / n;
  const double stddev = std::sqrt(sum2 / n - mean * mean);
  // With n > 1e5 the standard errors are below 3e-3 (mean) and 2.3e-3 (std).
  EXPECT_NEAR(mean, 0.0, 0.015);
  EXPECT_NEAR(stddev, 1.0, 0.02);
}

TEST(SimulateRig, DropoutAndNoiseDoNotMoveTheGeometry) {
  const SimOptions clean = Small(NoiseFree(3));
  SimOptions noisy = clean;
  noisy.dropout = 0.03;
  noisy.noise = 0.0025;
  const SimulatedRig a = SimulateRig(clean);
  const SimulatedRig b = SimulateRig(noisy);
  size_t seen = 0, dropped = 0;
  for (size_t c = 0; c < a.capture.cameras.size(); ++c) {
    EXPECT_TRUE(a.gt.at(SimSerial(c)).isApprox(b.gt.at(SimSerial(c)), 0.0));
    EXPECT_TRUE(a.init.at(SimSerial(c)).isApprox(b.init.at(SimSerial(c)), 0.0));
    const std::vector<float>& za = a.capture.cameras[c].depth_m;
    const std::vector<float>& zb = b.capture.cameras[c].depth_m;
    for (size_t i = 0; i < za.size(); ++i) {
      if (!std::isfinite(za[i]) || za[i] > 6.0f) continue;  // 10 m cut out of reach
      ++seen;
      dropped += std::isfinite(zb[i]) ? 0 : 1;
    }
  }
  ASSERT_GT(seen, 100000u);
  // Binomial standard error sqrt(0.03 * 0.97 / n) < 5.4e-4.
  EXPECT_NEAR(static_cast<double>(dropped) / seen, 0.03, 3e-3);
}

TEST(SimulateRig, SameSeedSameRigOtherSeedOtherRig) {
  const SimOptions options = Small(SimOptions{});
  const SimulatedRig a = SimulateRig(options);
  const SimulatedRig b = SimulateRig(options);
  SimOptions other_seed = options;
  other_seed.seed = 1;
  const SimulatedRig c = SimulateRig(other_seed);
  ASSERT_EQ(a.capture.cameras.size(), b.capture.cameras.size());
  for (size_t i = 0; i < a.capture.cameras.size(); ++i) {
    const CameraCapture& ca = a.capture.cameras[i];
    const CameraCapture& cb = b.capture.cameras[i];
    EXPECT_EQ(ca.serial, cb.serial);
    EXPECT_TRUE(SameBits(ca.depth_m, cb.depth_m));
    EXPECT_EQ(ca.color, cb.color);
    EXPECT_TRUE(a.gt.at(ca.serial).isApprox(b.gt.at(ca.serial), 0.0));
    EXPECT_TRUE(a.init.at(ca.serial).isApprox(b.init.at(ca.serial), 0.0));
    EXPECT_FALSE(SameBits(ca.depth_m, c.capture.cameras[i].depth_m));
    EXPECT_FALSE(a.gt.at(ca.serial).isApprox(c.gt.at(ca.serial), 1e-6));
  }
  EXPECT_NE(a.scene.size_x_m, c.scene.size_x_m);
}

TEST(SimulateRig, AnotherNoiseDrawKeepsTheRigAndRedrawsOnlyTheNoise) {
  const SimOptions options = Small(SimOptions{});
  SimOptions redrawn = options;
  redrawn.noise_draw = 1;
  const SimulatedRig a = SimulateRig(options);
  const SimulatedRig b = SimulateRig(redrawn);
  // Without noise and dropout the draws render the same depth.
  SimOptions clean = options;
  clean.noise = 0.0;
  clean.dropout = 0.0;
  SimOptions clean_redrawn = clean;
  clean_redrawn.noise_draw = 1;
  const SimulatedRig c = SimulateRig(clean);
  const SimulatedRig d = SimulateRig(clean_redrawn);
  ASSERT_EQ(a.capture.cameras.size(), b.capture.cameras.size());
  for (size_t i = 0; i < a.capture.cameras.size(); ++i) {
    const std::string& serial = a.capture.cameras[i].serial;
    EXPECT_TRUE(a.gt.at(serial).isApprox(b.gt.at(serial), 0.0));
    EXPECT_TRUE(a.init.at(serial).isApprox(b.init.at(serial), 0.0));
    EXPECT_FALSE(SameBits(a.capture.cameras[i].depth_m, b.capture.cameras[i].depth_m));
    EXPECT_TRUE(SameBits(c.capture.cameras[i].depth_m, d.capture.cameras[i].depth_m));
  }
  EXPECT_EQ(a.scene.size_x_m, b.scene.size_x_m);
}

TEST(GaussianNoiseField, UnitVarianceAndTheGaussianCorrelation) {
  // 400 x 400 pixels of a field correlated over 4 px: about (400 / 8)^2 = 2500 independent
  // patches, so the sample variance is within a few percent and the correlations within
  // about +-0.03.
  constexpr double kCorrPx = 4.0;
  constexpr int kSize = 400;
  SimRng rng(7, 3);
  const std::vector<double> field = GaussianNoiseField(kSize, kSize, kCorrPx, rng);
  const auto at = [&](int x, int y) { return field[static_cast<size_t>(y) * kSize + x]; };
  const auto correlation = [&](int dx) {
    double sum = 0.0;
    int n = 0;
    for (int y = 0; y < kSize; ++y) {
      for (int x = 0; x + dx < kSize; ++x) {
        sum += at(x, y) * at(x + dx, y);
        ++n;
      }
    }
    return sum / n;
  };
  EXPECT_NEAR(correlation(0), 1.0, 0.06);
  // Blurred white noise: exp(-d^2 / (4 sigma^2)), 0.78 at d = sigma, 0.018 at 4 sigma.
  EXPECT_NEAR(correlation(4), std::exp(-0.25), 0.06);
  EXPECT_NEAR(correlation(16), std::exp(-4.0), 0.04);
  // The model the bound uses (sim/noise_field.h): the same, exactly for the truncated kernel.
  const std::vector<double> rho = NoiseFieldCorrelation(kCorrPx);
  ASSERT_EQ(rho.size(), 25u);  // up to twice the kernel's radius, 2 ceil(3 sigma)
  EXPECT_NEAR(correlation(4), rho[4], 0.06);
  EXPECT_NEAR(correlation(16), rho[16], 0.04);
  // The kernel cut at 3 sigma loses its tails: within 3e-3 of the untruncated Gaussian.
  for (int d = 0; d <= 16; d += 4) EXPECT_NEAR(rho[d], std::exp(-d * d / 64.0), 3e-3) << d;
  // Separable: along the diagonal (4, 4) the correlation is rho(4)^2.
  double diagonal = 0.0;
  int n = 0;
  for (int y = 0; y + 4 < kSize; ++y) {
    for (int x = 0; x + 4 < kSize; ++x) {
      diagonal += at(x, y) * at(x + 4, y + 4);
      ++n;
    }
  }
  EXPECT_NEAR(diagonal / n, rho[4] * rho[4], 0.06);
}

TEST(SimulateRig, CorrelatedNoiseKeepsTheTotalSigmaAndTheDefaultsUnchanged) {
  SimOptions options = Small(NoiseFree(2));
  options.noise = 0.0025;
  SimOptions correlated = options;
  correlated.noise_corr_px = 4.0;
  correlated.noise_corr_share = 0.8;
  SimOptions unused_length = options;
  unused_length.noise_corr_px = 4.0;  // share 0: the white noise of before, bit for bit
  const SimulatedRig white = SimulateRig(options);
  const SimulatedRig same = SimulateRig(unused_length);
  const SimulatedRig rig = SimulateRig(correlated);
  double sum2 = 0.0, neighbour = 0.0;
  size_t n = 0, pairs = 0;
  for (size_t c = 0; c < rig.capture.cameras.size(); ++c) {
    EXPECT_TRUE(SameBits(white.capture.cameras[c].depth_m, same.capture.cameras[c].depth_m));
    const CameraCapture& camera = rig.capture.cameras[c];
    const Pose& T = rig.gt.at(camera.serial);
    const PinholeIntrinsics& K = camera.intrinsics;
    std::vector<double> e(camera.depth_m.size(), std::nan(""));
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        const size_t i = static_cast<size_t>(v) * camera.width + u;
        if (!std::isfinite(camera.depth_m[i])) continue;
        const Vec3 ray = T.linear() * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
        const double z = rig.scene.Raycast(T.translation(), ray)->t;
        if (z > 6.0) continue;
        e[i] = (camera.depth_m[i] - z) / (options.noise * z * z);
        sum2 += e[i] * e[i];
        ++n;
        if (u > 0 && std::isfinite(e[i - 1])) {
          neighbour += e[i] * e[i - 1];
          ++pairs;
        }
      }
    }
  }
  ASSERT_GT(n, 50000u);
  EXPECT_NEAR(std::sqrt(sum2 / n), 1.0, 0.05);  // the total sigma is still noise z^2
  // Neighbours share 0.8 of the variance at a correlation of exp(-1/64): about 0.79; white
  // noise would give 0.
  EXPECT_NEAR(neighbour / pairs, 0.8 * std::exp(-1.0 / 64.0), 0.05);
}

TEST(SimulateRig, SerialsAreSortedAndCamerasStandAroundTheRoom) {
  SimOptions options = Small(SimOptions{});
  options.cameras = 6;
  const SimulatedRig rig = SimulateRig(options);
  ASSERT_EQ(rig.capture.cameras.size(), 6u);
  EXPECT_EQ(rig.capture.cameras[0].serial, "31000000");
  EXPECT_EQ(rig.capture.cameras[2].serial, "31002234");
  for (size_t i = 1; i < rig.capture.cameras.size(); ++i) {
    EXPECT_LT(rig.capture.cameras[i - 1].serial, rig.capture.cameras[i].serial);
  }
  std::set<int> quadrants;
  for (const auto& [serial, T] : rig.gt) {
    const Vec3 c = T.translation();
    EXPECT_GE(c.y(), 1.8);
    EXPECT_LE(c.y(), 2.5);
    EXPECT_LT(std::abs(c.x()), 0.5 * rig.scene.size_x_m);
    EXPECT_LT(std::abs(c.z()), 0.5 * rig.scene.size_z_m);
    // Looking down (camera z has a negative world y component) with little roll (camera x
    // nearly horizontal).
    EXPECT_LT(T.linear().col(2).y(), -0.3);
    EXPECT_LT(std::abs(T.linear().col(0).y()), std::sin(2.0 * kDegToRad) + 1e-12);
    quadrants.insert((c.x() > 0 ? 1 : 0) + (c.z() > 0 ? 2 : 0));
  }
  EXPECT_GE(quadrants.size(), 3u);  // spread around the room
}

TEST(SimulateRig, InitDiffersFromGtWithinThePerturbation) {
  SimOptions options = Small(SimOptions{});
  options.cameras = 8;
  options.width = 16;  // images are irrelevant here
  options.height = 16;
  double max_yaw = 0.0, max_tilt = 0.0, max_xz = 0.0, max_y = 0.0;
  for (std::uint64_t seed = 0; seed < 5; ++seed) {
    options.seed = seed;
    const SimulatedRig rig = SimulateRig(options);
    for (const auto& [serial, gt] : rig.gt) {
      const Vec6 d = PoseDifference(gt, rig.init.at(serial));
      max_yaw = std::max(max_yaw, std::abs(d[1]));
      max_tilt = std::max(max_tilt, std::hypot(d[0], d[2]));
      max_xz = std::max({max_xz, std::abs(d[3]), std::abs(d[5])});
      max_y = std::max(max_y, std::abs(d[4]));
      EXPECT_NEAR(TiltErrorRad(rig.init.at(serial), gt), std::hypot(d[0], d[2]), 1e-6);
    }
  }
  constexpr double kEps = 1e-12;
  EXPECT_LE(max_yaw, options.perturb_yaw_deg * kDegToRad + kEps);
  EXPECT_LE(max_tilt, options.perturb_tilt_deg * kDegToRad + kEps);
  EXPECT_LE(max_xz, options.perturb_xz_m + kEps);
  EXPECT_LE(max_y, options.perturb_xz_m / 5.0 + kEps);
  // 40 uniform draws each: the largest reaches most of the range.
  EXPECT_GT(max_yaw, 0.8 * options.perturb_yaw_deg * kDegToRad);
  EXPECT_GT(max_tilt, 0.8 * options.perturb_tilt_deg * kDegToRad);
  EXPECT_GT(max_xz, 0.8 * options.perturb_xz_m);
  EXPECT_GT(max_y, 0.8 * options.perturb_xz_m / 5.0);

  options.perturb_yaw_deg = options.perturb_tilt_deg = options.perturb_xz_m = 0.0;
  const SimulatedRig unperturbed = SimulateRig(options);
  for (const auto& [serial, gt] : unperturbed.gt) {
    EXPECT_TRUE(unperturbed.init.at(serial).isApprox(gt, 0.0));
  }
}

TEST(SimulateRig, BareRoomHasOnlyFloorAndWalls) {
  SimOptions options = Small(NoiseFree(4));
  options.bare = true;
  const SimulatedRig rig = SimulateRig(options);
  for (const OrientedBox& box : rig.scene.boxes) {
    EXPECT_TRUE(box.kind == SurfaceKind::kFloor || box.kind == SurfaceKind::kWall);
  }
  const double hx = 0.5 * rig.scene.size_x_m;
  const double hz = 0.5 * rig.scene.size_z_m;
  for (const CameraCapture& camera : rig.capture.cameras) {
    for (const Vec3& p : WorldPoints(rig, camera, 2)) {
      const double to_plane = std::min(
          {std::abs(p.y()), std::abs(std::abs(p.x()) - hx), std::abs(std::abs(p.z()) - hz)});
      ASSERT_LT(to_plane, kOnSurfaceTolerance) << p.transpose();
    }
  }
  // Same seed, furnished: same room and cameras, more boxes.
  options.bare = false;
  const SimulatedRig furnished = SimulateRig(options);
  EXPECT_EQ(furnished.scene.size_x_m, rig.scene.size_x_m);
  EXPECT_GT(furnished.scene.boxes.size(), rig.scene.boxes.size() + 10);
  EXPECT_TRUE(furnished.gt.at(SimSerial(0)).isApprox(rig.gt.at(SimSerial(0)), 0.0));
}

/// Per camera, the fraction of its points on the floor and of its points on furniture or
/// baseboards in the near-floor band (vertical structure that fixes yaw and x, z).
struct FloorStats {
  double floor_fraction = 0.0;
  double band_structure_fraction = 0.0;
};

FloorStats Stats(const SimulatedRig& rig, const CameraCapture& camera) {
  const PointCloud points = WorldPoints(rig, camera, 2);
  const double hx = 0.5 * rig.scene.size_x_m;
  const double hz = 0.5 * rig.scene.size_z_m;
  size_t floor = 0, structure = 0;
  for (const Vec3& p : points) {
    if (std::abs(p.y()) < 0.01) ++floor;
    const bool on_wall =
        std::abs(std::abs(p.x()) - hx) < 0.005 || std::abs(std::abs(p.z()) - hz) < 0.005;
    if (p.y() > 0.01 && p.y() < 0.3 && !on_wall) ++structure;
  }
  return {static_cast<double>(floor) / points.size(),
          static_cast<double>(structure) / points.size()};
}

TEST(SimulateRig, EveryCameraSeesFloorAndNearFloorStructure) {
  for (std::uint64_t seed = 0; seed < 4; ++seed) {
    for (int cameras : {1, 4, 6}) {
      SimOptions options = Small(NoiseFree(seed));
      options.cameras = cameras;
      const SimulatedRig rig = SimulateRig(options);
      for (const CameraCapture& camera : rig.capture.cameras) {
        const FloorStats s = Stats(rig, camera);
        EXPECT_GT(s.floor_fraction, 0.25) << "seed " << seed << " camera " << camera.serial;
        EXPECT_GT(s.band_structure_fraction, 0.02)
            << "seed " << seed << " camera " << camera.serial;
      }
    }
  }
}

/// Fraction of camera a's near-floor points (y < 0.3) whose 10 cm voxel also holds a
/// near-floor point of camera b (all of b's pixels, so that b's far, sparse samples still
/// mark the voxels b sees).
double BandOverlap(const SimulatedRig& rig, const CameraCapture& a, const CameraCapture& b) {
  constexpr double kVoxel = 0.1;
  auto voxel = [](const Vec3& p) {
    return std::make_tuple(static_cast<long>(std::floor(p.x() / kVoxel)),
                           static_cast<long>(std::floor(p.y() / kVoxel)),
                           static_cast<long>(std::floor(p.z() / kVoxel)));
  };
  std::set<std::tuple<long, long, long>> occupied;
  for (const Vec3& p : WorldPoints(rig, b)) {
    if (p.y() < 0.3) occupied.insert(voxel(p));
  }
  size_t band = 0, shared = 0;
  for (const Vec3& p : WorldPoints(rig, a, 2)) {
    if (p.y() >= 0.3) continue;
    ++band;
    shared += occupied.count(voxel(p));
  }
  return band == 0 ? 0.0 : static_cast<double>(shared) / band;
}

TEST(SimulateRig, EveryCameraOverlapsAnotherInTheFloorBand) {
  for (std::uint64_t seed = 0; seed < 3; ++seed) {
    for (int cameras : {2, 4, 6}) {
      SimOptions options = Small(NoiseFree(seed));
      options.cameras = cameras;
      const SimulatedRig rig = SimulateRig(options);
      for (const CameraCapture& a : rig.capture.cameras) {
        double best = 0.0;
        for (const CameraCapture& b : rig.capture.cameras) {
          if (&a != &b) best = std::max(best, BandOverlap(rig, a, b));
        }
        EXPECT_GT(best, 0.3) << "seed " << seed << " cameras " << cameras << " camera " << a.serial;
      }
    }
  }
}

TEST(SimulateRig, ColorShadesTheSurfaces) {
  const SimulatedRig rig = SimulateRig(Small(SimOptions{}));
  for (const CameraCapture& camera : rig.capture.cameras) {
    ASSERT_EQ(camera.color.size(), camera.depth_m.size() * 3);
    std::set<std::array<std::uint8_t, 3>> colours;
    for (size_t i = 0; i < camera.depth_m.size(); i += 17) {
      colours.insert({camera.color[3 * i], camera.color[3 * i + 1], camera.color[3 * i + 2]});
    }
    EXPECT_GT(colours.size(), 5u) << camera.serial;
  }
}

TEST(SimulateRig, RejectsInvalidOptions) {
  const SimOptions valid;
  auto with = [&](auto change) {
    SimOptions o = valid;
    change(o);
    return o;
  };
  EXPECT_THROW(SimulateRig(with([](SimOptions& o) { o.cameras = 0; })), std::invalid_argument);
  EXPECT_THROW(SimulateRig(with([](SimOptions& o) { o.width = 1; })), std::invalid_argument);
  EXPECT_THROW(SimulateRig(with([](SimOptions& o) { o.noise = -1e-3; })), std::invalid_argument);
  EXPECT_THROW(SimulateRig(with([](SimOptions& o) { o.dropout = 1.0; })), std::invalid_argument);
  EXPECT_THROW(SimulateRig(with([](SimOptions& o) { o.perturb_xz_m = NAN; })),
               std::invalid_argument);
}

}  // namespace
}  // namespace rigfit
