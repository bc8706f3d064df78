// The RGB-D sequence simulator behind `rigfit simulate-sequence`: one hand-held Kinect-like
// camera walking through the simulated room (sim/simulate_rig.h SimulateRoom), with exact
// ground truth, for the dense RGB-D tracking pipeline (issue 19). Deterministic for a seed.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/rgbd.h"
#include "core/types.h"
#include "sim/random.h"
#include "sim/scene.h"
#include "sim/stereo_depth.h"
#include "sim/texture.h"

namespace rigfit {

/// The Kinect depth noise of the ICL-NUIM benchmark (Handa, Whelan, McDonald, Davison, "A
/// benchmark for RGB-D visual odometry, 3D reconstruction and SLAM", ICRA 2014), which follows
/// Barron & Malik (CVPR 2013), as its published code applies it to a noise-free depth image
/// (depth z in metres, z_cm = z / 0.01):
///  1. pixel shift: every pixel takes the depth at its own position moved by (dx, dy), i.i.d.
///     N(0, shift_sigma_px^2) per pixel and axis, interpolated bilinearly (mixed depths at
///     edges, as a Kinect shows);
///  2. z_cm is rounded to whole centimetres: z1 = round(z_cm);
///  3. disparity noise and quantisation: d = round(C / z1 + N(0, disparity_sigma^2) + offset)
///     and z_noisy = C / d centimetres, with C = 35130 = 8 f B (f about 585 px, B = 7.5 cm):
///     C / z_cm is the disparity in 1/8 pixel, so d is the disparity quantised to 1/8 px.
/// Left out: the 9x9 dot-pattern disparity filter of simkinect and the lateral noise along
/// the normal (Nguyen et al. 2012) of the CUDA code. The published code writes offset = 0.5
/// (round(x + 0.5)): a bias of half a step (the depth short by z_cm^2 / (2 C) cm, 5.7 mm
/// at 2 m); the default here is 0, rounding to nearest, so the noise has zero mean.
/// For small disparity_sigma the depth error has standard deviation about
/// (z_cm^2 / C) sqrt(disparity_sigma^2 + 1/12) cm from step 3 (rounding over a surface whose
/// disparity varies across pixels) and 1/sqrt(12) cm from step 2.
struct KinectNoiseOptions {
  double shift_sigma_px = 0.5;          ///< at 640 pixels across; scaled with the image width
  double disparity_sigma = 1.0 / 6.0;   ///< in 1/8 pixel
  double disparity_constant = 35130.0;  ///< C, in 1/8 pixel x centimetres
  double disparity_offset = 0.0;        ///< added before rounding; 0.5 as in the published code
};

/// Standard deviation (metres) of the depth error of KinectNoise on a smooth surface at depth
/// z_m whose disparity varies over many quantisation steps (see KinectNoiseOptions); ignores
/// the pixel shift.
double KinectNoiseSigma(const KinectNoiseOptions& options, double z_m);

/// The Kinect noise of KinectNoiseOptions applied to a frame's depth image (frame.depth_m,
/// frame.width x frame.height): a new image, NaN where the input is (and where a shifted
/// pixel's nearest neighbour is), where the noisy depth is not positive, and beyond
/// max_depth_m. pixel_scale multiplies shift_sigma_px (width / 640). Each pixel draws its
/// shift (2 variates) then its disparity noise (1), in row-major order.
std::vector<float> KinectNoise(const RgbdFrame& frame, const KinectNoiseOptions& options,
                               double pixel_scale, double max_depth_m, SimRng& rng);

/// The smooth path of a hand-held camera through the room, T_world_camera at time t (OpenCV
/// camera axes). The centre walks a closed curve around the room centre, an ellipse at
/// 45-60% of the room's half extents (at least 0.6 m from the walls) with a second and a
/// third harmonic of a few centimetres, at a height of 1.3-1.5 m varying by +-0.1 m, and a
/// hand's sway of 1 cm at the 7th harmonic. The camera looks toward the room centre,
/// its yaw swinging +-35 degrees about it (so it sees the walls beside), pitched 10-25
/// degrees down with +-5 degrees of nod, rolled +-3 degrees. Every term is a sinusoid of a
/// whole multiple of one phase theta = omega t, so the path is smooth (C-infinity) and
/// closes after each loop; omega makes the mean speed speed_mps. Deterministic for a seed.
class HandheldTrajectory {
 public:
  HandheldTrajectory() = default;
  HandheldTrajectory(const Scene& scene, double speed_mps, std::uint64_t seed);

