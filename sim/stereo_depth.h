// Stereo depth for the simulator (`rigfit simulate --depth-model stereo`): a textured
// left/right intensity pair of the room rendered with the scene's ray caster, matched by
// semi-global block matching (OpenCV's StereoSGBM), disparity turned into depth with the
// baseline. Block matching brings its own failure modes: holes on weakly textured surfaces
// and at occlusions, fattened depth edges, sub-pixel locking, per-surface bias.
#pragma once

#include <cstdint>
#include <vector>

#include "core/pose.h"
#include "core/types.h"
#include "sim/random.h"
#include "sim/scene.h"
#include "sim/texture.h"

namespace rigfit {

/// How the pair is rendered and matched.
struct StereoOptions {
  double baseline_m = 0.12;  ///< the right camera sits at +baseline_m along the camera's x
  /// Rendered and matched at this many times the resolution, the disparity averaged down over
  /// upsample x upsample blocks (as ZED HD modes do); 1 matches at the camera's resolution.
  int upsample = 1;
  double image_noise = 1.0;   ///< sensor noise of either image, grey levels (of 255)
  double min_depth_m = 0.8;   ///< nearest matchable depth: sets the disparity search range
  double max_depth_m = 10.0;  ///< farther depths are holes
  /// Miscalibration: the matched disparity d becomes d + disparity_offset_px (pixels of the
  /// camera's resolution), the depth depth_scale * fx * baseline_m / (d + offset).
  double disparity_offset_px = 0.0;
  double depth_scale = 1.0;
};

/// The camera's grey image, width x height (row-major, 0-255): the scene's shading (ShadeHit)
/// times the texture, plus N(0, image_noise^2) from rng; 0 where the ray leaves the room.
std::vector<std::uint8_t> RenderTexturedImage(const Scene& scene,
                                              const std::vector<SurfaceTexture>& textures,
                                              const SceneCamera& camera, double image_noise,
                                              SimRng& rng);

/// The stereo depth (metres, row-major, NaN for holes) of `camera` (the left one): the pair
/// rendered at `upsample` times the resolution (the images padded on the left by the search range,
/// so that every column can be matched), matched by StereoSGBM (5x5 blocks, 1/16 px disparities,
/// uniqueness 10%, left-right check 1 px, speckle filter), averaged down over blocks of which at
/// least half matched, then as StereoOptions says.
std::vector<float> StereoDepth(const Scene& scene, const std::vector<SurfaceTexture>& textures,
                               const SceneCamera& camera, const StereoOptions& options,
                               SimRng& rng);

}  // namespace rigfit
