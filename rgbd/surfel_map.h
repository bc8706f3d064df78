// Point-based fusion (Keller et al., 3DV 2013, section 4; the reference design
// ../shared/seeds/dense_slam_point_fusion.txt, section 3; formulas and measurements in
// docs/rgbd.md, "Fusion"): a map of surfels (position, normal, colour, confidence weight,
// radius, frame last seen) into which depth frames at known poses are merged.
//
// Fusing a frame at T_world_camera = [R | t]:
//   1. association, searched through projection (no k-d tree): every map point p is moved
//      into the camera, p_c = R^T (p - t), and projected to its nearest pixel; it is a
//      candidate of that pixel when p_c is in front of the camera and inside the image, the
//      pixel has a vertex q and normal n_q, |p_c - q| < max_distance_m and the angle between
//      R^T n_p and n_q is below max_normal_angle_deg (seed 3.1). A pixel keeps at most one
//      candidate: the closest to the camera along the ray (what an index map would render),
//      so that a pixel never merges into two points and fusing the same frame twice does not
//      grow the map.
//   2. merge (seed 3.2), a map point of weight w and its pixel (weight 1):
//        p <- (w p + R q + t) / (w + 1)
//        n <- normalise(w n_p + R n_q)
//        c <- (w c + c_q) / (w + 1)
//        w <- w + 1,  radius <- min(radius, r_q),  last seen <- this frame.
//   3. add (seed 3.3): every valid pixel that merged into no map point becomes a new point of
//      weight 1, unless a 4-neighbour merged into a point whose disc holds the pixel's vertex
//      (covered: the surface is in the map already; cover_radius_scale).
//   4. remove (the seed's bonus): points not seen for more than dormant_frames frames whose
//      weight is below min_stable_weight (seen too rarely to be trusted: outliers, moving
//      things, a pose that was off).
//
// The radius of a pixel's point is its footprint on the surface: r = z / f / max(|n_z|, 0.26),
// with f = (fx + fy) / 2 and n_z the cosine between the normal and the viewing axis (camera
// frame); the floor 0.26 (~75 degrees) keeps grazing views from giving huge surfels.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/pose.h"
#include "rgbd/frame.h"
#include "rgbd/zbuffer.h"

namespace rigfit {

struct FusionOptions {
  /// Distance gate: |p_c - q| must be below this (metres).
  double max_distance_m = 0.05;
  /// Normal-angle gate: the angle between the map normal (in the camera) and the pixel's
  /// normal must be below this (degrees).
  double max_normal_angle_deg = 30.0;
  /// Dormant-point removal: a point not seen for more than this many frames (frame_index -
  /// last_seen > dormant_frames) with weight below min_stable_weight is removed. 0: never
  /// remove (a rig's cameras, all at one instant, each see parts the others do not).
  int dormant_frames = 20;
  /// Coverage: a pixel that merged into no point is not added when a 4-neighbour pixel merged
  /// into a point whose disc, of radius cover_radius_scale * radius, holds the pixel's vertex
  /// (with normals within max_normal_angle_deg): the surface there is already in the map at
  /// this resolution. 0: every such pixel is added.
  double cover_radius_scale = 1.0;
  /// Fold duplicates: a map point that projects to a pixel merged into another point, passes
  /// that pixel's gates and overlaps the other's disc (normals within the angle gate) is
  /// folded into it (weights added) and removed (Keller et al.'s merging of overlapping
  /// points). Off: it halved the 7-Scenes map but made the ATE worse (docs/rgbd.md).
  bool fold_overlapping = false;
  double min_stable_weight = 3.0;
};

/// What one FuseFrame did.
struct FusionStats {
  int input_points = 0;  ///< the frame's valid pixels
  int merged = 0;        ///< pixels merged into a map point
  int added = 0;         ///< pixels added as new points
  int covered = 0;       ///< pixels neither merged nor added: covered by a neighbour's point
  int folded = 0;        ///< map points folded into an overlapping point (removed)
  int removed = 0;       ///< dormant points removed
  int projected = 0;     ///< map points projected for the association (all, or a MapView's)
};

/// The map points that can be seen from near a view (what RenderModel collects while it
/// projects the map, rgbd/slam.h): those at least kMinDepthM in front of the camera at
/// T_world_camera that project within margin_px pixels of its image.
/// FuseFrame then projects only them instead of the whole map, when the fused pose is close
/// enough to the view's that no other point can land in the image (MapView::Covers).
struct MapView {
  static constexpr float kMinDepthM = 0.05f;
  Pose T_world_camera = Pose::Identity();
  PinholeIntrinsics intrinsics;
  int width = 0;
  int height = 0;
  int margin_px = 32;
  int map_size = -1;  ///< the map's size when collected (-1: not collected)
  /// The points, in parts (one per thread of the rendering that collected them, each in
  /// increasing order; their buffers are kept between frames).
  std::vector<std::vector<int>> parts;

