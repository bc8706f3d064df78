// Procedural surface textures for the simulator: fractal value noise on every box face of the
// room, drawn per box from the seed. The stereo depth model (sim/stereo_depth.h) matches the
// textured grey images; the sequence simulator (sim/simulate_sequence.h) colours its frames
// with them, so that a view of a lone floor still shows texture to align (rgbd/photometric.h).
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.h"
#include "sim/scene.h"

namespace rigfit {

/// The procedural texture of one box's faces: fractal value noise in the face's own
/// coordinates (metres), multiplying the box's shaded grey by 1 + contrast * noise.
struct SurfaceTexture {
  double contrast = 0.3;    ///< relative amplitude; about 0.01 is a weakly textured surface
  double feature_m = 0.05;  ///< wavelength of the coarsest octave
  std::uint32_t seed = 0;
};

/// Textures of a room's boxes, drawn from the seed's own stream: contrast 0.1-0.4 on most
/// surfaces, weak (0.002-0.008) on a third of the furniture and half of the walls; feature
/// sizes 3-12 cm.
std::vector<SurfaceTexture> SimulateTextures(const Scene& scene, std::uint64_t seed);

/// The texture's factor 1 + contrast * noise at p_world on the face `hit` entered (the box's own
/// face coordinates), octaves shorter than about two pixel footprints (footprint_m, the
/// pixel's size on the surface) faded out, as a camera's pixels average them away.
double TextureFactor(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                     const RayHit& hit, const Vec3& p_world, double footprint_m);

/// The size on the surface of a pixel whose ray (direction, any length; its depth hit.t along
/// it as Scene::Raycast gives for a camera-frame z of 1) meets it: depth / fx, stretched by the
/// slant (at most 20x).
double PixelFootprint(const RayHit& hit, const Vec3& direction, double fx);

}  // namespace rigfit
