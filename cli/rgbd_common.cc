#include "cli/rgbd_common.h"

#include <stdexcept>

#include "cli/stderr_log.h"
#include "core/errors.h"
#include "core/format.h"
#include "io/rgbd_sequence.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {
namespace {

/// --guard/--no-guard and --weak-ratio (into *weak_ratio, applied by ApplyTrackingArgs).
void AddGuardFlags(CLI::App* sub, GuardOptions* guard, double* weak_ratio) {
  sub->add_flag("--guard,!--no-guard", guard->enabled,
                "Guard against divergence: damp the constant-velocity prior along weak "
                "directions, re-track a frame that jumps, loses its matches or whose residual "
                "rises from the last good pose, count it recovered or diverged (default; "
                "docs/rgbd.md)");
  sub->add_option("--weak-ratio", *weak_ratio,
                  "A direction of the motion is weak (held at the prediction) when its "
                  "eigenvalue of the scaled information matrix is below this share of the "
                  "largest")
      ->capture_default_str();
}

void AddLoopClosureFlag(CLI::App* sub, bool* loop_closure) {
  sub->add_flag("--loop-closure,!--no-loop-closure", *loop_closure,
                std::string("Close loops after the run: revisited keyframes verified by ICP, a "
                            "keyframe pose graph solved, every frame moved with its keyframe (") +
                    (LoopClosureOptions{}.enabled ? "default" : "off by default") +
                    "; docs/rgbd.md)");
}

}  // namespace

std::unique_ptr<RgbdSequence> OpenSequenceLogged(const std::string& path,
                                                 const SequenceOptions& options, const Log& log) {
  std::vector<std::string> warnings;
  std::unique_ptr<RgbdSequence> sequence = OpenRgbdSequence(path, options, &warnings);
  for (const std::string& warning : warnings) log.Warning(warning);
  log.Info(sequence->Describe());
  return sequence;
}

std::string TrajectoryEvaluationText(const RgbdSequence& sequence, const Trajectory& estimate,
                                     const Log& log) {
  const Trajectory gt = sequence.GroundTruth();
  if (gt.poses.empty()) {
    log.Warning("--evaluate: the sequence has no ground truth");
    return "";
  }
  std::string text;
  try {
    const TrajectoryErrors e = EvaluateTrajectory(estimate, gt, 0.02, 1);
    Appendf(&text,
            "against the sequence's ground truth (%d poses): ATE RMSE %.2f mm, RPE per frame "
            "%.2f mm / %.3f deg\n",
            e.pairs, e.ate_rmse_m * 1e3, e.rpe_translation_rmse_m * 1e3,
            e.rpe_rotation_rmse_rad * kRadToDeg);
    const EndPointDrift drift = MeasureEndPointDrift(estimate, gt, 0.02);
    if (drift.anchored && drift.path_m > 0.0) {
      Appendf(&text, "end-point drift %.2f mm over %.2f m travelled (%.2f mm per metre)\n",
              drift.drift_m * 1e3, drift.path_m, drift.drift_m * 1e3 / drift.path_m);
    } else {
      Appendf(&text,
              "end-point drift: not measured (the first frame has no ground-truth pose within "
              "0.02 s, or the camera did not move)\n");
    }
    const LoopDrift loop = MeasureLoopDrift(estimate, gt, 0.02);
    if (loop.closed) {
      Appendf(&text,
              "closed loop: end drift %.2f mm / %.3f deg (the last pose against the first)\n",
              loop.translation_m * 1e3, loop.rotation_rad * kRadToDeg);
    }
  } catch (const std::invalid_argument& error) {
    // The trajectory is written; only the comparison is impossible.
    log.Warning(std::string("--evaluate: ") + error.what());
  }
  return text;
}

void CountWeakDirections(const TrackResult& track, GuardCounts* counts) {
  for (const Vec6& weak : track.weak) ++counts->weak_names[WeakDirectionName(weak)];
}

namespace {

std::string WeakNamesText(const GuardCounts& counts) {
  std::string text;
  for (const auto& [name, frames] : counts.weak_names) {
    Appendf(&text, "%s%s (%d)", text.empty() ? "" : ", ", name.c_str(), frames);
  }
  return text;
}

}  // namespace

std::string GuardSummaryText(const GuardCounts& counts, const Log& log) {
  if (counts.weak_frames > 0) {
    log.Warning(std::to_string(counts.weak_frames) +
                " frame(s) saw too little structure to fix every direction of the motion (a flat "
                "wall, a floor): " +
                WeakNamesText(counts) + " held at the prediction" +
                (counts.color_aligned > 0
                     ? " or aligned by colour (" + std::to_string(counts.color_aligned) + " frames)"
                     : std::string()));
  }
  if (counts.diverged > 0) {
    log.Warning(std::to_string(counts.diverged) +
                " frame(s) diverged and kept the last good pose (see the warnings above)");
  }
  std::string text;
  Appendf(&text,
          "degenerate views: %d frame(s) with weak directions, %d of them aligned by colour, %d "
          "relocalised after a lone plane; divergence: %d frame(s) recovered, %d diverged\n",
          counts.weak_frames, counts.color_aligned, counts.relocalised, counts.recovered,
          counts.diverged);
  return text;
}

