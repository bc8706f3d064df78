#include "rgbd/slam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/errors.h"
#include "core/stopwatch.h"

namespace rigfit {

FrameLevel RenderModel(const SurfelMap& map, const Pose& T_world_camera, int width, int height,
                       const PinholeIntrinsics& intrinsics, const RenderOptions& options,
                       int frame_index) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  FrameLevel level;
  level.width = width;
  level.height = height;
  level.intrinsics = intrinsics;
  const std::size_t pixels = static_cast<std::size_t>(width) * height;
  level.depth_m.assign(pixels, kNaN);
  level.vertices.assign(pixels, Vec3f::Constant(kNaN));
  level.normals.assign(pixels, Vec3f::Constant(kNaN));
  std::vector<float> zbuffer(pixels, std::numeric_limits<float>::infinity());

  const Eigen::Matrix3f R_cw = T_world_camera.linear().transpose().cast<float>();
  const Vec3f t = T_world_camera.translation().cast<float>();
  const float fx = static_cast<float>(intrinsics.fx);
  const float fy = static_cast<float>(intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float focal = 0.5f * (fx + fy);
  const auto write = [&](int j, const Vec3f& vertex, const Vec3f& normal) {
    if (vertex.z() >= zbuffer[j]) return;
    zbuffer[j] = vertex.z();
    level.depth_m[j] = vertex.z();
    level.vertices[j] = vertex;
    level.normals[j] = normal;
  };
  const bool filtered = options.min_weight > 1.0f;
  for (int i = 0; i < map.size(); ++i) {
    if (filtered && map.weights()[i] < options.min_weight &&
        frame_index - map.last_seen()[i] > options.recent_frames) {
      continue;
    }
    const Vec3f p_c = R_cw * (map.positions()[i] - t);
    if (!(p_c.z() > 0.0f)) continue;
    const Vec3f n_c = R_cw * map.normals()[i];
    if (n_c.dot(p_c) >= 0.0f) continue;  // seen from behind
    const int u0 = static_cast<int>(std::lround(fx * p_c.x() / p_c.z() + cx));
    const int v0 = static_cast<int>(std::lround(fy * p_c.y() / p_c.z() + cy));
    const float radius = map.radii()[i];
    const int half =
        options.splat ? std::min(options.max_splat_px, static_cast<int>(radius * focal / p_c.z()))
                      : 0;
    if (u0 + half < 0 || v0 + half < 0 || u0 - half >= width || v0 - half >= height) continue;
    if (!options.splat) {
      if (u0 >= 0 && v0 >= 0 && u0 < width && v0 < height) write(v0 * width + u0, p_c, n_c);
      continue;
    }
    // The disc's pixels: the ray's intersection with the surfel's plane, within its radius
    // (the nearest pixel always: its ray passes within half a pixel of the point).
    const float plane = n_c.dot(p_c);
    const float radius_sq = radius * radius;
    for (int v = std::max(0, v0 - half); v <= std::min(height - 1, v0 + half); ++v) {
      for (int u = std::max(0, u0 - half); u <= std::min(width - 1, u0 + half); ++u) {
        const Vec3f ray((u - cx) / fx, (v - cy) / fy, 1.0f);
        const float denominator = n_c.dot(ray);
        if (!(denominator < -1e-3f)) continue;
        const Vec3f q = (plane / denominator) * ray;
        if ((u != u0 || v != v0) && (q - p_c).squaredNorm() > radius_sq) continue;
        write(v * width + u, q, n_c);
      }
    }
  }
  for (int j = 0; j < static_cast<int>(pixels); ++j) {
    if (level.Valid(j)) level.valid_pixels.push_back(j);
  }
  return level;
}

SlamResult RunSlam(const RgbdSequence& sequence, const SlamOptions& options, const Log& log,
                   const std::function<void(int, int, const SlamFrame&)>& progress) {
  if (options.stride < 1) throw InputError("slam: stride must be at least 1");
  if (options.max_frames < 0) throw InputError("slam: max frames must be >= 0 (0: all)");
  if (options.restart_after_failures < 1) {
    throw InputError("slam: restart after failures must be at least 1");
  }
  if (options.first_frame < 0 || options.first_frame >= sequence.size()) {
    throw InputError("slam: first frame " + std::to_string(options.first_frame) +
                     " is not in the sequence (" + std::to_string(sequence.size()) + " frames)");
  }
  std::vector<int> indices;
  for (int i = options.first_frame; i < sequence.size(); i += options.stride) {
    if (options.max_frames > 0 && static_cast<int>(indices.size()) >= options.max_frames) break;
    indices.push_back(i);
  }

  SlamResult result;
  Pose T_world_previous = Pose::Identity();
  Pose velocity = Pose::Identity();  // T_previous_current of the last step
  int failures_in_a_row = 0;
  bool use_color = false;
  for (std::size_t k = 0; k < indices.size(); ++k) {
    auto start = std::chrono::steady_clock::now();
    const RgbdFrame frame = sequence.Frame(indices[k]);
    result.load_s += SecondsSince(start);
    start = std::chrono::steady_clock::now();
    const FramePyramid pyramid = BuildFramePyramid(frame, options.frame, options.threads);
    result.preprocess_s += SecondsSince(start);
    if (k == 0) use_color = options.color && !frame.color.empty();
    const std::size_t pixels = static_cast<std::size_t>(frame.width) * frame.height;
    if (use_color && frame.color.size() != 3 * pixels) {
      throw InputError("slam: " + frame.source +
                       ": no colour image of the depth's size, while the first frame had one");
    }
    const std::vector<std::uint8_t> no_color;
    const std::vector<std::uint8_t>& color = use_color ? frame.color : no_color;

    SlamFrame tracked;
    tracked.index = indices[k];
    Pose T_world_current;
    bool fuse = true;
    if (k == 0) {
      T_world_current = frame.T_world_camera_gt.value_or(Pose::Identity());
      tracked.track.success = true;
    } else {
      const Pose predicted = options.prior == MotionPrior::kConstantVelocity
                                 ? T_world_previous * velocity
                                 : T_world_previous;
      start = std::chrono::steady_clock::now();
      const FrameLevel& base = pyramid.levels[0];
      FramePyramid model;
      model.levels.push_back(RenderModel(result.map, predicted, base.width, base.height,
                                         base.intrinsics, options.render, indices[k]));
      BuildCoarserLevels(&model, options.frame.levels, options.frame.max_depth_jump_ratio,
                         options.threads);
      tracked.model_pixels = static_cast<int>(model.levels[0].valid_pixels.size());
      result.render_s += SecondsSince(start);
      start = std::chrono::steady_clock::now();
      // The model is rendered at the prediction: the frame starts at the identity in it.
      tracked.track =
          TrackProjective(pyramid, model, Pose::Identity(), options.icp, options.threads);
      result.track_s += SecondsSince(start);
      if (tracked.track.success) {
        T_world_current = Reorthonormalized(predicted * tracked.track.T_target_source);
        failures_in_a_row = 0;
      } else {
        T_world_current = Reorthonormalized(predicted);
        fuse = false;
        ++result.failures;
        ++failures_in_a_row;
        log.Warning("frame " + std::to_string(indices[k]) + " (" + frame.source +
                    "): tracking failed: " + tracked.track.message +
                    "; kept the prediction, not fused");
        if (failures_in_a_row >= options.restart_after_failures && !base.valid_pixels.empty()) {
          log.Warning("lost track for " + std::to_string(failures_in_a_row) +
                      " frames: restarted the map from frame " + std::to_string(indices[k]) +
                      " at its predicted pose");
          result.map = SurfelMap();
          ++result.restarts;
          failures_in_a_row = 0;
          fuse = true;
        }
      }
    }
    if (fuse) {
      start = std::chrono::steady_clock::now();
      tracked.fusion = result.map.FuseFrame(pyramid.levels[0], T_world_current, indices[k],
                                            options.fusion, color);
      result.fuse_s += SecondsSince(start);
    }
    tracked.map_size = result.map.size();
    velocity =
        k == 0 ? Pose::Identity() : Reorthonormalized(T_world_previous.inverse() * T_world_current);
    T_world_previous = T_world_current;
    result.trajectory.timestamps.push_back(frame.timestamp);
    result.trajectory.poses.push_back(T_world_current);
    result.frames.push_back(tracked);
    if (progress) {
      progress(static_cast<int>(k) + 1, static_cast<int>(indices.size()), result.frames.back());
    }
  }
  return result;
}

}  // namespace rigfit
