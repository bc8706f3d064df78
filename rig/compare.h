// The comparison of `rigfit compare` and `rigfit.compare` (docs/usage.md, `rigfit compare`):
// the three ways to refine a rig run on the same capture and initial extrinsics, one after
// the other in this process, and measured the same way: each camera's change and (with the
// truth) its gauge-free error, each pair's fit before and after (rig/diagnostics.h), the
// joint 1-sigma, the surface bundle's plane thickness, wall time and peak memory, and a
// verdict from these numbers. Its JSON document and text tables are report/compare.h's.
#pragma once

#include <string>
#include <vector>

#include "core/evaluate.h"
#include "core/log.h"
#include "core/types.h"
#include "options/refine_options.h"
#include "rig/diagnostics.h"
#include "rig/refine.h"

namespace rigfit {

/// Where the inputs came from, as the JSON document and the header line name them (empty:
/// not given, null in the JSON).
struct CompareSources {
  std::string capture;
  std::string extrinsics;
  std::string ground_truth;
  std::string config;
};

/// One refinement of the comparison.
struct CompareRun {
  /// "pairwise" (pairwise ICP + pose graph), "joint" (joint registration) or
  /// "surface_bundle" (joint registration, then the surface bundle).
  std::string name;
  RefineMode mode = RefineMode::kJoint;
  RegistrationMethod method = RegistrationMethod::kPointToPlane;
  bool surface_bundle = false;  ///< the surface bundle ran after the registration
  bool success = false;         ///< false: the refinement was not applied (output = leveled)
  std::string message;
  std::vector<std::string> warnings;
  PoseMap output;  ///< what `rigfit refine` would write: refined, or leveled when not applied
  std::vector<CameraReport> cameras;  ///< capture order
  SurfaceBundleReport surface;        ///< ran only in the surface_bundle run
  double wall_s = 0.0;                ///< the Refine call
  double peak_rss_mb = 0.0;           ///< VmHWM after the Refine call (core/peak_memory.h)
  bool peak_per_run = false;          ///< false: the mark could not be reset (process-wide)
  std::vector<PairDiagnostics> fit;   ///< at `output`
  RigErrors errors;                   ///< against the truth, when CompareResult::has_gt
};

/// What Compare measured.
struct CompareResult {
  /// The registration residual of every run (icp.method).
  RegistrationMethod method = RegistrationMethod::kPointToPlane;
  std::string reference;
  std::vector<std::string> serials;  ///< the capture's cameras, in capture order
  PoseMap initial;
  PoseMap leveled;  ///< the shared start: leveling alone, as every run ran it
  /// The candidate pairs' cameras (PairDiagnostics::a, b index into it) and their fit at the
  /// leveled poses.
  std::vector<std::string> pair_serials;
  std::vector<PairDiagnostics> fit_before;
  std::vector<CompareRun> runs;  ///< pairwise, joint, surface_bundle
  bool has_gt = false;
  RigErrors errors_initial, errors_leveled;
  double baseline_rss_mb = 0.0;  ///< resident size before the runs
  std::string verdict;
};

/// Runs the three refinements of `capture` from `initial`, each with `options` but icp.mode
/// and icp.surface_bundle, which each run sets: pairwise and joint without the surface bundle,
/// then joint with it; all with the configured icp.method. `gt` (may be
/// null) adds the gauge-free errors; it must hold every camera of the capture. Progress goes
/// to `log`, each run's prefixed with its name; options.threads threads. Throws InputError on
/// inputs that do not match (CheckCompareInput, then Refine's CheckRefineInput), never on bad
/// geometry: a run that was not applied says so.
CompareResult Compare(const RigCapture& capture, const PoseMap& initial,
                      const RefineOptions& options, const PoseMap* gt, const Log& log = Log{});

/// One line naming the best run and the measured numbers behind it: with the truth, by the
/// RMS relative translation and rotation errors; without, by the pooled fit of the pairs
/// (off-floor RMSE, RMSE, inlier fraction). Runs within 5% of the best value of a measure
/// tie on it; the best is the run best or tied on every measure that is not a tie of all
/// ("even" when several, "mixed" when none). A run whose refinement was not applied is left
/// out and named. Compare sets CompareResult::verdict to it.
std::string CompareVerdict(const CompareResult& result);

/// Throws InputError ("compare: ...", naming the input by `names`, or "the capture" and "the
/// ground truth" when empty) for a capture of one camera or a camera of the capture that `gt`
/// (may be null) has no pose for. Compare calls it; callers with file names call it first.
void CheckCompareInput(const RigCapture& capture, const PoseMap* gt, const CompareSources& names);

/// All pairs pooled: RMS residual (all and off the floor) and inlier fraction.
struct PooledFit {
  double rmse_m = 0.0;
  double off_floor_rmse_m = 0.0;
  double inlier_fraction = 0.0;
  int correspondences = 0;
  int off_floor_correspondences = 0;
};

/// The pairs' fits pooled: RMS residual over all their correspondences (and over those off
/// the floor) and the share of their points matched.
PooledFit PoolFits(const std::vector<PairDiagnostics>& pairs);

}  // namespace rigfit
