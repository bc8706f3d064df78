#include "rgbd/loop_closure.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "core/errors.h"
#include "core/stopwatch.h"
#include "registration/pose_graph.h"
#include "rgbd/relocalise.h"

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

/// Where revisit candidates are looked for: within distance_m and angle_deg of a keyframe's
/// pose, among the nodes at most `last_pose` (a trajectory position).
struct CandidateGate {
  double distance_m = 0.0;
  double angle_deg = 0.0;
  int last_pose = std::numeric_limits<int>::max();
};

/// The options' own gate, or (across an open stretch that began after `from`) the gate widened
/// by the relocalisation grid's reach to the nodes before the stretch.
CandidateGate NearGate(const LoopClosureOptions& options) {
  return {options.candidate_distance_m, options.candidate_angle_deg};
}
CandidateGate AcrossGate(const LoopClosureOptions& options, int from) {
  return {options.candidate_distance_m + options.relocalise.max_slide_m,
          options.candidate_angle_deg + options.relocalise.max_turn_deg, from};
}

/// A keyframe's revisit candidate: an earlier node (-1: none) and its score.
struct Candidate {
  int node = -1;
  double score = std::numeric_limits<double>::infinity();
  int across = -1;  ///< the open stretch it is across (-1: none)
};

/// For the keyframe at node j, the earlier node nearest to it in pose (distance and angle
/// each over the gate's, summed) among those within the gate and at least min_path_m back.
Candidate FindCandidate(int j, const std::vector<int>& nodes, const Trajectory& trajectory,
                        const std::vector<double>& path, const CandidateGate& gate,
                        double min_path_m) {
  const Pose& T_j = trajectory.poses[nodes[j]];
  Candidate best;
  for (int i = 0; i < j && nodes[i] <= gate.last_pose; ++i) {
    if (path[nodes[j]] - path[nodes[i]] < min_path_m) continue;
    const Pose T_i_j = trajectory.poses[nodes[i]].inverse() * T_j;
    const double distance = T_i_j.translation().norm();
    const double angle_deg = LogSO3(T_i_j.linear()).norm() * kRadToDeg;
    if (distance > gate.distance_m || angle_deg > gate.angle_deg) continue;
    const double score = distance / gate.distance_m + angle_deg / gate.angle_deg;
    if (score < best.score) best = {i, score};
  }
  return best;
}

/// The last open stretch that ended by trajectory position `pose`; -1 when none.
int OpenStretchBefore(int pose, const std::vector<OpenStretch>& open) {
  int last = -1;
  for (std::size_t s = 0; s < open.size(); ++s) {
    if (open[s].to <= pose) last = static_cast<int>(s);
  }
  return last;
}

/// Each keyframe's candidate (index 0: none): by the options' gate, or else across the last
/// open stretch before it by the widened gate, of which the best max_searches_across per
/// stretch are kept.
std::vector<Candidate> FindCandidates(const std::vector<int>& nodes, const Trajectory& trajectory,
                                      const std::vector<OpenStretch>& open,
                                      const LoopClosureOptions& options) {
  const std::vector<double> path = PathLengths(trajectory);
  std::vector<Candidate> candidates(nodes.size());
  std::vector<std::vector<int>> across(open.size());  // per stretch, its keyframes
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    const int k = static_cast<int>(j);
    candidates[j] =
        FindCandidate(k, nodes, trajectory, path, NearGate(options), options.min_path_m);
    const int s = OpenStretchBefore(nodes[j], open);
    if (candidates[j].node >= 0 || s < 0) continue;
    candidates[j] = FindCandidate(k, nodes, trajectory, path, AcrossGate(options, open[s].from),
                                  options.min_path_m);
    if (candidates[j].node < 0) continue;
    candidates[j].across = s;
    across[s].push_back(k);
  }
  for (std::vector<int>& keyframes : across) {
    std::stable_sort(keyframes.begin(), keyframes.end(),
                     [&](int a, int b) { return candidates[a].score < candidates[b].score; });
    for (std::size_t r = std::max(0, options.max_searches_across); r < keyframes.size(); ++r) {
      candidates[keyframes[r]] = Candidate{};
    }
  }
  return candidates;
}

