#include "rgbd/slam.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/errors.h"
#include "core/parallel.h"
#include "core/stopwatch.h"

namespace rigfit {

namespace {

/// A map point in the camera: its position p_c, normal n_c and nearest pixel (u0, v0).
struct CameraPoint {
  Vec3f p_c;
  Vec3f n_c;
  int u0 = 0;
  int v0 = 0;
};

}  // namespace

void RenderModel(const SurfelMap& map, const Pose& T_world_camera, int width, int height,
                 const PinholeIntrinsics& intrinsics, const RenderOptions& options, int frame_index,
                 int threads, ZBuffer* zbuffer, FrameLevel* level, MapView* view) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  level->width = width;
  level->height = height;
  level->intrinsics = intrinsics;
  const int pixels = width * height;
  level->depth_m.assign(pixels, kNaN);
  level->vertices.assign(pixels, Vec3f::Constant(kNaN));
  level->normals.assign(pixels, Vec3f::Constant(kNaN));
  level->valid_pixels.clear();

  const Eigen::Matrix3f R_cw = T_world_camera.linear().transpose().cast<float>();
  const Vec3f t = T_world_camera.translation().cast<float>();
  const float fx = static_cast<float>(intrinsics.fx);
  const float fy = static_cast<float>(intrinsics.fy);
  const float cx = static_cast<float>(intrinsics.cx);
  const float cy = static_cast<float>(intrinsics.cy);
  const float focal = 0.5f * (fx + fy);
  const bool filtered = options.min_weight > 1.0f;
  // Point i in the camera and its nearest pixel; false behind the camera.
  const auto project = [&](int i, CameraPoint* point) {
    point->p_c = R_cw * (map.positions()[i] - t);
    if (!(point->p_c.z() > 0.0f)) return false;
    point->u0 = NearestPixel(fx * point->p_c.x() / point->p_c.z() + cx);
    point->v0 = NearestPixel(fy * point->p_c.y() / point->p_c.z() + cy);
    return true;
  };
  // Whether a projected point is rendered (not filtered, not seen from behind); sets n_c.
  const auto rendered = [&](int i, CameraPoint* point) {
    if (filtered && map.weights()[i] < options.min_weight &&
        frame_index - map.last_seen()[i] > options.recent_frames) {
      return false;
    }
    point->n_c = R_cw * map.normals()[i];
    return point->n_c.dot(point->p_c) < 0.0f;  // not seen from behind
  };
  const auto half_width = [&](int i, const CameraPoint& point) {
    return options.splat ? std::min(options.max_splat_px,
                                    static_cast<int>(map.radii()[i] * focal / point.p_c.z()))
                         : 0;
  };
  // What pixel (u, v) of surfel i's disc sees: the ray's intersection with the surfel's plane
  // when it lies within the radius (the nearest pixel always: its ray passes within half a
  // pixel of the point); false when the ray misses the disc or grazes the plane.
  const auto on_disc = [&](int i, const CameraPoint& point, int u, int v, Vec3f* q) {
    const Vec3f ray((u - cx) / fx, (v - cy) / fy, 1.0f);
    const float denominator = point.n_c.dot(ray);
    if (!(denominator < -1e-3f)) return false;
    *q = (point.n_c.dot(point.p_c) / denominator) * ray;
    return (u == point.u0 && v == point.v0) ||
           (*q - point.p_c).squaredNorm() <= map.radii()[i] * map.radii()[i];
  };

  // 1. Every thread projects its share of the points into its own z-buffer (and collects
  // the view's points).
  threads = std::max(1, threads);
  zbuffer->Reset(pixels, threads);
  const int margin = view ? view->margin_px : 0;
  if (view) view->parts.resize(threads);
  ParallelForChunks(map.size(), threads, [&](int c, int begin, int end) {
    std::uint64_t* keys = zbuffer->Thread(c);
    std::vector<int>* part = view ? &view->parts[c] : nullptr;
    if (part) part->clear();
    CameraPoint point;
    Vec3f q = Vec3f::Zero();
    for (int i = begin; i < end; ++i) {
      if (!project(i, &point)) continue;
      const int u0 = point.u0;
      const int v0 = point.v0;
      if (part && point.p_c.z() >= MapView::kMinDepthM && u0 >= -margin && v0 >= -margin &&
          u0 < width + margin && v0 < height + margin) {
        part->push_back(i);
      }
      if (!options.splat) {
        if (u0 >= 0 && v0 >= 0 && u0 < width && v0 < height && rendered(i, &point)) {
          ZBuffer::Write(keys, v0 * width + u0, ZBuffer::Key(point.p_c.z(), i));
        }
        continue;
      }
      const int half = half_width(i, point);
      if (u0 + half < 0 || v0 + half < 0 || u0 - half >= width || v0 - half >= height) continue;
      if (!rendered(i, &point)) continue;
      for (int v = std::max(0, v0 - half); v <= std::min(height - 1, v0 + half); ++v) {
        for (int u = std::max(0, u0 - half); u <= std::min(width - 1, u0 + half); ++u) {
          if (on_disc(i, point, u, v, &q))
            ZBuffer::Write(keys, v * width + u, ZBuffer::Key(q.z(), i));
        }
      }
    }
  });
  // 2. The nearest point of each pixel, then its vertex and normal in the level.
  const std::vector<std::uint64_t>& keys = zbuffer->Merge();
  ParallelForChunks(pixels, threads, [&](int, int begin, int end) {
    CameraPoint point;
    for (int j = begin; j < end; ++j) {
      if (keys[j] == ZBuffer::kEmpty) continue;
      const int i = ZBuffer::Index(keys[j]);
      project(i, &point);
      point.n_c = R_cw * map.normals()[i];  // it was rendered: what `rendered` sets
      Vec3f q = point.p_c;
      if (options.splat) on_disc(i, point, j % width, j / width, &q);
      level->depth_m[j] = q.z();
      level->vertices[j] = q;
      level->normals[j] = point.n_c;
    }
  });
  for (int j = 0; j < pixels; ++j) {
    if (keys[j] != ZBuffer::kEmpty) level->valid_pixels.push_back(j);
  }
  if (view) {
    view->T_world_camera = T_world_camera;
    view->intrinsics = intrinsics;
    view->width = width;
    view->height = height;
    view->map_size = map.size();
  }
}

