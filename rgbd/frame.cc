#include "rgbd/frame.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/errors.h"
#include "core/parallel.h"

namespace rigfit {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Rows per parallel block: a 640-pixel row is cheap, so blocks of rows keep the threads busy
// without a task per pixel.
constexpr int kRowsPerTask = 8;

template <typename Body>
void ForEachRow(int height, int threads, const Body& body) {
  ParallelFor(height, threads, body, kRowsPerTask);
}

/// The intrinsics of an image halved by 2x2 blocks (pixel centres at (u + 0.5) / 2 - 0.5).
PinholeIntrinsics Halved(const PinholeIntrinsics& k) {
  return {k.fx / 2.0, k.fy / 2.0, (k.cx + 0.5) / 2.0 - 0.5, (k.cy + 0.5) / 2.0 - 0.5};
}

// Half-resolution depth: per 2x2 block, the mean of the valid depths within the jump ratio
// of the block's nearest valid depth (the foreground, so a silhouette is not smeared). No
// branch per sample (whether a sample is valid, near or far has no pattern): an invalid
// sample is infinitely far, and a sample not taken adds 0 to the sum, which leaves it as it
// is, so the mean has the bits of a sum over the samples taken, in their order.
std::vector<float> Downsample(const std::vector<float>& depth, int width, int height,
                              double jump_ratio) {
  constexpr float kInfinity = std::numeric_limits<float>::infinity();
  const int w = width / 2;
  const int h = height / 2;
  std::vector<float> out(static_cast<std::size_t>(w) * h, kNaN);
  for (int v = 0; v < h; ++v) {
    const float* top = depth.data() + static_cast<std::size_t>(2 * v) * width;
    const float* bottom = top + width;
    for (int u = 0; u < w; ++u) {
      float samples[4] = {top[2 * u], top[2 * u + 1], bottom[2 * u], bottom[2 * u + 1]};
      for (float& z : samples) z = std::isnan(z) ? kInfinity : z;
      const float nearest =
          std::min(std::min(samples[0], samples[1]), std::min(samples[2], samples[3]));
      if (nearest == kInfinity) continue;
      const double gate = jump_ratio * nearest;
      double sum = 0.0;
      int count = 0;
      for (const float z : samples) {
        const bool taken = z - nearest <= gate;
        sum += taken ? z : 0.0;
        count += taken;
      }
      out[static_cast<std::size_t>(v) * w + u] = static_cast<float>(sum / count);
    }
  }
  return out;
}

/// The bilateral filter as two 1D passes, along x then along y, over depth whose invalid
/// samples are kFar (so far that their range weight is 0: no branch per neighbour).
class BilateralPasses {
 public:
  static constexpr float kFar = 1e30f;

  BilateralPasses(int width, int height, double sigma_px, double sigma_m, bool range_grows,
                  int threads)
      : width_(width),
        height_(height),
        threads_(threads),
        radius_(std::max(1, static_cast<int>(std::ceil(2.0 * sigma_px)))),
        spatial_(2 * radius_ + 1),
        range_(kRangeSteps * kRangeSigmas + 1),
        steps_per_m_(static_cast<float>(kRangeSteps / sigma_m)),
        last_step_(static_cast<float>(range_.size() - 1)),
        range_grows_(range_grows),
        pairs_(radius_) {
    for (int d = -radius_; d <= radius_; ++d) {
      spatial_[d + radius_] = static_cast<float>(std::exp(-d * d / (2.0 * sigma_px * sigma_px)));
    }
    // exp(-t^2 / 2) every kRangeSteps-th of a range sigma up to 4 of them (t = dz / sigma); every
    // step at or beyond it lands on the last entry, 0 (the weight there is below 3.4e-4).
    for (std::size_t k = 0; k + 1 < range_.size(); ++k) {
      const double t = static_cast<double>(k) / kRangeSteps;
      range_[k] = static_cast<float>(std::exp(-0.5 * t * t));
    }
    range_.back() = 0.0f;
  }

