// What `rigfit track` and `rigfit slam` share: the --intrinsics option and the --evaluate
// report against the sequence's ground truth.
#pragma once

#include <string>
#include <vector>

#include "core/rgbd.h"
#include "core/trajectory.h"
#include "io/rgbd_sequence.h"
#include "registration/log.h"

namespace rigfit::cli {

/// Sets options->intrinsics from --intrinsics fx,fy,cx,cy (nothing when empty); InputError
/// "<command>: --intrinsics takes fx,fy,cx,cy" on another count.
void ApplyIntrinsicsOption(const std::vector<double>& intrinsics, const std::string& command,
                           SequenceOptions* options);

/// Prints the ATE, the RPE per frame and the end-point drift of `estimate` against the
/// sequence's ground truth on stdout; a warning (not an error) when the sequence has none or
/// the two cannot be compared.
void PrintTrajectoryEvaluation(const RgbdSequence& sequence, const Trajectory& estimate,
                               const Log& log);

}  // namespace rigfit::cli