FrameLevel RenderModel(const SurfelMap& map, const Pose& T_world_camera, int width, int height,
                       const PinholeIntrinsics& intrinsics, const RenderOptions& options,
                       int frame_index, int threads) {
  FrameLevel level;
  ZBuffer zbuffer;
  RenderModel(map, T_world_camera, width, height, intrinsics, options, frame_index, threads,
              &zbuffer, &level, nullptr);
  return level;
}

SlamResult RunSlam(const RgbdSequence& sequence, const SlamOptions& options, const Log& log,
                   const std::function<void(int, int, const SlamFrame&)>& progress) {
  if (options.stride < 1) throw InputError("slam: stride must be at least 1");
  if (options.halvings < 0) throw InputError("slam: halvings must be >= 0");
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
  Pose velocity = Pose::Identity();        // T_previous_current of the last step, weak parts damped
  Pose T_world_target = Pose::Identity();  // where the model was rendered for the last track
  double previous_timestamp = 0.0;
  int failures_in_a_row = 0;
  MotionGuard guard(options.guard);
  bool use_color = false;
  FramePyramid model;  // the rendered model and its z-buffer, reused every frame
  ZBuffer zbuffer;
  MapView view;  // the map points near the rendered view, for the fusion that follows
  for (std::size_t k = 0; k < indices.size(); ++k) {
    auto start = std::chrono::steady_clock::now();
    RgbdFrame frame = sequence.Frame(indices[k]);
    for (int h = 0; h < options.halvings; ++h) {
      frame = HalveFrame(frame, options.frame.max_depth_jump_ratio);
    }
    result.load_s += SecondsSince(start);
    start = std::chrono::steady_clock::now();
    const FramePyramid pyramid = BuildFramePyramid(frame, options.frame, options.threads);
    result.preprocess_s += SecondsSince(start);
    if (k == 0) use_color = options.color && !frame.color.empty();
    const std::size_t pixels = static_cast<std::size_t>(frame.width) * frame.height;
    if (use_color && !frame.color.empty() && frame.color.size() != 3 * pixels) {
      throw InputError("slam: " + frame.source + ": a colour image not of the depth's size");
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
      // The model rendered at the start pose: the frame starts at the identity in it.
      const TrackFrom track_from = [&](const Pose& T_world_start) {
        const auto render_start = std::chrono::steady_clock::now();
        model.levels.resize(1);
        RenderModel(result.map, T_world_start, base.width, base.height, base.intrinsics,
                    options.render, indices[k], options.threads, &zbuffer, &model.levels[0], &view);
        BuildCoarserLevels(&model, options.frame.levels, options.frame.max_depth_jump_ratio,
                           options.threads);
        tracked.model_pixels = static_cast<int>(model.levels[0].valid_pixels.size());
        result.render_s += SecondsSince(render_start);
        TrackResult track =
            TrackProjective(pyramid, model, Pose::Identity(), options.icp, options.threads);
        return std::make_pair(track, Reorthonormalized(T_world_start * track.T_target_source));
      };
      const GuardedTrack guarded =
          guard.Track(track_from, predicted, T_world_previous, frame.timestamp - previous_timestamp,
                      "frame " + std::to_string(indices[k]) + " (" + frame.source + ")", log);
      result.track_s += SecondsSince(start);
      tracked.track = guarded.track;
      tracked.recovered = guarded.recovered;
      tracked.diverged = guarded.diverged;
      result.recovered += guarded.recovered ? 1 : 0;
      result.diverged += guarded.diverged ? 1 : 0;
      T_world_target = guarded.recovered ? T_world_previous : predicted;
      if (tracked.track.success) {
        T_world_current = guarded.T_world_camera;
        failures_in_a_row = 0;
        result.weak_frames += tracked.track.weak_directions > 0 ? 1 : 0;
      } else {
        T_world_current = guarded.diverged ? guarded.T_world_camera : Reorthonormalized(predicted);
        fuse = false;
        ++result.failures;
        ++failures_in_a_row;
        if (!guarded.diverged) {
          log.Warning("frame " + std::to_string(indices[k]) + " (" + frame.source +
                      "): tracking failed: " + tracked.track.message +
                      "; kept the prediction, not fused");
        }
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
    if (fuse && use_color && frame.color.empty()) {
      // A coloured map takes no colourless points (TUM: a depth image without a colour
      // image within the association's time window): tracked, not fused.
      fuse = false;
      ++result.without_color;
      log.Warning("frame " + std::to_string(indices[k]) + " (" + frame.source +
                  "): no colour image while the map is coloured; tracked, not fused");
    }
    if (fuse) {
      start = std::chrono::steady_clock::now();
      tracked.fusion = result.map.FuseFrame(pyramid.levels[0], T_world_current, indices[k],
                                            options.fusion, color, options.threads, &view);
      result.fuse_s += SecondsSince(start);
    }
    tracked.map_size = result.map.size();
    velocity = k == 0 ? Pose::Identity()
                      : NextVelocity(T_world_previous, T_world_current, T_world_target,
                                     tracked.track, tracked.diverged, options.guard);
    T_world_previous = T_world_current;
    previous_timestamp = frame.timestamp;
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
