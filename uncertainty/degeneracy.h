// Which directions of a camera's pose its correspondences barely constrain: the geometric
// stability analysis of point-to-plane ICP (Gelfand, Ikemoto, Rusinkiewicz and Levoy,
// "Geometrically stable sampling for the ICP algorithm", 3DIM 2003), named in world terms.
//
// A correspondence at world point p with (target) world normal n constrains a small
// motion of the camera's points by r = n . (w x (p - c) + v), w a rotation about the
// (weighted) centroid c of the camera's matched points and v a translation. With the
// rotation scaled by the RMS radius L of those points (so both halves are lengths) each
// correspondence gives the row j = [(p - c) x n / L ; n], and with weights a_j (the
// inverse variance of the residual under the depth noise model)
//   M = sum_j a_j j j^T / sum_j a_j
// is the scale-free information matrix of the camera's pose. A direction whose eigenvalue
// is below `threshold` times the largest is weakly constrained: a flat floor leaves x, z and
// yaw at exactly 0, and far, noisy walls add little. The weights matter: on the simulated
// rigs, unweighted fractions of the bare room (floor and walls) and of the furnished room
// overlap, weighted ones are 4x apart (docs/benchmarks.md).
#pragma once

#include <array>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/types.h"

namespace rigfit {

/// A direction of a camera's pose that the correspondences barely constrain.
struct WeakDirection {
  /// The eigen-direction u (unit, scaled coordinates [L w; v] above) as a row on the
  /// PoseManifold tangent of the camera (world rotation vector about the camera centre,
  /// world translation of the centre): u . [L w; v] = constraint . delta.
  Vec6 constraint = Vec6::Zero();
  double strength = 0.0;  ///< eigenvalue of M relative to its largest
  std::string name;       ///< e.g. "translation along world X", "yaw"
  std::string reason;     ///< e.g. "the near-floor band lacks vertical structure"
};

/// Orientations within this angle of a group's first are one surface orientation.
constexpr double kOrientationAngleDeg = 20.0;
/// The share of a camera's weight that makes an orientation count.
constexpr double kOrientationMinShare = 0.02;

/// How many distinct orientations the surfaces under one camera's pose have: the normals
/// (n and -n alike, weighted by their information) gathered greedily, heaviest first, into
/// groups within kOrientationAngleDeg of the group's first, counting the groups that hold at
/// least kOrientationMinShare of the weight. A camera on fewer than kFewSurfaceOrientations has
/// a pose that one surface's bias moves whole, with too few surfaces for the residuals to show
/// it (docs/uncertainty.md, "Inflation").
class SurfaceOrientations {
 public:
  void Add(const Vec3& n, double weight);
  int Count() const;  ///< 0 when nothing was added

 private:
  double sum_w_ = 0.0;
  /// Weight and weighted sum of the normals (sign made canonical) per cell of a 0.1 grid of
  /// the unit vector's coordinates.
  std::map<std::array<int, 3>, std::pair<double, Vec3>> normals_;
};

/// A pose on fewer surface orientations than this rests on few surfaces (SurfaceOrientations):
/// on one, in a rig the floor with nothing else holding 2 % of the camera's correspondences.
constexpr int kFewSurfaceOrientations = 2;

/// Accumulates the constraint rows of one camera's correspondences (world frame).
class StabilityAccumulator {
 public:
  /// One correspondence: the camera's point and the normal it is matched against, with a
  /// weight (1 / variance of its residual; 1 for the purely geometric analysis).
  void Add(const Vec3& p_world, const Vec3& n_world, double weight);
  int count() const { return count_; }

  /// The weak directions (strength below threshold, weakest first) of the camera whose
  /// centre is camera_center_world. Empty when fewer than 6 rows were added (nothing to
  /// analyse) or threshold <= 0.
  std::vector<WeakDirection> WeakDirections(const Vec3& camera_center_world,
                                            double threshold) const;

  /// How many distinct surface orientations the rows rest on (SurfaceOrientations, each row
  /// counted once: the noise weights give the near floor nearly all the weight).
  int Orientations() const { return orientations_.Count(); }

 private:
  Mat6 moments_ = Mat6::Zero();  ///< sum of [p x n; n][p x n; n]^T (about the world origin)
  double sum_w_ = 0.0;
  Vec3 sum_p_ = Vec3::Zero();
  double sum_p2_ = 0.0;
  int count_ = 0;
  SurfaceOrientations orientations_;
};

/// The information matrix (PoseManifold tangent of the camera) of a prior that holds the
/// weak directions with standard deviation sigma_m (metres; rotations as the arc length
/// at the radius L of the analysis): sum of constraint constraint^T / sigma_m^2.
Mat6 HoldInformation(const std::vector<WeakDirection>& weak, double sigma_m);

}  // namespace rigfit
