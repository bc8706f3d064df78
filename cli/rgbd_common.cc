#include "cli/rgbd_common.h"

#include <stdexcept>

#include "core/errors.h"
#include "core/format.h"
#include "rgbd/tracking_options.h"

namespace rigfit::cli {

void ApplyTrackingFlags(const std::string& command, const std::string& prior,
                        const std::vector<int>& iterations, int threads, int max_frames,
                        MotionPrior* motion_prior, FrameOptions* frame, ProjectiveIcpOptions* icp) {
  ApplyTrackingSettings(command, OptionSpelling::kFlag, prior, iterations, threads, max_frames,
                        motion_prior, frame, icp);
}

std::unique_ptr<RgbdSequence> OpenSequenceLogged(const std::string& path,
                                                 const SequenceOptions& options, const Log& log) {
  std::vector<std::string> warnings;
  std::unique_ptr<RgbdSequence> sequence = OpenRgbdSequence(path, options, &warnings);
  for (const std::string& warning : warnings) log.Warning(warning);
  log.Info(sequence->Describe());
  return sequence;
}

void ApplyIntrinsicsOption(const std::vector<double>& intrinsics, const std::string& command,
                           SequenceOptions* options) {
  SetSequenceIntrinsics(intrinsics, command, OptionSpelling::kFlag, options);
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
  } catch (const std::invalid_argument& error) {
    // The trajectory is written; only the comparison is impossible.
    log.Warning(std::string("--evaluate: ") + error.what());
  }
  return text;
}

}  // namespace rigfit::cli