/// The sequential edges between keyframes (positions `nodes`) that span part of an open
/// stretch lose their information in its plane's free directions (the turn about its normal,
/// the slides along it: the run held them at a prediction, which no frame measured) down to
/// the floor, so that a loop across the stretch moves the poses there.
void FreeAcrossOpenStretches(const std::vector<int>& nodes, const Trajectory& trajectory,
                             const std::vector<OpenStretch>& open, double floor_information,
                             std::vector<PoseGraphEdge>* sequential) {
  for (PoseGraphEdge& edge : *sequential) {
    for (const OpenStretch& s : open) {
      if (nodes[edge.b] <= s.from || nodes[edge.a] >= s.to) continue;
      const Vec3 n = trajectory.poses[nodes[edge.a]].linear().transpose() * s.n_world;
      Mat6 P = Mat6::Zero();  // onto the tilts and the height: [w; dt] in camera a's axes
      P.topLeftCorner<3, 3>() = Mat3::Identity() - n * n.transpose();
      P.bottomRightCorner<3, 3>() = n * n.transpose();
      edge.information = P * edge.information * P + floor_information * Mat6::Identity();
    }
  }
}

/// A candidate across an open stretch: `later` searched for over the free directions of the
/// stretch's plane (normal n_world) around its run pose with `earlier` as the one anchor, and
/// the pose found checked as any candidate's (VerifyLoop).
LoopCheck VerifyAcross(const FramePyramid& later, const FramePyramid& earlier,
                       const Pose& T_world_later, const Pose& T_world_earlier, const Vec3& n_world,
                       double median_rmse_m, const LoopClosureOptions& options) {
  const std::vector<Anchor> anchor = {{earlier, T_world_earlier, 0}};
  const Relocalisation found = Relocalise({&later, T_world_later, n_world, median_rmse_m}, anchor,
                                          options.icp, options.relocalise, options.threads);
  if (!found.success) {
    LoopCheck check;
    check.reason = "not found over the free directions of the open stretch's plane (" +
                   std::to_string(found.candidates) + " poses scored; no track within " +
                   std::to_string(options.relocalise.max_rmse_ratio) +
                   " x the sequential edges' RMS distance " + std::to_string(median_rmse_m * 1e3) +
                   " mm)";
    return check;
  }
  return VerifyLoop(later, earlier, T_world_earlier.inverse() * found.T_world_camera, median_rmse_m,
                    options);
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// The pose between A (s = 0) and B (s = 1): rotation along the geodesic, position on the line.
Pose Blend(const Pose& A, const Pose& B, double s) {
  Pose T = Pose::Identity();
  T.linear() = A.linear() * ExpSO3(s * LogSO3(A.linear().transpose() * B.linear()));
  T.translation() = (1.0 - s) * A.translation() + s * B.translation();
  return T;
}

/// The sequential edges and the loop edges flagged in `kept` but `left_out` (-1: none).
std::vector<PoseGraphEdge> GraphEdges(const std::vector<PoseGraphEdge>& sequential,
                                      const std::vector<PoseGraphEdge>& loops,
                                      const std::vector<bool>& kept, int left_out) {
  std::vector<PoseGraphEdge> edges = sequential;
  for (std::size_t e = 0; e < loops.size(); ++e) {
    if (kept[e] && static_cast<int>(e) != left_out) edges.push_back(loops[e]);
  }
  return edges;
}

/// The graph solved with the loops that survive its check (ConsistentLoopGraph), the
/// trajectory corrected from it, the loops' checks told which were dropped.
void SolveAndCorrect(const Trajectory& trajectory, const std::vector<PoseGraphEdge>& sequential,
                     const std::vector<PoseGraphEdge>& loops, const LoopClosureOptions& options,
                     LoopClosureResult* result, const Log& log) {
  const std::vector<int>& nodes = result->keyframes;
  std::vector<Pose> initial;
  for (int k : nodes) initial.push_back(trajectory.poses[k]);
  const LoopGraph solved = ConsistentLoopGraph(initial, sequential, loops, options);
  result->message = solved.graph.message;
  std::size_t e = 0;
  for (LoopCheck& check : result->checks) {
    if (!check.accepted) continue;
    check.chi2 = solved.chi2[e];
    if (!solved.kept[e]) {
      check.accepted = false;
      check.reason = "inconsistent with the rest after the solve (chi-square " +
                     std::to_string(check.chi2) + ")";
      ++result->rejected_after_solve;
      log.Warning("loop closure: the loop between trajectory poses " +
                  std::to_string(check.frame_a) + " and " + std::to_string(check.frame_b) +
                  " dropped: " + check.reason);
    }
    ++e;
  }
  if (!solved.graph.usable) {
    log.Warning("loop closure: the pose graph was not solved (" + solved.graph.message +
                "); the trajectory is the run's");
    return;
  }
  if (result->rejected_after_solve == result->accepted) {
    result->message = "every loop rejected after the solve";
    return;
  }
  result->correction = InterpolatedCorrections(trajectory, nodes, solved.graph.poses);
  for (std::size_t k = 0; k < trajectory.poses.size(); ++k) {
    result->trajectory.poses[k] = Reorthonormalized(result->correction[k] * trajectory.poses[k]);
  }
  result->applied = true;
}

}  // namespace

