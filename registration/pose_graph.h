// Pairwise mode, step 2: a pose graph over the cameras with one relative-pose edge per
// accepted pair, the reference camera held constant, solved with Ceres.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "core/types.h"

namespace rigfit {

struct PoseGraphEdge {
  int a = 0;
  int b = 0;
  Pose T_a_b = Pose::Identity();        ///< measured T_world_a^-1 T_world_b
  Mat6 information = Mat6::Identity();  ///< in RelativePoseCost's error frame (camera a)
  /// Under the Cauchy loss (below); false: plain least squares (an edge trusted to hold, e.g.
  /// a verified loop closure that the loss would take for an outlier while the graph is far
  /// from it).
  bool robust = true;
};

struct PoseGraphResult {
  std::vector<Pose> poses;      ///< optimised poses; unconnected ones as given
  std::vector<bool> connected;  ///< reachable from the reference through edges
  bool usable = false;          ///< Ceres' solution is usable
  /// Twice Ceres' final cost: the sum of the edges' squared whitened errors (chi-square),
  /// each robust edge's through the Cauchy loss.
  double cost = 0.0;
  std::string message;
};

/// Which of n cameras the links (pairs of camera indices) connect to `reference`, the
/// reference included.
std::vector<bool> ConnectedTo(int reference, size_t n,
                              const std::vector<std::pair<int, int>>& links);

/// Optimises the poses of the cameras connected to `reference` (held constant). Robust edges
/// carry a Cauchy loss so one inconsistent pair cannot drag the others. Single-threaded (a
/// few edges; the result does not depend on the caller's thread count). Never throws.
PoseGraphResult OptimizePoseGraph(const std::vector<Pose>& initial,
                                  const std::vector<PoseGraphEdge>& edges, int reference);

}  // namespace rigfit
