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

/// The map as one camera sees it: which points are rendered and which pixels each covers.
class MapProjector {
 public:
  MapProjector(const SurfelMap& map, const Pose& T_world_camera,
               const PinholeIntrinsics& intrinsics, const RenderOptions& options, int frame_index)
      : map_(map),
        options_(options),
        frame_index_(frame_index),
        R_cw_(T_world_camera.linear().transpose().cast<float>()),
        t_(T_world_camera.translation().cast<float>()),
        fx_(static_cast<float>(intrinsics.fx)),
        fy_(static_cast<float>(intrinsics.fy)),
        cx_(static_cast<float>(intrinsics.cx)),
        cy_(static_cast<float>(intrinsics.cy)),
        focal_(0.5f * (fx_ + fy_)) {}

  /// Point i in the camera and its nearest pixel; false behind the camera.
  bool Project(int i, CameraPoint* point) const {
    point->p_c = R_cw_ * (map_.positions()[i] - t_);
    if (!(point->p_c.z() > 0.0f)) return false;
    point->u0 = NearestPixel(fx_ * point->p_c.x() / point->p_c.z() + cx_);
    point->v0 = NearestPixel(fy_ * point->p_c.y() / point->p_c.z() + cy_);
    return true;
  }

  /// Whether a projected point is rendered (not filtered, not seen from behind); sets n_c.
  bool Rendered(int i, CameraPoint* point) const {
    if (options_.min_weight > 1.0f && map_.weights()[i] < options_.min_weight &&
        frame_index_ - map_.last_seen()[i] > options_.recent_frames) {
      return false;
    }
    point->n_c = R_cw_ * map_.normals()[i];
    return point->n_c.dot(point->p_c) < 0.0f;  // not seen from behind
  }

  /// Writes the projected point i into `keys` (a width x height z-buffer): its nearest pixel,
  /// or with splats every pixel of its disc.
  void Write(int i, CameraPoint* point, int width, int height, std::uint64_t* keys) const {
    const int u0 = point->u0;
    const int v0 = point->v0;
    const int half = options_.splat
                         ? std::min(options_.max_splat_px,
                                    static_cast<int>(map_.radii()[i] * focal_ / point->p_c.z()))
                         : 0;
    if (u0 + half < 0 || v0 + half < 0 || u0 - half >= width || v0 - half >= height) return;
    if (!Rendered(i, point)) return;
    if (!options_.splat) {
      ZBuffer::Write(keys, v0 * width + u0, ZBuffer::Key(point->p_c.z(), i));
      return;
    }
    Vec3f q = Vec3f::Zero();
    for (int v = std::max(0, v0 - half); v <= std::min(height - 1, v0 + half); ++v) {
      for (int u = std::max(0, u0 - half); u <= std::min(width - 1, u0 + half); ++u) {
        if (OnDisc(i, *point, u, v, &q))
          ZBuffer::Write(keys, v * width + u, ZBuffer::Key(q.z(), i));
      }
    }
  }

  /// What pixel (u, v) of surfel i's disc sees: the ray's intersection with the surfel's plane
  /// when it lies within the radius (the nearest pixel always: its ray passes within half a
  /// pixel of the point); false when the ray misses the disc or grazes the plane.
  bool OnDisc(int i, const CameraPoint& point, int u, int v, Vec3f* q) const {
    const Vec3f ray((u - cx_) / fx_, (v - cy_) / fy_, 1.0f);
    const float denominator = point.n_c.dot(ray);
    if (!(denominator < -1e-3f)) return false;
    *q = (point.n_c.dot(point.p_c) / denominator) * ray;
    return (u == point.u0 && v == point.v0) ||
           (*q - point.p_c).squaredNorm() <= map_.radii()[i] * map_.radii()[i];
  }

  /// Pixel j's vertex seen on point i (rendered there).
  Vec3f Vertex(int i, int j, int width, CameraPoint* point) const {
    Project(i, point);
    point->n_c = R_cw_ * map_.normals()[i];  // it was rendered: what Rendered sets
    Vec3f q = point->p_c;
    if (options_.splat) OnDisc(i, *point, j % width, j / width, &q);
    return q;
  }

 private:
  const SurfelMap& map_;
  const RenderOptions& options_;
  int frame_index_;
  Eigen::Matrix3f R_cw_;
  Vec3f t_;
  float fx_, fy_, cx_, cy_;
  float focal_;
};