LoopGraph ConsistentLoopGraph(const std::vector<Pose>& initial,
                              const std::vector<PoseGraphEdge>& sequential,
                              const std::vector<PoseGraphEdge>& loops,
                              const LoopClosureOptions& options) {
  LoopGraph out;
  out.kept.assign(loops.size(), true);
  out.chi2.assign(loops.size(), 0.0);
  for (;;) {
    out.graph = OptimizePoseGraph(initial, GraphEdges(sequential, loops, out.kept, -1), 0);
    if (!out.graph.usable) return out;
    int worst = -1;
    std::vector<double> kept_chi2;
    for (std::size_t e = 0; e < loops.size(); ++e) {
      if (!out.kept[e]) continue;
      const PoseGraphResult without =
          OptimizePoseGraph(initial, GraphEdges(sequential, loops, out.kept, e), 0);
      out.chi2[e] =
          without.usable ? out.graph.cost - without.cost : std::numeric_limits<double>::infinity();
      if (worst < 0 || out.chi2[e] > out.chi2[worst]) worst = static_cast<int>(e);
      kept_chi2.push_back(out.chi2[e]);
    }
    const double limit =
        std::max(options.max_loop_chi2, options.max_loop_chi2_ratio * Median(kept_chi2));
    if (worst < 0 || out.chi2[worst] <= limit) return out;
    out.kept[worst] = false;
  }
}

std::vector<bool> SelectKeyframes(const Trajectory& trajectory, const std::vector<bool>& usable,
                                  const LoopClosureOptions& options) {
  std::vector<bool> keyframes(trajectory.poses.size(), false);
  int last = -1;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (!usable[k]) continue;
    if (last >= 0) {
      const Pose T_last_k = trajectory.poses[last].inverse() * trajectory.poses[k];
      if (WithinMotion(T_last_k, options.keyframe_translation_m, options.keyframe_rotation_deg)) {
        continue;
      }
    }
    keyframes[k] = true;
    last = static_cast<int>(k);
  }
  return keyframes;
}