  /// Where the camera is at t seconds and how it is turned: T_world_camera is
  /// CameraLookingAlong(centre, forward(yaw, pitch), roll) (sim/simulate_rig.h), yaw about
  /// world +Y from +Z, pitch up from the horizontal, radians.
  struct Attitude {
    Vec3 centre = Vec3::Zero();
    double yaw = 0.0;
    double pitch = 0.0;
    double roll = 0.0;
  };
  Attitude AttitudeAt(double t) const;
  /// T_world_camera at t seconds.
  Pose At(double t) const;
  /// Seconds per loop of the closed curve.
  double LoopSeconds() const { return 2.0 * M_PI / omega_; }
  /// Length of one loop of the centre's curve, metres.
  double LoopLength() const { return loop_length_m_; }

 private:
  Vec3 Centre(double theta) const;

  double loop_length_m_ = 0.0;
  double omega_ = 1.0;  ///< rad/s
  double radius_x_ = 1.0, radius_z_ = 1.0, height_ = 1.4;
  double phase_[8] = {};
  double pitch_ = -0.3;
  int direction_ = 1;  ///< +1 or -1: which way round
};

/// Depth noise of a simulated sequence: none (the ray-cast depth), ICL-NUIM's Kinect model, or
/// stereo block matching of a rendered, textured pair (sim/stereo_depth.h: holes on weakly
/// textured surfaces and at occlusions, fattened edges, sub-pixel locking, per-surface bias).
enum class SequenceNoise { kNone, kKinect, kStereo };

/// The one surface a lone-plane stretch shows.
enum class LonePlane { kNone, kFloor, kWall };

/// A stretch of the path where the camera sees a single plane and nothing else (the
/// degenerate views of docs/rgbd.md, "Degenerate views and divergence"): it turns within
/// turn_s seconds (smoothly, from its hand-held attitude) to look 75 degrees down at the floor,
/// or level at the wall nearest to it, stays so for `seconds` from start_s, and turns back.
/// During [start_s, start_s + seconds] only that surface is rendered (the floor slab, or the
/// one wall slab: furniture, baseboards and other walls are not), so every frame of the stretch
/// shows one plane.
struct LonePlaneStretch {
  LonePlane plane = LonePlane::kNone;
  double start_s = 5.0;
  double seconds = 1.0;
  double turn_s = 0.7;
};

/// The stereo matching of a hand-held sequence: StereoOptions with the search range from
/// 0.5 m (the rig simulator's starts at 0.8 m, its cameras look down from 1.8-2.5 m).
inline StereoOptions SequenceStereoOptions() {
  StereoOptions o;
  o.min_depth_m = 0.5;
  return o;
}

/// What to simulate. Defaults are those of `rigfit simulate-sequence`.
struct SimSequenceOptions {
  int frames = 300;
  double rate_hz = 30.0;
  double speed_mps = 0.4;  ///< mean speed of the camera centre
  std::uint64_t seed = 0;
  int width = 640;  ///< pixels; intrinsics scale with width / 640 (SequenceIntrinsics)
  int height = 480;
  SequenceNoise noise = SequenceNoise::kKinect;
  KinectNoiseOptions kinect;
  /// kStereo: the pair and its matching (the baseline along the camera's x; the search range
  /// from 0.5 m, as a hand-held ZED or RealSense sees a table: SequenceStereoOptions).
  StereoOptions stereo = SequenceStereoOptions();
  bool color = true;  ///< render the registered colour image
  /// The colour textured (sim/texture.h: fractal noise on every box, weak on some walls and
  /// furniture, as real rooms); off: each box's flat shaded albedo.
  bool texture = true;
  bool bare = false;  ///< floor and walls only
  /// Walk exactly one loop: the speed is set (speed_mps ignored) so that the last frame is
  /// back at the first frame's pose (a closed loop, for the end drift of docs/usage.md).
  bool closed_loop = false;
  LonePlaneStretch lone_plane;
  double max_depth_m = 10.0;  ///< depths beyond are invalid (NaN)
};

/// The intrinsics of a sequence of width x height: the TUM / ICL-NUIM default
/// fx = fy = 525, cx = 319.5, cy = 239.5 at 640 x 480, the focal length scaled by
/// width / 640 (square pixels), cx and cy by width / 640 and height / 480 about pixel centres
/// (c = (c_640 + 0.5) s - 0.5): 320 x 240 has 262.5, 159.5, 119.5.
PinholeIntrinsics SequenceIntrinsics(int width, int height);

/// The first surfaces `camera` sees: depth (camera z, metres) per pixel,
/// NaN where the ray leaves the room or hits beyond max_depth_m; when color is not null,
/// the [height, width, 3] shaded albedo (black where nothing is hit), times each box's
/// texture when `textures` holds one per box. Rows in parallel.
std::vector<float> RenderDepth(const Scene& scene, const SceneCamera& camera, double max_depth_m,
                               std::vector<std::uint8_t>* color,
                               const std::vector<SurfaceTexture>& textures = {});

/// A simulated sequence read like a dataset: frame i is rendered on demand at timestamp
/// i / rate_hz (seconds), with its exact T_world_camera_gt (the hand-held path, turned toward
/// the lone plane during its stretch); the pixel noise of a frame comes from its own random
/// stream, so frames can be rendered in any order.
class SimulatedSequence : public RgbdSequence {
 public:
  /// Throws std::invalid_argument for options out of range (frames < 1, width or
  /// height < 2, non-positive rate or speed, negative noise parameters, ...).
  explicit SimulatedSequence(const SimSequenceOptions& options);