  /// One pass along x or y, the range weight taken against each pixel's own depth: the weight
  /// of two samples d pixels apart is the same from either (|a - b| = |b - a|), so it is
  /// computed once per pair; each pixel then sums its taps d = -radius..radius in order.
  std::vector<float> Pass(const std::vector<float>& in, bool along_x) {
    along_x_ = along_x;
    for (std::vector<float>& pair : pairs_) pair.resize(in.size());
    ForEachRow(height_, threads_, [&](int v) { PairWeights(in, v); });
    std::vector<float> out(in.size(), kNaN);
    ForEachRow(height_, threads_, [&](int v) { FilterRow(in, v, &out); });
    return out;
  }

 private:
  static constexpr int kRangeSteps = 64;
  static constexpr int kRangeSigmas = 4;

  /// The step from a pixel to its next neighbour in this pass.
  std::ptrdiff_t Stride() const { return along_x_ ? 1 : width_; }

  /// The pixels [first, second) of row v whose neighbour d is in the image.
  std::pair<int, int> Span(int v, int d) const {
    if (along_x_) return {std::max(0, -d), std::min(width_, width_ - d)};
    return {0, v + d >= 0 && v + d < height_ ? width_ : 0};
  }

  /// pairs_[d - 1][i]: the weight of pixel i and its neighbour d > 0, in row v.
  void PairWeights(const std::vector<float>& in, int v) {
    const std::size_t row = static_cast<std::size_t>(v) * width_;
    for (int d = 1; d <= radius_; ++d) {
      const auto [begin, end] = Span(v, d);
      const std::size_t offset = d * Stride();
      float* pair = pairs_[d - 1].data();
      for (int u = begin; u < end; ++u) {
        const std::size_t i = row + u;
        // With range_grows_, the range sigma grows as z^2 beyond 1 m, z the nearer depth (a
        // pair with one invalid sample still lands on the last entry; two invalid ones give
        // 0 / inf = 0, a weight only their own NaN outputs read).
        const float z = std::min(in[i + offset], in[i]);
        const float scale = range_grows_ ? std::max(1.0f, z * z) : 1.0f;
        const float step =
            std::min(std::abs(in[i + offset] - in[i]) * steps_per_m_ / scale, last_step_);
        pair[i] = spatial_[d + radius_] * range_[static_cast<int>(step + 0.5f)];
      }
    }
  }

  /// Row v of the pass: per pixel sum_d w_d z_d / sum_d w_d (NaN where `in` is invalid).
  void FilterRow(const std::vector<float>& in, int v, std::vector<float>* out) const {
    const std::ptrdiff_t row = static_cast<std::ptrdiff_t>(v) * width_;
    std::vector<float> sum(width_, 0.0f);
    std::vector<float> weight(width_, 0.0f);
    const float centre = spatial_[radius_] * range_[0];  // d = 0: no depth difference
    for (int d = -radius_; d <= radius_; ++d) {
      const auto [begin, end] = Span(v, d);
      const std::ptrdiff_t offset = d * Stride();
      // A pair's weight is kept at its first pixel: the neighbour's when d < 0.
      const float* pair = d == 0 ? nullptr : pairs_[std::abs(d) - 1].data();
      const std::ptrdiff_t at = row + std::min<std::ptrdiff_t>(offset, 0);
      for (int u = begin; u < end; ++u) {
        const float w = pair ? pair[at + u] : centre;
        sum[u] += w * in[row + offset + u];
        weight[u] += w;
      }
    }
    for (int u = 0; u < width_; ++u) {
      if (in[row + u] != kFar) (*out)[row + u] = sum[u] / weight[u];
    }
  }

  int width_, height_, threads_, radius_;
  std::vector<float> spatial_;
  std::vector<float> range_;
  float steps_per_m_, last_step_;
  bool range_grows_;
  std::vector<std::vector<float>> pairs_;  // per d = 1..radius, reused by both passes
  bool along_x_ = true;                    // the pass in progress (Pass)
};

}  // namespace

std::vector<float> BilateralFilter(const std::vector<float>& depth_m, int width, int height,
                                   double sigma_px, double sigma_m, bool range_grows, int threads) {
  BilateralPasses passes(width, height, sigma_px, sigma_m, range_grows, threads);
  const auto far_invalid = [](std::vector<float> depth) {
    for (float& z : depth) z = std::isnan(z) ? BilateralPasses::kFar : z;
    return depth;
  };
  return passes.Pass(far_invalid(passes.Pass(far_invalid(depth_m), true)), false);
}