std::string ColorTrackingSummaryText(const TrackingLoopOptions& loop, const TrackingRun& run,
                                     int frames) {
  std::string text;
  if (loop.color_tracking != ColorTracking::kOff) {
    Appendf(&text,
            "colour tracking (%s): %d of %d frames refined by colour, %d of them tracked by "
            "colour alone where the depth failed, %d where its track was unverified\n",
            ColorTrackingName(loop.color_tracking), run.color_tracked, frames, run.color_rescued,
            run.color_alone);
  }
  return text;
}

void WarnLowMatchedShare(double mean_share, const TrackingLoopOptions& loop, const Log& log) {
  if (!(mean_share < kLowMatchedShare)) return;
  std::string flags;
  if (loop.frame.bilateral && !loop.frame.bilateral_range_grows) flags = "--bilateral-range-grows";
  if (loop.icp.association.max_normal_angle_deg < 60.0) {
    flags += (flags.empty() ? "" : " and ") + std::string("--max-angle 60");
  }
  std::string text;
  Appendf(&text,
          "the frames matched %.2f of their pixels on average: their normals may be too noisy to "
          "associate by (stereo depth, far depth)%s%s (docs/rgbd.md section 2)",
          mean_share, flags.empty() ? "" : "; try ", flags.c_str());
  log.Warning(text);
}

std::vector<std::string> GuardMetadata(const std::string& command, const GuardCounts& counts) {
  std::vector<std::string> lines;
  std::string line;
  Appendf(&line,
          "rigfit %s: frames %d, failed %d, restarts %d, recovered %d, diverged %d, "
          "weak-direction frames %d, relocalised %d, aligned by colour %d",
          command.c_str(), counts.frames, counts.failures, counts.restarts, counts.recovered,
          counts.diverged, counts.weak_frames, counts.relocalised, counts.color_aligned);
  lines.push_back(line);
  if (!counts.weak_names.empty()) lines.push_back("weak directions: " + WeakNamesText(counts));
  return lines;
}

std::string LoopClosureSummaryText(const LoopClosureResult& closed) {
  std::string kept;
  for (const LoopCheck& check : closed.checks) {
    if (check.accepted) Appendf(&kept, "%s%.1f", kept.empty() ? "" : ", ", check.chi2);
  }
  if (!kept.empty()) kept = " (chi-square against the rest " + kept + ")";
  if (closed.accepted_across > 0) {
    Appendf(&kept, "; %d across an open lone-plane stretch", closed.accepted_across);
  }
  if (closed.accepted_by_color > 0) {
    Appendf(&kept, "; %d refined by colour", closed.accepted_by_color);
  }
  std::string text;
  Appendf(&text,
          "loop closure: %zu keyframes, %d candidate(s), %d loop(s) accepted, %d rejected after "
          "the solve%s; %s (%.2f s)\n",
          closed.keyframes.size(), closed.candidates, closed.accepted, closed.rejected_after_solve,
          kept.c_str(),
          closed.applied ? "trajectory corrected" : ("not applied: " + closed.message).c_str(),
          closed.seconds);
  return text;
}

std::string LoopClosureMetadata(const LoopClosureResult& closed) {
  std::string line;
  Appendf(&line,
          "loop closure: keyframes %zu, candidates %d, accepted %d (across an open lone-plane "
          "stretch %d, refined by colour %d), rejected after the solve %d, applied %s",
          closed.keyframes.size(), closed.candidates, closed.accepted, closed.accepted_across,
          closed.accepted_by_color, closed.rejected_after_solve, closed.applied ? "yes" : "no");
  return line;
}

std::string UnclosedEvaluationText(const RgbdSequence& sequence, const Trajectory& unclosed,
                                   const Log& log) {
  const std::string text = TrajectoryEvaluationText(sequence, unclosed, log);
  std::string prefixed;
  std::size_t begin = 0;
  while (begin < text.size()) {
    const std::size_t end = text.find('\n', begin);
    prefixed += "without loop closure: " + text.substr(begin, end + 1 - begin);
    begin = end + 1;
  }
  return prefixed;
}

void AddSequenceArguments(CLI::App* sub, TrackingArgs* args) {
  sub->add_option("SEQUENCE", args->sequence_path, "Sequence folder or capture file")->required();
  sub->add_option("--out", args->out_path, "Trajectory to write (TUM format)")->required();
}

