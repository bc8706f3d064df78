#include "rgbd/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "core/errors.h"
#include "core/stopwatch.h"
#include "registration/pose_graph.h"

namespace rigfit {
namespace {

/// The keyframe's pyramid as the run built it.
FramePyramid LoadPyramid(const RgbdSequence& sequence, int index,
                         const LoopClosureOptions& options) {
  RgbdFrame frame = sequence.Frame(index);
  for (int h = 0; h < options.halvings; ++h) {
    frame = HalveFrame(frame, options.frame.max_depth_jump_ratio);
  }
  return BuildFramePyramid(frame, options.frame, options.threads);
}

/// The edge a -> b measured at T_a_b, weighed by the information of the ICP's pairs there
/// (header comment); rmse_m of its pairs.
struct MeasuredEdge {
  PoseGraphEdge edge;
  double rmse_m = 0.0;
};

MeasuredEdge MeasureEdge(const FramePyramid& b, const FramePyramid& a, int node_a, int node_b,
                         const Pose& T_a_b, const LoopClosureOptions& options) {
  const NormalEquations eq =
      AccumulateProjective(b.levels[0], a.levels[0], T_a_b, options.icp.association,
                           options.icp.weighting, options.threads);
  MeasuredEdge measured;
  measured.edge.a = node_a;
  measured.edge.b = node_b;
  measured.edge.T_a_b = T_a_b;
  Mat6 information = Mat6::Zero();
  if (eq.count > 0) {
    measured.rmse_m = std::sqrt(eq.squared_error / eq.count);
    const double variance = std::max(measured.rmse_m * measured.rmse_m, 1e-12);
    Mat6 J_inverse = Mat6::Identity();
    J_inverse.block<3, 3>(3, 0) = Hat(T_a_b.translation());
    information = J_inverse.transpose() * (options.information_scale / variance * eq.H) * J_inverse;
  }
  measured.edge.information = information + options.floor_information * Mat6::Identity();
  return measured;
}

/// The path length travelled up to every pose.
std::vector<double> PathLengths(const Trajectory& trajectory) {
  std::vector<double> path(trajectory.poses.size(), 0.0);
  for (std::size_t k = 1; k < path.size(); ++k) {
    path[k] = path[k - 1] +
              (trajectory.poses[k].translation() - trajectory.poses[k - 1].translation()).norm();
  }
  return path;
}

/// For the keyframe at node j, the earlier node nearest to it in pose (distance and angle
/// each over its threshold, summed) among those within both thresholds and at least
/// min_path_m back; -1 when none.
int FindCandidate(int j, const std::vector<int>& nodes, const Trajectory& trajectory,
                  const std::vector<double>& path, const LoopClosureOptions& options) {
  const Pose& T_j = trajectory.poses[nodes[j]];
  int best = -1;
  double best_score = std::numeric_limits<double>::infinity();
  for (int i = 0; i < j; ++i) {
    if (path[nodes[j]] - path[nodes[i]] < options.min_path_m) continue;
    const Pose T_i_j = trajectory.poses[nodes[i]].inverse() * T_j;
    const double distance = T_i_j.translation().norm();
    const double angle_deg = LogSO3(T_i_j.linear()).norm() * kRadToDeg;
    if (distance > options.candidate_distance_m || angle_deg > options.candidate_angle_deg) {
      continue;
    }
    const double score =
        distance / options.candidate_distance_m + angle_deg / options.candidate_angle_deg;
    if (score < best_score) {
      best_score = score;
      best = i;
    }
  }
  return best;
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// Every frame moved with the last keyframe at or before it: T <- T'_kf T_kf^-1 T.
void CorrectTrajectory(const std::vector<int>& nodes, const std::vector<Pose>& solved,
                       LoopClosureResult* result) {
  std::vector<Pose> corrections;
  for (std::size_t j = 0; j < nodes.size(); ++j) {
    corrections.push_back(
        Reorthonormalized(solved[j] * result->trajectory.poses[nodes[j]].inverse()));
  }
  std::size_t node = 0;
  for (std::size_t k = 0; k < result->trajectory.poses.size(); ++k) {
    while (node + 1 < nodes.size() && nodes[node + 1] <= static_cast<int>(k)) ++node;
    result->correction[k] = corrections[node];
    result->trajectory.poses[k] =
        Reorthonormalized(corrections[node] * result->trajectory.poses[k]);
  }
}

}  // namespace

std::vector<bool> SelectKeyframes(const Trajectory& trajectory, const std::vector<bool>& usable,
                                  const LoopClosureOptions& options) {
  std::vector<bool> keyframes(trajectory.poses.size(), false);
  int last = -1;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (!usable[k]) continue;
    if (last >= 0) {
      const Pose T_last_k = trajectory.poses[last].inverse() * trajectory.poses[k];
      if (T_last_k.translation().norm() <= options.keyframe_translation_m &&
          LogSO3(T_last_k.linear()).norm() <= options.keyframe_rotation_deg * kDegToRad) {
        continue;
      }
    }
    keyframes[k] = true;
    last = static_cast<int>(k);
  }
  return keyframes;
}

LoopCheck VerifyLoop(const FramePyramid& later, const FramePyramid& earlier, const Pose& T_init,
                     double median_rmse_m, const LoopClosureOptions& options) {
  LoopCheck check;
  check.track = TrackProjective(later, earlier, T_init, options.icp, options.threads);
  const TrackResult& t = check.track;
  if (!t.success) {
    check.reason = "ICP failed: " + t.message;
  } else if (t.weak_directions > 0) {
    check.reason = "weak directions (the views do not fix the motion)";
  } else if (t.matched_ratio < options.min_matched_ratio) {
    check.reason = "matched share " + std::to_string(t.matched_ratio) + " below " +
                   std::to_string(options.min_matched_ratio);
  } else if (t.rmse_m > options.max_rmse_ratio * median_rmse_m) {
    check.reason = "RMS distance " + std::to_string(t.rmse_m * 1e3) + " mm above " +
                   std::to_string(options.max_rmse_ratio) + " x the sequential edges' " +
                   std::to_string(median_rmse_m * 1e3) + " mm";
  } else {
    check.accepted = true;
  }
  return check;
}

LoopClosureResult CloseLoops(const RgbdSequence& sequence, const std::vector<int>& frames,
                             const Trajectory& trajectory, const std::vector<bool>& keyframes,
                             const LoopClosureOptions& options, const Log& log) {
  const auto start = std::chrono::steady_clock::now();
  const std::size_t n = trajectory.poses.size();
  if (frames.size() != n || keyframes.size() != n) {
    throw InputError("loop closure: frames, poses and keyframe flags differ in number");
  }
  LoopClosureResult result;
  result.trajectory = trajectory;
  result.correction.assign(n, Pose::Identity());
  for (std::size_t k = 0; k < n; ++k) {
    if (keyframes[k]) result.keyframes.push_back(static_cast<int>(k));
  }
  const std::vector<int>& nodes = result.keyframes;
  if (nodes.size() < 3 || nodes.front() != 0) {
    result.message = "too few keyframes";
    return result;
  }
  // Sequential edges, and each keyframe's revisit candidate.
  std::vector<PoseGraphEdge> edges;
  std::vector<double> rmse;
  const std::vector<double> path = PathLengths(trajectory);
  std::vector<int> candidate(nodes.size(), -1);
  FramePyramid previous = LoadPyramid(sequence, frames[nodes[0]], options);
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    FramePyramid current = LoadPyramid(sequence, frames[nodes[j]], options);
    const Pose T_a_b = trajectory.poses[nodes[j - 1]].inverse() * trajectory.poses[nodes[j]];
    const MeasuredEdge m = MeasureEdge(current, previous, j - 1, j, T_a_b, options);
    edges.push_back(m.edge);
    rmse.push_back(m.rmse_m);
    candidate[j] = FindCandidate(static_cast<int>(j), nodes, trajectory, path, options);
    result.candidates += candidate[j] >= 0 ? 1 : 0;
    previous = std::move(current);
  }
  const double median_rmse_m = Median(rmse);
  // Each candidate verified by ICP from the run's relative pose.
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    if (candidate[j] < 0) continue;
    const int i = candidate[j];
    const FramePyramid later = LoadPyramid(sequence, frames[nodes[j]], options);
    const FramePyramid earlier = LoadPyramid(sequence, frames[nodes[i]], options);
    const Pose T_init = trajectory.poses[nodes[i]].inverse() * trajectory.poses[nodes[j]];
    LoopCheck check = VerifyLoop(later, earlier, T_init, median_rmse_m, options);
    check.frame_a = nodes[i];
    check.frame_b = nodes[j];
    if (check.accepted) {
      ++result.accepted;
      PoseGraphEdge loop =
          MeasureEdge(later, earlier, i, static_cast<int>(j), check.track.T_target_source, options)
              .edge;
      loop.robust = false;  // verified; the loss would reject it while the drift is open
      edges.push_back(loop);
    } else {
      log.Debug("loop closure: frames " + std::to_string(frames[nodes[i]]) + " and " +
                std::to_string(frames[nodes[j]]) + " rejected: " + check.reason);
    }
    result.checks.push_back(std::move(check));
  }
  if (result.accepted == 0) {
    result.message = "no loop accepted";
  } else {
    std::vector<Pose> initial;
    for (int k : nodes) initial.push_back(trajectory.poses[k]);
    const PoseGraphResult graph = OptimizePoseGraph(initial, edges, 0);
    result.message = graph.message;
    if (graph.usable) {
      CorrectTrajectory(nodes, graph.poses, &result);
      result.applied = true;
    } else {
      log.Warning("loop closure: the pose graph was not solved (" + graph.message +
                  "); the trajectory is the run's");
    }
  }
  result.seconds = SecondsSince(start);
  return result;
}

