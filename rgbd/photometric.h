// Photometric alignment along the directions depth leaves free (docs/rgbd.md, section 4b). A
// view of nothing but a floor or a wall leaves three directions of the motion to the prediction
// (the turn about the plane's normal and the two slides along it; rgbd/motion_guard.h), and a
// view with too little structure leaves those its eigenvalues call weak: depth cannot tell
// them. Colour can, where the surfaces have texture: the frame's pixels, warped into the
// previous frame's image, fix them (direct alignment as in Steinbruecker et al. 2011 and Kerl
// et al. 2013, here confined to the directions the depth leaves free). The grey levels are
// compared as they are (no exposure compensation), and the pixels' residuals are taken as
// independent, so the standard deviations it reports are optimistic.
//
// For a source pixel u with vertex p (source camera) and the estimate T = T_reference_source,
// the residual is the grey level it lands on minus its own, both in [0, 1]:
//
//   r(u) = I_ref(pi(T p)) - I_src(u).
//
// An update multiplies T on the LEFT, as projective ICP's (rgbd/projective_icp.h): z = T p,
// z' = Exp(w) z + dt, so dz = -[z]_x w + dt. Confined to the free directions, x = [w; dt] =
// S F a with F the orthonormal free directions in the scaled space [length_m w; dt] (6 x k) and
// S = diag(I / length_m, I), the Jacobian of r in a is
//
//   J = grad I_ref(pi(z)) (d pi / dz) [-[z]_x  I] S F   (1 x k),
//   d pi / dz = [fx / z_z, 0, -fx z_x / z_z^2; 0, fy / z_z, -fy z_y / z_z^2],
//
// and each Gauss-Newton step solves (sum w J^T J) a = -sum w J^T r with Huber weights w, coarse
// to fine over the frame's pyramid.
//
// Colour tracking (rgbd/tracking_loop.h) frees all six directions and adds the depth: the
// projective ICP's information P about its estimate T_init (TrackResult::information, on the
// left update x = S F a) as a prior. Each step then solves
//
//   (H / s^2 + P_a) a = -(g / s^2 + P_a a_0),   P_a = (S F)^T P (S F),
//
// with H, g the sums above, s^2 = sum w r^2 / (pixels - k) the grey levels' variance measured
// at that step and a_0 the move from T_init so far: one Gauss-Newton step of the photometric
// cost and the depth's (quadratic about its estimate) together, each weighed by its own
// measured noise (the ICP's residual variance is in P; as ElasticFusion's joint ICP and RGB
// cost, with the weight measured instead of fixed).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/pose.h"
#include "rgbd/frame.h"

namespace rigfit {

struct PhotometricOptions {
  /// Off: a lone plane's free directions stay at the prediction (the behaviour before it).
  bool enabled = true;
  /// Gauss-Newton steps per pyramid level.
  int iterations = 10;
  /// Converged when a step moves less than this in the scaled space (metres).
  double converged_m = 1e-5;
  /// Huber threshold of the grey-level residual (grey levels in [0, 1]).
  double huber = 0.05;
  /// Pixels whose own grey-level gradient is below this (per pixel) carry no information and
  /// are skipped.
  double min_gradient = 0.005;
  /// The alignment is kept when at least this many pixels take part at the finest level...
  int min_pixels = 300;
  /// ...and each free direction's standard deviation (the scaled space: metres, a rotation
  /// times length_m) is below this, the RMS residual no larger than at the start (over the
  /// pixels that land in the image at either pose), and the change from the start pose below
  /// max_change_m in that space (above the guard's 5 cm jump: a turn down to a floor is
  /// measured 6 cm off its prediction; the tracked pose already passed the guard).
  double max_sigma_m = 0.002;
  double max_change_m = 0.2;
};

/// One level's grey image in [0, 1] and its central-difference gradients (zero on the border).
struct GreyLevel {
  int width = 0;
  int height = 0;
  std::vector<float> grey;
  std::vector<float> gx;
  std::vector<float> gy;
};

/// A frame's grey images at the sizes of its pyramid's levels.
struct GreyPyramid {
  std::vector<GreyLevel> levels;
};

/// The grey pyramid of an RGB image (`color`, [height, width, 3] with the size of
/// pyramid.levels[0]): luma 0.299 R + 0.587 G + 0.114 B, each coarser level the mean of 2x2
/// blocks, at the sizes of `pyramid`'s levels. Throws std::invalid_argument on a size mismatch.
GreyPyramid BuildGreyPyramid(const std::vector<std::uint8_t>& color, const FramePyramid& pyramid);

/// What is aligned: the source frame's vertices and grey images, the reference frame's grey
/// images (the same camera: the source's intrinsics at every level), and the free directions.
struct PhotometricProblem {
  const FramePyramid* source = nullptr;
  const GreyPyramid* source_grey = nullptr;
  const GreyPyramid* reference_grey = nullptr;
  /// 1 to 6 orthonormal directions in the scaled space [length_m w; dt], in the reference's
  /// axes (a track's weak directions moved into them: rgbd/tracking_loop.cc).
  std::vector<Vec6> free;
  double length_m = 1.0;  ///< the rotation's scale: the source's mean depth
  /// Colour tracking: the depth's information about the move from T_init (a left update [w;
  /// dt] in the reference's axes; TrackResult::information), null for none (header).
  const Mat6* prior = nullptr;
};

/// The six unit directions of the scaled space: a problem free in every direction.
std::vector<Vec6> AllDirections();

struct PhotometricResult {
  bool success = false;
  std::string message;  ///< why it was not kept
  Pose T_reference_source = Pose::Identity();
  int pixels = 0;         ///< taking part at the finest level's last step
  double rmse = 0.0;      ///< RMS grey-level residual there
  double sigma_m = 0.0;   ///< the largest standard deviation, free directions (and prior)
  double change_m = 0.0;  ///< the move from the start pose, scaled space
};

/// The RMS grey-level residual at T (T_reference_source) over the finest level's pixels that
/// take part: what AlignPhotometric reports as rmse at its estimate; 0 when none take part.
/// Throws as AlignPhotometric does.
double PhotometricRmse(const PhotometricProblem& problem, const Pose& T,
                       const PhotometricOptions& options, int threads = 2);

/// Aligns the source to the reference along the free directions from T_init
/// (T_reference_source), as the header says; the other directions keep T_init's. Throws
/// std::invalid_argument unless there are 1 to 6 free directions and both grey pyramids have
/// the source pyramid's levels and sizes. Each step's sums are taken in `threads` contiguous
/// chunks of the pixels, one thread each, then added in order (as AccumulateProjective's: the
/// result depends on the thread count in its last bits, not on the run).
PhotometricResult AlignPhotometric(const PhotometricProblem& problem, const Pose& T_init,
                                   const PhotometricOptions& options, int threads = 2);

}  // namespace rigfit
