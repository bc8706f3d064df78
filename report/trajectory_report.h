// The pictures of `rigfit evaluate-trajectory --report DIR`: the estimated (aligned) and the
// ground-truth trajectories seen from above, and the absolute trajectory error over time
// (docs/usage.md, "rigfit evaluate-trajectory").
#pragma once

#include <string>
#include <vector>

#include "core/trajectory.h"
#include "report/plots.h"

namespace rigfit {

/// The report's files, in DIR.
inline constexpr const char* kTrajectoryPlanFile = "trajectory_plan.png";
inline constexpr const char* kTrajectoryAteFile = "trajectory_ate.png";

/// How every picture draws a ground truth (wide, grey) and an estimate (narrow, in
/// CameraColor(0), on top): where the two coincide the grey shows as a rim.
inline constexpr Rgb kGroundTruthColor{120, 120, 120};
inline constexpr int kGroundTruthWidth = 7;  ///< pixels
inline constexpr int kEstimateWidth = 3;

/// The plane a trajectory is seen in: through the mean of its positions, spanned by their
/// first two principal axes (the direction of largest spread to the right, the second one
/// up, each signed so that its largest component is positive). The view is along the axis
/// of least spread, which for a camera carried through a room is the vertical whatever the
/// world's up axis is (TUM motion capture is not +Y up).
struct TrajectoryPlane {
  Vec3 origin = Vec3::Zero();
  Vec3 axis_1 = Vec3::UnitX();  ///< plot x
  Vec3 axis_2 = Vec3::UnitY();  ///< plot y
  /// Coordinates (metres) of p in the plane.
  double X(const Vec3& p) const { return axis_1.dot(p - origin); }
  double Y(const Vec3& p) const { return axis_2.dot(p - origin); }
};

/// The principal plane of the positions (fewer than 2: the world x-y plane through them).
TrajectoryPlane FitTrajectoryPlane(const std::vector<Vec3>& positions);

/// The two curves of the plan view in the plane of gt: gt's positions (drawn first, wide)
/// and est's positions moved by errors.T_gt_est (the ATE alignment; narrow, on top).
std::vector<PlotCurve> TrajectoryPlanCurves(const Trajectory& est, const Trajectory& gt,
                                            const TrajectoryErrors& errors,
                                            const TrajectoryPlane& plane);

/// Writes, in dir (created if missing; its parent must exist), kTrajectoryPlanFile (the
/// plan view of TrajectoryPlanCurves at equal scale on both axes, kPlanViewWidth x
/// kPlanViewHeight) and kTrajectoryAteFile (errors.ate_m in mm against the ground-truth
/// timestamp of each pair, seconds from the first pair's, kTimePlotWidth x kTimePlotHeight).
/// The pairs are those of EvaluateTrajectory (AssociateByTimestamp with max_dt). Also
/// kReportIndexFile (report/html.h): one page showing `summary` (the text the command
/// printed; may be empty) and the two pictures. Returns the paths written, the page last.
/// Throws InputError when dir or a file cannot be written.
std::vector<std::string> WriteTrajectoryReport(const std::string& dir, const Trajectory& est,
                                               const Trajectory& gt, const TrajectoryErrors& errors,
                                               double max_dt, const std::string& summary = "");

}  // namespace rigfit
