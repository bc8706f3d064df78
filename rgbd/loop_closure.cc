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

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

/// The keyframe's pyramid as the run built it, with its grey pyramid when `color` and the
/// frame has colour.
LoopKeyframe LoadKeyframe(const RgbdSequence& sequence, int index,
                          const LoopClosureOptions& options, bool color = false) {
  RgbdFrame frame = sequence.Frame(index);
  for (int h = 0; h < options.halvings; ++h) {
    frame = HalveFrame(frame, options.frame.max_depth_jump_ratio);
  }
  LoopKeyframe keyframe{BuildFramePyramid(frame, options.frame, options.threads), {}};
  if (color && HasColor(frame, keyframe.pyramid)) {
    keyframe.grey = BuildGreyPyramid(frame.color, keyframe.pyramid);
  }
  return keyframe;
}

/// `later` against `earlier` by colour over all six directions (rgbd/photometric.h), with the
/// depth's `prior` (null: none).
PhotometricProblem ColorProblem(const LoopKeyframe& later, const LoopKeyframe& earlier,
                                const Mat6* prior) {
  return {&later.pyramid,
          &later.grey,
          &earlier.grey,
          AllDirections(),
          MeanDepth(later.pyramid.levels[0]),
          prior};
}

/// Whether the candidates are refined by colour, given the sequential edges' median share.
bool LoopsByColor(const LoopClosureOptions& options, double median_share) {
  return options.color_tracking == ColorTracking::kOn ||
         (options.color_tracking == ColorTracking::kAuto &&
          median_share < options.color_tracking_share);
}

/// What the depth's pairs of `source` say at their pose: their RMS distance and their share of
/// the source's pixels (0 and 0 without pairs).
struct PairStats {
  double rmse_m = 0.0;
  double matched_share = 0.0;
};

PairStats StatsOf(const NormalEquations& eq, const FrameLevel& source) {
  if (eq.count == 0) return {};
  return {std::sqrt(eq.squared_error / eq.count),
          static_cast<double>(eq.count) / static_cast<double>(source.valid_pixels.size())};
}

/// The edge a -> b measured at T_a_b, weighed by the information of the ICP's pairs there
/// (header comment); rmse_m of its pairs, matched_share their share of b's pixels.
struct MeasuredEdge {
  PoseGraphEdge edge;
  double rmse_m = 0.0;
  double matched_share = 0.0;
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
    const PairStats stats = StatsOf(eq, b.levels[0]);
    measured.rmse_m = stats.rmse_m;
    measured.matched_share = stats.matched_share;
    const double variance = std::max(measured.rmse_m * measured.rmse_m, 1e-12);
    Mat6 J_inverse = Mat6::Identity();
    J_inverse.block<3, 3>(3, 0) = Hat(T_a_b.translation());
    information = J_inverse.transpose() * (options.information_scale / variance * eq.H) * J_inverse;
  }
  measured.edge.information = information + options.floor_information * Mat6::Identity();
  return measured;
}

/// The sequential edges between consecutive keyframes (trajectory positions `nodes`) at the
/// run's relative poses, and their medians; the grey-level residual's only where colour may be
/// used (LoopClosureOptions::color_tracking) and both keyframes have colour.
SequentialMedians MeasureSequential(const RgbdSequence& sequence, const std::vector<int>& frames,
                                    const std::vector<int>& nodes, const Trajectory& trajectory,
                                    const LoopClosureOptions& options,
                                    std::vector<PoseGraphEdge>* edges) {
  const bool color = options.color_tracking != ColorTracking::kOff;
  std::vector<double> rmse;
  std::vector<double> share;
  std::vector<double> grey;
  std::vector<double> overlap_matched;
  LoopKeyframe previous = LoadKeyframe(sequence, frames[nodes[0]], options, color);
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    LoopKeyframe current = LoadKeyframe(sequence, frames[nodes[j]], options, color);
    const Pose T_a_b = trajectory.poses[nodes[j - 1]].inverse() * trajectory.poses[nodes[j]];
    const MeasuredEdge m = MeasureEdge(current.pyramid, previous.pyramid, j - 1, j, T_a_b, options);
    edges->push_back(m.edge);
    rmse.push_back(m.rmse_m);
    share.push_back(m.matched_share);
    if (color && m.matched_share > 0.0) {  // what colour-refined candidates are judged by
      const double overlap = OverlapShare(current.pyramid.levels[0], previous.pyramid.levels[0],
                                          T_a_b, options.icp.association);
      if (overlap > 0.0) overlap_matched.push_back(m.matched_share / overlap);
    }
    if (!current.grey.levels.empty() && !previous.grey.levels.empty()) {
      grey.push_back(PhotometricRmse(ColorProblem(current, previous, nullptr), T_a_b,
                                     options.photometric, options.threads));
    }
    previous = std::move(current);
  }
  return {Median(rmse), Median(share), Median(grey), Median(overlap_matched)};
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