namespace {

// The back-projection V(u, v) = z ((u - cx) / fx, (v - cy) / fy, 1); NaN where z is NaN.
std::vector<Vec3f> BackProject(const std::vector<float>& depth_m, int width, int height,
                               const PinholeIntrinsics& K, int threads) {
  std::vector<Vec3f> vertices(depth_m.size(), Vec3f::Constant(kNaN));
  const float inv_fx = static_cast<float>(1.0 / K.fx);
  const float inv_fy = static_cast<float>(1.0 / K.fy);
  const float cx = static_cast<float>(K.cx);
  const float cy = static_cast<float>(K.cy);
  ForEachRow(height, threads, [&](int v) {
    for (int u = 0; u < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width + u;
      const float z = depth_m[i];
      if (std::isnan(z)) continue;
      vertices[i] = Vec3f((u - cx) * inv_fx * z, (v - cy) * inv_fy * z, z);
    }
  });
  return vertices;
}

}  // namespace

void ComputeVertexNormalMaps(FrameLevel* level, double max_depth_jump_ratio, int threads,
                             const std::vector<float>* normal_depth_m) {
  const int width = level->width;
  const int height = level->height;
  level->vertices = BackProject(level->depth_m, width, height, level->intrinsics, threads);
  level->normals.assign(level->vertices.size(), Vec3f::Constant(kNaN));
  const std::vector<float>& depth = normal_depth_m ? *normal_depth_m : level->depth_m;
  std::vector<Vec3f> smoothed_vertices;
  if (normal_depth_m) {
    smoothed_vertices = BackProject(depth, width, height, level->intrinsics, threads);
  }
  const std::vector<Vec3f>& vertices = normal_depth_m ? smoothed_vertices : level->vertices;
  const float ratio = static_cast<float>(max_depth_jump_ratio);
  ForEachRow(height, threads, [&](int v) {
    if (v == 0 || v == height - 1) return;
    for (int u = 1; u + 1 < width; ++u) {
      const std::size_t i = static_cast<std::size_t>(v) * width + u;
      const float z = depth[i];
      if (std::isnan(z) || std::isnan(level->depth_m[i])) continue;
      // Usable when no neighbour is invalid (NaN fails every comparison) or across a jump.
      const float jump = ratio * z;
      const bool usable =
          (std::abs(depth[i - 1] - z) <= jump) & (std::abs(depth[i + 1] - z) <= jump) &
          (std::abs(depth[i - width] - z) <= jump) & (std::abs(depth[i + width] - z) <= jump);
      if (!usable) continue;
      const Vec3f du = vertices[i + 1] - vertices[i - 1];
      const Vec3f dv = vertices[i + width] - vertices[i - width];
      Vec3f normal = du.cross(dv);
      const float norm = normal.norm();
      if (!(norm > 0.0f)) continue;
      normal /= norm;
      if (normal.dot(vertices[i]) > 0.0f) normal = -normal;
      level->normals[i] = normal;
    }
  });
  level->valid_pixels.clear();
  for (int i = 0; i < width * height; ++i) {
    if (level->Valid(i)) level->valid_pixels.push_back(i);
  }
}

double MeanDepth(const FrameLevel& level) {
  double sum = 0.0;
  for (const int i : level.valid_pixels) sum += level.vertices[i].z();
  return level.valid_pixels.empty() ? 0.0 : sum / static_cast<double>(level.valid_pixels.size());
}

