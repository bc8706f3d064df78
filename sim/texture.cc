#include "sim/texture.h"

#include <algorithm>
#include <cmath>

#include "sim/random.h"

namespace rigfit {
namespace {

constexpr std::uint64_t kTextureStream = 3;  // after the room, camera and perturbation streams
constexpr int kOctaves = 4;

/// A lattice value in [-1, 1]: an integer hash of (x, y, seed).
double LatticeValue(int x, int y, std::uint32_t seed) {
  std::uint32_t h = static_cast<std::uint32_t>(x) * 0x8da6b343u ^
                    static_cast<std::uint32_t>(y) * 0xd8163841u ^ seed * 0xcb1ab31fu;
  h ^= h >> 15;
  h *= 0x2c1b3c6du;
  h ^= h >> 12;
  h *= 0x297a2d39u;
  h ^= h >> 15;
  return h * (2.0 / 4294967295.0) - 1.0;
}

/// Value noise: the lattice values interpolated by smoothstep, wavelength 1.
double ValueNoise(double x, double y, std::uint32_t seed) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const int ix = static_cast<int>(fx);
  const int iy = static_cast<int>(fy);
  const auto smooth = [](double a) { return a * a * (3.0 - 2.0 * a); };
  const double sx = smooth(x - fx);
  const double sy = smooth(y - fy);
  const double top = (1 - sx) * LatticeValue(ix, iy, seed) + sx * LatticeValue(ix + 1, iy, seed);
  const double bottom =
      (1 - sx) * LatticeValue(ix, iy + 1, seed) + sx * LatticeValue(ix + 1, iy + 1, seed);
  return (1 - sy) * top + sy * bottom;
}

/// The texture's value at face coordinates (s, t) metres, octaves shorter than about two
/// pixel footprints (footprint_m, the pixel's size on the surface) faded out, as a camera's
/// pixels average them away instead of aliasing them.
double FractalTexture(const SurfaceTexture& texture, std::uint32_t face, double s, double t,
                      double footprint_m) {
  double value = 0.0;
  double amplitude = 1.0;
  double wavelength = texture.feature_m;
  for (int o = 0; o < kOctaves; ++o) {
    const double fade = std::clamp(0.5 * (wavelength / footprint_m - 2.0), 0.0, 1.0);
    if (fade <= 0.0) break;
    const std::uint32_t seed = texture.seed * 131u + face * 17u + static_cast<std::uint32_t>(o);
    value += fade * amplitude * ValueNoise(s / wavelength, t / wavelength, seed);
    amplitude *= 0.6;
    wavelength *= 0.5;
  }
  return value;
}

}  // namespace

std::vector<SurfaceTexture> SimulateTextures(const Scene& scene, std::uint64_t seed) {
  SimRng rng(seed, kTextureStream);
  std::vector<SurfaceTexture> textures(scene.boxes.size());
  for (SurfaceTexture& texture : textures) {
    texture.seed = static_cast<std::uint32_t>(rng.UniformInt(0, 1 << 30));
    texture.feature_m = rng.Uniform(0.03, 0.12);
    texture.contrast = rng.Uniform(0.1, 0.4);
  }
  for (size_t i = 0; i < scene.boxes.size(); ++i) {
    const double weak_share = scene.boxes[i].kind == SurfaceKind::kWall        ? 0.5
                              : scene.boxes[i].kind == SurfaceKind::kFurniture ? 1.0 / 3.0
                                                                               : 0.0;
    if (rng.Uniform() < weak_share) textures[i].contrast = rng.Uniform(0.002, 0.008);
  }
  return textures;
}

double TextureFactor(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                     const RayHit& hit, const Vec3& p_world, double footprint_m) {
  const OrientedBox& box = scene.boxes[hit.box_index];
  const Vec3 p_box = box.R_world_box.transpose() * (p_world - box.center);
  const Vec3 n_box = box.R_world_box.transpose() * hit.normal_world;
  int axis = 0;
  n_box.cwiseAbs().maxCoeff(&axis);
  const std::uint32_t face = static_cast<std::uint32_t>(2 * axis + (n_box[axis] > 0.0 ? 1 : 0));
  const SurfaceTexture& texture = textures[hit.box_index];
  const double value =
      FractalTexture(texture, face, p_box[(axis + 1) % 3], p_box[(axis + 2) % 3], footprint_m);
  return 1.0 + texture.contrast * value;
}

double PixelFootprint(const RayHit& hit, const Vec3& direction, double fx) {
  const double slant = std::abs(hit.normal_world.dot(direction.normalized()));
  return hit.t / fx / std::max(slant, 0.05);
}

}  // namespace rigfit
