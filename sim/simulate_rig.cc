#include "sim/simulate_rig.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "core/errors.h"
#include "sim/noise_field.h"
#include "sim/random.h"
#include "sim/stereo_depth.h"

namespace rigfit {
namespace {

// Random streams of a seed (sim/random.h); pixel noise of camera i uses kPixelStream + i,
// plus noise_draw x kNoiseDrawStreams for another draw of it.
enum Stream : std::uint64_t { kRoomStream = 0, kCameraStream = 1, kPerturbStream = 2 };
constexpr std::uint64_t kPixelStream = 1000;
constexpr std::uint64_t kNoiseDrawStreams = std::uint64_t{1} << 32;  // above any camera index
// The correlated noise field of camera i: kFieldStream + i (+ the noise draw's offset).
constexpr std::uint64_t kFieldStream = 2000;
// The stereo pair's image noise of camera i: kStereoStream + i (+ the noise draw's offset).
constexpr std::uint64_t kStereoStream = 3000;

// Room and camera layout.
constexpr double kWallHeight = 2.5;
constexpr double kSlabThickness = 0.1;  // floor and wall slabs, outside the room
constexpr double kBaseboardHeight = 0.08;
constexpr double kBaseboardDepth = 0.015;
constexpr double kMinCameraHeight = 1.8;
constexpr double kMaxCameraHeight = 2.5;
constexpr double kMaxCameraRollDeg = 2.0;

using Rgb = std::array<std::uint8_t, 3>;
constexpr Rgb kFloorRgb = {150, 118, 84};
constexpr Rgb kWallRgb = {222, 216, 200};
constexpr Rgb kBaseboardRgb = {245, 245, 240};
constexpr Rgb kFurnitureRgb[] = {{176, 64, 52},  {70, 110, 160}, {90, 140, 80},
                                 {200, 170, 90}, {120, 90, 140}, {60, 60, 64}};

void CheckOptions(const SimOptions& o) {
  auto fail = [](const std::string& what) { throw std::invalid_argument("SimulateRig: " + what); };
  if (o.cameras < 1) fail("cameras must be at least 1");
  if (o.width < 2 || o.height < 2) fail("width and height must be at least 2 pixels");
  if (!(o.noise >= 0.0) || !std::isfinite(o.noise)) fail("noise must be finite and >= 0");
  if (!(o.dropout >= 0.0 && o.dropout < 1.0)) fail("dropout must be in [0, 1)");
  if (!(o.max_depth_m > 0.0)) fail("max_depth_m must be > 0");
  for (double p : {o.perturb_yaw_deg, o.perturb_xz_m, o.perturb_tilt_deg}) {
    if (!(p >= 0.0) || !std::isfinite(p)) fail("perturbations must be finite and >= 0");
  }
  if (!(o.noise_corr_px >= 0.0) || !std::isfinite(o.noise_corr_px)) {
    fail("noise_corr_px must be finite and >= 0");
  }
  if (!(o.noise_corr_share >= 0.0 && o.noise_corr_share <= 1.0)) {
    fail("noise_corr_share must be in [0, 1]");
  }
  if (o.noise_corr_share > 0.0 && !(o.noise_corr_px > 0.0)) {
    fail("noise_corr_share > 0 needs noise_corr_px > 0");
  }
  if (!(o.disparity_quant_px >= 0.0) || !std::isfinite(o.disparity_quant_px)) {
    fail("disparity_quant_px must be finite and >= 0");
  }
  if (!(o.stereo_baseline_m > 0.0) || !std::isfinite(o.stereo_baseline_m)) {
    fail("stereo_baseline_m must be finite and > 0");
  }
  if (o.stereo_upsample < 1) fail("stereo_upsample must be at least 1");
  if (!std::isfinite(o.disparity_offset_px)) fail("disparity_offset_px must be finite");
  if (!(o.depth_scale > 0.0) || !std::isfinite(o.depth_scale)) {
    fail("depth_scale must be finite and > 0");
  }
}

/// Whether camera `index` is one of the miscalibrated ones (SimOptions::miscalibrated_cameras)
/// with a miscalibration to apply.
bool Miscalibrated(const SimOptions& o, int index) {
  if (o.disparity_offset_px == 0.0 && o.depth_scale == 1.0) return false;
  if (o.miscalibrated_cameras.empty()) return index != 0;
  return std::find(o.miscalibrated_cameras.begin(), o.miscalibrated_cameras.end(), index) !=
         o.miscalibrated_cameras.end();
}

/// A miscalibrated camera's Gaussian-model depth: disparity f B / z offset, depth scaled;
/// NaN where the disparity is no longer positive or the depth beyond max_depth_m.
void MiscalibrateDepth(const SimOptions& o, double fx, std::vector<float>* depth_m) {
  const double f_b = fx * o.stereo_baseline_m;
  for (float& z : *depth_m) {
    if (!std::isfinite(z)) continue;
    const double d = f_b / z + o.disparity_offset_px;
    const double scaled = o.depth_scale * f_b / d;
    z = d > 0.0 && scaled <= o.max_depth_m ? static_cast<float>(scaled)
                                           : std::numeric_limits<float>::quiet_NaN();
  }
}

Mat3 RotationY(double angle) { return ExpSO3(angle * Vec3::UnitY()); }

/// Builds the parts of one piece of furniture in its own frame (y up, resting on y = 0),
/// then places it at (x, z) with the given yaw.
class Furniture {
 public:
  void AddPart(const Vec3& center, const Vec3& size) { parts_.push_back({center, 0.5 * size}); }

