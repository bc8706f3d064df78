#include "sim/stereo_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

constexpr std::uint64_t kTextureStream = 3;  // after the room, camera and perturbation streams
constexpr int kOctaves = 4;
constexpr int kBlockSize = 5;
constexpr int kSgbmFractionBits = 4;  // StereoSGBM's disparities are in 1/16 px

/// A lattice value in [-1, 1]: an integer hash of (x, y, seed).
double LatticeValue(int x, int y, std::uint32_t seed) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 0x8da6b343u ^
                    static_cast<std::uint32_t>(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return h * (2.0 / 4294967295.0) - 1.0;
}

/// Value noise: the lattice values interpolated by smoothstep, wavelength 1.
double ValueNoise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const int ix = static_cast<int>(fx);
  const int iy = static_cast<int>(fy);
  const auto smooth = [](double a) { return a * a * (3.0 - 2.0 * a); };
  const double sx = smooth(x - fx);
  const double sy = smooth(y - fy);
  const double top = (1 - sx) * LatticeValue(ix, iy, seed) + sx * LatticeValue(ix + 1, iy, seed);
  const double bottom =
      (1 - sx) * LatticeValue(ix, iy + 1, seed) + sx * LatticeValue(ix + 1, iy + 1, seed);
  return (1 - sy) * top + sy * bottom;
}

/// The texture's value at face coordinates (s, t) metres, octaves shorter than about two
/// pixel footprints (footprint_m, the pixel's size on the surface) faded out, as a camera's
/// pixels average them away instead of aliasing them.
double FractalTexture(const SurfaceTexture& texture, std::uint32_t face, double s, double t,
                      double footprint_m) {
  double value = 0.0;
  double amplitude = 1.0;
  double wavelength = texture.feature_m;
  for (int o = 0; o < kOctaves; ++o) {
    const double fade = std::clamp(0.5 * (wavelength / footprint_m - 2.0), 0.0, 1.0);
    if (fade <= 0.0) break;
    const std::uint32_t seed = texture.seed * 131u + face * 17u + static_cast<std::uint32_t>(o);
    value += fade * amplitude * ValueNoise(s / wavelength, t / wavelength, seed);
    amplitude *= 0.6;
    wavelength *= 0.5;
  }
  return value;
}

/// The grey level (before noise) of a ray's hit: ShadeHit's luminance times the texture.
double TexturedGrey(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                    const RayHit& hit, const Vec3& p_world, double footprint_m) {
  const std::array<std::uint8_t, 3> rgb = ShadeHit(scene, hit, p_world);
  const double grey = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2];
  const OrientedBox& box = scene.boxes[hit.box_index];
  const Vec3 p_box = box.R_world_box.transpose() * (p_world - box.center);
  const Vec3 n_box = box.R_world_box.transpose() * hit.normal_world;
  int axis = 0;
  n_box.cwiseAbs().maxCoeff(&axis);
  const std::uint32_t face = static_cast<std::uint32_t>(2 * axis + (n_box[axis] > 0.0 ? 1 : 0));
  const SurfaceTexture& texture = textures[hit.box_index];
  const double value =
      FractalTexture(texture, face, p_box[(axis + 1) % 3], p_box[(axis + 2) % 3], footprint_m);
  return grey * (1.0 + texture.contrast * value);
}

/// One camera of the pair at resolution upsample x the camera's, padded on the left by `pad`
/// columns: intrinsics of that grid.
PinholeIntrinsics MatchingGrid(const PinholeIntrinsics& K, int upsample, int pad) {
  // Pixel i of the camera covers [i - 1/2, i + 1/2]: fine pixel u (i + 1/2) - 1/2 is its centre.
  PinholeIntrinsics fine;
  fine.fx = upsample * K.fx;
  fine.fy = upsample * K.fy;
  fine.cx = upsample * (K.cx + 0.5) - 0.5 + pad;
  fine.cy = upsample * (K.cy + 0.5) - 0.5;
  return fine;
}

/// Disparity averaged over upsample x upsample blocks (fine pixels, 1/16 px units, padded by
/// pad columns) in pixels of the camera; NaN where fewer than half the block matched.
std::vector<double> AverageDown(const cv::Mat& disparity16, int width, int height, int upsample,
                                int pad) {
  std::vector<double> disparity(static_cast<size_t>(width) * height,
                                std::numeric_limits<double>::quiet_NaN());
  const int block = upsample * upsample;
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      double sum = 0.0;
      int matched = 0;
      for (int dv = 0; dv < upsample; ++dv) {
        const std::int16_t* row = disparity16.ptr<std::int16_t>(upsample * v + dv);
        for (int du = 0; du < upsample; ++du) {
          const int raw = row[pad + upsample * u + du];
          if (raw <= 0) continue;  // unmatched (-16) or at infinity
          sum += raw;
          ++matched;
        }
      }
      if (2 * matched >= block) {
        disparity[static_cast<size_t>(v) * width + u] =
            sum / (matched * (1 << kSgbmFractionBits) * upsample);
      }
    }
  }
  return disparity;
}

}  // namespace

