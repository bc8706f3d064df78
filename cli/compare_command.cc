// `rigfit compare`: parses the flags, loads the capture and the extrinsics, runs the comparison
// of the three ways to refine a rig (pairwise, joint, surface bundle; report/compare.h) and
// prints it, and writes its JSON document with --json and its report (a 3-D view of the rig at
// every run's poses, report/refine_report.h) with --report (docs/usage.md, `rigfit compare`).
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "cli/stderr_log.h"
#include "core/errors.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "report/compare.h"
#include "report/refine_meta.h"
#include "report/refine_report.h"
#include "rig/refine.h"

namespace rigfit::cli {
namespace {

struct CompareArgs {
  std::string capture_path;
  std::string extrinsics_path;
  std::string gt_path;      ///< empty: no ground truth
  std::string config_path;  ///< empty: defaults
  std::string json_path;    ///< empty: no JSON output
  std::string report_dir;   ///< empty: no report
  int threads = 2;
  bool quiet = false;
};

int RunCompare(const CompareArgs& a) {
  if (a.threads < 1 || a.threads > kMaxRefineThreads) {
    throw InputError("compare: --threads must be in [1, " + std::to_string(kMaxRefineThreads) +
                     "], got " + std::to_string(a.threads));
  }
  std::vector<std::string> inputs = {a.capture_path, a.extrinsics_path};
  for (const std::string* path : {&a.gt_path, &a.config_path}) {
    if (!path->empty()) inputs.push_back(*path);
  }
  if (!a.json_path.empty()) RefuseToOverwriteInputs(a.json_path, inputs, "compare: --json");
  if (!a.report_dir.empty()) CheckReportDirectory(a.report_dir, "compare: --report");
  RefineOptions options = a.config_path.empty() ? RefineOptions{} : LoadConfig(a.config_path);
  options.threads = a.threads;
  // The report's 3-D view draws the surface_bundle run's planes (its poses are the same either
  // way; the other runs do not run the bundle).
  options.icp.keep_surface_diagnostics = !a.report_dir.empty();
  const RigCapture capture = ReadCaptureGuarded(a.capture_path);
  const ExtrinsicsDocument initial = ReadExtrinsics(a.extrinsics_path);
  CheckRefineInput(capture, initial.poses, options,
                   {"compare", a.capture_path, a.extrinsics_path, "icp.reference"});
  std::vector<std::string> input_warnings = CaptureWarnings(capture, a.capture_path);
  input_warnings.insert(input_warnings.end(), initial.warnings.begin(), initial.warnings.end());
  PoseMap gt;
  if (!a.gt_path.empty()) {
    ExtrinsicsDocument truth = ReadExtrinsics(a.gt_path);
    input_warnings.insert(input_warnings.end(), truth.warnings.begin(), truth.warnings.end());
    gt = std::move(truth.poses);
  }
  for (const std::string& w : input_warnings) {
    std::fprintf(stderr, "compare: warning: %s\n", w.c_str());
  }
  const CompareSources sources = {a.capture_path, a.extrinsics_path, a.gt_path, a.config_path};
  const PoseMap* truth = a.gt_path.empty() ? nullptr : &gt;
  CheckCompareInput(capture, truth, sources);

  const CompareResult result =
      Compare(capture, initial.poses, options, truth,
              StderrLog("compare: ", a.quiet ? Verbosity::kQuiet : Verbosity::kNormal));
  if (!a.json_path.empty()) {
    nlohmann::json json = CompareToJson(result, sources);
    for (const std::string& path : ReplaceNonFinite(json, "compare")) {
      std::fprintf(stderr, "compare: warning: %s was not finite and is written as null\n",
                   path.c_str());
    }
    WriteJsonFile(a.json_path, json);
  }
  const std::string text = CompareText(result, sources);
  std::fputs(text.c_str(), stdout);
  if (!a.report_dir.empty()) {
    for (const std::string& file :
         WriteCompareReport(a.report_dir, capture, result, options, text)) {
      std::printf("report: %s\n", file.c_str());
    }
  }
  return kExitOk;
}

}  // namespace

Command AddCompareCommand(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CompareArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "compare",
      "Run the three ways to refine a rig on the same capture and initial extrinsics and print "
      "them side by side: pairwise (pairwise ICP + pose graph) and joint (joint registration), "
      "both without the surface bundle, and surface_bundle (joint registration, then the "
      "surface bundle); all with the config's icp.method (point_to_plane or gicp). Shows each "
      "camera's change and (with --gt) its error, the joint 1-sigma, the "
      "surface bundle's plane thickness before and after, each pair's residual RMSE and "
      "inlier fraction before and after, wall time and peak memory, and which run did best. "
      "Writes no extrinsics. Exit codes: 0 done; 2 bad input or usage (nothing written); 1 "
      "internal error.");
  sub->add_option("--capture", a.capture_path, "Rig capture (HDF5)")->required();
  sub->add_option("--extrinsics", a.extrinsics_path,
                  "Initial extrinsics (JSON): a pose for every camera of the capture")
      ->required();
  sub->add_option("--gt", a.gt_path,
                  "Ground-truth extrinsics (JSON): adds each run's gauge-free errors");
  sub->add_option(
      "--config", a.config_path,
      "Options (YAML, docs/config.md); icp.mode and icp.surface_bundle are ignored (the three "
      "runs set them)");
  sub->add_option("--json", a.json_path,
                  "Also write the comparison to this JSON file (replaced atomically; must not "
                  "be an input)");
  sub->add_option("--report", a.report_dir,
                  "Also write a report into this directory (created if missing; its parent must "
                  "exist): index.html and an interactive 3-D view of the rig at the initial, "
                  "leveled and each run's poses (view3d.html, opens offline)");
  sub->add_option("--threads", a.threads, "Worker threads")->capture_default_str();
  sub->add_flag("--quiet,-q", a.quiet, "Progress off: stderr shows only warnings and errors");
  return {sub, [args] { return RunCompare(*args); }};
}

}  // namespace rigfit::cli