/// The points a view can use, as five half-spaces through the camera centre: in front of the
/// camera, and nearest pixel (u0, v0) within reach_px of the image (as NearestPixel rounds,
/// with 2 px to spare for single-precision rounding). Misses tells whether a run of map points
/// lies wholly outside one of them (by its bounding box): none of them can then be rendered or
/// collected into the view, and the run is skipped without projecting its points.
class ViewFrustum {
 public:
  ViewFrustum(const Pose& T_world_camera, int width, int height,
              const PinholeIntrinsics& intrinsics, int reach_px) {
    const double reach = reach_px + 0.5 + kSlackPx;
    const Vec3 in_camera[5] = {
        {0.0, 0.0, 1.0},                                               // z >= 0
        {intrinsics.fx, 0.0, intrinsics.cx + reach},                   // u0 >= -reach
        {-intrinsics.fx, 0.0, width - 1.0 + reach - intrinsics.cx},    // u0 < width + reach
        {0.0, intrinsics.fy, intrinsics.cy + reach},                   // v0 >= -reach
        {0.0, -intrinsics.fy, height - 1.0 + reach - intrinsics.cy}};  // v0 < height + reach
    for (int k = 0; k < 5; ++k) {
      // n . R^T (p - t) >= 0  <=>  (R n) . p >= (R n) . t
      const Vec3 n = T_world_camera.linear() * in_camera[k];
      normals_[k] = n.cast<float>();
      offsets_[k] = static_cast<float>(n.dot(T_world_camera.translation()));
    }
  }

  /// Whether the `count` points at `points` are all outside one of the half-spaces.
  bool Misses(const Vec3f* points, int count) const {
    Vec3f low = points[0];
    Vec3f high = points[0];
    for (int i = 1; i < count; ++i) {
      low = low.cwiseMin(points[i]);
      high = high.cwiseMax(points[i]);
    }
    const Vec3f centre = 0.5f * (low + high);
    const Vec3f half = 0.5f * (high - low);
    for (int k = 0; k < 5; ++k) {
      const float highest = normals_[k].dot(centre) + normals_[k].cwiseAbs().dot(half);
      if (highest < offsets_[k] - kSlackScale * std::abs(offsets_[k]) - kSlackAbs) return true;
    }
    return false;
  }

 private:
  static constexpr double kSlackPx = 2.0;
  static constexpr float kSlackScale = 1e-5f;  // the test's own rounding
  static constexpr float kSlackAbs = 1e-5f;
  Vec3f normals_[5];
  float offsets_[5];
};

/// How many consecutive map points ViewFrustum::Misses tests at once (RunSlam keeps them near
/// each other: SurfelMap::SortNewPoints).
constexpr int kCullRun = 64;

/// How often RunSlam sorts the map's new points by cell (SurfelMap::SortNewPoints), frames
/// fused, and the cells' side.
constexpr int kSortEveryFrames = 10;
constexpr double kSortCellM = 0.2;

/// An empty level of the given size: no depth, no vertex, no normal.
void ClearLevel(int width, int height, const PinholeIntrinsics& intrinsics, FrameLevel* level) {
  constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
  level->width = width;
  level->height = height;
  level->intrinsics = intrinsics;
  const int pixels = width * height;
  level->depth_m.assign(pixels, kNaN);
  level->vertices.assign(pixels, Vec3f::Constant(kNaN));
  level->normals.assign(pixels, Vec3f::Constant(kNaN));
  level->valid_pixels.clear();
}

}  // namespace