  int size() const override { return options_.frames; }
  RgbdFrame Frame(int index) const override;
  /// One pose per frame, at the frames' timestamps.
  Trajectory GroundTruth() const override;
  std::string Describe() const override;

  const Scene& scene() const { return scene_; }
  const HandheldTrajectory& trajectory() const { return trajectory_; }
  const SimSequenceOptions& options() const { return options_; }
  /// T_world_camera at t seconds: the hand-held path with the lone-plane stretch's turn.
  Pose CameraPose(double t) const;
  /// Whether the camera sees only the lone plane at t seconds.
  bool InLonePlaneStretch(double t) const;
  /// Seconds of frame index: index / rate_hz rounded to the microsecond, so that the
  /// TUM files' 6-decimal names and timestamps are exact.
  double Timestamp(int index) const;

 private:
  SimSequenceOptions options_;
  Scene scene_;
  HandheldTrajectory trajectory_;
  PinholeIntrinsics intrinsics_;
  std::vector<SurfaceTexture> textures_;             ///< one per box of scene_ (none: flat colour)
  std::vector<SurfaceTexture> stereo_textures_;      ///< what stereo matches (kStereo only)
  Scene lone_plane_scene_;                           ///< the stretch's one surface
  std::vector<SurfaceTexture> lone_plane_textures_;  ///< its box's texture
  std::vector<SurfaceTexture> lone_plane_stereo_textures_;
  double lone_plane_yaw_ = 0.0;  ///< looking at the wall: the yaw facing it
};

}  // namespace rigfit
