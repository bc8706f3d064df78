// `rigfit evaluate-trajectory EST GT`: the errors of an estimated camera trajectory against
// ground truth, in the TUM RGB-D benchmark's conventions (core/trajectory.h).
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "core/errors.h"
#include "core/format.h"
#include "core/pose.h"
#include "core/trajectory.h"
#include "io/trajectory_tum.h"
#include "report/refine_report.h"
#include "report/trajectory_report.h"

namespace rigfit::cli {
namespace {

struct EvaluateTrajectoryArgs {
  std::string estimate_path;
  std::string ground_truth_path;
  double max_dt = 0.02;
  int delta = 1;
  std::string report_dir;  ///< empty: no report
};

int RunEvaluateTrajectory(const EvaluateTrajectoryArgs& a) {
  CheckTrajectoryEvaluationSettings(a.max_dt, a.delta);
  if (!a.report_dir.empty()) CheckReportDirectory(a.report_dir, "evaluate-trajectory: --report");
  const Trajectory est = ReadTumTrajectory(a.estimate_path);
  const Trajectory gt = ReadTumTrajectory(a.ground_truth_path);
  TrajectoryErrors e;
  try {
    e = EvaluateTrajectory(est, gt, a.max_dt, a.delta);
  } catch (const std::invalid_argument& error) {
    throw InputError("evaluate-trajectory: " + a.estimate_path + " against " + a.ground_truth_path +
                     ": " + error.what());
  }
  std::string summary;
  Appendf(&summary,
          "%s against %s: %d of %zu poses matched in time (within %.3f s), the estimate "
          "aligned rigidly (no scale)\n\n",
          a.estimate_path.c_str(), a.ground_truth_path.c_str(), e.pairs, est.poses.size(),
          a.max_dt);
  Appendf(&summary,
          "ATE (absolute trajectory error, mm): RMSE %.2f, mean %.2f, median %.2f, max %.2f\n",
          e.ate_rmse_m * 1e3, e.ate_mean_m * 1e3, e.ate_median_m * 1e3, e.ate_max_m * 1e3);
  Appendf(&summary,
          "RPE over %d matched pose(s) (%d pairs): translation RMSE %.2f mm, rotation RMSE "
          "%.3f deg\n",
          a.delta, e.rpe_pairs, e.rpe_translation_rmse_m * 1e3,
          e.rpe_rotation_rmse_rad * kRadToDeg);
  const LoopDrift loop = MeasureLoopDrift(est, gt, a.max_dt);
  Appendf(
      &summary, "%s %.2f mm / %.3f deg (the motion from the first matched pose to the last)\n",
      loop.closed ? "closed loop (the ground truth ends where it starts): end drift" : "end drift",
      loop.translation_m * 1e3, loop.rotation_rad * kRadToDeg);
  std::fputs(summary.c_str(), stdout);
  if (!a.report_dir.empty()) {
    for (const std::string& file :
         WriteTrajectoryReport(a.report_dir, est, gt, e, a.max_dt, summary)) {
      std::printf("report: %s\n", file.c_str());
    }
  }
  return kExitOk;
}

}  // namespace

Command AddEvaluateTrajectoryCommand(CLI::App& app) {
  auto args = std::make_shared<EvaluateTrajectoryArgs>();
  CLI::App* sub = app.add_subcommand(
      "evaluate-trajectory",
      "Errors of an estimated camera trajectory EST against ground truth GT, both in the TUM "
      "RGB-D format (timestamp tx ty tz qx qy qz qw per line): poses matched by nearest "
      "timestamp, the absolute trajectory error (ATE) after the rigid alignment that minimises "
      "it (no scale), and the relative pose error (RPE) over --delta matched poses. Exit codes: "
      "0 done; 2 bad input or usage.");
  sub->add_option("EST", args->estimate_path, "Estimated trajectory (TUM format)")->required();
  sub->add_option("GT", args->ground_truth_path, "Ground-truth trajectory (TUM format)")
      ->required();
  sub->add_option("--max-dt", args->max_dt, "Largest time difference of matched poses, seconds")
      ->capture_default_str();
  sub->add_option("--delta", args->delta, "RPE: matched poses between the two of a pair")
      ->capture_default_str();
  sub->add_option("--report", args->report_dir,
                  "Also write pictures to this directory (created if missing; its parent must "
                  "exist): the aligned estimate and the ground truth seen from above (along the "
                  "ground truth's axis of least spread) and the ATE over time (docs/usage.md)");
  return {sub, [args] { return RunEvaluateTrajectory(*args); }};
}

}  // namespace rigfit::cli
