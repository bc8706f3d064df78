#include "report/trajectory_report.h"

#include <Eigen/Eigenvalues>

#include "core/format.h"
#include "core/geometry.h"
#include "io/png.h"
#include "report/html.h"
#include "report/palette.h"
#include "report/refine_report.h"

namespace rigfit {

TrajectoryPlane FitTrajectoryPlane(const std::vector<Vec3>& positions) {
  TrajectoryPlane plane;
  if (positions.empty()) return plane;
  for (const Vec3& p : positions) plane.origin += p;
  plane.origin /= static_cast<double>(positions.size());
  if (positions.size() < 2) return plane;
  Mat3 scatter = Mat3::Zero();
  for (const Vec3& p : positions) scatter += (p - plane.origin) * (p - plane.origin).transpose();
  const Eigen::SelfAdjointEigenSolver<Mat3> eigen(scatter);  // eigenvalues ascending
  plane.axis_1 = Signed(eigen.eigenvectors().col(2));
  plane.axis_2 = Signed(eigen.eigenvectors().col(1));
  return plane;
}

std::vector<PlotCurve> TrajectoryPlanCurves(const Trajectory& est, const Trajectory& gt,
                                            const TrajectoryErrors& errors,
                                            const TrajectoryPlane& plane) {
  PlotCurve truth{"ground truth", kGroundTruthColor, kGroundTruthWidth, {}, {}};
  for (const Pose& T : gt.poses) {
    truth.x.push_back(plane.X(T.translation()));
    truth.y.push_back(plane.Y(T.translation()));
  }
  PlotCurve estimate{"estimate (aligned)", CameraColor(0), kEstimateWidth, {}, {}};
  for (const Pose& T : est.poses) {
    const Vec3 p = errors.T_gt_est * T.translation();
    estimate.x.push_back(plane.X(p));
    estimate.y.push_back(plane.Y(p));
  }
  return {truth, estimate};
}

std::vector<std::string> WriteTrajectoryReport(const std::string& dir, const Trajectory& est,
                                               const Trajectory& gt, const TrajectoryErrors& errors,
                                               double max_dt, const std::string& summary) {
  CreateReportDirectory(dir);
  ReportDirectory report(dir);

  std::vector<Vec3> gt_positions;
  for (const Pose& T : gt.poses) gt_positions.push_back(T.translation());
  const TrajectoryPlane plane = FitTrajectoryPlane(gt_positions);
  const std::vector<PlotCurve> plan = TrajectoryPlanCurves(est, gt, errors, plane);
  const std::string ate = "ATE RMSE " + Fixed(errors.ate_rmse_m * 1e3, 2) + " mm over " +
                          std::to_string(errors.pairs) + " matched poses";
  report.AddPicture(
      kTrajectoryPlanFile,
      DrawCurves(plan, FitPlotFrame(plan, kPlanViewWidth, kPlanViewHeight, true, false),
                 "Trajectories from above",
                 ate + "; seen along the ground truth's axis of least spread", "axis 1 (m)",
                 "axis 2 (m)"),
      "The aligned estimate and the ground truth seen from above; " + ate);

  const std::vector<std::pair<int, int>> pairs =
      AssociateByTimestamp(est.timestamps, gt.timestamps, max_dt);
  PlotCurve error{"ATE per pose", CameraColor(0), 2, {}, {}};
  for (size_t k = 0; k < pairs.size() && k < errors.ate_m.size(); ++k) {
    error.x.push_back(gt.timestamps[pairs[k].second] - gt.timestamps[pairs.front().second]);
    error.y.push_back(errors.ate_m[k] * 1e3);
  }
  report.AddPicture(
      kTrajectoryAteFile,
      DrawCurves({error}, FitPlotFrame({error}, kTimePlotWidth, kTimePlotHeight, false, true),
                 "Absolute trajectory error over time", ate, "time (s)", "ATE (mm)"),
      "Absolute trajectory error of each matched pose over time");
  return report.Finish("rigfit evaluate-trajectory report", summary);
}

}  // namespace rigfit
