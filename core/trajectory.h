// Trajectories of a moving camera and their errors against ground truth, in the conventions of
// the TUM RGB-D benchmark (Sturm et al., IROS 2012): poses associated by timestamp, the
// absolute trajectory error (ATE) after the rigid alignment that minimises it (Horn / Umeyama,
// no scale), and the relative pose error (RPE) over a fixed number of frames.
#pragma once

#include <string>
#include <vector>

#include "core/pose.h"
#include "core/setting_error.h"

namespace rigfit {

/// A camera trajectory: T_world_camera at increasing timestamps (seconds).
struct Trajectory {
  std::vector<double> timestamps;
  std::vector<Pose> poses;
};

/// Pairs (i in est, j in gt) of nearest timestamps: each estimate takes the ground-truth pose
/// closest in time, kept when within max_dt seconds; each ground-truth pose is used once, by
/// the estimate closest to it (the TUM tools' greedy association). Sorted by the estimate's
/// index.
std::vector<std::pair<int, int>> AssociateByTimestamp(const std::vector<double>& est,
                                                      const std::vector<double>& gt, double max_dt);

/// The rigid motion S (rotation and translation, no scale) minimising sum |S a_k - b_k|^2, in
/// closed form (Umeyama 1991 without scale: the SVD of the cross-covariance, det corrected).
/// Needs at least 3 points not on a line for a unique rotation; fewer give the best the SVD
/// offers.
Pose AlignRigid(const std::vector<Vec3>& a, const std::vector<Vec3>& b);

struct TrajectoryErrors {
  int pairs = 0;            ///< associated poses
  Pose T_gt_est;            ///< the alignment applied to the estimate
  double ate_rmse_m = 0.0;  ///< RMS of |t_gt - S t_est| over the pairs
  double ate_mean_m = 0.0;
  double ate_median_m = 0.0;
  double ate_max_m = 0.0;
  std::vector<double> ate_m;  ///< per pair, in pair order
  int rpe_pairs = 0;          ///< pose pairs `delta` frames apart (in the associated list)
  double rpe_translation_rmse_m = 0.0;
  double rpe_rotation_rmse_rad = 0.0;
};

/// ATE and RPE of `est` against `gt` over the associated pairs (AssociateByTimestamp with
/// max_dt). RPE compares the relative motions (T_i^-1 T_{i+delta}) of the pairs' estimate and
/// truth, delta >= 1 pairs apart. Throws std::invalid_argument with fewer than 3 pairs.
TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& gt, double max_dt,
                                    int delta);

/// The checks of `rigfit evaluate-trajectory`'s --max-dt and --delta (rigfit's
/// evaluate_trajectory(max_dt=, delta=)): max_dt > 0, delta >= 1. Throws SettingError
/// (core/setting_error.h) on a bad value.
void CheckTrajectoryEvaluationSettings(double max_dt, int delta);

/// How far a trajectory that starts at the truth has wandered off at its end: over the pairs
/// of AssociateByTimestamp(max_dt), the distance between the last pair's positions (no
/// alignment) and the length of the true path between the first and the last pair.
/// `anchored` is false when the first pair's poses differ (by more than 1e-6 m or rad): the
/// drift of an estimate in another frame means nothing. Throws std::invalid_argument with
/// fewer than 2 pairs.
struct EndPointDrift {
  double drift_m = 0.0;
  double path_m = 0.0;
  bool anchored = false;
};
EndPointDrift MeasureEndPointDrift(const Trajectory& est, const Trajectory& gt, double max_dt);

/// The end drift of a loop: the error of the estimated motion from the first matched pose to
/// the last, E = (T_gt_first^-1 T_gt_last)^-1 (T_est_first^-1 T_est_last), independent of the
/// estimate's frame. On a closed loop (the ground truth's last pose back at its first within
/// 1 mm and 0.1 degree: `closed`) it is the last pose against the first. Throws
/// std::invalid_argument with fewer than 2 pairs (AssociateByTimestamp with max_dt).
struct LoopDrift {
  double translation_m = 0.0;  ///< |E's translation|
  double rotation_rad = 0.0;   ///< E's rotation angle
  bool closed = false;
};
LoopDrift MeasureLoopDrift(const Trajectory& est, const Trajectory& gt, double max_dt);

}  // namespace rigfit