std::vector<Pose> InterpolatedCorrections(const Trajectory& run, const std::vector<int>& keyframes,
                                          const std::vector<Pose>& solved,
                                          const std::vector<double>& progress) {
  if (keyframes.size() != solved.size() || keyframes.empty() || keyframes.front() != 0) {
    throw InputError(
        "loop closure: keyframes and solved poses differ in number, or pose 0 is no keyframe");
  }
  if (!progress.empty() && progress.size() != run.poses.size()) {
    throw InputError("loop closure: progress and poses differ in number");
  }
  const auto at = [&](int k) { return progress.empty() ? static_cast<double>(k) : progress[k]; };
  const int last = static_cast<int>(keyframes.size()) - 1;
  std::vector<Pose> corrections;
  for (int j = 0; j <= last; ++j) {
    corrections.push_back(Reorthonormalized(solved[j] * run.poses[keyframes[j]].inverse()));
  }
  std::vector<Pose> result(run.poses.size(), Pose::Identity());
  int j = 0;
  for (std::size_t k = 0; k < result.size(); ++k) {
    while (j < last && keyframes[j + 1] <= static_cast<int>(k)) ++j;
    const Pose with_j = corrections[j] * run.poses[k];
    Pose corrected = with_j;
    if (j < last) {
      const double span = at(keyframes[j + 1]) - at(keyframes[j]);
      const double s = span > 0.0 ? (at(static_cast<int>(k)) - at(keyframes[j])) / span : 0.0;
      corrected = Blend(with_j, corrections[j + 1] * run.poses[k], s);
    }
    result[k] = Reorthonormalized(corrected * run.poses[k].inverse());
  }
  return result;
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
                             const LoopClosureOptions& options, const Log& log,
                             const std::vector<OpenStretch>& open) {
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
  // Sequential edges, then each keyframe's revisit candidate.
  std::vector<PoseGraphEdge> sequential;
  std::vector<PoseGraphEdge> loops;
  std::vector<double> rmse;
  FramePyramid previous = LoadPyramid(sequence, frames[nodes[0]], options);
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    FramePyramid current = LoadPyramid(sequence, frames[nodes[j]], options);
    const Pose T_a_b = trajectory.poses[nodes[j - 1]].inverse() * trajectory.poses[nodes[j]];
    const MeasuredEdge m = MeasureEdge(current, previous, j - 1, j, T_a_b, options);
    sequential.push_back(m.edge);
    rmse.push_back(m.rmse_m);
    previous = std::move(current);
  }
  const std::vector<Candidate> candidate = FindCandidates(nodes, trajectory, open, options);
  FreeAcrossOpenStretches(nodes, trajectory, open, options.floor_information, &sequential);
  const double median_rmse_m = Median(rmse);
  // Each candidate verified by ICP from the run's relative pose (across an open stretch: from
  // the pose the search over the plane's free directions found).
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    if (candidate[j].node < 0) continue;
    ++result.candidates;
    const int i = candidate[j].node;
    const int across = candidate[j].across;
    const FramePyramid later = LoadPyramid(sequence, frames[nodes[j]], options);
    const FramePyramid earlier = LoadPyramid(sequence, frames[nodes[i]], options);
    const Pose& T_world_i = trajectory.poses[nodes[i]];
    const Pose& T_world_j = trajectory.poses[nodes[j]];
    LoopCheck check = across < 0 ? VerifyLoop(later, earlier, T_world_i.inverse() * T_world_j,
                                              median_rmse_m, options)
                                 : VerifyAcross(later, earlier, T_world_j, T_world_i,
                                                open[across].n_world, median_rmse_m, options);
    check.frame_a = nodes[i];
    check.frame_b = nodes[j];
    if (check.accepted) {
      ++result.accepted;
      result.accepted_across += across >= 0 ? 1 : 0;
      PoseGraphEdge loop =
          MeasureEdge(later, earlier, i, static_cast<int>(j), check.track.T_target_source, options)
              .edge;
      loop.robust = false;  // verified; the loss would reject it while the drift is open
      loops.push_back(loop);
    } else {
      log.Debug("loop closure: frames " + std::to_string(frames[nodes[i]]) + " and " +
                std::to_string(frames[nodes[j]]) + " rejected: " + check.reason);
    }
    result.checks.push_back(std::move(check));
  }
  if (result.accepted == 0) {
    result.message = "no loop accepted";
  } else {
    SolveAndCorrect(trajectory, sequential, loops, options, &result, log);
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
  o.relocalise = options.relocalise;
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

LoopClosureOptions LoopClosureOptionsOf(const SlamOptions& options, const SlamResult& run) {
  LoopClosureOptions o = LoopClosureOptionsOfLoop(options);
  o.halvings = run.halvings;
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
                                        LoopClosureOptionsOf(options), log, result->open_stretches);
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
  const LoopClosureOptions o = LoopClosureOptionsOf(options, *result);
  LoopClosureResult closed =
      CloseLoops(sequence, frames, result->trajectory,
                 SelectKeyframes(result->trajectory, usable, o), o, log, result->open_stretches);
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
