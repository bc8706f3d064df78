#include "sim/simulate_sequence.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>

#include "core/parallel.h"
#include "core/pose.h"
#include "sim/simulate_rig.h"
#include "sim/stereo_depth.h"

namespace rigfit {
namespace {

// Random streams of a seed (sim/random.h), apart from the room's (SimulateRoom); the pixel
// noise of frame i uses kFrameStream + i.
constexpr std::uint64_t kTrajectoryStream = 10;
constexpr std::uint64_t kFrameStream = std::uint64_t{1} << 20;

// The hand-held path (HandheldTrajectory).
constexpr double kMinRadiusShare = 0.45;  // of the room's half extent
constexpr double kMaxRadiusShare = 0.6;
constexpr double kMinWallClearance = 0.6;  // metres
constexpr double kSecondHarmonicM = 0.05;
constexpr double kThirdHarmonicM = 0.03;
constexpr double kSwayM = 0.01;  // 7th harmonic
constexpr double kMinHeight = 1.3, kMaxHeight = 1.5, kHeightSwingM = 0.1;
constexpr double kYawSwingDeg = 35.0;
constexpr double kMinPitchDownDeg = 10.0, kMaxPitchDownDeg = 25.0, kNodDeg = 5.0;
constexpr double kRollDeg = 3.0;
constexpr int kArcSamples = 4096;  // arc length of a loop, for the speed

// The lone-plane stretch (LonePlaneStretch).
constexpr double kFloorPitchDeg = -75.0;

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

void CheckOptions(const SimSequenceOptions& o) {
  auto fail = [](const std::string& what) {
    throw std::invalid_argument("SimulatedSequence: " + what);
  };
  auto finite_non_negative = [](double x) { return std::isfinite(x) && x >= 0.0; };
  if (o.frames < 1) fail("frames must be at least 1");
  if (o.width < 2 || o.height < 2) fail("width and height must be at least 2 pixels");
  if (!(o.rate_hz > 0.0) || !std::isfinite(o.rate_hz)) fail("rate_hz must be finite and > 0");
  if (!(o.speed_mps > 0.0) || !std::isfinite(o.speed_mps)) {
    fail("speed_mps must be finite and > 0");
  }
  if (!(o.max_depth_m > 0.0)) fail("max_depth_m must be > 0");
  const KinectNoiseOptions& k = o.kinect;
  if (!finite_non_negative(k.shift_sigma_px)) fail("shift_sigma_px must be finite and >= 0");
  if (!finite_non_negative(k.disparity_sigma)) fail("disparity_sigma must be finite and >= 0");
  if (!(k.disparity_constant > 0.0) || !std::isfinite(k.disparity_constant)) {
    fail("disparity_constant must be finite and > 0");
  }
  if (!std::isfinite(k.disparity_offset)) fail("disparity_offset must be finite");
  if (o.closed_loop && o.frames < 2) fail("a closed loop needs at least 2 frames");
  const LonePlaneStretch& l = o.lone_plane;
  const StereoOptions& st = o.stereo;
  if (o.noise == SequenceNoise::kStereo &&
      !(st.baseline_m > 0.0 && std::isfinite(st.baseline_m) && st.upsample >= 1 &&
        finite_non_negative(st.image_noise) && st.min_depth_m > 0.0 &&
        st.max_depth_m > st.min_depth_m && std::isfinite(st.disparity_offset_px) &&
        st.depth_scale > 0.0)) {
    fail(
        "stereo noise needs baseline_m > 0, upsample >= 1, image_noise >= 0, 0 < "
        "min_depth_m < max_depth_m, a finite disparity_offset_px and depth_scale > 0");
  }
  if (l.plane != LonePlane::kNone &&
      !(finite_non_negative(l.start_s) && l.seconds > 0.0 && std::isfinite(l.seconds) &&
        l.turn_s > 0.0 && std::isfinite(l.turn_s))) {
    fail("the lone-plane stretch needs start_s >= 0, seconds > 0 and turn_s > 0");
  }
}

// 0 outside [t0 - turn, t1 + turn], 1 inside [t0, t1], a smoothstep between.
double StretchBlend(const LonePlaneStretch& l, double t) {
  const double t0 = l.start_s, t1 = l.start_s + l.seconds;
  if (t >= t0 && t <= t1) return 1.0;
  const double u = t < t0 ? 1.0 - (t0 - t) / l.turn_s : 1.0 - (t - t1) / l.turn_s;
  if (u <= 0.0) return 0.0;
  return u * u * (3.0 - 2.0 * u);
}

// The wall slab nearest to `centre` and the yaw of a camera there facing it.
const OrientedBox& NearestWall(const Scene& scene, const Vec3& centre, double* yaw) {
  const OrientedBox* nearest = nullptr;
  for (const OrientedBox& box : scene.boxes) {
    if (box.kind != SurfaceKind::kWall) continue;
    if (!nearest || SignedDistance(box, centre) < SignedDistance(*nearest, centre)) {
      nearest = &box;
    }
  }
  int thin = 0;  // the slab's thickness axis: its normal
  nearest->half_extents.minCoeff(&thin);
  const Vec3 local = nearest->R_world_box.transpose() * (centre - nearest->center);
  const Vec3 toward = -std::copysign(1.0, local(thin)) * nearest->R_world_box.col(thin);
  *yaw = std::atan2(toward.x(), toward.z());
  return *nearest;
}

/// The colour of a ray's hit (ShadeHit), times its box's texture when `textures` has one per
/// box, into rgb[0..2].
void ShadeTextured(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                   const RayHit& hit, const Vec3& origin, const Vec3& direction, double fx,
                   std::uint8_t* rgb) {
  const Vec3 p_world = origin + hit.t * direction;
  const auto shaded = ShadeHit(scene, hit, p_world);
  const double factor = textures.empty() ? 1.0
                                         : TextureFactor(scene, textures, hit, p_world,
                                                         PixelFootprint(hit, direction, fx));
  for (int c = 0; c < 3; ++c) {
    rgb[c] = static_cast<std::uint8_t>(std::clamp(std::lround(factor * shaded[c]), 0l, 255l));
  }
}

}  // namespace

double KinectNoiseSigma(const KinectNoiseOptions& options, double z_m) {
  const double z_cm = 100.0 * z_m;
  const double s = options.disparity_sigma;
  const double disparity_cm =
      z_cm * z_cm / options.disparity_constant * std::sqrt(s * s + 1.0 / 12);
  return 0.01 * std::sqrt(disparity_cm * disparity_cm + 1.0 / 12);
}

std::vector<float> KinectNoise(const RgbdFrame& frame, const KinectNoiseOptions& options,
                               double pixel_scale, double max_depth_m, SimRng& rng) {
  const std::vector<float>& depth_m = frame.depth_m;
  const int width = frame.width;
  const int height = frame.height;
  const double shift_sigma = options.shift_sigma_px * pixel_scale;
  const double C = options.disparity_constant;
  const auto at = [&](int u, int v) { return depth_m[static_cast<size_t>(v) * width + u]; };
  std::vector<float> noisy(depth_m.size(), kNaNf);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const double dx = shift_sigma * rng.Normal();
      const double dy = shift_sigma * rng.Normal();
      const double n = options.disparity_sigma * rng.Normal();
      // 1. The depth at the shifted position, bilinear; nearest where a neighbour of
      //    non-zero weight is invalid.
      const double x = std::clamp(u + dx, 0.0, width - 1.0);
      const double y = std::clamp(v + dy, 0.0, height - 1.0);
      const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
      const int x1 = std::min(x0 + 1, width - 1), y1 = std::min(y0 + 1, height - 1);
      const double fx = x - x0, fy = y - y0;
      const double w[4] = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
      const float z[4] = {at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1)};
      double z_m = 0.0;
      for (int k = 0; k < 4; ++k) {
        if (w[k] == 0.0) continue;
        if (!std::isfinite(z[k])) {
          z_m = at(static_cast<int>(std::lround(x)), static_cast<int>(std::lround(y)));
          break;
        }
        z_m += w[k] * z[k];
      }
      if (!std::isfinite(z_m)) continue;
      // 2. Whole centimetres; 3. disparity noise and quantisation to 1/8 px.
      const double z_cm = std::round(100.0 * z_m);
      if (!(z_cm > 0.0)) continue;
      const double d = std::round(C / z_cm + n + options.disparity_offset);
      if (!(d > 0.0)) continue;
      const double z_noisy = 0.01 * C / d;
      if (z_noisy > max_depth_m) continue;
      noisy[static_cast<size_t>(v) * width + u] = static_cast<float>(z_noisy);
    }
  }
  return noisy;
}