void RenderModel(const SurfelMap& map, const ModelViewpoint& viewpoint,
                 const RenderOptions& options, int threads, const RenderBuffers& out) {
  ZBuffer* zbuffer = out.zbuffer;
  FrameLevel* level = out.level;
  MapView* view = out.view;
  const int width = viewpoint.width;
  const int height = viewpoint.height;
  ClearLevel(width, height, viewpoint.intrinsics, level);
  const MapProjector projector(map, viewpoint.T_world_camera, viewpoint.intrinsics, options,
                               viewpoint.frame_index);
  // 1. Every thread projects its share of the points into its own z-buffer (and collects
  // the view's points).
  const int pixels = width * height;
  threads = std::max(1, threads);
  zbuffer->Reset(pixels, threads);
  const int margin = view ? view->margin_px : 0;
  if (view) view->parts.resize(threads);
  const int reach = std::max(margin, options.splat ? options.max_splat_px : 0);
  const ViewFrustum frustum(viewpoint.T_world_camera, width, height, viewpoint.intrinsics, reach);
  ParallelForChunks(map.size(), threads, [&](int c, int begin, int end) {
    std::uint64_t* keys = zbuffer->Thread(c);
    // Collected into a vector of this thread's own (the parts' headers share a cache line,
    // which the threads' push_backs fought over), its buffer taken from the part and returned.
    std::vector<int> part;
    if (view) part.swap(view->parts[c]);
    part.clear();
    CameraPoint point;
    for (int run = begin; run < end; run += kCullRun) {
      const int run_end = std::min(end, run + kCullRun);
      if (frustum.Misses(map.positions().data() + run, run_end - run)) continue;
      for (int i = run; i < run_end; ++i) {
        if (!projector.Project(i, &point)) continue;
        if (view && point.p_c.z() >= MapView::kMinDepthM && point.u0 >= -margin &&
            point.v0 >= -margin && point.u0 < width + margin && point.v0 < height + margin) {
          part.push_back(i);
        }
        projector.Write(i, &point, width, height, keys);
      }
    }
    if (view) part.swap(view->parts[c]);
  });
  // 2. The nearest point of each pixel, then its vertex and normal in the level.
  const std::vector<std::uint64_t>& keys = zbuffer->Merge();
  ParallelForChunks(pixels, threads, [&](int, int begin, int end) {
    CameraPoint point;
    for (int j = begin; j < end; ++j) {
      if (keys[j] == ZBuffer::kEmpty) continue;
      const Vec3f q = projector.Vertex(ZBuffer::Index(keys[j]), j, width, &point);
      level->depth_m[j] = q.z();
      level->vertices[j] = q;
      level->normals[j] = point.n_c;
    }
  });
  for (int j = 0; j < pixels; ++j) {
    if (keys[j] != ZBuffer::kEmpty) level->valid_pixels.push_back(j);
  }
  if (view) {
    view->T_world_camera = viewpoint.T_world_camera;
    view->intrinsics = viewpoint.intrinsics;
    view->width = width;
    view->height = height;
    view->map_size = map.size();
  }
}

FrameLevel RenderModel(const SurfelMap& map, const ModelViewpoint& viewpoint,
                       const RenderOptions& options, int threads) {
  FrameLevel level;
  ZBuffer zbuffer;
  RenderModel(map, viewpoint, options, threads, {&zbuffer, &level});
  return level;
}

namespace {

/// Tracks each frame against the map rendered at the frame's start pose, then fuses it.
class ModelTarget : public TrackingTarget {
 public:
  ModelTarget(const SlamOptions& options, const Log& log, SlamResult* result)
      : options_(options), log_(log), result_(result) {}

  /// The frame halved as asked, its colour (when fused) checked.
  RgbdFrame Load(const RgbdSequence& sequence, int index) const override {
    RgbdFrame frame = sequence.Frame(index);
    for (int h = 0; h < options_.halvings.value_or(0); ++h) {
      frame = HalveFrame(frame, options_.frame.max_depth_jump_ratio);
    }
    const std::size_t pixels = static_cast<std::size_t>(frame.width) * frame.height;
    if (options_.color && !frame.color.empty() && frame.color.size() != 3 * pixels) {
      throw InputError("slam: " + frame.source + ": a colour image not of the depth's size");
    }
    return frame;
  }

  /// The model rendered at the start pose: the frame starts at the identity in it.
  std::pair<TrackResult, Pose> Track(const FramePyramid& pyramid, int index,
                                     const Pose& T_world_start) override {
    const auto start = std::chrono::steady_clock::now();
    const FrameLevel& base = pyramid.levels[0];
    model_.levels.resize(1);
    RenderModel(result_->map, {T_world_start, base.width, base.height, base.intrinsics, index},
                options_.render, options_.threads, {&zbuffer_, &model_.levels[0], &view_});
    BuildCoarserLevels(&model_, options_.frame.levels, options_.frame.max_depth_jump_ratio,
                       options_.threads);
    model_pixels_ = static_cast<int>(model_.levels[0].valid_pixels.size());
    T_world_model_ = T_world_start;
    result_->render_s += SecondsSince(start);
    TrackResult track =
        TrackProjective(pyramid, model_, Pose::Identity(), options_.icp, options_.threads);
    return {track, Reorthonormalized(T_world_start * track.T_target_source)};
  }

  Pose MotionOrigin() const override { return T_world_model_; }

  ColorReference ColorReferenceOf() const override {
    return {color_key_ ? &*color_key_ : nullptr, T_world_color_key_};
  }

