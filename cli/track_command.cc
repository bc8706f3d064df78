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
#include "cli/stderr_log.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "io/trajectory_tum.h"
#include "rgbd/loop_closure.h"
#include "rgbd/odometry.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {
namespace {

struct TrackArgs {
  std::string sequence_path;
  std::string out_path;
  SequenceOptions sequence;
  OdometryOptions odometry;
  std::string prior = "constant-velocity";
  std::vector<int> iterations = {10, 5, 4};
  std::vector<double> intrinsics;  ///< fx, fy, cx, cy
  double min_step_m = ProjectiveIcpOptions{}.converged_translation_m;
  double weak_ratio = ProjectiveIcpOptions{}.weak_direction_ratio;
  bool loop_closure = LoopClosureOptions{}.enabled;
  bool evaluate = false;
  bool quiet = false;
};

int RunTrack(TrackArgs a) {
  ApplyTrackingSettings(a.prior, a.iterations, a.odometry.threads, a.odometry.max_frames,
                        &a.odometry.prior, &a.odometry.frame, &a.odometry.icp);
  ApplyMinStep(a.min_step_m, &a.odometry.icp);
  ApplyWeakRatio(a.weak_ratio, &a.odometry.icp);

  SetSequenceIntrinsics(a.intrinsics, &a.sequence);

  const Log log = StderrLog("track: ", a.quiet ? Verbosity::kQuiet : Verbosity::kNormal);
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
  const double tracked_s = result.preprocess_s + result.track_s;
  std::printf("tracked %d frames (%d failed, %d restarts, %d keyframes) -> %s\n", frames,
              result.failures, result.restarts, keyframes, a.out_path.c_str());
  std::printf(
      "mean matched share %.2f; time (s): load %.2f, preprocessing %.2f, tracking %.2f "
      "(%.1f frames/s without loading)\n",
      frames > 1 ? matched / (frames - 1) : 0.0, result.load_s, result.preprocess_s, result.track_s,
      tracked_s > 0.0 ? frames / tracked_s : 0.0);
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
  sub->add_option("SEQUENCE", args->sequence_path, "Sequence folder or capture file")->required();
  sub->add_option("--out", args->out_path, "Trajectory to write (TUM format)")->required();
  sub->add_option("--camera", args->sequence.serial,
                  "Capture file: the camera's serial (default: the first)");
  sub->add_option("--tum-camera", args->sequence.tum_camera,
                  "TUM folder: fr1, fr2, fr3 or default (default: from the folder or depth.txt)");
  sub->add_option("--intrinsics", args->intrinsics,
                  "fx,fy,cx,cy of the depth image instead of the format's")
      ->delimiter(',');
  sub->add_option("--first", args->odometry.first_frame, "First frame index")
      ->capture_default_str();
  sub->add_option("--max-frames", args->odometry.max_frames, "Frames to track (0 = all)")
      ->capture_default_str();
  sub->add_option("--stride", args->odometry.stride, "Track every N-th frame")
      ->capture_default_str();
  sub->add_option("--iterations", args->iterations,
                  "Gauss-Newton iterations per pyramid level, finest first (the count of "
                  "numbers is the number of levels)")
      ->delimiter(',')
      ->capture_default_str();
  sub->add_option("--prior", args->prior, "Start of each frame: constant-velocity or identity")
      ->capture_default_str();
  sub->add_flag("--keyframes,!--no-keyframes", args->odometry.keyframes,
                "Track against a keyframe, renewed after 10 cm, 5 deg or half the pixels lost "
                "(default), or against the previous frame");
  sub->add_option("--min-depth", args->odometry.frame.min_depth_m, "Depth used from, metres")
      ->capture_default_str();
  sub->add_option("--max-depth", args->odometry.frame.max_depth_m, "Depth used up to, metres")
      ->capture_default_str();
  sub->add_flag("--bilateral,!--no-bilateral", args->odometry.frame.bilateral,
                "Level-0 normals from the bilateral-filtered depth; the points stay the measured "
                "ones (default)");
  sub->add_option("--max-distance", args->odometry.icp.association.max_distance_m,
                  "Association: largest point distance, metres")
      ->capture_default_str();
  sub->add_option("--max-angle", args->odometry.icp.association.max_normal_angle_deg,
                  "Association: largest normal angle, degrees")
      ->capture_default_str();
  sub->add_flag("--depth-weights,!--no-depth-weights", args->odometry.icp.weighting.depth_noise,
                "Weigh pairs by the inverse variance of depth noise growing as z^2 (default)");
  sub->add_option("--huber", args->odometry.icp.weighting.huber_delta_m,
                  "Huber threshold on the whitened point-to-plane distance (metres at 1 m depth; "
                  "with depth weights it grows as z^2); 0 = off")
      ->capture_default_str();
  sub->add_option("--min-step", args->min_step_m,
                  "A pyramid level ends when a step moves the camera less than this (metres) and "
                  "turns it less than this many radians")
      ->capture_default_str();
  AddGuardFlags(sub, &args->odometry.guard, &args->weak_ratio);
  AddLoopClosureFlag(sub, &args->loop_closure);
  sub->add_option("--threads", args->odometry.threads, "Threads")->capture_default_str();
  sub->add_flag("--evaluate", args->evaluate,
                "Print ATE and RPE against the sequence's own ground truth");
  sub->add_flag("--quiet", args->quiet, "No progress on stderr (warnings still)");
  return {sub, [args] { return RunTrack(*args); }};
}

}  // namespace rigfit::cli