  /// True when every map point that can be associated with a pixel of `frame` (depth within
  /// max_distance_m of a valid vertex) seen at T_world_camera is in `parts`: same camera,
  /// same map size, and a first-order bound of how far the pose change moves a point in the
  /// image, f (|dtheta| |p| / z + |dt| / z) (1 + |x / z|) with 50% slack, below margin_px.
  bool Covers(const FrameLevel& frame, const Pose& T_world_camera_now, int map_size_now,
              double max_distance_m) const;
};

/// How FuseFrame does its work; neither setting changes its result.
struct FusionExecution {
  /// The association and the merge are split over this many threads.
  int threads = 2;
  /// With a view that covers the frame (MapView::Covers) only its points are projected for the
  /// association (the others cannot land in the image); null: every map point is.
  const MapView* view = nullptr;
};

struct FusionCamera;  // a fused frame's camera (surfel_map.cc)

/// The surfel map, stored as a structure of arrays (one array per property, index = point).
class SurfelMap {
 public:
  /// Fuses the valid pixels of `frame` (vertices and normals in the camera frame) seen at
  /// T_world_camera as frame `frame_index` (the clock of dormancy; increasing). `color`:
  /// empty, or [height, width, 3] RGB of the frame's pixels. A map holds colours when its
  /// first fused frame had them; every later frame must then have them too, and a map
  /// without colours takes no frame with colour. Throws std::invalid_argument on a colour
  /// of the wrong size or presence, or maps of inconsistent sizes. `execution`: threads and
  /// a MapView to project through (FusionExecution; the result does not depend on them).
  FusionStats FuseFrame(const FrameLevel& frame, const Pose& T_world_camera, int frame_index,
                        const FusionOptions& options, const std::vector<std::uint8_t>& color = {},
                        const FusionExecution& execution = {});

  /// Reorders the points fused since the last call (or since the map began) by the cube of
  /// side cell_m (> 0) each lies in, the cubes in Morton (Z-curve) order and the points of one
  /// cube in their order; the points before them keep theirs. A frame's new points are
  /// scattered pixels: sorted, consecutive points lie near each other, which lets RenderModel
  /// skip whole runs of them out of view. What each point holds is unchanged; only indices
  /// move (and with them which of two points at exactly equal depth a z-buffer keeps).
  void SortNewPoints(double cell_m);

  /// Moves every point by the world correction of the frame that last saw it (loop closure,
  /// rgbd/loop_closure.h): p <- C p, n <- R_C n with C = correction(last_seen()[i]).
  void MovePoints(const std::function<Pose(int frame_index)>& correction);

  int size() const { return static_cast<int>(positions_.size()); }
  bool has_color() const { return has_color_; }
  /// Valid pixels of every frame fused so far (the size of the naively concatenated input).
  std::int64_t input_points() const { return input_points_; }
  /// input_points() / size() (seed 3.4); 0 for an empty map.
  double CompressionRatio() const;

  const std::vector<Vec3f>& positions() const { return positions_; }  ///< world, metres
  const std::vector<Vec3f>& normals() const { return normals_; }      ///< world, unit
  /// RGB in [0, 255] (averages, hence float); empty unless has_color().
  const std::vector<Vec3f>& colors() const { return colors_; }
  const std::vector<float>& weights() const { return weights_; }
  const std::vector<float>& radii() const { return radii_; }  ///< metres
  const std::vector<int>& last_seen() const { return last_seen_; }

 private:
  // FuseFrame's steps (surfel_map.cc).
  void CheckFrame(const FrameLevel& frame, const std::vector<std::uint8_t>& color);
  int Associate(const FusionCamera& camera, const FusionOptions& options,
                const FusionExecution& execution);
  void MergeMatched(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                    const std::vector<std::uint8_t>& color, int frame_index, int threads);
  int FoldOverlapping(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                      int threads);
  void AddUnmatched(const FusionCamera& camera, const std::vector<std::uint64_t>& match,
                    const FusionOptions& options, const std::vector<std::uint8_t>& color,
                    int frame_index, FusionStats* stats);
  void RemoveDormant(int frame_index, const FusionOptions& options, FusionStats* stats);
  /// Asks for the cache lines of the map point a z-buffer key names (none for kEmpty).
  void Prefetch(std::uint64_t key) const;

  std::vector<Vec3f> positions_;
  std::vector<Vec3f> normals_;
  std::vector<Vec3f> colors_;
  std::vector<float> weights_;
  std::vector<float> radii_;
  std::vector<int> last_seen_;
  std::vector<int> fold_into_;  ///< per point: the point it folds into, or -1 (scratch)
  std::vector<int> gone_;       ///< RemoveDormant's scratch: the points to remove, increasing
  ZBuffer zbuffer_;             ///< the association's, kept between frames (no reallocation)
  int sorted_ = 0;              ///< the leading points SortNewPoints has sorted
  bool has_color_ = false;
  int frames_ = 0;  ///< frames fused
  std::int64_t input_points_ = 0;
};

/// The radius of a pixel's surfel (header comment): z / f / max(|n_z|, 0.26).
float SurfelRadius(float z, float n_z, double focal_px);

}  // namespace rigfit
