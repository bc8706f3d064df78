#include "rig/compare.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "core/errors.h"
#include "core/format.h"
#include "core/peak_memory.h"
#include "core/stopwatch.h"

namespace rigfit {
namespace {

constexpr double kMToMm = 1e3;
/// Two numbers closer than this fraction of the larger one are called even in the verdict.
constexpr double kEvenFraction = 0.05;
/// The most decimals a number of the verdict is written with.
constexpr int kMaxVerdictDigits = 6;

/// Runs Refine once, as `rigfit refine` would with `options` (whose icp.mode and
/// icp.surface_bundle the caller set for this run). Its peak resident memory is the process's
/// high-water mark, reset before the run (core/peak_memory.h): the capture already loaded counts in
/// it, memory an earlier run freed does not.
CompareRun RunOne(const std::string& name, const RigCapture& capture, const PoseMap& initial,
                  RefineOptions options, const Log& log) {
  CompareRun run;
  run.name = name;
  run.mode = options.icp.mode;
  run.method = options.icp.method;
  run.surface_bundle = options.icp.surface_bundle;
  const Log run_log{[&log, name](LogLevel level, const std::string& message) {
    if (log.sink) log.sink(level, name + ": " + message);
  }};
  const PeakMemory memory;
  const auto start = std::chrono::steady_clock::now();
  RefineResult result;
  try {
    options.run_registration = true;
    result = Refine(capture, initial, options, run_log);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw std::runtime_error("compare: " + name + ": " + e.what());
  }
  run.wall_s = SecondsSince(start);
  run.peak_rss_mb = memory.PeakMb();
  run.peak_per_run = memory.reset();
  run.success = result.success;
  run.message = result.message;
  run.warnings = result.warnings;
  run.output = result.success ? result.refined : result.leveled;
  run.cameras = result.cameras;
  run.surface = result.surface;
  return run;
}

/// How the runs are measured in the verdict: one number per applied run.
struct Metric {
  std::string what;
  std::vector<double> values;  ///< per applied run
  int digits = 2;
  std::string unit;
  bool higher_is_better = false;
};

/// The runs (indices into `applied`) within kEvenFraction of the metric's best value.
std::vector<size_t> Best(const Metric& m) {
  double best = m.values[0];
  for (double v : m.values) best = m.higher_is_better ? std::max(best, v) : std::min(best, v);
  std::vector<size_t> out;
  for (size_t r = 0; r < m.values.size(); ++r) {
    const double v = m.values[r];
    if (std::abs(v - best) <= kEvenFraction * std::max(std::abs(v), std::abs(best))) {
      out.push_back(r);
    }
  }
  return out;
}

/// A name for an input in the text: its source, or `fallback` when not given.
std::string NameOr(const std::string& name, const std::string& fallback) {
  return name.empty() ? fallback : name;
}

}  // namespace

PooledFit PoolFits(const std::vector<PairDiagnostics>& pairs) {
  PooledFit pooled;
  double sum_squares = 0.0, off_floor_sum_squares = 0.0;
  int points = 0;
  for (const PairDiagnostics& p : pairs) {
    sum_squares += p.rmse_m * p.rmse_m * p.correspondences;
    off_floor_sum_squares += p.off_floor_rmse_m * p.off_floor_rmse_m * p.off_floor_correspondences;
    pooled.correspondences += p.correspondences;
    pooled.off_floor_correspondences += p.off_floor_correspondences;
    points += p.points;
  }
  if (pooled.correspondences > 0) pooled.rmse_m = std::sqrt(sum_squares / pooled.correspondences);
  if (pooled.off_floor_correspondences > 0) {
    pooled.off_floor_rmse_m = std::sqrt(off_floor_sum_squares / pooled.off_floor_correspondences);
  }
  if (points > 0) pooled.inlier_fraction = static_cast<double>(pooled.correspondences) / points;
  return pooled;
}

namespace {

/// The measures of the applied runs: with the truth, the RMS relative errors; without, the
/// pooled fit of the pairs. `basis` says which.
std::vector<Metric> VerdictMetrics(const CompareResult& c,
                                   const std::vector<const CompareRun*>& applied,
                                   std::string* basis) {
  std::vector<Metric> metrics;
  if (c.has_gt) {
    *basis = "against the ground truth";
    metrics = {{"RMS relative translation error", {}, 2, " mm", false},
               {"RMS relative rotation error", {}, 3, " deg", false}};
    for (const CompareRun* run : applied) {
      metrics[0].values.push_back(run->errors.rms_translation_m * kMToMm);
      metrics[1].values.push_back(run->errors.rms_rotation_rad * kRadToDeg);
    }
    return metrics;
  }
  *basis = "no ground truth: judged by the fit of the pairs";
  metrics = {{"RMS off-floor pair residual", {}, 2, " mm", false},
             {"RMS pair residual", {}, 2, " mm", false},
             {"inlier fraction", {}, 3, "", true}};
  for (const CompareRun* run : applied) {
    const PooledFit f = PoolFits(run->fit);
    metrics[0].values.push_back(f.off_floor_rmse_m * kMToMm);
    metrics[1].values.push_back(f.rmse_m * kMToMm);
    metrics[2].values.push_back(f.inlier_fraction);
  }
  return metrics;
}

/// "joint and surface_bundle": the names of the runs (indices into `applied`).
std::string RunNames(const std::vector<const CompareRun*>& applied,
                     const std::vector<size_t>& runs) {
  std::vector<std::string> out;
  for (size_t r : runs) out.push_back(applied[r]->name);
  return Join(out, " and ");
}

/// "<what> 13.11 mm (pairwise), 9.20 mm (joint), ...", with 3 significant digits at least, so
/// that numbers the verdict tells apart print apart.
std::string MetricNumbers(const std::vector<const CompareRun*>& applied, const Metric& m) {
  int digits = m.digits;
  for (double v : m.values) {
    if (std::abs(v) > 0.0) {
      digits = std::max(digits, 2 - static_cast<int>(std::floor(std::log10(std::abs(v)))));
    }
  }
  digits = std::min(digits, kMaxVerdictDigits);
  std::vector<std::string> parts;
  for (size_t r = 0; r < m.values.size(); ++r) {
    parts.push_back(Fixed(m.values[r], digits) + m.unit + " (" + applied[r]->name + ")");
  }
  return m.what + " " + Join(parts, ", ");
}

}  // namespace

std::string CompareVerdict(const CompareResult& c) {
  std::vector<const CompareRun*> applied;
  std::vector<std::string> not_applied;
  for (const CompareRun& run : c.runs) {
    if (run.success) {
      applied.push_back(&run);
    } else {
      not_applied.push_back(run.name + " (" + run.message + ")");
    }
  }
  const std::string not_applied_note =
      not_applied.empty() ? "" : "; not applied: " + Join(not_applied, ", ");
  if (applied.empty()) return "no run refined the rig" + not_applied_note;
  if (applied.size() == 1) return applied[0]->name + ": the only run applied" + not_applied_note;

  std::string basis;
  const std::vector<Metric> metrics = VerdictMetrics(c, applied, &basis);
  std::vector<std::string> decided, even, mixed;
  std::vector<size_t> best_on_all(applied.size());
  for (size_t r = 0; r < applied.size(); ++r) best_on_all[r] = r;
  for (const Metric& m : metrics) {
    const std::vector<size_t> best = Best(m);
    if (best.size() == applied.size()) {
      even.push_back(MetricNumbers(applied, m));
      continue;
    }
    decided.push_back(MetricNumbers(applied, m));
    mixed.push_back(RunNames(applied, best) + " best on " + MetricNumbers(applied, m));
    std::vector<size_t> kept;
    std::set_intersection(best_on_all.begin(), best_on_all.end(), best.begin(), best.end(),
                          std::back_inserter(kept));
    best_on_all = kept;
  }
  const std::string within = Fixed(kEvenFraction * 100.0, 0) + "%";
  if (decided.empty()) {
    return "no clear winner (" + basis + ", within " + within + "): " + Join(even, "; ") +
           not_applied_note;
  }
  if (best_on_all.empty()) return "mixed (" + basis + "): " + Join(mixed, "; ") + not_applied_note;
  const std::string even_note = even.empty() ? "" : "; even: " + Join(even, "; ");
  const std::string winner =
      best_on_all.size() == 1
          ? RunNames(applied, best_on_all) + " is best"
          : RunNames(applied, best_on_all) + " are even (within " + within + ") and best";
  return winner + " (" + basis + "): " + Join(decided, "; ") + even_note + not_applied_note;
}

void CheckCompareInput(const RigCapture& capture, const PoseMap* gt, const CompareSources& names) {
  if (capture.cameras.size() < 2) {
    throw InputError("compare: " + NameOr(names.capture, "the capture") +
                     " holds one camera: nothing to register");
  }
  if (gt == nullptr) return;
  for (const CameraCapture& camera : capture.cameras) {
    if (gt->count(camera.serial) == 0) {
      throw InputError("compare: " + NameOr(names.ground_truth, "the ground truth") +
                       " has no pose for camera " + camera.serial + " of the capture");
    }
  }
}

CompareResult Compare(const RigCapture& capture, const PoseMap& initial,
                      const RefineOptions& options, const PoseMap* gt, const Log& log) {
  CheckCompareInput(capture, gt, {});
  CompareResult c;
  c.method = options.icp.method;
  for (const CameraCapture& camera : capture.cameras) c.serials.push_back(camera.serial);
  c.initial = initial;
  c.baseline_rss_mb = CurrentRssMb();
  // The three runs: each sets icp.mode and icp.surface_bundle, the rest is the caller's.
  const auto run_options = [&options](RefineMode mode, bool surface_bundle) {
    RefineOptions o = options;
    o.icp.mode = mode;
    o.icp.surface_bundle = surface_bundle;
    return o;
  };
  c.runs.push_back(
      RunOne("pairwise", capture, initial, run_options(RefineMode::kPairwise, false), log));
  c.runs.push_back(RunOne("joint", capture, initial, run_options(RefineMode::kJoint, false), log));
  c.runs.push_back(
      RunOne("surface_bundle", capture, initial, run_options(RefineMode::kJoint, true), log));

  // The shared start: leveling alone, as every run ran it.
  RefineOptions leveling_only = options;
  leveling_only.run_registration = false;
  const RefineResult leveling = Refine(capture, initial, leveling_only);
  c.leveled = leveling.leveled;
  c.reference = leveling.reference;
  const DiagnosticRig rig = PrepareDiagnostics(capture, leveling, options, options.threads);
  c.pair_serials = rig.serials;
  c.fit_before = Diagnose(rig, c.leveled, options.icp, options.threads);
  for (CompareRun& run : c.runs) run.fit = Diagnose(rig, run.output, options.icp, options.threads);
  c.has_gt = gt != nullptr;
  if (c.has_gt) {
    PoseMap truth;  // the capture's cameras only
    for (const std::string& serial : c.serials) truth[serial] = gt->at(serial);
    c.errors_initial = EvaluateRig(c.initial, truth);
    c.errors_leveled = EvaluateRig(c.leveled, truth);
    for (CompareRun& run : c.runs) run.errors = EvaluateRig(run.output, truth);
  }
  c.verdict = CompareVerdict(c);
  return c;
}

}  // namespace rigfit