HandheldTrajectory::HandheldTrajectory(const Scene& scene, double speed_mps, std::uint64_t seed) {
  SimRng rng(seed, kTrajectoryStream);
  const auto radius = [&](double half) {
    return std::min(rng.Uniform(kMinRadiusShare, kMaxRadiusShare) * half, half - kMinWallClearance);
  };
  radius_x_ = radius(0.5 * scene.size_x_m);
  radius_z_ = radius(0.5 * scene.size_z_m);
  height_ = rng.Uniform(kMinHeight, kMaxHeight);
  pitch_ = -rng.Uniform(kMinPitchDownDeg, kMaxPitchDownDeg) * kDegToRad;
  direction_ = rng.Uniform() < 0.5 ? -1 : 1;
  for (double& phase : phase_) phase = rng.Uniform(0.0, 2.0 * M_PI);
  // The centre depends on theta only: speed = omega |dCentre/dtheta|, so the mean speed
  // over a loop is omega L / (2 pi).
  double length = 0.0;
  Vec3 previous = Centre(0.0);
  for (int k = 1; k <= kArcSamples; ++k) {
    const Vec3 p = Centre(2.0 * M_PI * k / kArcSamples);
    length += (p - previous).norm();
    previous = p;
  }
  loop_length_m_ = length;
  omega_ = 2.0 * M_PI * speed_mps / length;
}