  /// Radius of the footprint's bounding circle about the origin.
  double FootprintRadius() const {
    double r = 0.0;
    for (const Part& p : parts_) {
      r = std::max(
          r, std::hypot(std::abs(p.center.x()) + p.half.x(), std::abs(p.center.z()) + p.half.z()));
    }
    return r;
  }

  void Place(double x, double z, double yaw, const Rgb& albedo, Scene* scene) const {
    const Mat3 R = RotationY(yaw);
    for (const Part& p : parts_) {
      OrientedBox box;
      box.center = Vec3(x, 0.0, z) + R * p.center;
      box.R_world_box = R;
      box.half_extents = p.half;
      box.kind = SurfaceKind::kFurniture;
      box.albedo_rgb = albedo;
      scene->boxes.push_back(box);
    }
  }

 private:
  struct Part {
    Vec3 center;
    Vec3 half;
  };
  std::vector<Part> parts_;
};

Furniture MakeBlock(SimRng& rng, bool low) {
  const double sx = rng.Uniform(0.3, 1.0);
  const double sz = rng.Uniform(0.3, 1.0);
  const double h = low ? rng.Uniform(0.15, 0.35) : rng.Uniform(0.3, 1.0);
  Furniture f;
  f.AddPart(Vec3(0.0, 0.5 * h, 0.0), Vec3(sx, h, sz));
  return f;
}

Furniture MakeTable(SimRng& rng) {
  const double sx = rng.Uniform(0.9, 1.5);
  const double sz = rng.Uniform(0.6, 0.9);
  const double h = rng.Uniform(0.72, 0.78);
  constexpr double kTop = 0.03;
  constexpr double kLeg = 0.04;
  constexpr double kInset = 0.06;  // leg centre from the top's edges
  Furniture f;
  f.AddPart(Vec3(0.0, h - 0.5 * kTop, 0.0), Vec3(sx, kTop, sz));
  const double leg_h = h - kTop;
  for (double ux : {-1.0, 1.0}) {
    for (double uz : {-1.0, 1.0}) {
      f.AddPart(Vec3(ux * (0.5 * sx - kInset), 0.5 * leg_h, uz * (0.5 * sz - kInset)),
                Vec3(kLeg, leg_h, kLeg));
    }
  }
  return f;
}

Furniture MakeChair() {
  constexpr double kSeat = 0.44;
  constexpr double kSeatHeight = 0.45;
  constexpr double kSeatThickness = 0.04;
  constexpr double kLeg = 0.035;
  constexpr double kBackTop = 0.9;
  constexpr double kBackThickness = 0.03;
  Furniture f;
  f.AddPart(Vec3(0.0, kSeatHeight - 0.5 * kSeatThickness, 0.0), Vec3(kSeat, kSeatThickness, kSeat));
  const double leg_h = kSeatHeight - kSeatThickness;
  const double offset = 0.5 * (kSeat - kLeg);
  for (double ux : {-1.0, 1.0}) {
    for (double uz : {-1.0, 1.0}) {
      f.AddPart(Vec3(ux * offset, 0.5 * leg_h, uz * offset), Vec3(kLeg, leg_h, kLeg));
    }
  }
  f.AddPart(Vec3(0.0, 0.5 * (kSeatHeight + kBackTop), -0.5 * (kSeat - kBackThickness)),
            Vec3(kSeat, kBackTop - kSeatHeight, kBackThickness));
  return f;
}

void AddBox(const Vec3& center, const Vec3& size, SurfaceKind kind, const Rgb& albedo,
            Scene* scene) {
  OrientedBox box;
  box.center = center;
  box.half_extents = 0.5 * size;
  box.kind = kind;
  box.albedo_rgb = albedo;
  scene->boxes.push_back(box);
}

}  // namespace

/// The room: floor and wall slabs, then (unless bare) baseboards and furniture placed by
/// rejection sampling so that footprints do not overlap.
Scene SimulateRoom(std::uint64_t seed, bool bare) {
  SimRng rng(seed, kRoomStream);
  Scene scene;
  scene.size_x_m = rng.Uniform(5.6, 6.4);
  scene.size_z_m = rng.Uniform(4.6, 5.4);
  scene.wall_height_m = kWallHeight;
  const double hx = 0.5 * scene.size_x_m;
  const double hz = 0.5 * scene.size_z_m;
  const double t = kSlabThickness;
  AddBox(Vec3(0.0, -0.5 * t, 0.0), Vec3(2 * (hx + t), t, 2 * (hz + t)), SurfaceKind::kFloor,
         kFloorRgb, &scene);
  for (double s : {-1.0, 1.0}) {
    AddBox(Vec3(s * (hx + 0.5 * t), 0.5 * kWallHeight, 0.0), Vec3(t, kWallHeight, 2 * (hz + t)),
           SurfaceKind::kWall, kWallRgb, &scene);
    AddBox(Vec3(0.0, 0.5 * kWallHeight, s * (hz + 0.5 * t)), Vec3(2 * (hx + t), kWallHeight, t),
           SurfaceKind::kWall, kWallRgb, &scene);
  }
  if (bare) return scene;

  const double b = kBaseboardDepth;
  for (double s : {-1.0, 1.0}) {
    AddBox(Vec3(s * (hx - 0.5 * b), 0.5 * kBaseboardHeight, 0.0), Vec3(b, kBaseboardHeight, 2 * hz),
           SurfaceKind::kBaseboard, kBaseboardRgb, &scene);
    AddBox(Vec3(0.0, 0.5 * kBaseboardHeight, s * (hz - 0.5 * b)), Vec3(2 * hx, kBaseboardHeight, b),
           SurfaceKind::kBaseboard, kBaseboardRgb, &scene);
  }

  // Two tables, a chair, two low boxes and four taller ones.
  std::vector<Furniture> items = {MakeTable(rng), MakeTable(rng), MakeChair()};
  for (int i = 0; i < 6; ++i) items.push_back(MakeBlock(rng, i < 2));
  struct Footprint {
    double x, z, r;
  };
  std::vector<Footprint> placed;
  constexpr int kMaxAttempts = 200;
  constexpr double kGap = 0.05;  // between footprints, and to the baseboards
  for (size_t i = 0; i < items.size(); ++i) {
    const double r = items[i].FootprintRadius();
    const double yaw = rng.Uniform(0.0, M_PI);
    const Rgb& albedo = kFurnitureRgb[rng.UniformInt(0, std::size(kFurnitureRgb) - 1)];
    const double margin = r + b + kGap;
    for (int attempt = 0; attempt < kMaxAttempts; ++attempt) {
      const double x = rng.Uniform(-hx + margin, hx - margin);
      const double z = rng.Uniform(-hz + margin, hz - margin);
      const bool free = std::all_of(placed.begin(), placed.end(), [&](const Footprint& f) {
        return std::hypot(x - f.x, z - f.z) > r + f.r + kGap;
      });
      if (free) {
        items[i].Place(x, z, yaw, albedo, &scene);
        placed.push_back({x, z, r});
        break;
      }
    }
  }
  return scene;
}

namespace {

/// True camera poses: spread in azimuth around the room, inset from the walls, at
/// 1.8-2.5 m, looking at floor points near the room centre, with a little roll.
std::vector<Pose> PlaceCameras(const SimOptions& options, const Scene& scene) {
  SimRng rng(options.seed, kCameraStream);
  const int n = options.cameras;
  const double azimuth0 = rng.Uniform(0.0, 2.0 * M_PI);
  const double sector = 2.0 * M_PI / n;
  std::vector<Pose> poses;
  for (int i = 0; i < n; ++i) {
    const double azimuth = azimuth0 + sector * (i + rng.Uniform(-0.2, 0.2));
    const double inset = rng.Uniform(0.3, 0.6);
    const Vec3 centre((0.5 * scene.size_x_m - inset) * std::cos(azimuth),
                      rng.Uniform(kMinCameraHeight, kMaxCameraHeight),
                      (0.5 * scene.size_z_m - inset) * std::sin(azimuth));
    const Vec3 target(rng.Uniform(-0.5, 0.5), 0.0, rng.Uniform(-0.5, 0.5));
    const double roll = rng.Uniform(-kMaxCameraRollDeg, kMaxCameraRollDeg) * kDegToRad;
    poses.push_back(CameraLookingAlong(centre, target - centre, roll));
  }
  return poses;
}

/// The perturbed starting poses, as documented at SimulateRig.
std::vector<Pose> PerturbPoses(const SimOptions& options, const std::vector<Pose>& gt) {
  SimRng rng(options.seed, kPerturbStream);
  std::vector<Pose> init;
  for (const Pose& T : gt) {
    const double yaw = rng.Uniform(-1.0, 1.0) * options.perturb_yaw_deg * kDegToRad;
    const double tilt_axis = rng.Uniform(0.0, 2.0 * M_PI);
    const double tilt = rng.Uniform() * options.perturb_tilt_deg * kDegToRad;
    Vec6 delta;
    delta << tilt * std::cos(tilt_axis), yaw, tilt * std::sin(tilt_axis),
        rng.Uniform(-1.0, 1.0) * options.perturb_xz_m,
        rng.Uniform(-1.0, 1.0) * options.perturb_xz_m / 5.0,
        rng.Uniform(-1.0, 1.0) * options.perturb_xz_m;
    init.push_back(PosePlus(T, delta));
  }
  return init;
}

}  // namespace

Pose CameraLookingAlong(const Vec3& centre, const Vec3& forward, double roll) {
  // OpenCV camera axes in the world: z forward, x = z cross up (right), y = z cross x
  // (down), then the roll about z.
  const Vec3 z_axis = forward.normalized();
  const Vec3 x_axis = z_axis.cross(Vec3::UnitY()).normalized();
  Mat3 R;
  R << x_axis, z_axis.cross(x_axis), z_axis;
  Pose T_world_camera = Pose::Identity();
  T_world_camera.linear() = R * ExpSO3(roll * Vec3::UnitZ());
  T_world_camera.translation() = centre;
  return T_world_camera;
}

Rgb ShadeHit(const Scene& scene, const RayHit& hit, const Vec3& p_world) {
  static const Vec3 kLight = Vec3(0.35, 1.0, 0.25).normalized();
  const OrientedBox& box = scene.boxes[hit.box_index];
  double shade = 0.55 + 0.45 * std::abs(hit.normal_world.dot(kLight));
  if (box.kind == SurfaceKind::kFloor &&
      (static_cast<long>(std::floor(2.0 * p_world.x()) + std::floor(2.0 * p_world.z())) & 1)) {
    shade *= 0.85;
  }
  Rgb rgb;
  for (int c = 0; c < 3; ++c) {
    rgb[c] = static_cast<std::uint8_t>(std::lround(shade * box.albedo_rgb[c]));
  }
  return rgb;
}

namespace {

/// Ray-casts one camera and corrupts its depth like a stereo camera (see SimulateRig).
/// Every pixel draws its dropout and noise variates in row-major order, hit or not, so
/// the noise of a pixel depends only on the seed, the noise draw, the camera and the pixel.
void RenderCameraGaussian(const SimOptions& options, const Scene& scene, const Pose& T_world_camera,
                          int index, CameraCapture* camera) {
  SimRng rng(options.seed, kPixelStream + options.noise_draw * kNoiseDrawStreams +
                               static_cast<std::uint64_t>(index));
  const int w = options.width;
  const int h = options.height;
  const PinholeIntrinsics K = SimIntrinsics(w, h);
  camera->serial = SimSerial(index);
  camera->width = w;
  camera->height = h;
  camera->intrinsics = K;
  camera->depth_m.assign(static_cast<size_t>(w) * h, std::numeric_limits<float>::quiet_NaN());
  camera->color.assign(static_cast<size_t>(w) * h * 3, 0);
  const Mat3& R = T_world_camera.linear();
  const Vec3 origin = T_world_camera.translation();
  // The correlated share of the noise, from its own stream: the white noise stays the same.
  const double share = options.noise_corr_share;
  std::vector<double> field;
  if (share > 0.0) {
    SimRng field_rng(options.seed, kFieldStream + options.noise_draw * kNoiseDrawStreams +
                                       static_cast<std::uint64_t>(index));
    field = GaussianNoiseField(w, h, options.noise_corr_px, field_rng);
  }
  const double white_weight = std::sqrt(1.0 - share);
  const double field_weight = std::sqrt(share);
  const double f_b = K.fx * options.stereo_baseline_m;  // disparity = f B / z
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const bool dropped = rng.Uniform() < options.dropout;
      const double white = rng.Normal();
      const double gaussian =
          share > 0.0 ? white_weight * white + field_weight * field[static_cast<size_t>(v) * w + u]
                      : white;
      // With the camera-frame direction ((u - cx) / fx, (v - cy) / fy, 1), the ray
      // parameter of the hit is its depth z.
      const Vec3 direction = R * Vec3((u - K.cx) / K.fx, (v - K.cy) / K.fy, 1.0);
      const std::optional<RayHit> hit = scene.Raycast(origin, direction);
      if (!hit) continue;
      const size_t i = static_cast<size_t>(v) * w + u;
      const Rgb rgb = ShadeHit(scene, *hit, origin + hit->t * direction);
      std::copy(rgb.begin(), rgb.end(), camera->color.begin() + 3 * i);
      // Stereo depth error grows with z^2: sigma = noise * z^2.
      double z = hit->t + options.noise * hit->t * hit->t * gaussian;
      if (options.disparity_quant_px > 0.0 && z > 0.0) {
        const double q = options.disparity_quant_px;
        z = f_b / (q * std::max(1.0, std::round(f_b / z / q)));
      }
      if (dropped || !(z > 0.0 && z <= options.max_depth_m)) continue;
      camera->depth_m[i] = static_cast<float>(z);
    }
  }
}