void AddFrameSelectionFlags(CLI::App* sub, TrackingArgs* args, TrackingLoopOptions* loop) {
  sub->add_option("--camera", args->sequence.serial,
                  "Capture file: the camera's serial (default: the first)");
  sub->add_option("--tum-camera", args->sequence.tum_camera,
                  "TUM folder: fr1, fr2, fr3 or default (default: from the folder or depth.txt)");
  sub->add_option("--intrinsics", args->intrinsics,
                  "fx,fy,cx,cy of the depth image instead of the format's")
      ->delimiter(',');
  sub->add_option("--first", loop->first_frame, "First frame index")->capture_default_str();
  sub->add_option("--max-frames", loop->max_frames, "Frames to track (0 = all)")
      ->capture_default_str();
  sub->add_option("--stride", loop->stride, "Track every N-th frame")->capture_default_str();
}

void AddFrameStartFlags(CLI::App* sub, TrackingArgs* args) {
  sub->add_option("--iterations", args->iterations,
                  "Gauss-Newton iterations per pyramid level, finest first (the count of "
                  "numbers is the number of levels)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--prior", args->prior, "Start of each frame: constant-velocity or identity")
      ->capture_default_str();
}

void AddDepthAndPairFlags(CLI::App* sub, TrackingLoopOptions* loop) {
  sub->add_option("--min-depth", loop->frame.min_depth_m, "Depth used from, metres")
      ->capture_default_str();
  sub->add_option("--max-depth", loop->frame.max_depth_m, "Depth used up to, metres")
      ->capture_default_str();
  sub->add_option("--max-distance", loop->icp.association.max_distance_m,
                  "Tracking: largest point distance, metres")
      ->capture_default_str();
  sub->add_option("--max-angle", loop->icp.association.max_normal_angle_deg,
                  "Tracking: largest normal angle, degrees")
      ->capture_default_str();
  sub->add_flag("--bilateral,!--no-bilateral", loop->frame.bilateral,
                "Level-0 normals from the bilateral-filtered depth; the points stay the measured "
                "ones (default)");
  sub->add_flag("--bilateral-range-grows,!--no-bilateral-range-grows",
                loop->frame.bilateral_range_grows,
                "The bilateral filter's range sigma (3 cm) grows as z^2 beyond 1 m, as depth "
                "noise does: for stereo depth (ZED, RealSense; docs/rgbd.md)");
  sub->add_flag("--depth-weights,!--no-depth-weights", loop->icp.weighting.depth_noise,
                "Weigh pairs by the inverse variance of depth noise growing as z^2 (default)");
  sub->add_option("--noise-floor-depth", loop->icp.weighting.noise_floor_depth_m,
                  "Depth weights: a depth nearer than this (metres) weighs as this one (the "
                  "association's and the normals' error, growing as z, dominate there); 0 = no "
                  "floor")
      ->capture_default_str();
  sub->add_option("--huber", loop->icp.weighting.huber_delta_m,
                  "Huber threshold on the whitened point-to-plane distance (metres at 1 m depth; "
                  "with depth weights it grows as z^2); 0 = off")
      ->capture_default_str();
}

void AddRunFlags(CLI::App* sub, TrackingArgs* args, TrackingLoopOptions* loop) {
  AddGuardFlags(sub, &loop->guard, &args->weak_ratio);
  sub->add_flag("--color-align,!--no-color-align", loop->photometric.enabled,
                "Align a frame's weak directions (a lone floor or wall) by colour against the "
                "previous frame when both have colour registered to depth (default; "
                "docs/rgbd.md)");
  sub->add_option("--color-tracking", args->color_tracking,
                  "Refine each track by colour against a recent frame's, the depth's "
                  "information as a prior, when the frames have colour registered to depth: "
                  "auto (frames that matched under 0.6 of their pixels: noisy depth such as "
                  "stereo matching's), on (every frame without weak directions) or off; unless "
                  "off, a frame whose depth track failed or diverged is tracked by colour alone, "
                  "one whose depth track is unverified (not converged, or re-tracked) also "
                  "aligned by colour alone and the better kept, and the loop closure registers "
                  "its candidates by colour too (docs/rgbd.md sections 4c and 7)")
      ->capture_default_str();
  AddLoopClosureFlag(sub, &args->loop_closure);
  sub->add_option("--threads", loop->threads, "Threads")->capture_default_str();
  sub->add_flag("--evaluate", args->evaluate,
                "Print ATE and RPE against the sequence's own ground truth");
  sub->add_flag("--quiet", args->quiet, "No progress on stderr (warnings still)");
  sub->add_flag("--verbose,-v", args->verbose,
                "Also debug messages (why a frame's weak directions were not aligned by colour, "
                "why a loop was rejected)");
}

void ApplyTrackingArgs(TrackingArgs* args, TrackingLoopOptions* loop) {
  ApplyTrackingSettings(args->prior, args->iterations, loop);
  ApplyWeakRatio(args->weak_ratio, &loop->icp);
  ApplyColorTracking(args->color_tracking, loop);
  SetSequenceIntrinsics(args->intrinsics, &args->sequence);
}

Log TrackingLog(const std::string& prefix, const TrackingArgs& args) {
  return StderrLog(prefix, args.quiet     ? Verbosity::kQuiet
                           : args.verbose ? Verbosity::kVerbose
                                          : Verbosity::kNormal);
}

}  // namespace rigfit::cli