/// `later` aligned to `earlier` by colour from T_start (T_earlier_later; ColorProblem).
PhotometricResult AlignLoopByColor(const LoopKeyframe& later, const LoopKeyframe& earlier,
                                   const Pose& T_start, const Mat6* prior,
                                   const PhotometricOptions& options, int threads) {
  return AlignPhotometric(ColorProblem(later, earlier, prior), T_start, options, threads);
}

/// The check's track moved to T_earlier_later: the depth's pairs there (their share of the
/// later keyframe's pixels and RMS distance) judge it, and colour measured every direction.
void TrackAtColorPose(const LoopKeyframe& later, const LoopKeyframe& earlier,
                      const Pose& T_earlier_later, const LoopClosureOptions& options,
                      TrackResult* track) {
  const FrameLevel& source = later.pyramid.levels[0];
  const NormalEquations eq =
      AccumulateProjective(source, earlier.pyramid.levels[0], T_earlier_later,
                           options.icp.association, options.icp.weighting, options.threads);
  const PairStats stats = StatsOf(eq, source);
  track->T_target_source = T_earlier_later;
  track->correspondences = eq.count;
  track->matched_ratio = stats.matched_share;
  track->rmse_m = stats.rmse_m;
  track->success = track->matched_ratio >= options.icp.min_matched_ratio;
  track->message = track->success ? "" : "too few pixels matched at the pose colour found";
  track->weak.clear();
  track->weak_directions = 0;
}

/// The first colour alignment of a candidate, without a prior, from T_init and from T_init
/// turned both ways about each axis (LoopClosureOptions::color_start_turn_deg): the kept one
/// with the lowest grey-level residual, else the one from T_init.
PhotometricResult FirstColorAlignment(const LoopKeyframe& later, const LoopKeyframe& earlier,
                                      const Pose& T_init, const LoopClosureOptions& options) {
  PhotometricOptions wide = options.photometric;
  wide.max_change_m = options.color_max_change_m;
  PhotometricResult best = AlignLoopByColor(later, earlier, T_init, nullptr, wide, options.threads);
  if (options.color_start_turn_deg <= 0.0) return best;
  for (int i = 0; i < 6; ++i) {
    Vec6 turn = Vec6::Zero();
    turn(i / 2) = (i % 2 == 0 ? 1.0 : -1.0) * options.color_start_turn_deg * kDegToRad;
    const PhotometricResult r = AlignLoopByColor(later, earlier, ApplyLeftUpdate(turn, T_init),
                                                 nullptr, wide, options.threads);
    if (r.success && (!best.success || r.rmse < best.rmse)) best = r;
  }
  return best;
}