std::vector<SurfaceTexture> SimulateTextures(const Scene& scene, std::uint64_t seed) {
  SimRng rng(seed, kTextureStream);
  std::vector<SurfaceTexture> textures(scene.boxes.size());
  for (SurfaceTexture& texture : textures) {
    texture.seed = static_cast<std::uint32_t>(rng.UniformInt(0, 1 << 30));
    texture.feature_m = rng.Uniform(0.03, 0.12);
    texture.contrast = rng.Uniform(0.1, 0.4);
  }
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const double weak_share = scene.boxes[i].kind == SurfaceKind::kWall        ? 0.5
                              : scene.boxes[i].kind == SurfaceKind::kFurniture ? 1.0 / 3.0
                                                                               : 0.0;
    if (rng.Uniform() < weak_share) textures[i].contrast = rng.Uniform(0.002, 0.008);
  }
  return textures;
}

std::vector<std::uint8_t> RenderTexturedImage(const Scene& scene,
                                              const std::vector<SurfaceTexture>& textures,
                                              const SceneCamera& camera, double image_noise,
                                              SimRng& rng) {
  const PinholeIntrinsics& K = camera.K;
  const int width = camera.width;
  const int height = camera.height;
  std::vector<std::uint8_t> image(static_cast<size_t>(width) * height, 0);
  const Mat3& R = camera.T_world_camera.linear();
  const Vec3 origin = camera.T_world_camera.translation();
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double noise = image_noise * rng.Normal();
      const Vec3 direction = R * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const std::optional<RayHit> hit = scene.Raycast(origin, direction);
      if (!hit) continue;
      // The pixel's size on the surface: depth / fx, stretched by the slant.
      const double slant = std::abs(hit->normal_world.dot(direction.normalized()));
      const double footprint_m = hit->t / K.fx / std::max(slant, 0.05);
      const double grey =
          TexturedGrey(scene, textures, *hit, origin + hit->t * direction, footprint_m) + noise;
      image[static_cast<size_t>(v) * width + u] =
          static_cast<std::uint8_t>(std::clamp(std::lround(grey), 0l, 255l));
    }
  }
  return image;
}

std::vector<float> StereoDepth(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                               const SceneCamera& camera, const StereoOptions& options,
                               SimRng& rng) {
  const Pose& T_world_camera = camera.T_world_camera;
  const PinholeIntrinsics& K = camera.K;
  const int width = camera.width;
  const int height = camera.height;
  const int s = options.upsample;
  const double f_b = K.fx * options.baseline_m;  // disparity = f B / z, camera pixels
  // The search range covers depths down to min_depth_m, in whole multiples of 16 fine pixels.
  const int range = 16 * static_cast<int>(std::ceil(s * f_b / options.min_depth_m / 16.0));
  const PinholeIntrinsics fine = MatchingGrid(K, s, range);
  const int fine_width = s * width + range;
  const int fine_height = s * height;
  Pose T_world_right = T_world_camera;
  T_world_right.translation() += T_world_camera.linear() * Vec3(options.baseline_m, 0.0, 0.0);
  std::vector<std::uint8_t> left = RenderTexturedImage(
      scene, textures, {T_world_camera, fine, fine_width, fine_height}, options.image_noise, rng);
  std::vector<std::uint8_t> right = RenderTexturedImage(
      scene, textures, {T_world_right, fine, fine_width, fine_height}, options.image_noise, rng);
  const cv::Mat left_image(fine_height, fine_width, CV_8UC1, left.data());
  const cv::Mat right_image(fine_height, fine_width, CV_8UC1, right.data());
  constexpr int kArea = kBlockSize * kBlockSize;
  const cv::Ptr<cv::StereoSGBM> sgbm =
      cv::StereoSGBM::create(0, range, kBlockSize, 8 * kArea, 32 * kArea, /*disp12MaxDiff=*/1,
                             /*preFilterCap=*/31, /*uniquenessRatio=*/10,
                             /*speckleWindowSize=*/50 * s * s, /*speckleRange=*/2);
  cv::Mat disparity16;
  sgbm->compute(left_image, right_image, disparity16);
  const std::vector<double> disparity = AverageDown(disparity16, width, height, s, range);
  std::vector<float> depth(disparity.size(), std::numeric_limits<float>::quiet_NaN());
  for (size_t i = 0; i < disparity.size(); ++i) {
    const double d = disparity[i] + options.disparity_offset_px;
    if (!(d > 0.0)) continue;
    const double z = options.depth_scale * f_b / d;
    if (z <= options.max_depth_m) depth[i] = static_cast<float>(z);
  }
  return depth;
}

}  // namespace rigfit
