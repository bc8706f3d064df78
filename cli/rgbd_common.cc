#include "cli/rgbd_common.h"

#include <cstdio>
#include <stdexcept>

#include "core/errors.h"

namespace rigfit::cli {

void ApplyTrackingFlags(const std::string& command, const std::string& prior,
                        const std::vector<int>& iterations, int threads, int max_frames,
                        MotionPrior* motion_prior, FrameOptions* frame, ProjectiveIcpOptions* icp) {
  const std::string c = command + ": ";
  if (prior == "constant-velocity") {
    *motion_prior = MotionPrior::kConstantVelocity;
  } else if (prior == "identity") {
    *motion_prior = MotionPrior::kIdentity;
  } else {
    throw InputError(c + "--prior must be constant-velocity or identity, got " + prior);
  }
  if (iterations.empty() || iterations.size() > 6) {
    throw InputError(c + "--iterations takes 1 to 6 counts, finest level first");
  }
  for (const int n : iterations) {
    if (n < 0 || n > 100) throw InputError(c + "--iterations: each count in [0, 100]");
  }
  icp->iterations = iterations;
  frame->levels = static_cast<int>(iterations.size());
  if (!(frame->min_depth_m >= 0.0 && frame->max_depth_m > frame->min_depth_m)) {
    throw InputError(c + "need 0 <= --min-depth < --max-depth");
  }
  const AssociationOptions& association = icp->association;
  if (!(association.max_distance_m > 0.0) ||
      !(association.max_normal_angle_deg > 0.0 && association.max_normal_angle_deg <= 180.0)) {
    throw InputError(c + "--max-distance must be > 0 and --max-angle in (0, 180]");
  }
  if (!(icp->weighting.huber_delta_m >= 0.0)) throw InputError(c + "--huber must be >= 0");
  if (threads < 1 || threads > kMaxTrackingThreads) {
    throw InputError(c + "--threads must be in [1, " + std::to_string(kMaxTrackingThreads) + "]");
  }
  if (max_frames < 0) throw InputError(c + "--max-frames must be >= 0 (0: all)");
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
  if (intrinsics.empty()) return;
  if (intrinsics.size() != 4) throw InputError(command + ": --intrinsics takes fx,fy,cx,cy");
  options->intrinsics =
      PinholeIntrinsics{intrinsics[0], intrinsics[1], intrinsics[2], intrinsics[3]};
}

void PrintTrajectoryEvaluation(const RgbdSequence& sequence, const Trajectory& estimate,
                               const Log& log) {
  const Trajectory gt = sequence.GroundTruth();
  if (gt.poses.empty()) {
    log.Warning("--evaluate: the sequence has no ground truth");
  } else {
    try {
      const TrajectoryErrors e = EvaluateTrajectory(estimate, gt, 0.02, 1);
      std::printf(
          "against the sequence's ground truth (%d poses): ATE RMSE %.2f mm, RPE per "
          "frame %.2f mm / %.3f deg\n",
          e.pairs, e.ate_rmse_m * 1e3, e.rpe_translation_rmse_m * 1e3,
          e.rpe_rotation_rmse_rad * kRadToDeg);
      const EndPointDrift drift = MeasureEndPointDrift(estimate, gt, 0.02);
      if (drift.anchored && drift.path_m > 0.0) {
        std::printf("end-point drift %.2f mm over %.2f m travelled (%.2f mm per metre)\n",
                    drift.drift_m * 1e3, drift.path_m, drift.drift_m * 1e3 / drift.path_m);
      } else {
        std::printf(
            "end-point drift: not measured (the first frame has no ground-truth pose "
            "within 0.02 s, or the camera did not move)\n");
      }
    } catch (const std::invalid_argument& error) {
      // The trajectory is written; only the comparison is impossible.
      log.Warning(std::string("--evaluate: ") + error.what());
    }
  }
}

}  // namespace rigfit::cli