/// A candidate with colour: aligned by colour alone from the run's pose (the drift a loop
/// closes is larger than depth ICP's reach on noisy depth, and colour's coarse levels reach
/// further; FirstColorAlignment), then by ICP from there, then refined by colour with the ICP's
/// information as a prior (colour tracking); judged by the depth at the last pose colour kept
/// (TrackAtColorPose). False, with the reason, when colour kept none: on the depth colour is
/// used for, the ICP alone also accepts pairs far from the truth.
bool VerifyByColor(const LoopKeyframe& later, const LoopKeyframe& earlier, const Pose& T_init,
                   const LoopClosureOptions& options, LoopCheck* check) {
  const PhotometricResult coarse = FirstColorAlignment(later, earlier, T_init, options);
  const Pose start = coarse.success ? coarse.T_reference_source : T_init;
  check->track =
      TrackProjective(later.pyramid, earlier.pyramid, start, options.icp, options.threads);
  const TrackResult& t = check->track;
  if (t.success && t.weak_directions == 0) {
    const PhotometricResult fine = AlignLoopByColor(
        later, earlier, t.T_target_source, &t.information, options.photometric, options.threads);
    if (fine.success) {
      TrackAtColorPose(later, earlier, fine.T_reference_source, options, &check->track);
      check->color_refined = true;
      check->grey_rmse = fine.rmse;
      return true;
    }
  }
  if (!coarse.success) {
    check->reason = "not registered by colour: " + coarse.message;
    return false;
  }
  TrackAtColorPose(later, earlier, coarse.T_reference_source, options, &check->track);
  check->color_refined = true;
  check->grey_rmse = coarse.rmse;
  return true;
}