/// One camera: colour and depth as the depth model says, then its miscalibration.
void RenderCamera(const SimOptions& options, const Scene& scene,
                  const std::vector<SurfaceTexture>& textures, const Pose& T_world_camera,
                  int index, CameraCapture* camera) {
  RenderCameraGaussian(options, scene, T_world_camera, index, camera);
  const bool miscalibrated = Miscalibrated(options, index);
  if (options.depth_model == DepthModel::kGaussian) {
    if (miscalibrated) MiscalibrateDepth(options, camera->intrinsics.fx, &camera->depth_m);
    return;
  }
  StereoOptions stereo;
  stereo.baseline_m = options.stereo_baseline_m;
  stereo.upsample = options.stereo_upsample;
  stereo.max_depth_m = options.max_depth_m;
  if (miscalibrated) {
    stereo.disparity_offset_px = options.disparity_offset_px;
    stereo.depth_scale = options.depth_scale;
  }
  SimRng rng(options.seed, kStereoStream + options.noise_draw * kNoiseDrawStreams +
                               static_cast<std::uint64_t>(index));
  camera->depth_m =
      StereoDepth(scene, textures,
                  {T_world_camera, camera->intrinsics, camera->width, camera->height}, stereo, rng);
  camera->baseline_m = options.stereo_baseline_m;
}

}  // namespace

