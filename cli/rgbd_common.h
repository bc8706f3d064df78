// What `rigfit track` and `rigfit slam` share: their arguments and flags, the --evaluate
// lines against the sequence's ground truth, the guard's and the loop closure's outputs.
#pragma once

#include <CLI/CLI.hpp>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "rgbd/frame.h"
#include "rgbd/loop_closure.h"
#include "rgbd/motion_guard.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"
#include "rgbd/tracking_loop.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {

/// The command-line arguments both commands read beside their options structs.
struct TrackingArgs {
  std::string sequence_path;
  std::string out_path;
  SequenceOptions sequence;
  std::string prior = "constant-velocity";
  std::vector<int> iterations = {10, 5, 4};
  std::vector<double> intrinsics;  ///< fx, fy, cx, cy
  double weak_ratio = ProjectiveIcpOptions{}.weak_direction_ratio;
  bool loop_closure = LoopClosureOptions{}.enabled;
  std::string color_tracking = ColorTrackingName(TrackingLoopOptions{}.color_tracking);
  bool evaluate = false;
  bool quiet = false;
  bool verbose = false;
};

/// SEQUENCE and --out.
void AddSequenceArguments(CLI::App* sub, TrackingArgs* args);

/// The frames to track: --camera, --tum-camera, --intrinsics, --first, --max-frames, --stride.
void AddFrameSelectionFlags(CLI::App* sub, TrackingArgs* args, TrackingLoopOptions* loop);

/// How each frame starts: --iterations and --prior.
void AddFrameStartFlags(CLI::App* sub, TrackingArgs* args);

/// The depth used, the tracking's association and its pairs' weights: --min-depth,
/// --max-depth, --max-distance, --max-angle, --bilateral, --bilateral-range-grows, --depth-weights,
/// --noise-floor-depth, --huber.
void AddDepthAndPairFlags(CLI::App* sub, TrackingLoopOptions* loop);

/// The run's end: the guard's flags, --loop-closure, --threads, --evaluate, --quiet and
/// --verbose.
void AddRunFlags(CLI::App* sub, TrackingArgs* args, TrackingLoopOptions* loop);

/// frames / seconds for the summaries, 0 for no time.
inline double FramesPerSecond(int frames, double seconds) {
  return seconds > 0.0 ? frames / seconds : 0.0;
}

/// Applies what `args` holds beside `loop` (--prior, --iterations, --weak-ratio into `loop`;
/// --intrinsics into args->sequence) and checks the loop's settings (SettingError).
void ApplyTrackingArgs(TrackingArgs* args, TrackingLoopOptions* loop);

/// The command's messages on stderr as --quiet and --verbose say (StderrLog).
Log TrackingLog(const std::string& prefix, const TrackingArgs& args);

/// Opens the sequence (io/rgbd_sequence.h), its loader's warnings and its description to `log`.
std::unique_ptr<RgbdSequence> OpenSequenceLogged(const std::string& path,
                                                 const SequenceOptions& options, const Log& log);

/// The ATE, the RPE per frame and the end-point drift of `estimate` against the sequence's
/// ground truth, as lines for stdout; empty, with a warning (not an error) to `log`, when the
/// sequence has none or the two cannot be compared.
std::string TrajectoryEvaluationText(const RgbdSequence& sequence, const Trajectory& estimate,
                                     const Log& log);

/// What a run's frames went through, for the summary and the trajectory's metadata.
struct GuardCounts {
  int frames = 0;
  int failures = 0;
  int restarts = 0;
  int recovered = 0;
  int diverged = 0;
  int weak_frames = 0;
  int relocalised = 0;                    ///< frames relocalised after a lone-plane stretch
  int color_aligned = 0;                  ///< weak-direction frames aligned by colour
  std::map<std::string, int> weak_names;  ///< WeakDirectionName -> frames held along it
};

/// Adds a tracked frame's weak directions to counts->weak_names.
void CountWeakDirections(const TrackResult& track, GuardCounts* counts);

/// The counts of a run of RunOdometry or RunSlam (OdometryResult, SlamResult), the weak
/// directions of its frames included.
template <typename Result>
GuardCounts GuardCountsOf(const Result& result) {
  GuardCounts counts{static_cast<int>(result.frames.size()),
                     result.failures,
                     result.restarts,
                     result.recovered,
                     result.diverged,
                     result.weak_frames,
                     result.relocalised,
                     result.color_aligned,
                     {}};
  for (const auto& frame : result.frames) CountWeakDirections(frame.track, &counts);
  return counts;
}

/// The summary line "colour tracking (MODE): N of F frames refined by colour, R of them tracked
/// by colour alone where the depth failed", empty when the mode is off.
std::string ColorTrackingSummaryText(const TrackingLoopOptions& loop, const TrackingRun& run,
                                     int frames);

/// A run whose frames matched less than this share of their pixels on average has normals too
/// noisy to associate by: the matched-share column of docs/benchmarks.md ("Dense RGB-D
/// tracking") puts stereo depth below it, Kinect-like noise and the real sequences above.
inline constexpr double kLowMatchedShare = 0.6;

/// Warns when `mean_share` is below kLowMatchedShare, naming the flags (those not given) that
/// smooth the normals of far depth and widen their gate.
void WarnLowMatchedShare(double mean_share, const TrackingLoopOptions& loop, const Log& log);

/// The guard's line of the summary: "degenerate views: W frame(s) with weak directions, C of them
/// aligned by colour, L relocalised after a lone plane;
/// divergence: R recovered, D diverged"; also warns (log) when frames had weak directions, naming
/// them.
std::string GuardSummaryText(const GuardCounts& counts, const Log& log);

/// The '#' lines of the TUM output: "<command>: frames F, failed X, restarts S, recovered R,
/// diverged D, weak-direction frames W, relocalised L, aligned by colour C" and, when any, the
/// weak directions' counts.
std::vector<std::string> GuardMetadata(const std::string& command, const GuardCounts& counts);

/// The summary line of a loop closure: keyframes, candidates, accepted loops, whether the
/// trajectory was corrected, the time.
std::string LoopClosureSummaryText(const LoopClosureResult& closed);

/// The '#' line of the TUM output: "loop closure: keyframes K, candidates C, accepted A,
/// applied yes|no".
std::string LoopClosureMetadata(const LoopClosureResult& closed);

/// TrajectoryEvaluationText of the run's trajectory before the loop closure, each line
/// prefixed "without loop closure: ".
std::string UnclosedEvaluationText(const RgbdSequence& sequence, const Trajectory& unclosed,
                                   const Log& log);

}  // namespace rigfit::cli