Vec3 HandheldTrajectory::Centre(double theta) const {
  const double* f = phase_;
  return Vec3(
      radius_x_ * std::cos(theta) + kSecondHarmonicM * std::cos(2 * theta + f[1]) +
          kThirdHarmonicM * std::cos(3 * theta + f[2]) + kSwayM * std::cos(7 * theta + f[3]),
      height_ + kHeightSwingM * std::sin(2 * theta + f[4]) + kSwayM * std::sin(7 * theta + f[5]),
      radius_z_ * std::sin(theta) + kSecondHarmonicM * std::sin(2 * theta + f[1]) +
          kThirdHarmonicM * std::sin(3 * theta + f[2]) + kSwayM * std::sin(7 * theta + f[6]));
}

HandheldTrajectory::Attitude HandheldTrajectory::AttitudeAt(double t) const {
  const double theta = phase_[0] + direction_ * omega_ * t;
  Attitude a;
  a.centre = Centre(theta);
  // Heading toward the room centre (never at it: the curve keeps about a metre away), then
  // the swing, nod and roll.
  a.yaw = std::atan2(-a.centre.x(), -a.centre.z()) +
          kYawSwingDeg * kDegToRad * std::sin(2 * theta + phase_[7]);
  a.pitch = pitch_ + kNodDeg * kDegToRad * std::sin(3 * theta + phase_[4]);
  a.roll = kRollDeg * kDegToRad * std::sin(5 * theta + phase_[1]);
  return a;
}

namespace {

Pose AttitudePose(const HandheldTrajectory::Attitude& a) {
  const Vec3 forward(std::cos(a.pitch) * std::sin(a.yaw), std::sin(a.pitch),
                     std::cos(a.pitch) * std::cos(a.yaw));
  return CameraLookingAlong(a.centre, forward, a.roll);
}

}  // namespace

Pose HandheldTrajectory::At(double t) const { return AttitudePose(AttitudeAt(t)); }