/// A candidate across an open stretch: `later` searched for over the free directions of the
/// stretch's plane (normal n_world) around its run pose with `earlier` as the one anchor, and
/// the pose found checked as any candidate's (VerifyLoop).
LoopCheck VerifyAcross(const LoopKeyframe& later, const LoopKeyframe& earlier,
                       const Pose& T_world_later, const Pose& T_world_earlier, const Vec3& n_world,
                       const SequentialMedians& sequential, const LoopClosureOptions& options) {
  const std::vector<Anchor> anchor = {{earlier.pyramid, T_world_earlier, 0}};
  const Relocalisation found =
      Relocalise({&later.pyramid, T_world_later, n_world, sequential.rmse_m}, anchor, options.icp,
                 options.relocalise, options.threads);
  if (!found.success) {
    LoopCheck check;
    check.reason = "not found over the free directions of the open stretch's plane (" +
                   std::to_string(found.candidates) + " poses scored; no track within " +
                   std::to_string(options.relocalise.max_rmse_ratio) +
                   " x the sequential edges' RMS distance " +
                   std::to_string(sequential.rmse_m * 1e3) + " mm)";
    return check;
  }
  return VerifyLoop(later, earlier, T_world_earlier.inverse() * found.T_world_camera, sequential,
                    options);
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

LoopCheck VerifyLoop(const LoopKeyframe& later, const LoopKeyframe& earlier, const Pose& T_init,
                     const SequentialMedians& sequential, const LoopClosureOptions& options) {
  LoopCheck check;
  if (later.grey.levels.empty() || earlier.grey.levels.empty()) {
    check.track =
        TrackProjective(later.pyramid, earlier.pyramid, T_init, options.icp, options.threads);
  } else if (!VerifyByColor(later, earlier, T_init, options, &check)) {
    return check;
  }
  const TrackResult& t = check.track;
  const auto least = [&](double median) {
    return std::min(options.min_matched_ratio, options.matched_share_ratio * median);
  };
  const double min_share = least(sequential.matched_share);
  const double min_of_overlap = least(sequential.overlap_matched);
  if (t.success && check.color_refined) {
    check.overlap = OverlapShare(later.pyramid.levels[0], earlier.pyramid.levels[0],
                                 t.T_target_source, options.icp.association);
  }
  const bool overlap_matched =
      check.overlap > 0.0 && t.matched_ratio / check.overlap >= min_of_overlap;
  if (!t.success) {
    check.reason = "ICP failed: " + t.message;
  } else if (t.weak_directions > 0) {
    check.reason = "weak directions (the views do not fix the motion)";
  } else if (t.matched_ratio < min_share && !overlap_matched) {
    check.reason =
        "matched share " + std::to_string(t.matched_ratio) + " below " + std::to_string(min_share) +
        (check.overlap > 0.0
             ? " (" + std::to_string(t.matched_ratio / check.overlap) + " of its overlap " +
                   std::to_string(check.overlap) + ", below " + std::to_string(min_of_overlap) + ")"
             : "");
  } else if (t.rmse_m > options.max_rmse_ratio * sequential.rmse_m) {
    check.reason = "RMS distance " + std::to_string(t.rmse_m * 1e3) + " mm above " +
                   std::to_string(options.max_rmse_ratio) + " x the sequential edges' " +
                   std::to_string(sequential.rmse_m * 1e3) + " mm";
  } else if (check.color_refined && sequential.grey_rmse > 0.0 &&
             check.grey_rmse > options.max_grey_rmse_ratio * sequential.grey_rmse) {
    check.reason = "RMS grey-level residual " + std::to_string(check.grey_rmse) + " above " +
                   std::to_string(options.max_grey_rmse_ratio) + " x the sequential edges' " +
                   std::to_string(sequential.grey_rmse);
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
  const SequentialMedians medians =
      MeasureSequential(sequence, frames, nodes, trajectory, options, &sequential);
  const std::vector<Candidate> candidate = FindCandidates(nodes, trajectory, open, options);
  FreeAcrossOpenStretches(nodes, trajectory, open, options.floor_information, &sequential);
  const bool color = LoopsByColor(options, medians.matched_share);
  // Each candidate verified by ICP (and colour) from the run's relative pose (across an open
  // stretch: from the pose the search over the plane's free directions found).
  for (std::size_t j = 1; j < nodes.size(); ++j) {
    if (candidate[j].node < 0) continue;
    ++result.candidates;
    const int i = candidate[j].node;
    const int across = candidate[j].across;
    const LoopKeyframe later = LoadKeyframe(sequence, frames[nodes[j]], options, color);
    const LoopKeyframe earlier = LoadKeyframe(sequence, frames[nodes[i]], options, color);
    const Pose& T_world_i = trajectory.poses[nodes[i]];
    const Pose& T_world_j = trajectory.poses[nodes[j]];
    LoopCheck check =
        across < 0 ? VerifyLoop(later, earlier, T_world_i.inverse() * T_world_j, medians, options)
                   : VerifyAcross(later, earlier, T_world_j, T_world_i, open[across].n_world,
                                  medians, options);
    check.frame_a = nodes[i];
    check.frame_b = nodes[j];
    if (check.accepted) {
      ++result.accepted;
      result.accepted_across += across >= 0 ? 1 : 0;
      result.accepted_by_color += check.color_refined ? 1 : 0;
      PoseGraphEdge loop = MeasureEdge(later.pyramid, earlier.pyramid, i, static_cast<int>(j),
                                       check.track.T_target_source, options)
                               .edge;
      loop.robust = false;  // verified; the loss would reject it while the drift is open
      loops.push_back(loop);
    }
    log.Debug("loop closure: frames " + std::to_string(frames[nodes[i]]) + " and " +
              std::to_string(frames[nodes[j]]) + ": share " +
              std::to_string(check.track.matched_ratio) + ", RMS " +
              std::to_string(check.track.rmse_m * 1e3) + " mm" +
              (check.color_refined ? ", refined by colour" : "") + ": " +
              (check.accepted ? "accepted" : "rejected: " + check.reason));
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

/// The settings a loop closure shares with the run it closes: frames, ICP, colour, threads.
LoopClosureOptions LoopClosureOptionsOfLoop(const TrackingLoopOptions& options) {
  LoopClosureOptions o;
  o.frame = options.frame;
  o.icp = options.icp;
  o.relocalise = options.relocalise;
  o.color_tracking = options.color_tracking;
  o.color_tracking_share = options.color_tracking_share;
  o.photometric = options.photometric;
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
