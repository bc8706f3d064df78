// `rigfit compare`: runs the pairwise and the joint mode (each with the configured method)
// on the same capture and initial extrinsics, and prints them side by side: each camera's
// change and (with --gt) its error, each pair's fit before and after (rig/diagnostics.h),
// the joint mode's 1-sigma, wall time and peak memory, and a verdict from these numbers.
// Both modes run in this process, one after the other; each one's peak memory is the
// process's high-water mark reset before it (docs/usage.md, `rigfit compare`).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/stderr_log.h"
#include "core/errors.h"
#include "core/evaluate.h"
#include "core/format.h"
#include "core/peak_memory.h"
#include "core/stopwatch.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/text_table.h"
#include "rig/diagnostics.h"
#include "rig/refine.h"

namespace rigfit::cli {
namespace {

using Json = nlohmann::json;

constexpr double kMToMm = 1e3;
constexpr int kMaxThreads = 256;
/// Two numbers closer than this fraction of the larger one are called even in the verdict.
constexpr double kEvenFraction = 0.05;

struct CompareArgs {
  std::string capture_path;
  std::string extrinsics_path;
  std::string gt_path;      ///< empty: no ground truth
  std::string config_path;  ///< empty: defaults
  std::string json_path;    ///< empty: no JSON output
  int threads = 2;
  bool quiet = false;
};

/// One mode's run.
struct ModeRun {
  std::string name;  ///< "pairwise" or "joint"
  bool success = false;
  std::string message;
  std::vector<std::string> warnings;
  PoseMap output;  ///< what `rigfit refine` would write: refined, or leveled when not applied
  std::vector<CameraReport> cameras;  ///< capture order
  double wall_s = 0.0;                ///< the Refine call
  double peak_rss_mb = 0.0;           ///< VmHWM after the Refine call (PeakMemory)
  bool peak_per_mode = false;         ///< false: the mark could not be reset (process-wide)
  std::vector<PairDiagnostics> fit;   ///< at `output`
};

std::string ModeName(RefineMode mode) {
  RefineOptions options;
  options.icp.mode = mode;
  return ConfigToJson(options)["icp"]["mode"];
}

/// Runs Refine in one mode in this process. Its peak resident memory is the process's
/// high-water mark, reset before the run (core/peak_memory.h): the capture already loaded
/// here counts in it, memory the previous mode freed does not.
ModeRun RunMode(RefineMode mode, const RigCapture& capture, const PoseMap& initial,
                RefineOptions options, const CompareArgs& a) {
  ModeRun run;
  run.name = ModeName(mode);
  options.icp.mode = mode;
  const PeakMemory memory;
  const auto start = std::chrono::steady_clock::now();
  RefineResult result;
  try {
    result = Refine(
        capture, initial, options, true, a.threads,
        StderrLog("compare: " + run.name + ": ", a.quiet ? Verbosity::kQuiet : Verbosity::kNormal));
  } catch (const std::exception& e) {
    throw std::runtime_error("compare: " + run.name + ": " + e.what());
  }
  run.wall_s = SecondsSince(start);
  run.peak_rss_mb = memory.PeakMb();
  run.peak_per_mode = memory.reset();
  run.success = result.success;
  run.message = result.message;
  run.warnings = result.warnings;
  run.output = result.success ? result.refined : result.leveled;
  run.cameras = result.cameras;
  return run;
}

// --- What the tables and the JSON show.

/// All pairs pooled: RMS residual (all and off the floor) and inlier fraction.
struct PooledFit {
  double rmse_m = 0.0;
  double off_floor_rmse_m = 0.0;
  double inlier_fraction = 0.0;
  int correspondences = 0;
  int off_floor_correspondences = 0;
};

PooledFit Pool(const std::vector<PairDiagnostics>& pairs) {
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

/// The change a mode made to a camera, from the leveled pose.
struct Change {
  double rotation_deg = 0.0;
  double translation_mm = 0.0;
};

Change ChangeOf(const PoseMap& leveled, const PoseMap& output, const std::string& serial) {
  const Vec6 d = PoseDifference(leveled.at(serial), output.at(serial));
  return {d.head<3>().norm() * kRadToDeg, d.tail<3>().norm() * kMToMm};
}

/// A camera's gauge-free error: its pose relative to the reference camera against the
/// truth (the pair (reference, camera) of EvaluateRig), and its tilt.
struct CameraError {
  bool has_relative = false;  ///< false for the reference itself
  double rotation_deg = 0.0;
  double translation_mm = 0.0;
  double tilt_deg = 0.0;
};

CameraError CameraErrorOf(const RigErrors& e, const std::string& serial,
                          const std::string& reference) {
  CameraError out;
  for (const PairError& p : e.pairs) {
    if ((p.serial_i == reference && p.serial_j == serial) ||
        (p.serial_j == reference && p.serial_i == serial)) {
      out = {true, p.error.rotation_rad * kRadToDeg, p.error.translation_m * kMToMm, 0.0};
    }
  }
  for (const auto& [s, tilt] : e.tilt_rad) {
    if (s == serial) out.tilt_deg = tilt * kRadToDeg;
  }
  return out;
}

std::string Result(const ModeRun& run, size_t cameras) {
  if (!run.success) return "not applied: " + run.message;
  int refined = 0;
  for (const CameraReport& c : run.cameras) refined += !c.reference && c.accepted ? 1 : 0;
  return "refined " + std::to_string(refined) + " of " + std::to_string(cameras - 1) +
         " non-reference cameras";
}

/// "a" when a is lower by more than kEvenFraction of the larger, "b" the other way, ""
/// when even.
std::string Lower(double a, double b, const std::string& name_a, const std::string& name_b) {
  if (std::abs(a - b) <= kEvenFraction * std::max(std::abs(a), std::abs(b))) return "";
  return a < b ? name_a : name_b;
}

/// One line naming the better mode and the measured numbers behind it.
std::string Verdict(const ModeRun& p, const ModeRun& j, const RigErrors* e_p,
                    const RigErrors* e_j) {
  if (!p.success && !j.success) return "neither mode refined the rig";
  if (!p.success) return "joint: the pairwise refinement was not applied (" + p.message + ")";
  if (!j.success) return "pairwise: the joint refinement was not applied (" + j.message + ")";
  struct Metric {
    std::string what;
    double pairwise, joint;
    int digits;
    std::string unit;
    bool higher_is_better;
  };
  std::vector<Metric> metrics;
  std::string basis;
  if (e_p != nullptr) {
    basis = "against the ground truth";
    metrics = {{"RMS relative translation error", e_p->rms_translation_m * kMToMm,
                e_j->rms_translation_m * kMToMm, 2, " mm", false},
               {"RMS relative rotation error", e_p->rms_rotation_rad * kRadToDeg,
                e_j->rms_rotation_rad * kRadToDeg, 3, " deg", false}};
  } else {
    basis = "no ground truth: judged by the fit of the pairs";
    const PooledFit f_p = Pool(p.fit), f_j = Pool(j.fit);
    metrics = {{"RMS off-floor pair residual", f_p.off_floor_rmse_m * kMToMm,
                f_j.off_floor_rmse_m * kMToMm, 2, " mm", false},
               {"RMS pair residual", f_p.rmse_m * kMToMm, f_j.rmse_m * kMToMm, 2, " mm", false},
               {"inlier fraction", f_p.inlier_fraction, f_j.inlier_fraction, 3, "", true}};
  }
  std::vector<std::string> favour_p, favour_j, even;
  for (const Metric& m : metrics) {
    const std::string numbers = m.what + " " + Fixed(m.pairwise, m.digits) + m.unit +
                                " (pairwise) vs " + Fixed(m.joint, m.digits) + m.unit + " (joint)";
    const std::string lower = m.higher_is_better ? Lower(-m.pairwise, -m.joint, "p", "j")
                                                 : Lower(m.pairwise, m.joint, "p", "j");
    (lower == "p" ? favour_p : lower == "j" ? favour_j : even).push_back(numbers);
  }
  const std::string even_note = even.empty() ? "" : "; even: " + Join(even, "; ");
  if (!favour_p.empty() && favour_j.empty()) {
    return "pairwise is better (" + basis + "): " + Join(favour_p, "; ") + even_note;
  }
  if (!favour_j.empty() && favour_p.empty()) {
    return "joint is better (" + basis + "): " + Join(favour_j, "; ") + even_note;
  }
  if (favour_p.empty()) {
    return "no clear winner (" + basis + ", within " + Fixed(kEvenFraction * 100.0, 0) +
           "%): " + Join(even, "; ");
  }
  return "mixed (" + basis + "): pairwise better on " + Join(favour_p, "; ") +
         "; joint better on " + Join(favour_j, "; ");
}

struct Comparison {
  const CompareArgs* args = nullptr;
  const RigCapture* capture = nullptr;
  std::string method;
  std::string reference;
  PoseMap initial;
  PoseMap leveled;
  std::vector<PairDiagnostics> fit_before;  ///< at the leveled poses
  const DiagnosticRig* rig = nullptr;
  ModeRun runs[2];  ///< pairwise, joint
  bool has_gt = false;
  RigErrors errors_initial, errors_leveled, errors[2];
  double baseline_rss_mb = 0.0;
  std::string verdict;
};

/// The comparison as printed: prose, one table a view, the verdict.
std::string Tables(const Comparison& c) {
  const ModeRun* runs = c.runs;
  std::string text;
  Appendf(&text, "\ncompare: %s, %zu cameras, method %s, reference %s\n",
          c.args->capture_path.c_str(), c.capture->cameras.size(), c.method.c_str(),
          c.reference.c_str());
  Appendf(&text,
          "Both modes start from the same leveled poses; \"change\" is each mode's move from "
          "there%s.\n",
          c.has_gt ? ", \"error\" the camera's pose relative to the reference against the truth "
                     "(and its tilt)"
                   : "");

  // Per camera: each mode's change (and error), the joint 1-sigma.
  std::vector<TextColumn> columns = {{16, Align::kLeft, ""}};
  std::vector<TextSpan> modes = {{"", 1}}, parts = {{"", 1}};
  std::vector<std::string> units = {"camera"};
  for (const ModeRun& run : c.runs) {
    columns.insert(columns.end(), {{6, Align::kRight, " | "}, {7}});
    parts.push_back({"change", 2});
    units.insert(units.end(), {"deg", "mm"});
    if (c.has_gt) {
      columns.insert(columns.end(), {{6}, {7}, {6}});
      parts.push_back({"error vs gt", 3});
      units.insert(units.end(), {"deg", "mm", "tilt"});
    }
    modes.push_back({run.name, c.has_gt ? 5 : 2});
  }
  columns.insert(columns.end(),
                 {{7, Align::kRight, " | "}, {8}, {6}, {6}, {6}, {0, Align::kLeft, "  "}});
  modes.push_back({"joint 1-sigma", 5});
  parts.push_back({"", 5});
  units.insert(units.end(), {"yaw deg", "tilt deg", "x mm", "y mm", "z mm"});
  TextTable cameras(columns);
  cameras.AddSpans(modes);
  cameras.AddSpans(parts);
  cameras.AddRow(units);
  for (size_t i = 0; i < c.capture->cameras.size(); ++i) {
    const std::string& serial = c.capture->cameras[i].serial;
    std::vector<std::string> row = {serial};
    for (int m = 0; m < 2; ++m) {
      const Change change = ChangeOf(c.leveled, runs[m].output, serial);
      row.insert(row.end(), {Fixed(change.rotation_deg, 3), Fixed(change.translation_mm, 1)});
      if (c.has_gt) {
        const CameraError e = CameraErrorOf(c.errors[m], serial, c.reference);
        row.insert(row.end(),
                   {FixedOrDash(e.has_relative, e.rotation_deg, 3),
                    FixedOrDash(e.has_relative, e.translation_mm, 1), Fixed(e.tilt_deg, 3)});
      }
    }
    const CameraReport& joint = runs[1].cameras[i];
    const PoseSigma s = SigmaOf(joint.covariance);
    const bool shown = joint.has_covariance;
    row.insert(row.end(), {FixedOrDash(shown, s.yaw_deg, 3), FixedOrDash(shown, s.tilt_deg, 3),
                           FixedOrDash(shown, s.x_mm, 2), FixedOrDash(shown, s.y_mm, 2),
                           FixedOrDash(shown, s.z_mm, 2), joint.reference ? "(reference)" : ""});
    cameras.AddRow(row);
  }
  text += "\n" + cameras.text();

  // Per pair: the fit before and after each mode.
  TextTable pairs({{35, Align::kLeft, ""},
                   {7, Align::kRight, " | "},
                   {7},
                   {8},
                   {7, Align::kRight, " | "},
                   {7},
                   {8},
                   {7, Align::kRight, " | "},
                   {7},
                   {8}});
  pairs.AddSpans({{"pair fit (finest scale, both ways)", 1},
                  {"before", 3},
                  {runs[0].name, 3},
                  {runs[1].name, 3}});
  pairs.AddRow({"pair: RMSE mm (all, off-floor)", "all", "off", "inliers", "all", "off", "inliers",
                "all", "off", "inliers"});
  // A pair's fit or the pooled one (PairDiagnostics, PooledFit): RMSE, off-floor, inliers.
  const auto add_fit = [](const auto& fit, std::vector<std::string>* row) {
    row->insert(row->end(), {Fixed(fit.rmse_m * kMToMm, 2), Fixed(fit.off_floor_rmse_m * kMToMm, 2),
                             Fixed(fit.inlier_fraction, 3)});
  };
  for (size_t k = 0; k < c.fit_before.size(); ++k) {
    const PairDiagnostics* fits[3] = {&c.fit_before[k], &runs[0].fit[k], &runs[1].fit[k]};
    std::vector<std::string> row = {c.rig->serials[fits[0]->a] + " - " +
                                    c.rig->serials[fits[0]->b]};
    for (const PairDiagnostics* f : fits) add_fit(*f, &row);
    pairs.AddRow(row);
  }
  if (!c.fit_before.empty()) {
    std::vector<std::string> row = {"all pairs"};
    for (const std::vector<PairDiagnostics>* fits : {&c.fit_before, &runs[0].fit, &runs[1].fit}) {
      add_fit(Pool(*fits), &row);
    }
    pairs.AddRow(row);
  }
  text += "\n" + pairs.text();
  if (c.fit_before.empty()) text += "(no candidate pairs)\n";

  // Against the truth.
  if (c.has_gt) {
    TextTable errors({{35, Align::kLeft, ""},
                      {9, Align::kRight, " | "},
                      {9},
                      {9, Align::kRight, " | "},
                      {9},
                      {9, Align::kRight, " | "}});
    errors.AddRow(
        {"errors vs gt (gauge-free)", "rot RMS", "rot max", "trans RMS", "trans max", "tilt RMS"});
    errors.AddRow({"", "deg", "deg", "mm", "mm", "deg"});
    const std::pair<std::string, const RigErrors*> rows[] = {{"input", &c.errors_initial},
                                                             {"leveled", &c.errors_leveled},
                                                             {runs[0].name, &c.errors[0]},
                                                             {runs[1].name, &c.errors[1]}};
    for (const auto& [name, e] : rows) {
      const bool pairs_shown = !e->pairs.empty();
      errors.AddRow({name, FixedOrDash(pairs_shown, e->rms_rotation_rad * kRadToDeg, 3),
                     FixedOrDash(pairs_shown, e->max_rotation_rad * kRadToDeg, 3),
                     FixedOrDash(pairs_shown, e->rms_translation_m * kMToMm, 2),
                     FixedOrDash(pairs_shown, e->max_translation_m * kMToMm, 2),
                     Fixed(e->rms_tilt_rad * kRadToDeg, 3)});
    }
    text += "\n" + errors.text();
  }

  // Resources and results.
  TextTable resources({{10, Align::kLeft, ""}, {8}, {12}, {0, Align::kLeft, "  "}});
  resources.AddRow({"mode", "wall s", "peak RSS MB", "result"});
  for (const ModeRun& run : c.runs) {
    resources.AddRow({run.name, Fixed(run.wall_s, 2), Fixed(run.peak_rss_mb, 0),
                      Result(run, c.capture->cameras.size())});
  }
  text += "\n" + resources.text();
  if (c.runs[0].peak_per_mode && c.runs[1].peak_per_mode) {
    Appendf(&text,
            "(wall s: the refinement alone, loading excluded; peak RSS: the high-water mark of "
            "this process, which holds the loaded capture (%s MB before the runs), during that "
            "mode)\n",
            Fixed(c.baseline_rss_mb, 0).c_str());
  } else {
    Appendf(&text,
            "(wall s: the refinement alone, loading excluded; peak RSS: the high-water mark of "
            "this process since it started, loading included (%s MB before the runs): the mark "
            "could not be reset per mode through /proc/self/clear_refs)\n",
            Fixed(c.baseline_rss_mb, 0).c_str());
  }
  Appendf(&text, "\nverdict: %s\n", c.verdict.c_str());
  return text;
}

Json FitJson(const std::vector<PairDiagnostics>& fits, const DiagnosticRig& rig) {
  Json pairs = Json::array();
  for (const PairDiagnostics& f : fits) {
    pairs.push_back({{"serial_a", rig.serials[f.a]},
                     {"serial_b", rig.serials[f.b]},
                     {"rmse_mm", f.rmse_m * kMToMm},
                     {"off_floor_rmse_mm", f.off_floor_rmse_m * kMToMm},
                     {"inlier_fraction", f.inlier_fraction},
                     {"correspondences", f.correspondences},
                     {"off_floor_correspondences", f.off_floor_correspondences}});
  }
  const PooledFit all = Pool(fits);
  return {{"pairs", pairs},
          {"all_pairs",
           {{"rmse_mm", all.rmse_m * kMToMm},
            {"off_floor_rmse_mm", all.off_floor_rmse_m * kMToMm},
            {"inlier_fraction", all.inlier_fraction},
            {"correspondences", all.correspondences},
            {"off_floor_correspondences", all.off_floor_correspondences}}}};
}

Json ComparisonJson(const Comparison& c) {
  Json modes = Json::object();
  for (int m = 0; m < 2; ++m) {
    const ModeRun& run = c.runs[m];
    Json cameras = Json::object();
    for (size_t i = 0; i < c.capture->cameras.size(); ++i) {
      const std::string& serial = c.capture->cameras[i].serial;
      const CameraReport& outcome = run.cameras[i];
      const Change change = ChangeOf(c.leveled, run.output, serial);
      Json camera = {{"reference", outcome.reference},
                     {"accepted", outcome.accepted},
                     {"message", outcome.message},
                     {"change_rotation_deg", change.rotation_deg},
                     {"change_translation_mm", change.translation_mm},
                     {"T_world_camera", PoseToJson(run.output.at(serial))}};
      if (c.has_gt) {
        const CameraError e = CameraErrorOf(c.errors[m], serial, c.reference);
        camera["error"] = {
            {"rotation_to_reference_deg", e.has_relative ? Json(e.rotation_deg) : Json()},
            {"translation_to_reference_mm", e.has_relative ? Json(e.translation_mm) : Json()},
            {"tilt_deg", e.tilt_deg}};
      }
      if (outcome.has_covariance) {
        const PoseSigma s = SigmaOf(outcome.covariance);
        camera["sigma"] = {{"yaw_deg", s.yaw_deg},
                           {"tilt_deg", s.tilt_deg},
                           {"x_mm", s.x_mm},
                           {"y_mm", s.y_mm},
                           {"z_mm", s.z_mm}};
      }
      cameras[serial] = camera;
    }
    modes[run.name] = {{"success", run.success},
                       {"message", run.message},
                       {"warnings", run.warnings},
                       {"wall_s", run.wall_s},
                       {"peak_rss_mb", run.peak_rss_mb},
                       {"peak_rss_per_mode", run.peak_per_mode},
                       {"cameras", cameras},
                       {"fit", FitJson(run.fit, *c.rig)},
                       {"errors", c.has_gt ? RigErrorsSummaryJson(c.errors[m]) : Json()}};
  }
  return {{"capture", c.args->capture_path},
          {"extrinsics", c.args->extrinsics_path},
          {"ground_truth", c.has_gt ? Json(c.args->gt_path) : Json()},
          {"config", c.args->config_path.empty() ? Json() : Json(c.args->config_path)},
          {"method", c.method},
          {"reference", c.reference},
          {"before",
           {{"fit", FitJson(c.fit_before, *c.rig)},
            {"errors_input", c.has_gt ? RigErrorsSummaryJson(c.errors_initial) : Json()},
            {"errors_leveled", c.has_gt ? RigErrorsSummaryJson(c.errors_leveled) : Json()}}},
          {"modes", modes},
          {"baseline_rss_mb", c.baseline_rss_mb},
          {"verdict", c.verdict}};
}

/// Every capture camera needs an initial pose (and a true one with --gt).
void CheckPoses(const RigCapture& capture, const PoseMap& poses, const std::string& path) {
  for (const CameraCapture& camera : capture.cameras) {
    if (poses.count(camera.serial) == 0) {
      throw InputError("compare: " + path + " has no pose for camera " + camera.serial + " of " +
                       "the capture");
    }
  }
}

int RunCompare(const CompareArgs& a) {
  if (a.threads < 1 || a.threads > kMaxThreads) {
    throw InputError("compare: --threads must be in [1, " + std::to_string(kMaxThreads) +
                     "], got " + std::to_string(a.threads));
  }
  std::vector<std::string> inputs = {a.capture_path, a.extrinsics_path};
  for (const std::string* path : {&a.gt_path, &a.config_path}) {
    if (!path->empty()) inputs.push_back(*path);
  }
  if (!a.json_path.empty()) RefuseToOverwriteInputs(a.json_path, inputs, "compare: --json");
  const RefineOptions options = a.config_path.empty() ? RefineOptions{} : LoadConfig(a.config_path);
  const RigCapture capture = ReadCaptureGuarded(a.capture_path);
  const ExtrinsicsDocument initial = ReadExtrinsics(a.extrinsics_path);
  CheckRefineInput(capture, initial.poses, options,
                   {"compare", a.capture_path, a.extrinsics_path, "icp.reference"});
  std::vector<std::string> input_warnings = CaptureWarnings(capture, a.capture_path);
  input_warnings.insert(input_warnings.end(), initial.warnings.begin(), initial.warnings.end());
  PoseMap gt;
  if (!a.gt_path.empty()) {
    ExtrinsicsDocument truth = ReadExtrinsics(a.gt_path);
    CheckPoses(capture, truth.poses, a.gt_path);
    input_warnings.insert(input_warnings.end(), truth.warnings.begin(), truth.warnings.end());
    gt = std::move(truth.poses);
  }
  for (const std::string& w : input_warnings) {
    std::fprintf(stderr, "compare: warning: %s\n", w.c_str());
  }
  if (capture.cameras.size() < 2) {
    throw InputError("compare: " + a.capture_path + " holds one camera: nothing to register");
  }

  Comparison c;
  c.args = &a;
  c.capture = &capture;
  c.method = ConfigToJson(options)["icp"]["method"];
  c.initial = initial.poses;
  c.baseline_rss_mb = CurrentRssMb();
  c.runs[0] = RunMode(RefineMode::kPairwise, capture, initial.poses, options, a);
  c.runs[1] = RunMode(RefineMode::kJoint, capture, initial.poses, options, a);

  // The shared start: leveling alone, as both modes ran it.
  const RefineResult leveling = Refine(capture, initial.poses, options, false, a.threads,
                                       StderrLog("compare: ", Verbosity::kQuiet));
  c.leveled = leveling.leveled;
  c.reference = leveling.reference;
  const DiagnosticRig rig = PrepareDiagnostics(capture, leveling, options, a.threads);
  c.rig = &rig;
  c.fit_before = Diagnose(rig, c.leveled, options.icp, a.threads);
  for (ModeRun& run : c.runs) run.fit = Diagnose(rig, run.output, options.icp, a.threads);
  c.has_gt = !gt.empty();
  if (c.has_gt) {
    PoseMap truth;  // the capture's cameras only
    for (const CameraCapture& camera : capture.cameras) truth[camera.serial] = gt.at(camera.serial);
    c.errors_initial = EvaluateRig(c.initial, truth);
    c.errors_leveled = EvaluateRig(c.leveled, truth);
    for (int m = 0; m < 2; ++m) c.errors[m] = EvaluateRig(c.runs[m].output, truth);
  }
  c.verdict = Verdict(c.runs[0], c.runs[1], c.has_gt ? &c.errors[0] : nullptr,
                      c.has_gt ? &c.errors[1] : nullptr);
  if (!a.json_path.empty()) WriteJsonFile(a.json_path, ComparisonJson(c));
  std::fputs(Tables(c).c_str(), stdout);
  return kExitOk;
}

}  // namespace

Command AddCompareCommand(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CompareArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "compare",
      "Run the pairwise and the joint mode (each with the configured method) on the same "
      "capture and initial extrinsics and print them side by side: each camera's change and "
      "(with --gt) its error, each pair's residual RMSE and inlier fraction before and after, "
      "the joint 1-sigma, wall time and peak memory, and which mode did better. Writes no "
      "extrinsics. Exit codes: 0 done; 2 bad input or usage (nothing written); 1 internal "
      "error.");
  sub->add_option("--capture", a.capture_path, "Rig capture (HDF5)")->required();
  sub->add_option("--extrinsics", a.extrinsics_path,
                  "Initial extrinsics (JSON): a pose for every camera of the capture")
      ->required();
  sub->add_option("--gt", a.gt_path,
                  "Ground-truth extrinsics (JSON): adds each mode's gauge-free errors");
  sub->add_option("--config", a.config_path,
                  "Options (YAML, docs/config.md); icp.mode is ignored (both modes run)");
  sub->add_option("--json", a.json_path,
                  "Also write the comparison to this JSON file (replaced atomically; must not "
                  "be an input)");
  sub->add_option("--threads", a.threads, "Worker threads")->capture_default_str();
  sub->add_flag("--quiet,-q", a.quiet, "Progress off: stderr shows only warnings and errors");
  return {sub, [args] { return RunCompare(*args); }};
}

}  // namespace rigfit::cli