PinholeIntrinsics SequenceIntrinsics(int width, int height) {
  constexpr double kF = 525.0, kCx = 319.5, kCy = 239.5, kWidth = 640.0, kHeight = 480.0;
  const double s = width / kWidth;
  PinholeIntrinsics K;
  K.fx = K.fy = kF * s;
  K.cx = (kCx + 0.5) * s - 0.5;
  K.cy = (kCy + 0.5) * (height / kHeight) - 0.5;
  return K;
}

std::vector<float> RenderDepth(const Scene& scene, const SceneCamera& camera, double max_depth_m,
                               std::vector<std::uint8_t>* color,
                               const std::vector<SurfaceTexture>& textures) {
  const Pose& T_world_camera = camera.T_world_camera;
  const PinholeIntrinsics& K = camera.K;
  const int width = camera.width;
  const int height = camera.height;
  std::vector<float> depth(static_cast<size_t>(width) * height, kNaNf);
  if (color) color->assign(depth.size() * 3, 0);
  const Mat3& R = T_world_camera.linear();
  const Vec3 origin = T_world_camera.translation();
  const int threads = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  ParallelFor(
      height, threads,
      [&](int v) {
        for (int u = 0; u < width; ++u) {
          // With the camera-frame direction ((u - cx) / fx, (v - cy) / fy, 1), the ray
          // parameter of the hit is its depth z.
          const Vec3 direction = R * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
          const std::optional<RayHit> hit = scene.Raycast(origin, direction);
          if (!hit || hit->t > max_depth_m) continue;
          const size_t i = static_cast<size_t>(v) * width + u;
          depth[i] = static_cast<float>(hit->t);
          if (color) {
            ShadeTextured(scene, textures, *hit, origin, direction, K.fx, &(*color)[3 * i]);
          }
        }
      },
      8);
  return depth;
}

SimulatedSequence::SimulatedSequence(const SimSequenceOptions& options) : options_(options) {
  CheckOptions(options);
  scene_ = SimulateRoom(options.seed, options.bare);
  if (options.color && options.texture) textures_ = SimulateTextures(scene_, options.seed);
  if (options.noise == SequenceNoise::kStereo) {
    stereo_textures_ = textures_.empty() ? SimulateTextures(scene_, options.seed) : textures_;
    options_.stereo.max_depth_m = std::min(options_.stereo.max_depth_m, options.max_depth_m);
  }
  trajectory_ = HandheldTrajectory(scene_, options.speed_mps, options.seed);
  if (options.closed_loop) {
    options_.speed_mps = trajectory_.LoopLength() / Timestamp(options.frames - 1);
    trajectory_ = HandheldTrajectory(scene_, options_.speed_mps, options.seed);
  }
  intrinsics_ = SequenceIntrinsics(options.width, options.height);
  const LonePlaneStretch& l = options.lone_plane;
  if (l.plane == LonePlane::kNone) return;
  lone_plane_scene_ = scene_;
  lone_plane_scene_.boxes.clear();
  std::vector<int> kept;  // the boxes of scene_ that the stretch's scene keeps
  if (l.plane == LonePlane::kFloor) {
    for (size_t b = 0; b < scene_.boxes.size(); ++b) {
      if (scene_.boxes[b].kind == SurfaceKind::kFloor) kept.push_back(static_cast<int>(b));
    }
  } else {
    const Vec3 centre = trajectory_.AttitudeAt(l.start_s + 0.5 * l.seconds).centre;
    kept.push_back(
        static_cast<int>(&NearestWall(scene_, centre, &lone_plane_yaw_) - scene_.boxes.data()));
  }
  for (const int b : kept) {
    lone_plane_scene_.boxes.push_back(scene_.boxes[b]);
    if (!textures_.empty()) lone_plane_textures_.push_back(textures_[b]);
    if (!stereo_textures_.empty()) lone_plane_stereo_textures_.push_back(stereo_textures_[b]);
  }
}

