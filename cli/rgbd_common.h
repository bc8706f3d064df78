// What `rigfit track` and `rigfit slam` share: the tracking flags, the --intrinsics option
// and the --evaluate report against the sequence's ground truth.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/rgbd.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "registration/log.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"

namespace rigfit::cli {

/// Largest --threads.
inline constexpr int kMaxTrackingThreads = 64;

/// Checks and applies the tracking flags both commands have: --prior (constant-velocity or
/// identity), --iterations (1 to 6 counts in [0, 100], finest level first; their count is the
/// number of levels), --min-depth < --max-depth, --max-distance > 0, --max-angle in (0, 180],
/// --huber >= 0 (already in icp), --threads in [1, kMaxTrackingThreads], --max-frames >= 0.
/// InputError "<command>: <flag> ..." on a bad value.
void ApplyTrackingFlags(const std::string& command, const std::string& prior,
                        const std::vector<int>& iterations, int threads, int max_frames,
                        MotionPrior* motion_prior, FrameOptions* frame, ProjectiveIcpOptions* icp);

/// Sets options->intrinsics from --intrinsics fx,fy,cx,cy (nothing when empty); InputError
/// "<command>: --intrinsics takes fx,fy,cx,cy" on another count.
void ApplyIntrinsicsOption(const std::vector<double>& intrinsics, const std::string& command,
                           SequenceOptions* options);

/// Opens the sequence (io/rgbd_sequence.h), its loader's warnings and its description to `log`.
std::unique_ptr<RgbdSequence> OpenSequenceLogged(const std::string& path,
                                                 const SequenceOptions& options, const Log& log);

/// Prints the ATE, the RPE per frame and the end-point drift of `estimate` against the
/// sequence's ground truth on stdout; a warning (not an error) when the sequence has none or
/// the two cannot be compared.
void PrintTrajectoryEvaluation(const RgbdSequence& sequence, const Trajectory& estimate,
                               const Log& log);

}  // namespace rigfit::cli