std::vector<double> GaussianNoiseField(int width, int height, double corr_px, SimRng& rng) {
  const std::vector<double> kernel = NoiseFieldKernel(corr_px);
  const int radius = static_cast<int>(kernel.size() / 2);
  double norm2 = 0.0;
  for (const double k : kernel) norm2 += k * k;
  // White noise on the padded canvas, blurred along rows, then along columns: every output
  // pixel sees the whole kernel, so its variance is norm2^2 exactly (before the division).
  const int pw = width + 2 * radius;
  const int ph = height + 2 * radius;
  std::vector<double> white(static_cast<size_t>(pw) * ph);
  for (double& x : white) x = rng.Normal();
  std::vector<double> rows(static_cast<size_t>(width) * ph, 0.0);
  for (int y = 0; y < ph; ++y) {
    for (int x = 0; x < width; ++x) {
      double acc = 0.0;
      for (int k = 0; k <= 2 * radius; ++k)
        acc += kernel[k] * white[static_cast<size_t>(y) * pw + x + k];
      rows[static_cast<size_t>(y) * width + x] = acc;
    }
  }
  std::vector<double> field(static_cast<size_t>(width) * height, 0.0);
  const double scale = 1.0 / norm2;  // sqrt(norm2^2)
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      double acc = 0.0;
      for (int k = 0; k <= 2 * radius; ++k)
        acc += kernel[k] * rows[static_cast<size_t>(y + k) * width + x];
      field[static_cast<size_t>(y) * width + x] = acc * scale;
    }
  }
  return field;
}

