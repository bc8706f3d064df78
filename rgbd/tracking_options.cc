#include "rgbd/tracking_options.h"

#include "core/setting_error.h"

namespace rigfit {

const char* MotionPriorName(MotionPrior prior) {
  return prior == MotionPrior::kConstantVelocity ? "constant-velocity" : "identity";
}

void ApplyTrackingSettings(const std::string& prior, const std::vector<int>& iterations,
                           TrackingLoopOptions* loop) {
  FrameOptions* frame = &loop->frame;
  ProjectiveIcpOptions* icp = &loop->icp;
  if (prior == MotionPriorName(MotionPrior::kConstantVelocity)) {
    loop->prior = MotionPrior::kConstantVelocity;
  } else if (prior == MotionPriorName(MotionPrior::kIdentity)) {
    loop->prior = MotionPrior::kIdentity;
  } else {
    throw SettingError("prior", "must be constant-velocity or identity, got " + prior);
  }
  if (iterations.empty() || iterations.size() > 6) {
    throw SettingError("iterations", "takes 1 to 6 counts, finest level first");
  }
  for (const int n : iterations) {
    if (n < 0 || n > 100) {
      throw SettingError::Worded("iterations", "{iterations}: each count in [0, 100]");
    }
  }
  icp->iterations = iterations;
  frame->levels = static_cast<int>(iterations.size());
  if (!(frame->min_depth_m >= 0.0 && frame->max_depth_m > frame->min_depth_m)) {
    throw SettingError::Worded("min_depth", "need 0 <= {min_depth} < {max_depth}");
  }
  const AssociationOptions& association = icp->association;
  if (!(association.max_distance_m > 0.0) ||
      !(association.max_normal_angle_deg > 0.0 && association.max_normal_angle_deg <= 180.0)) {
    throw SettingError("max_distance", "must be > 0 and {max_angle} in (0, 180]");
  }
  if (!(icp->weighting.huber_delta_m >= 0.0)) {
    throw SettingError("huber", "must be >= 0");
  }
  if (!(icp->weighting.noise_floor_depth_m >= 0.0)) {
    throw SettingError("noise_floor_depth", "must be >= 0 (0: no floor)");
  }
  if (loop->threads < 1 || loop->threads > kMaxTrackingThreads) {
    throw SettingError("threads", "must be in [1, " + std::to_string(kMaxTrackingThreads) + "]");
  }
  if (loop->max_frames < 0) throw SettingError("max_frames", "must be >= 0 (0: all)");
}

const char* ColorTrackingName(ColorTracking mode) {
  switch (mode) {
    case ColorTracking::kOff:
      return "off";
    case ColorTracking::kOn:
      return "on";
    case ColorTracking::kAuto:
      break;
  }
  return "auto";
}

void ApplyColorTracking(const std::string& mode, TrackingLoopOptions* loop) {
  for (const ColorTracking m : {ColorTracking::kAuto, ColorTracking::kOn, ColorTracking::kOff}) {
    if (mode == ColorTrackingName(m)) {
      loop->color_tracking = m;
      return;
    }
  }
  throw SettingError("color_tracking", "must be auto, on or off, got " + mode);
}

void ApplyMinStep(double min_step_m, ProjectiveIcpOptions* icp) {
  if (!(min_step_m > 0.0)) throw SettingError("min_step", "must be > 0");
  icp->converged_translation_m = min_step_m;
  icp->converged_rotation_rad = min_step_m;
}

void ApplyWeakRatio(double weak_ratio, ProjectiveIcpOptions* icp) {
  if (!(weak_ratio > 0.0 && weak_ratio < 1.0))
    throw SettingError("weak_ratio", "must be in (0, 1)");
  icp->weak_direction_ratio = weak_ratio;
}

}  // namespace rigfit
