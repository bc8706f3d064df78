#include "sim/stereo_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "sim/simulate_rig.h"
#include "sim/texture.h"

namespace rigfit {
namespace {

constexpr int kBlockSize = 5;
constexpr int kSgbmFractionBits = 4;  // StereoSGBM's disparities are in 1/16 px

/// The grey level (before noise) of a ray's hit: ShadeHit's luminance times the texture.
double TexturedGrey(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                    const RayHit& hit, const Vec3& p_world, double footprint_m) {
  const std::array<std::uint8_t, 3> rgb = ShadeHit(scene, hit, p_world);
  const double grey = 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2];
  return grey * TextureFactor(scene, textures, hit, p_world, footprint_m);
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
      const double footprint_m = PixelFootprint(*hit, direction, K.fx);
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
