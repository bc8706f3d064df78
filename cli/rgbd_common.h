// What `rigfit track` and `rigfit slam` share: the tracking flags, the --intrinsics option
// and the --evaluate lines against the sequence's ground truth.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/log.h"
#include "core/rgbd.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "rgbd/frame.h"
#include "rgbd/odometry.h"
#include "rgbd/projective_icp.h"

namespace rigfit::cli {

/// rgbd/tracking_options.h's ApplyTrackingSettings with the flags' spelling ("--prior", ...):
/// the checks rigfit.track shares.
void ApplyTrackingFlags(const std::string& command, const std::string& prior,
                        const std::vector<int>& iterations, int threads, int max_frames,
                        MotionPrior* motion_prior, FrameOptions* frame, ProjectiveIcpOptions* icp);

/// io/rgbd_sequence.h's SetSequenceIntrinsics for --intrinsics fx,fy,cx,cy (nothing when
/// empty).
void ApplyIntrinsicsOption(const std::vector<double>& intrinsics, const std::string& command,
                           SequenceOptions* options);

/// Opens the sequence (io/rgbd_sequence.h), its loader's warnings and its description to `log`.
std::unique_ptr<RgbdSequence> OpenSequenceLogged(const std::string& path,
                                                 const SequenceOptions& options, const Log& log);

/// The ATE, the RPE per frame and the end-point drift of `estimate` against the sequence's
/// ground truth, as lines for stdout; empty, with a warning (not an error) to `log`, when the
/// sequence has none or the two cannot be compared.
std::string TrajectoryEvaluationText(const RgbdSequence& sequence, const Trajectory& estimate,
                                     const Log& log);

}  // namespace rigfit::cli