std::string SimSerial(int index) { return std::to_string(31000000 + 1117 * index); }

const char* DepthModelName(DepthModel model) {
  return model == DepthModel::kStereo ? "stereo" : "gaussian";
}

DepthModel DepthModelNamed(const std::string& name) {
  for (const DepthModel model : {DepthModel::kGaussian, DepthModel::kStereo}) {
    if (name == DepthModelName(model)) return model;
  }
  throw SettingError("depth_model", "must be gaussian or stereo, got " + name);
}

PinholeIntrinsics SimIntrinsics(int width, int height) {
  PinholeIntrinsics K;
  K.fx = 0.5 * width / std::tan(0.5 * kSimHorizontalFovDeg * kDegToRad);
  K.fy = K.fx;
  K.cx = 0.5 * (width - 1);
  K.cy = 0.5 * (height - 1);
  return K;
}

void CheckSimImageSize(int width, int height) {
  for (const auto& [key, value] : {std::pair{"width", width}, std::pair{"height", height}}) {
    if (value < kMinSimImageSize || value > kMaxSimImageSize) {
      throw SettingError(key, "must be in [" + std::to_string(kMinSimImageSize) + ", " +
                                  std::to_string(kMaxSimImageSize) + "] pixels, got " +
                                  std::to_string(value));
    }
  }
}

