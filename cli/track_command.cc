// `rigfit track SEQUENCE --out traj.txt`: dense RGB-D odometry (frame to keyframe) over a
// sequence (rgbd/odometry.h), the trajectory in the TUM format.
#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/rgbd_common.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "io/trajectory_tum.h"
#include "rgbd/loop_closure.h"
#include "rgbd/odometry.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {
namespace {

struct TrackArgs : TrackingArgs {
  OdometryOptions odometry;
  double min_step_m = ProjectiveIcpOptions{}.converged_translation_m;
};
int RunTrack(TrackArgs a) {
  ApplyTrackingArgs(&a, &a.odometry);
  ApplyMinStep(a.min_step_m, &a.odometry.icp);

  const Log log = TrackingLog("track: ", a);
  const std::unique_ptr<RgbdSequence> sequence =
      OpenSequenceLogged(a.sequence_path, a.sequence, log);
  int last_percent = -1;
  const auto progress = [&](int done, int total) {
    const int percent = 100 * done / total;
    if (a.quiet || (percent / 10 == last_percent / 10 && done != total)) return;
    last_percent = percent;
    std::fprintf(stderr, "track: %d/%d frames\n", done, total);
  };
  OdometryResult result = RunOdometry(*sequence, a.odometry, log, progress);
  const Trajectory unclosed = result.trajectory;
  std::optional<LoopClosureResult> closed;
  if (a.loop_closure) closed = CloseOdometryLoops(*sequence, a.odometry, &result, log);

  const int frames = static_cast<int>(result.frames.size());
  int keyframes = 0;
  double matched = 0.0;
  const GuardCounts counts = GuardCountsOf(result);
  for (const OdometryFrame& frame : result.frames) {
    keyframes += frame.keyframe ? 1 : 0;
    matched += frame.track.matched_ratio;
  }
  std::vector<std::string> metadata = GuardMetadata("track", counts);
  if (closed) metadata.push_back(LoopClosureMetadata(*closed));
  WriteTumTrajectory(a.out_path, result.trajectory, metadata);
  std::printf("tracked %d frames (%d failed, %d restarts, %d keyframes) -> %s\n", frames,
              result.failures, result.restarts, keyframes, a.out_path.c_str());
  const double mean_matched = frames > 1 ? matched / (frames - 1) : 0.0;
  std::printf(
      "mean matched share %.2f; time (s): waiting for frames %.2f, tracking %.2f, all %.2f "
      "(%.1f frames/s with loading, %.1f without); preprocessing %.2f while the frame before "
      "was tracked\n",
      mean_matched, result.load_s, result.track_s, result.loop_s,
      FramesPerSecond(frames, result.loop_s),
      FramesPerSecond(frames, result.loop_s - result.load_s), result.preprocess_s);
  std::fputs(ColorTrackingSummaryText(a.odometry, result, frames).c_str(), stdout);
  if (frames > 1) WarnLowMatchedShare(mean_matched, a.odometry, log);
  std::fputs(GuardSummaryText(counts, log).c_str(), stdout);
  if (closed) std::fputs(LoopClosureSummaryText(*closed).c_str(), stdout);
  if (a.evaluate && closed && closed->applied) {
    std::fputs(UnclosedEvaluationText(*sequence, unclosed, log).c_str(), stdout);
  }
  if (a.evaluate) {
    std::fputs(TrajectoryEvaluationText(*sequence, result.trajectory, log).c_str(), stdout);
  }
  return kExitOk;
}

}  // namespace

Command AddTrackCommand(CLI::App& app) {
  auto args = std::make_shared<TrackArgs>();
  CLI::App* sub = app.add_subcommand(
      "track",
      "Dense RGB-D odometry: each depth frame of SEQUENCE (a TUM RGB-D or ICL-NUIM folder, a "
      "7-Scenes folder, or a rig capture's burst) is tracked against the last keyframe (with "
      "--no-keyframes: the previous frame) by projective point-to-plane ICP, coarse to fine; "
      "the trajectory is written in the TUM format (timestamp tx ty tz qx qy qz qw). Exit "
      "codes: 0 done (failed frames are warned and counted); 2 bad input or usage.");
  TrackArgs& a = *args;
  AddSequenceArguments(sub, &a);
  AddFrameSelectionFlags(sub, &a, &a.odometry);
  AddFrameStartFlags(sub, &a);
  sub->add_flag(
      "--keyframes,!--no-keyframes", a.odometry.keyframes,
      "Track against a keyframe, renewed after 10 cm, 5 deg or half its matched pixels lost "
      "(default), or against the previous frame");
  AddDepthAndPairFlags(sub, &a.odometry);
  sub->add_option("--min-step", a.min_step_m,
                  "A pyramid level ends when a step moves the camera less than this (metres) and "
                  "turns it less than this many radians")
      ->capture_default_str();
  AddRunFlags(sub, &a, &a.odometry);
  return {sub, [args] { return RunTrack(*args); }};
}

}  // namespace rigfit::cli