FramePyramid BuildFramePyramid(const RgbdFrame& frame, const FrameOptions& options, int threads) {
  if (options.levels < 1) throw InputError("frame options: levels must be at least 1");
  if (options.bilateral && !(options.bilateral_sigma_px > 0.0 && options.bilateral_sigma_m > 0.0)) {
    throw InputError("frame options: the bilateral filter's sigmas must be > 0");
  }
  const std::size_t n = static_cast<std::size_t>(frame.width) * frame.height;
  if (frame.width <= 0 || frame.height <= 0 || frame.depth_m.size() != n) {
    throw InputError(frame.source + ": depth holds " + std::to_string(frame.depth_m.size()) +
                     " samples for a " + std::to_string(frame.width) + "x" +
                     std::to_string(frame.height) + " image");
  }
  FramePyramid pyramid;
  pyramid.levels.resize(options.levels);
  FrameLevel& base = pyramid.levels[0];
  base.width = frame.width;
  base.height = frame.height;
  base.intrinsics = frame.intrinsics;
  base.depth_m = frame.depth_m;
  const float z_min = static_cast<float>(options.min_depth_m);
  const float z_max = static_cast<float>(options.max_depth_m);
  for (float& z : base.depth_m) {
    if (!(z >= z_min && z <= z_max)) z = kNaN;
  }
  std::vector<float> filtered;
  if (options.bilateral) {
    filtered = BilateralFilter(base.depth_m, base.width, base.height, options.bilateral_sigma_px,
                               options.bilateral_sigma_m, options.bilateral_range_grows, threads);
  }
  ComputeVertexNormalMaps(&base, options.max_depth_jump_ratio, threads,
                          options.bilateral ? &filtered : nullptr);
  BuildCoarserLevels(&pyramid, options.levels, options.max_depth_jump_ratio, threads);
  return pyramid;
}

RgbdFrame HalveFrame(const RgbdFrame& frame, double max_depth_jump_ratio) {
  const std::size_t n = static_cast<std::size_t>(frame.width) * frame.height;
  if (frame.width < 2 || frame.height < 2 || frame.depth_m.size() != n ||
      (!frame.color.empty() && frame.color.size() != 3 * n)) {
    throw InputError(frame.source + ": cannot halve a " + std::to_string(frame.width) + "x" +
                     std::to_string(frame.height) + " frame of " +
                     std::to_string(frame.depth_m.size()) + " depths and " +
                     std::to_string(frame.color.size()) + " colour bytes");
  }
  // The frame's description; its images are made below, not copied at full size first.
  RgbdFrame half;
  half.index = frame.index;
  half.timestamp = frame.timestamp;
  half.source = frame.source;
  half.T_world_camera_gt = frame.T_world_camera_gt;
  half.width = frame.width / 2;
  half.height = frame.height / 2;
  half.intrinsics = Halved(frame.intrinsics);
  half.depth_m = Downsample(frame.depth_m, frame.width, frame.height, max_depth_jump_ratio);
  if (!frame.color.empty()) {
    half.color.assign(3 * static_cast<std::size_t>(half.width) * half.height, 0);
    for (int v = 0; v < half.height; ++v) {
      for (int u = 0; u < half.width; ++u) {
        for (int c = 0; c < 3; ++c) {
          int sum = 0;
          for (int dv = 0; dv < 2; ++dv) {
            for (int du = 0; du < 2; ++du) {
              sum += frame.color[3 * ((static_cast<std::size_t>(2 * v + dv)) * frame.width + 2 * u +
                                      du) +
                                 c];
            }
          }
          half.color[3 * (static_cast<std::size_t>(v) * half.width + u) + c] =
              static_cast<std::uint8_t>((sum + 2) / 4);
        }
      }
    }
  }
  return half;
}

void BuildCoarserLevels(FramePyramid* pyramid, int levels, double max_depth_jump_ratio,
                        int threads) {
  if (levels < 1 || pyramid->levels.empty()) {
    throw InputError("pyramid: need level 0 and at least 1 level");
  }
  pyramid->levels.resize(levels);
  for (int l = 1; l < levels; ++l) {
    const FrameLevel& fine = pyramid->levels[l - 1];
    FrameLevel& coarse = pyramid->levels[l];
    coarse.width = fine.width / 2;
    coarse.height = fine.height / 2;
    coarse.intrinsics = Halved(fine.intrinsics);
    coarse.depth_m = Downsample(fine.depth_m, fine.width, fine.height, max_depth_jump_ratio);
    ComputeVertexNormalMaps(&coarse, max_depth_jump_ratio, threads);
  }
}

}  // namespace rigfit
