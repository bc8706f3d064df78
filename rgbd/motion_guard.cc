#include "rgbd/motion_guard.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/geometry.h"

namespace rigfit {
namespace {

/// The median of the recent values (the upper one of an even count).
double Median(const std::deque<double>& values) {
  std::vector<double> copy(values.begin(), values.end());
  return Quantile(&copy, 0.5);
}

// "0.12 m and 3.4 deg".
std::string Motion(const Pose& T) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.3f m and %.2f deg", T.translation().norm(),
                LogSO3(T.linear()).norm() * kRadToDeg);
  return text;
}

// Minimum history before the matched share and the residual are compared with it.
constexpr std::size_t kMinHistory = 3;

}  // namespace

Pose DampWeakVelocity(const Pose& velocity, const std::vector<Vec6>& weak, double length_m,
                      const Mat3& R_target_previous, double damping) {
  if (weak.empty()) return velocity;
  Vec6 y;
  y << length_m * (R_target_previous * LogSO3(velocity.linear())),
      R_target_previous * velocity.translation();
  // The weak directions are orthonormal eigenvectors: damp each component in turn.
  for (const Vec6& v : weak) y -= (1.0 - damping) * v.dot(y) * v;
  Pose damped = Pose::Identity();
  damped.linear() = ExpSO3(R_target_previous.transpose() * y.head<3>() / length_m);
  damped.translation() = R_target_previous.transpose() * y.tail<3>();
  return damped;
}

Pose NextVelocity(const Pose& T_world_previous, const Pose& T_world_current,
                  const Pose& T_world_target, const TrackResult& track, bool diverged,
                  const GuardOptions& options) {
  if (diverged) return Pose::Identity();
  const Pose velocity = Reorthonormalized(T_world_previous.inverse() * T_world_current);
  if (!options.enabled || !track.success) return velocity;
  const Mat3 R_target_previous = T_world_target.linear().transpose() * T_world_previous.linear();
  return DampWeakVelocity(velocity, track.weak, track.length_m, R_target_previous,
                          options.weak_velocity_damping);
}

std::string WeakDirectionName(const Vec6& weak) {
  int k = 0;
  weak.cwiseAbs().maxCoeff(&k);
  const char axis = static_cast<char>('x' + k % 3);
  return (k < 3 ? std::string("rotation about camera ")
                : std::string("translation along camera ")) +
         axis;
}

std::string MotionGuard::Suspect(const TrackResult& track, const Pose& T_prediction_estimate,
                                 const Pose& T_previous_estimate, double dt_s) const {
  const std::string motion = SuspectMotion(T_prediction_estimate, T_previous_estimate, dt_s);
  return motion.empty() ? SuspectHistory(track) : motion;
}

std::string MotionGuard::SuspectMotion(const Pose& T_prediction_estimate,
                                       const Pose& T_previous_estimate, double dt_s) const {
  const GuardOptions& o = options_;
  if (T_prediction_estimate.translation().norm() > o.max_correction_m ||
      LogSO3(T_prediction_estimate.linear()).norm() > o.max_correction_deg * kDegToRad) {
    return "a jump of " + Motion(T_prediction_estimate) + " from the prediction";
  }
  if (dt_s > 0.0 &&
      (T_previous_estimate.translation().norm() > o.max_speed_mps * dt_s ||
       LogSO3(T_previous_estimate.linear()).norm() > o.max_angular_speed_dps * kDegToRad * dt_s)) {
    return "moved " + Motion(T_previous_estimate) + " in " + std::to_string(dt_s) + " s";
  }
  return "";
}

std::string MotionGuard::SuspectHistory(const TrackResult& track) const {
  const GuardOptions& o = options_;
  if (matched_.size() < kMinHistory) return "";
  const double matched = Median(matched_);
  if (track.matched_ratio < o.min_matched_share * matched) {
    return "the matched share fell to " + std::to_string(track.matched_ratio) + " (recent " +
           std::to_string(matched) + ")";
  }
  const double rmse = Median(rmse_);
  if (track.rmse_m > o.max_rmse_growth * rmse) {
    return "the residual rose to " + std::to_string(track.rmse_m * 1e3) + " mm (recent " +
           std::to_string(rmse * 1e3) + " mm)";
  }
  return "";
}

bool MotionGuard::SamePose(const Pose& a, const Pose& b) const {
  return WithinMotion(a.inverse() * b, options_.same_pose_m, options_.same_pose_deg);
}

double MotionGuard::RecentMatchedShare() const {
  return matched_.size() < kMinHistory ? 1.0 : Median(matched_);
}

void MotionGuard::Forget() {
  matched_.clear();
  rmse_.clear();
}

void MotionGuard::Remember(const TrackResult& track) {
  matched_.push_back(track.matched_ratio);
  rmse_.push_back(track.rmse_m);
  while (static_cast<int>(matched_.size()) > std::max(1, options_.history)) {
    matched_.pop_front();
    rmse_.pop_front();
  }
}

GuardedTrack MotionGuard::Track(const TrackFrom& track_from, const Pose& predicted,
                                const Pose& T_world_previous, double dt_s,
                                const std::string& frame_name, const Log& log) {
  GuardedTrack guarded;
  std::tie(guarded.track, guarded.T_world_camera) = track_from(predicted);
  if (!options_.enabled || !guarded.track.success) {
    if (guarded.track.success) Remember(guarded.track);
    return guarded;
  }
  const Pose& estimate = guarded.T_world_camera;
  const std::string motion =
      SuspectMotion(predicted.inverse() * estimate, T_world_previous.inverse() * estimate, dt_s);
  const std::string reason = motion.empty() ? SuspectHistory(guarded.track) : motion;
  if (reason.empty()) {
    Remember(guarded.track);
    return guarded;
  }
  auto [retrack, T_retrack] = track_from(T_world_previous);
  if (retrack.success && motion.empty() && SamePose(estimate, T_retrack)) {
    log.Warning(frame_name + ": suspected divergence (" + reason +
                "); re-tracked from the last good pose to the same pose: accepted");
    guarded.recovered = true;
    Remember(guarded.track);
    return guarded;
  }
  const Pose step = T_world_previous.inverse() * T_retrack;
  const std::string again = retrack.success ? Suspect(retrack, step, step, dt_s) : retrack.message;
  if (again.empty()) {
    log.Warning(frame_name + ": suspected divergence (" + reason +
                "); re-tracked from the last good pose: recovered");
    guarded.track = retrack;
    guarded.T_world_camera = T_retrack;
    guarded.recovered = true;
    Remember(retrack);
    return guarded;
  }
  log.Warning(frame_name + ": diverged (" + reason +
              "; re-tracked from the last good pose: " + again + "); kept the last good pose");
  guarded.track.success = false;
  guarded.track.message = "diverged: " + reason;
  guarded.T_world_camera = T_world_previous;
  guarded.diverged = true;
  return guarded;
}

}  // namespace rigfit