namespace {

/// CheckSimOptions' checks of the stereo model's and the miscalibration's options.
template <typename Fail>
void CheckStereoOptions(const SimOptions& o, const Fail& fail) {
  if (!(o.stereo_baseline_m > 0.0) || !std::isfinite(o.stereo_baseline_m)) {
    fail("stereo_baseline_m", "must be a finite number > 0");
  }
  if (o.stereo_upsample < 1 || o.stereo_upsample > 4) {
    fail("stereo_upsample", "must be in [1, 4], got " + std::to_string(o.stereo_upsample));
  }
  if (!std::isfinite(o.disparity_offset_px)) fail("disparity_offset_px", "must be finite");
  if (!(o.depth_scale >= 0.5 && o.depth_scale <= 2.0)) fail("depth_scale", "must be in [0.5, 2]");
  for (const int index : o.miscalibrated_cameras) {
    if (index < 0 || index >= o.cameras) {
      fail("miscalibrated_cameras", "must be camera indices in [0, " +
                                        std::to_string(o.cameras - 1) + "], got " +
                                        std::to_string(index));
    }
  }
  if (o.depth_model != DepthModel::kStereo) return;
  if (o.disparity_quant_px > 0.0) {
    fail("disparity_quant_px",
         "must be 0 with {depth_model} stereo (the block matcher quantises by itself)");
  }
  if (o.noise_corr_share > 0.0) {
    fail("noise_corr_share",
         "must be 0 with {depth_model} stereo (its noise comes from the matching)");
  }
}

}  // namespace

