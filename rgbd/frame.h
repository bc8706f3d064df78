// Frame preprocessing of the dense RGB-D pipeline (KinectFusion, Newcombe et al. 2011,
// section 3.2): depth truncation, an optional bilateral filter, a depth pyramid, and per level
// the vertex map (the back-projected points, camera frame) and the normal map (from the
// neighbouring pixels). Maps are float: they are read many times per frame and a float keeps
// twice as many of them in cache; every sum over them is accumulated in double.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "core/rgbd.h"

namespace rigfit {

struct FrameOptions {
  /// Depth outside [min_depth_m, max_depth_m] is dropped (truncation: Kinect-type sensors'
  /// noise grows with z^2, and far depth is where the sensor is least reliable).
  double min_depth_m = 0.2;
  double max_depth_m = 4.0;
  /// Pyramid levels (level 0 = full resolution, each next level half the size).
  int levels = 3;
  /// Bilateral filter of the level-0 depth (KinectFusion's) for the level-0 normals; the
  /// vertices keep the measured depth (a filter moves points at creases and on slanted faces:
  /// filtered vertices cost 0.8 mm of drift over 100 noise-free frames, docs/rgbd.md). On by
  /// default: the normals of raw Kinect depth are too noisy to associate by (7-Scenes: 55% of
  /// the pixels matched without it, 84% with it). Spatial sigma in pixels, range sigma in
  /// metres.
  bool bilateral = true;
  double bilateral_sigma_px = 2.0;
  double bilateral_sigma_m = 0.03;
  /// The range sigma as above up to 1 m depth and growing as z^2 beyond, as the depth noise
  /// does (BilateralFilter). For stereo depth (ZED, RealSense), whose noise at 3 m is several
  /// centimetres: a fixed 3 cm averages nothing there, and the angle gate on such normals holds
  /// the motion short (docs/rgbd.md, "The angle gate on noisy normals"). Off by default: on
  /// Kinect-like depth it smooths far creases, and runs through a lone-plane stretch came out
  /// worse (docs/benchmarks.md).
  bool bilateral_range_grows = false;
  /// Neighbours whose depth differs from a pixel's by more than this share of its depth
  /// are across a depth discontinuity: they are averaged with nothing, and no normal is
  /// estimated across them.
  double max_depth_jump_ratio = 0.05;
};

/// One level of a frame's pyramid. Invalid pixels hold NaN vertices and normals.
struct FrameLevel {
  int width = 0;
  int height = 0;
  PinholeIntrinsics intrinsics;
  std::vector<float> depth_m;
  std::vector<Vec3f> vertices;  ///< camera frame, metres
  std::vector<Vec3f> normals;   ///< unit, facing the camera (n . v < 0)
  /// The pixels with a vertex and a normal, in pixel order (what tracking iterates over).
  std::vector<int> valid_pixels;

  bool Valid(int i) const { return !std::isnan(normals[i].x()); }
};

/// A preprocessed frame: levels[0] is the full resolution.
struct FramePyramid {
  std::vector<FrameLevel> levels;
};

/// The mean depth of the level's valid pixels; 0 when it has none.
double MeanDepth(const FrameLevel& level);

/// Truncates the frame's depth and builds `options.levels` levels (the level-0 normals from
/// the bilateral-filtered depth when options.bilateral).
/// Each coarser level averages the valid depths of a 2x2 block that lie within the depth-jump
/// ratio of the block's nearest one (no averaging across a silhouette), and scales the
/// intrinsics: f' = f / 2, c' = (c + 0.5) / 2 - 0.5.
FramePyramid BuildFramePyramid(const RgbdFrame& frame, const FrameOptions& options,
                               int threads = 2);

/// Resizes the pyramid to `levels` levels and builds levels 1.. from levels[0]'s depth_m, as
/// BuildFramePyramid does (the 2x2 downsampling and the scaled intrinsics above, then the
/// vertex and normal maps of each coarser level); levels[0] is left as it is. What
/// BuildFramePyramid uses after level 0, and what builds the pyramid of a rendered model
/// (rgbd/slam.h) whose level 0 did not come from a depth image.
void BuildCoarserLevels(FramePyramid* pyramid, int levels, double max_depth_jump_ratio,
                        int threads = 2);

/// The frame at half its resolution, what a sensor of half the size would give: the depth
/// downsampled as the pyramid's coarser levels are (2x2 blocks, no averaging across a depth
/// jump of more than max_depth_jump_ratio), the colour averaged over each 2x2 block, the
/// intrinsics scaled as a coarser level's. Odd widths and heights lose their last column or
/// row.
RgbdFrame HalveFrame(const RgbdFrame& frame, double max_depth_jump_ratio);

/// The vertex and normal maps of a depth image (NaN for invalid depth). The normal of pixel
/// (u, v) is (V(u+1, v) - V(u-1, v)) x (V(u, v+1) - V(u, v-1)), normalised and turned to face
/// the camera; invalid at the image border, next to an invalid pixel, or across a depth jump.
/// Fills valid_pixels. With normal_depth_m (a filtered copy of the level's depth), the normals
/// come from it and the vertices from the level's own depth.
void ComputeVertexNormalMaps(FrameLevel* level, double max_depth_jump_ratio, int threads = 2,
                             const std::vector<float>* normal_depth_m = nullptr);

/// Depth filtered by a bilateral filter (window radius 2 sigma_px), as two 1D passes (along
/// x, then y; the usual separable approximation, 8x fewer taps than the 2D window at
/// sigma_px = 2): weights exp(-d_px^2 / 2 sigma_px^2 - dz^2 / 2 sigma_z^2) over the valid
/// neighbours, the range weight tabulated and zero beyond 4 sigma_z; sigma_z = sigma_m, or with
/// range_grows sigma_m max(1, z^2), z the nearer of the two depths in metres, as the depth
/// noise of structured light and stereo grows (FrameOptions::bilateral_range_grows).
std::vector<float> BilateralFilter(const std::vector<float>& depth_m, int width, int height,
                                   double sigma_px, double sigma_m, bool range_grows = false,
                                   int threads = 2);

}  // namespace rigfit
