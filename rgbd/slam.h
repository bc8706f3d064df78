// Frame-to-model dense RGB-D SLAM (Keller et al., 3DV 2013; the reference design
// ../shared/seeds/dense_slam_point_fusion.txt, section 4; docs/rgbd.md, "Frame-to-model
// SLAM"): the surfel map (rgbd/surfel_map.h) is rendered at the predicted pose, the incoming
// frame is tracked against that rendering by projective ICP (rgbd/projective_icp.h; source =
// the frame, target = the model), and then fused into the map at the tracked pose.
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "core/log.h"
#include "core/pose.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"
#include "rgbd/surfel_map.h"
#include "rgbd/tracking_loop.h"
#include "rgbd/zbuffer.h"

namespace rigfit {

struct RenderOptions {
  /// Confidence filter: only map points of at least this weight are rendered (a point of
  /// weight w was merged w - 1 times), except those seen in the last recent_frames frames
  /// (a surface just discovered has to be tracked against before it can be stable).
  /// 1 = every point.
  float min_weight = 1.0f;
  int recent_frames = 0;
  /// Each point covers its surfel disc (radius()), not only the pixel it projects to (a
  /// covered pixel gets the ray's intersection with the surfel's plane). Off by default:
  /// measured worse (a simulated Kinect-noise sequence: 31 mm ATE against 0.4 mm with each
  /// point on its nearest pixel only; docs/rgbd.md).
  bool splat = false;
  /// The largest half-width of a splat, pixels.
  int max_splat_px = 2;
};

/// Where the model is seen from: the camera's pose, image size and intrinsics, and the current
/// frame (the clock of RenderOptions::recent_frames).
struct ModelViewpoint {
  Pose T_world_camera = Pose::Identity();
  int width = 0;
  int height = 0;
  PinholeIntrinsics intrinsics;
  int frame_index = 0;
};

/// The map seen from `viewpoint`: a z-buffer (index map) where each rendered map point p, moved
/// into the camera (p_c = R^T (p - t)) and projected, fills its nearest pixel (and with
/// options.splat the pixels of its disc) unless a point closer along the ray is already there
/// (at equal depth: the lower index). The level's vertices and normals are the points' (camera
/// frame), depth_m their z; uncovered pixels are invalid (NaN), as in a frame. The points are
/// split over `threads` threads, each with its own z-buffer, merged by depth: the result has
/// the same bits for every thread count.
FrameLevel RenderModel(const SurfelMap& map, const ModelViewpoint& viewpoint,
                       const RenderOptions& options, int threads = 2);

/// Where RenderModel renders into: buffers a sequence reuses every frame.
struct RenderBuffers {
  ZBuffer* zbuffer = nullptr;   ///< the z-buffer (its buffers reused)
  FrameLevel* level = nullptr;  ///< the rendered level (its buffers reused)
  /// Optional: also collects the map points near the view (MapView, rgbd/surfel_map.h) for the
  /// fusion of the same frame.
  MapView* view = nullptr;
};

/// As above, into *out.level, whose buffers are reused, as are *out.zbuffer's (what a sequence
/// renders every frame without allocating); with out.view, also the map points near the view.
void RenderModel(const SurfelMap& map, const ModelViewpoint& viewpoint,
                 const RenderOptions& options, int threads, const RenderBuffers& out);

/// SLAM's settings: the shared loop's (rgbd/tracking_loop.h; a restart drops the map and starts
/// a new one from the current frame), fusion, rendering, colour and resolution.
struct SlamOptions : TrackingLoopOptions {
  FusionOptions fusion;
  RenderOptions render;
  /// Fuse the sequence's registered colour when its first frame has one (a later frame
  /// without colour is then tracked but not fused: SlamResult::without_color).
  bool color = true;
  /// Halve every frame's resolution this many times before anything else (HalveFrame,
  /// rgbd/frame.h); unset (the default): as many times as bring the width to at most
  /// kAutoHalvingMaxWidth (SlamHalvings: 640x480 runs at 320x240), which tracks as well as the
  /// full resolution on the measured sequences in a fraction of the time (docs/rgbd.md
  /// section 6). Timed with the loading (load_s): a sensor of that size would not do it.
  std::optional<int> halvings;
  /// Colour tracking's reference (TrackingLoopOptions::color_tracking): the last fused frame
  /// with colour that moved or turned more than these from the one before (the model renders
  /// no colour), as the odometry's keyframe.
  double color_keyframe_translation_m = 0.1;
  double color_keyframe_rotation_deg = 5.0;
};

/// The widest frame SlamOptions::halvings' default leaves unhalved, pixels.
inline constexpr int kAutoHalvingMaxWidth = 480;

/// How many times RunSlam halves frames `width` pixels wide: `halvings` when set, else until
/// the width is at most kAutoHalvingMaxWidth.
int SlamHalvings(const std::optional<int>& halvings, int width);

struct SlamFrame {
  int index = 0;           ///< frame index in the sequence
  TrackResult track;       ///< against the rendered model (T_target_source: predicted <- frame)
  int model_pixels = 0;    ///< valid pixels of the rendered model's level 0
  FusionStats fusion;      ///< what FuseFrame did (zeros for a failed frame: not fused)
  int map_size = 0;        ///< map points after this frame
  bool recovered = false;  ///< suspected of divergence, re-tracked from the last good pose
  bool diverged = false;   ///< so was the re-track: kept the last good pose, not fused
};

struct SlamResult : TrackingRun {
  std::vector<SlamFrame> frames;
  SurfelMap map;  ///< the final map (since the last restart)
  /// Frames tracked but not fused because they had no colour image while the map (from a
  /// first frame with colour) is coloured.
  int without_color = 0;
  double render_s = 0.0;  ///< rendering the model and its pyramid (not in track_s)
  int halvings = 0;       ///< times every frame was halved (SlamOptions::halvings resolved)
  double fuse_s = 0.0;
};

SlamResult RunSlam(const RgbdSequence& sequence, const SlamOptions& options, const Log& log = {},
                   const std::function<void(int, int, const SlamFrame&)>& progress = {});

}  // namespace rigfit