void CheckSimOptions(const SimOptions& o) {
  const auto fail = [](const char* key, const std::string& what) { throw SettingError(key, what); };
  const auto finite_non_negative = [](double x) { return std::isfinite(x) && x >= 0.0; };
  if (o.cameras < 1 || o.cameras > kMaxSimCameras) {
    fail("cameras", "must be in [1, " + std::to_string(kMaxSimCameras) + "], got " +
                        std::to_string(o.cameras));
  }
  CheckSimImageSize(o.width, o.height);
  if (!finite_non_negative(o.noise)) fail("noise", "must be a finite number >= 0");
  if (!(o.dropout >= 0.0 && o.dropout < 1.0)) fail("dropout", "must be in [0, 1)");
  if (!finite_non_negative(o.perturb_yaw_deg) || o.perturb_yaw_deg > 180.0) {
    fail("perturb_yaw_deg", "must be in [0, 180]");
  }
  if (!finite_non_negative(o.perturb_tilt_deg) || o.perturb_tilt_deg > 90.0) {
    fail("perturb_tilt_deg", "must be in [0, 90]");
  }
  if (!finite_non_negative(o.perturb_xz_m)) fail("perturb_xz_m", "must be a finite number >= 0");
  if (!finite_non_negative(o.noise_corr_px)) {
    fail("noise_corr_px", "must be a finite number >= 0");
  }
  if (!(o.noise_corr_share >= 0.0 && o.noise_corr_share <= 1.0)) {
    fail("noise_corr_share", "must be in [0, 1]");
  }
  if (o.noise_corr_share > 0.0 && o.noise_corr_px <= 0.0) {
    fail("noise_corr_share", "> 0 needs {noise_corr_px} > 0");
  }
  if (!finite_non_negative(o.disparity_quant_px)) {
    fail("disparity_quant_px", "must be a finite number >= 0");
  }
  CheckStereoOptions(o, fail);
}

SimulatedRig SimulateRig(const SimOptions& options) {
  CheckOptions(options);
  SimulatedRig rig;
  rig.scene = SimulateRoom(options.seed, options.bare);
  const std::vector<Pose> gt = PlaceCameras(options, rig.scene);
  const std::vector<Pose> init = PerturbPoses(options, gt);
  rig.capture.cameras.resize(gt.size());
  const std::vector<SurfaceTexture> textures = options.depth_model == DepthModel::kStereo
                                                   ? SimulateTextures(rig.scene, options.seed)
                                                   : std::vector<SurfaceTexture>();
  // Cameras are independent (own noise stream), so they render in parallel threads.
  const int threads =
      std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, options.cameras);
  std::vector<std::thread> workers;
  for (int t = 0; t < threads; ++t) {
    workers.emplace_back([&, t] {
      for (int i = t; i < options.cameras; i += threads) {
        RenderCamera(options, rig.scene, textures, gt[i], i, &rig.capture.cameras[i]);
      }
    });
  }
  for (std::thread& worker : workers) worker.join();
  for (int i = 0; i < options.cameras; ++i) {
    rig.gt[SimSerial(i)] = gt[i];
    rig.init[SimSerial(i)] = init[i];
  }
  return rig;
}

}  // namespace rigfit