Pose SimulatedSequence::CameraPose(double t) const {
  HandheldTrajectory::Attitude a = trajectory_.AttitudeAt(t);
  const LonePlaneStretch& l = options_.lone_plane;
  if (l.plane == LonePlane::kNone) return AttitudePose(a);
  const double s = StretchBlend(l, t);
  const double target_yaw = l.plane == LonePlane::kWall ? lone_plane_yaw_ : a.yaw;
  const double target_pitch = l.plane == LonePlane::kWall ? 0.0 : kFloorPitchDeg * kDegToRad;
  a.yaw += s * std::remainder(target_yaw - a.yaw, 2.0 * M_PI);
  a.pitch += s * (target_pitch - a.pitch);
  a.roll *= 1.0 - s;
  return AttitudePose(a);
}

bool SimulatedSequence::InLonePlaneStretch(double t) const {
  const LonePlaneStretch& l = options_.lone_plane;
  return l.plane != LonePlane::kNone && t >= l.start_s && t <= l.start_s + l.seconds;
}

double SimulatedSequence::Timestamp(int index) const {
  return std::round(index * 1e6 / options_.rate_hz) * 1e-6;
}

RgbdFrame SimulatedSequence::Frame(int index) const {
  if (index < 0 || index >= options_.frames) {
    throw std::out_of_range("SimulatedSequence: frame " + std::to_string(index) + " out of range");
  }
  RgbdFrame frame;
  frame.index = index;
  frame.timestamp = Timestamp(index);
  frame.source = "simulated frame " + std::to_string(index);
  frame.width = options_.width;
  frame.height = options_.height;
  frame.intrinsics = intrinsics_;
  const Pose T_world_camera = CameraPose(frame.timestamp);
  frame.T_world_camera_gt = T_world_camera;
  const bool stretch = InLonePlaneStretch(frame.timestamp);
  const Scene& scene = stretch ? lone_plane_scene_ : scene_;
  const SceneCamera camera{T_world_camera, intrinsics_, options_.width, options_.height};
  frame.depth_m =
      RenderDepth(scene, camera, options_.max_depth_m, options_.color ? &frame.color : nullptr,
                  stretch ? lone_plane_textures_ : textures_);
  SimRng rng(options_.seed, kFrameStream + static_cast<std::uint64_t>(index));
  if (options_.noise == SequenceNoise::kKinect) {
    frame.depth_m =
        KinectNoise(frame, options_.kinect, options_.width / 640.0, options_.max_depth_m, rng);
  } else if (options_.noise == SequenceNoise::kStereo) {
    frame.depth_m = StereoDepth(scene, stretch ? lone_plane_stereo_textures_ : stereo_textures_,
                                camera, options_.stereo, rng);
  }
  return frame;
}

Trajectory SimulatedSequence::GroundTruth() const {
  Trajectory gt;
  for (int i = 0; i < options_.frames; ++i) {
    gt.timestamps.push_back(Timestamp(i));
    gt.poses.push_back(CameraPose(gt.timestamps.back()));
  }
  return gt;
}

std::string SimulatedSequence::Describe() const {
  return "simulated sequence: " + std::to_string(options_.frames) + " frames of " +
         std::to_string(options_.width) + "x" + std::to_string(options_.height) + " at " +
         std::to_string(options_.rate_hz) + " Hz, seed " + std::to_string(options_.seed) +
         (options_.noise == SequenceNoise::kKinect ? ", Kinect noise"
          : options_.noise == SequenceNoise::kStereo
              ? ", stereo depth (baseline " + std::to_string(options_.stereo.baseline_m) + " m)"
              : ", no noise") +
         (options_.closed_loop ? ", one closed loop" : "") +
         (options_.lone_plane.plane == LonePlane::kNone
              ? ""
              : std::string(", only the ") +
                    (options_.lone_plane.plane == LonePlane::kFloor ? "floor" : "nearest wall") +
                    " seen from " + std::to_string(options_.lone_plane.start_s) + " s for " +
                    std::to_string(options_.lone_plane.seconds) + " s");
}

}  // namespace rigfit