namespace {

/// The settings a loop closure shares with the run it closes: frames, ICP, threads.
LoopClosureOptions LoopClosureOptionsOfLoop(const TrackingLoopOptions& options) {
  LoopClosureOptions o;
  o.frame = options.frame;
  o.icp = options.icp;
  o.threads = options.threads;
  return o;
}

}  // namespace

LoopClosureOptions LoopClosureOptionsOf(const OdometryOptions& options) {
  LoopClosureOptions o = LoopClosureOptionsOfLoop(options);
  o.keyframe_translation_m = options.keyframe_translation_m;
  o.keyframe_rotation_deg = options.keyframe_rotation_deg;
  return o;
}

LoopClosureOptions LoopClosureOptionsOf(const SlamOptions& options) {
  LoopClosureOptions o = LoopClosureOptionsOfLoop(options);
  o.halvings = options.halvings.value_or(0);
  return o;
}

LoopClosureResult CloseOdometryLoops(const RgbdSequence& sequence, const OdometryOptions& options,
                                     OdometryResult* result, const Log& log) {
  std::vector<int> frames;
  std::vector<bool> keyframes;
  for (const OdometryFrame& f : result->frames) {
    frames.push_back(f.index);
    keyframes.push_back(f.keyframe);
  }
  LoopClosureResult closed = CloseLoops(sequence, frames, result->trajectory, keyframes,
                                        LoopClosureOptionsOf(options), log);
  result->trajectory = closed.trajectory;
  return closed;
}

LoopClosureResult CloseSlamLoops(const RgbdSequence& sequence, const SlamOptions& options,
                                 SlamResult* result, const Log& log) {
  std::vector<int> frames;
  std::vector<bool> usable;
  for (const SlamFrame& f : result->frames) {
    frames.push_back(f.index);
    usable.push_back(f.track.success && !f.diverged);
  }
  LoopClosureOptions o = LoopClosureOptionsOf(options);
  o.halvings = result->halvings;  // as the run halved its frames
  LoopClosureResult closed = CloseLoops(sequence, frames, result->trajectory,
                                        SelectKeyframes(result->trajectory, usable, o), o, log);
  if (closed.applied) {
    result->trajectory = closed.trajectory;
    std::unordered_map<int, Pose> correction_of_frame;
    for (std::size_t k = 0; k < frames.size(); ++k) {
      correction_of_frame[frames[k]] = closed.correction[k];
    }
    result->map.MovePoints([&](int frame) {
      const auto found = correction_of_frame.find(frame);
      return found == correction_of_frame.end() ? Pose::Identity() : found->second;
    });
  }
  return closed;
}

}  // namespace rigfit