  /// Fuses the frame unless its track failed (a restart drops the map and fuses it anew), colour
  /// alone tracked it (its depth did not match the model) or it lacks the colour the map has; the
  /// first frame decides whether the map is coloured.
  void Accept(const TrackedStep& step, const RgbdFrame& frame, FramePyramid pyramid) override {
    if (result_->frames.empty()) use_color_ = options_.color && !frame.color.empty();
    SlamFrame tracked;
    tracked.index = step.index;
    tracked.track = step.track;
    tracked.model_pixels = model_pixels_;
    tracked.recovered = step.recovered;
    tracked.diverged = step.diverged;
    if (step.restart) result_->map = SurfelMap();
    if (step.restart) color_key_.reset();
    if (Fuses(step, frame)) {
      KeepColorKey(step, frame, pyramid);
      const auto start = std::chrono::steady_clock::now();
      const std::vector<std::uint8_t> no_color;
      tracked.fusion = result_->map.FuseFrame(pyramid.levels[0], step.T_world_camera, step.index,
                                              options_.fusion, use_color_ ? frame.color : no_color,
                                              {options_.threads, &view_});
      if (++fused_ % kSortEveryFrames == 0) result_->map.SortNewPoints(kSortCellM);
      result_->fuse_s += SecondsSince(start);
    }
    tracked.map_size = result_->map.size();
    result_->frames.push_back(tracked);
  }

  std::string FailureNote() const override { return "kept the prediction, not fused"; }
  std::string RestartNote() const override { return "restarted the map"; }

 private:
  bool Fuses(const TrackedStep& step, const RgbdFrame& frame) {
    if ((!step.track.success || step.unverified || step.color_rescued) && !step.restart) {
      return false;
    }
    if (!use_color_ || !frame.color.empty()) return true;
    // A coloured map takes no colourless points (TUM: a depth image without a colour image
    // within the association's time window): tracked, not fused.
    ++result_->without_color;
    log_.Warning("frame " + std::to_string(step.index) + " (" + frame.source +
                 "): no colour image while the map is coloured; tracked, not fused");
    return false;
  }

  /// A fused frame with colour becomes colour tracking's reference when there is none or it
  /// moved or turned enough from it (SlamOptions::color_keyframe_*).
  void KeepColorKey(const TrackedStep& step, const RgbdFrame& frame, const FramePyramid& pyramid) {
    if (options_.color_tracking == ColorTracking::kOff || !HasColor(frame, pyramid)) return;
    if (color_key_ &&
        WithinMotion(T_world_color_key_.inverse() * step.T_world_camera,
                     options_.color_keyframe_translation_m, options_.color_keyframe_rotation_deg)) {
      return;
    }
    color_key_ = BuildGreyPyramid(frame.color, pyramid);
    T_world_color_key_ = step.T_world_camera;
  }

  const SlamOptions& options_;
  const Log& log_;
  SlamResult* result_;
  bool use_color_ = false;
  FramePyramid model_;  // the rendered model and its z-buffer, reused every frame
  ZBuffer zbuffer_;
  MapView view_;  // the map points near the rendered view, for the fusion that follows
  int model_pixels_ = 0;
  int fused_ = 0;  // frames fused (the clock of the map's sorting)
  Pose T_world_model_ = Pose::Identity();
  std::optional<GreyPyramid> color_key_;  // colour tracking's reference and its pose
  Pose T_world_color_key_ = Pose::Identity();
};

}  // namespace

int SlamHalvings(const std::optional<int>& halvings, int width) {
  if (halvings) return *halvings;
  int count = 0;
  for (; width > kAutoHalvingMaxWidth; width /= 2) ++count;
  return count;
}

SlamResult RunSlam(const RgbdSequence& sequence, const SlamOptions& options, const Log& log,
                   const std::function<void(int, int, const SlamFrame&)>& progress) {
  if (options.halvings.value_or(0) < 0) throw InputError("slam: halvings must be >= 0");
  SlamResult result;
  // The default halving follows the first frame's width (a first frame out of the sequence
  // is RunTracking's error).
  SlamOptions run = options;
  const bool first_in_sequence = options.first_frame >= 0 && options.first_frame < sequence.size();
  run.halvings = options.halvings || !first_in_sequence
                     ? options.halvings.value_or(0)
                     : SlamHalvings(std::nullopt, sequence.Frame(options.first_frame).width);
  result.halvings = *run.halvings;
  if (!run.guard.enabled) run.icp.lone_plane.min_share = 0.0;  // the behaviour before the guard
  ModelTarget target(run, log, &result);
  const auto frame_done = [&](int done, int total) {
    if (progress) progress(done, total, result.frames.back());
  };
  static_cast<TrackingRun&>(result) = RunTracking(sequence, run, "slam", &target, log, frame_done);
  // Rendering is timed inside tracking; the result keeps the two apart.
  result.track_s -= result.render_s;
  return result;
}

}  // namespace rigfit
