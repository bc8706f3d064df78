#include "core/trajectory.h"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "core/errors.h"
#include "core/geometry.h"

namespace rigfit {

std::vector<std::pair<int, int>> AssociateByTimestamp(const std::vector<double>& est,
                                                      const std::vector<double>& gt,
                                                      double max_dt) {
  // Every candidate (|dt| <= max_dt), closest first; each index used once.
  struct Candidate {
    double dt;
    int i;
    int j;
  };
  std::vector<Candidate> candidates;
  for (int i = 0; i < static_cast<int>(est.size()); ++i) {
    const auto lo = std::lower_bound(gt.begin(), gt.end(), est[i] - max_dt);
    for (auto it = lo; it != gt.end() && *it <= est[i] + max_dt; ++it) {
      candidates.push_back({std::abs(*it - est[i]), i, static_cast<int>(it - gt.begin())});
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const Candidate& a, const Candidate& b) { return a.dt < b.dt; });
  std::vector<bool> used_est(est.size(), false), used_gt(gt.size(), false);
  std::vector<std::pair<int, int>> pairs;
  for (const Candidate& c : candidates) {
    if (used_est[c.i] || used_gt[c.j]) continue;
    used_est[c.i] = used_gt[c.j] = true;
    pairs.emplace_back(c.i, c.j);
  }
  std::sort(pairs.begin(), pairs.end());
  return pairs;
}

Pose AlignRigid(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  Pose S = Pose::Identity();
  if (a.empty() || a.size() != b.size()) return S;
  Vec3 mean_a = Vec3::Zero(), mean_b = Vec3::Zero();
  for (size_t k = 0; k < a.size(); ++k) {
    mean_a += a[k];
    mean_b += b[k];
  }
  mean_a /= static_cast<double>(a.size());
  mean_b /= static_cast<double>(b.size());
  Mat3 cross = Mat3::Zero();  // sum (b - mean_b)(a - mean_a)^T
  for (size_t k = 0; k < a.size(); ++k) {
    cross += (b[k] - mean_b) * (a[k] - mean_a).transpose();
  }
  const Eigen::JacobiSVD<Mat3> svd(cross, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0) D(2, 2) = -1.0;
  S.linear() = svd.matrixU() * D * svd.matrixV().transpose();
  S.translation() = mean_b - S.linear() * mean_a;
  return S;
}

void CheckTrajectoryEvaluationSettings(double max_dt, int delta) {
  if (!(max_dt > 0.0)) throw SettingError("max_dt", "must be > 0");
  if (delta < 1) throw SettingError("delta", "must be >= 1");
}

TrajectoryErrors EvaluateTrajectory(const Trajectory& est, const Trajectory& gt, double max_dt,
                                    int delta) {
  if (delta < 1) throw std::invalid_argument("EvaluateTrajectory: delta must be >= 1");
  const std::vector<std::pair<int, int>> pairs =
      AssociateByTimestamp(est.timestamps, gt.timestamps, max_dt);
  if (pairs.size() < 3) {
    throw std::invalid_argument("only " + std::to_string(pairs.size()) +
                                " poses match in time (within " + std::to_string(max_dt) +
                                " s): at least 3 are needed");
  }
  TrajectoryErrors e;
  e.pairs = static_cast<int>(pairs.size());
  std::vector<Vec3> a, b;
  for (const auto& [i, j] : pairs) {
    a.push_back(est.poses[i].translation());
    b.push_back(gt.poses[j].translation());
  }
  e.T_gt_est = AlignRigid(a, b);
  double sum2 = 0.0, sum = 0.0;
  for (size_t k = 0; k < a.size(); ++k) {
    const double d = (b[k] - e.T_gt_est * a[k]).norm();
    e.ate_m.push_back(d);
    sum2 += d * d;
    sum += d;
    e.ate_max_m = std::max(e.ate_max_m, d);
  }
  e.ate_rmse_m = std::sqrt(sum2 / a.size());
  e.ate_mean_m = sum / a.size();
  std::vector<double> ate = e.ate_m;
  e.ate_median_m = Quantile(&ate, 0.5);  // the upper median of an even count

  double t2 = 0.0, r2 = 0.0;
  for (size_t k = 0; k + delta < pairs.size(); ++k) {
    const auto [i0, j0] = pairs[k];
    const auto [i1, j1] = pairs[k + delta];
    const RelativePoseError r =
        RelativeError(est.poses[i0], est.poses[i1], gt.poses[j0], gt.poses[j1]);
    t2 += r.translation_m * r.translation_m;
    r2 += r.rotation_rad * r.rotation_rad;
    ++e.rpe_pairs;
  }
  if (e.rpe_pairs > 0) {
    e.rpe_translation_rmse_m = std::sqrt(t2 / e.rpe_pairs);
    e.rpe_rotation_rmse_rad = std::sqrt(r2 / e.rpe_pairs);
  }
  return e;
}

EndPointDrift MeasureEndPointDrift(const Trajectory& est, const Trajectory& gt, double max_dt) {
  const std::vector<std::pair<int, int>> pairs =
      AssociateByTimestamp(est.timestamps, gt.timestamps, max_dt);
  if (pairs.size() < 2) {
    throw std::invalid_argument("end-point drift needs at least 2 poses matched in time, got " +
                                std::to_string(pairs.size()));
  }
  EndPointDrift drift;
  const auto& [e0, g0] = pairs.front();
  const auto& [e1, g1] = pairs.back();
  const Vec6 start = PoseDifference(gt.poses[g0], est.poses[e0]);
  drift.anchored = start.head<3>().norm() < 1e-6 && start.tail<3>().norm() < 1e-6;
  drift.drift_m = (est.poses[e1].translation() - gt.poses[g1].translation()).norm();
  for (std::size_t k = 1; k < pairs.size(); ++k) {
    drift.path_m +=
        (gt.poses[pairs[k].second].translation() - gt.poses[pairs[k - 1].second].translation())
            .norm();
  }
  return drift;
}

LoopDrift MeasureLoopDrift(const Trajectory& est, const Trajectory& gt, double max_dt) {
  const std::vector<std::pair<int, int>> pairs =
      AssociateByTimestamp(est.timestamps, gt.timestamps, max_dt);
  if (pairs.size() < 2) {
    throw std::invalid_argument(
        "the loop's end drift needs at least 2 poses matched in time, got " +
        std::to_string(pairs.size()));
  }
  constexpr double kClosedM = 1e-3;
  constexpr double kClosedRad = 0.1 * kDegToRad;
  const auto& [e0, g0] = pairs.front();
  const auto& [e1, g1] = pairs.back();
  const Pose gt_motion = gt.poses[g0].inverse() * gt.poses[g1];
  const Pose error = gt_motion.inverse() * (est.poses[e0].inverse() * est.poses[e1]);
  LoopDrift drift;
  drift.translation_m = error.translation().norm();
  drift.rotation_rad = LogSO3(error.linear()).norm();
  drift.closed =
      gt_motion.translation().norm() < kClosedM && LogSO3(gt_motion.linear()).norm() < kClosedRad;
  return drift;
}

}  // namespace rigfit
