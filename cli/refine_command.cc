// `rigfit refine`: refines the extrinsics of a rig from one capture (rig/refine.h: ground
// leveling, then registration of the near-floor band). Every input is checked before any work;
// the refined extrinsics are written with their report in _meta (../shared/docs/formats.md,
// docs/usage.md), and a summary is printed on stdout.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "cli/commands.h"
#include "cli/stderr_log.h"
#include "core/errors.h"
#include "core/evaluate.h"
#include "core/format.h"
#include "core/stopwatch.h"
#include "io/atomic_file.h"
#include "io/capture_h5.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/text_table.h"
#include "report/refine_meta.h"
#include "report/refine_report.h"
#include "rig/refine.h"

namespace rigfit::cli {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using Clock = std::chrono::steady_clock;

struct RefineArgs {
  std::string capture_path;
  std::string extrinsics_path;
  std::string out_path;
  std::string config_path;
  std::string report_dir;  ///< empty: no report
  // Overrides of the config; applied only when given (see the options below).
  std::string mode;
  std::string method;
  double voxel_size = 0.0;
  std::string reference;
  bool surface_bundle = false;
  CLI::Option* mode_option = nullptr;
  CLI::Option* method_option = nullptr;
  CLI::Option* surface_bundle_option = nullptr;
  CLI::Option* voxel_size_option = nullptr;
  CLI::Option* reference_option = nullptr;
  bool no_ground = false;
  bool no_icp = false;
  bool no_timings = false;
  bool quiet = false;
  bool verbose = false;
  int threads = 2;
};

/// The flags that do not map to a config key.
void CheckFlags(const RefineArgs& a) {
  std::vector<std::string> problems;
  if (a.voxel_size_option->count() > 0 && !(std::isfinite(a.voxel_size) && a.voxel_size > 0.0)) {
    problems.push_back("--voxel-size must be a finite number > 0, got " +
                       a.voxel_size_option->as<std::string>());
  }
  if (a.threads < 1 || a.threads > kMaxRefineThreads) {
    problems.push_back("--threads must be in [1, " + std::to_string(kMaxRefineThreads) + "], got " +
                       std::to_string(a.threads));
  }
  if (!problems.empty()) throw InputError("refine: " + Join(problems, "; "));
}

/// The files the run reads, which --out must not replace.
std::vector<std::string> InputFiles(const RefineArgs& a) {
  std::vector<std::string> inputs = {a.capture_path, a.extrinsics_path};
  if (!a.config_path.empty()) inputs.push_back(a.config_path);
  return inputs;
}

/// --out must be a new or replaceable file, in an existing directory, and none of the inputs.
void CheckOutputPath(const RefineArgs& a) {
  RefuseToOverwriteInputs(a.out_path, InputFiles(a), "refine: --out");
  const fs::path out(a.out_path);
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw InputError("refine: --out " + a.out_path + ": directory " + dir.string() +
                     " does not exist");
  }
  if (fs::is_directory(out, ec)) {
    throw InputError("refine: --out " + a.out_path + " is a directory, expected a JSON file name");
  }
}

/// The config file (or the defaults) with the command-line overrides applied, checked.
RefineOptions EffectiveOptions(const RefineArgs& a) {
  RefineOptions options = a.config_path.empty() ? RefineOptions{} : LoadConfig(a.config_path);
  if (a.mode_option->count() > 0) {
    options.icp.mode = a.mode == "joint" ? RefineMode::kJoint : RefineMode::kPairwise;
  }
  if (a.method_option->count() > 0) {
    options.icp.method = RegistrationMethodNamed(a.method);
  }
  if (a.surface_bundle_option->count() > 0) options.icp.surface_bundle = a.surface_bundle;
  if (a.voxel_size_option->count() > 0) options.icp.voxel_size = a.voxel_size;
  if (a.reference_option->count() > 0) options.icp.reference = a.reference;
  if (a.no_ground) options.ground.enabled = false;
  options.run_registration = !a.no_icp;
  options.threads = a.threads;
  const std::vector<std::string> problems = OptionProblems(options);
  if (!problems.empty()) {
    throw InputError("refine: invalid options (config file with command-line overrides):\n  " +
                     Join(problems, "\n  "));
  }
  return options;
}

struct Timings {
  double load_s = 0.0;
  StageTimes solver;
  double output_s = 0.0;
  double total_s = 0.0;
};

Json TimingsJson(const Timings& t) {
  return {{"load", t.load_s},
          {"leveling", t.solver.leveling_s},
          {"preprocessing", t.solver.preprocessing_s},
          {"registration", t.solver.registration_s},
          {"correspondences", t.solver.correspondences_s},
          {"solve", t.solver.solve_s},
          {"pose_graph", t.solver.pose_graph_s},
          {"output", t.output_s},
          {"total", t.total_s}};
}

/// A camera's result column of the summary.
std::string CameraStatus(const CameraReport& c, const RefineOptions& options, const RefineArgs& a) {
  const GroundResult& g = c.ground;
  std::string status;
  if (!options.ground.enabled) {
    status = "not leveled (skipped)";
  } else if (!g.accepted) {
    status = "not leveled: " + g.message;
  } else if (a.no_icp) {
    status = "leveled";
  }
  if (!a.no_icp) {
    const std::string reference = c.surface_leveled
                                      ? "reference (yaw and centre held, tilt from the floor)"
                                      : "reference (held fixed)";
    const std::string registration = c.reference  ? reference
                                     : c.accepted ? "refined"
                                                  : "kept leveled pose: " + c.message;
    status += (status.empty() ? "" : "; ") + registration;
  }
  return status;
}

/// How much the 1-sigma was inflated, "rotation/translation" ("-" without a covariance).
std::string InflationText(const CameraReport& c) {
  if (!c.has_covariance) return "-";
  return Fixed(c.sigma_inflation.rotation, 1) + "/" + Fixed(c.sigma_inflation.translation, 1);
}

/// The surface orientations under a joint pose, "few" when too few ("-" elsewhere).
std::string SurfacesText(const RefineResult& result, const CameraReport& c) {
  if (result.mode != RefineMode::kJoint || c.reference || !c.connected) return "-";
  return std::to_string(c.surfaces) + (c.few_surfaces ? " few" : "");
}

/// The cameras' table: leveling, registration and against the rig (deg, mm each), the
/// 1-sigma with its inflation and the surfaces under the pose, the result.
std::string CameraTable(const RefineResult& result, const RefineOptions& options,
                        const RefineArgs& a) {
  std::vector<TextColumn> columns = {{16, Align::kLeft, ""}};
  for (size_t width : {7, 6, 7, 7, 7, 7, 8, 8, 6, 6, 6, 9, 8}) columns.push_back({width});
  columns.push_back({0, Align::kLeft, "  "});
  TextTable table(columns);
  table.AddSpans({{"", 1},
                  {"leveling", 2, Align::kCentre},
                  {"registration", 2, Align::kCentre},
                  {"against the rig", 2, Align::kCentre},
                  {"1-sigma", 6, Align::kCentre},
                  {"", 1}});
  table.AddRow({"camera", "deg", "mm", "deg", "mm", "deg", "mm", "yaw deg", "tilt deg", "x mm",
                "y mm", "z mm", "inflated", "surfaces", "result"});
  for (const CameraReport& c : result.cameras) {
    const GroundResult& g = c.ground;
    const bool level_shown = options.ground.enabled && g.accepted;
    const bool registered = ChangeMeasured(result, c);
    const PoseSigma sigma = SigmaOf(c.covariance);
    table.AddRow({c.serial, FixedOrDash(level_shown, g.correction_rotation_deg, 3),
                  FixedOrDash(level_shown, g.correction_translation_m * 1e3, 1),
                  FixedOrDash(registered, c.delta_rotation_deg, 3),
                  FixedOrDash(registered, c.delta_translation_m * 1e3, 1),
                  FixedOrDash(registered, c.own_rotation_deg, 3),
                  FixedOrDash(registered, c.own_translation_m * 1e3, 1),
                  FixedOrDash(c.has_covariance, sigma.yaw_deg, 3),
                  FixedOrDash(c.has_covariance, sigma.tilt_deg, 3),
                  FixedOrDash(c.has_covariance, sigma.x_mm, 2),
                  FixedOrDash(c.has_covariance, sigma.y_mm, 2),
                  FixedOrDash(c.has_covariance, sigma.z_mm, 2), InflationText(c),
                  SurfacesText(result, c), CameraStatus(c, options, a)});
  }
  return table.text();
}

/// A camera's depth model (icp.depth_model) for the surface bundle's table: empty when it had
/// none (the option off, the reference, a points camera).
std::string DepthModelText(const DepthModelEstimate& d) {
  if (!(d.offset_prior_sigma > 0.0)) return "";
  if (!d.solved) return "depth model not observable";
  std::string text = "depth model ";
  if (d.scale_prior_sigma > 0.0) {
    text += "scale " + Fixed(d.scale, 4) + "+-" + Fixed(d.scale_sigma, 4) + ", ";
  }
  if (d.offset_px != 0.0) {
    const double per_px = d.offset_px / d.offset;
    return text + "offset " + Fixed(d.offset_px, 3) + "+-" + Fixed(d.offset_sigma * per_px, 3) +
           " px";
  }
  return text + "offset " + Fixed(d.offset * 1e3, 3) + "+-" + Fixed(d.offset_sigma * 1e3, 3) +
         " 1/km";
}

/// The pairs' table and, when it ran, the surface bundle's.
std::string RegistrationTables(const RefineResult& result) {
  // Pairwise ICP moves b onto a; the joint mode moves both.
  const std::string link = result.mode == RefineMode::kPairwise ? " <- " : " - ";
  TextTable pair_table({{35, Align::kLeft, ""}, {7}, {22}, {6}, {0, Align::kLeft, "  "}});
  pair_table.AddRow({"pair", "fitness", "RMSE before->after mm", "iters", "result"});
  for (const PairReport& p : result.pairs) {
    pair_table.AddRow({p.serial_a + link + p.serial_b, Fixed(p.fitness, 3),
                       Fixed(p.rmse_before_m * 1e3, 2) + " -> " + Fixed(p.rmse_after_m * 1e3, 2),
                       std::to_string(p.iterations),
                       p.accepted ? "accepted" : "rejected: " + p.message});
  }
  std::string text = "\n" + pair_table.text();
  if (result.pairs.empty()) text += "(no candidate pairs)\n";
  if (!result.surface.ran) return text;
  const SurfaceBundleReport& sb = result.surface;
  Appendf(&text,
          "\nsurface bundle: %d planes, %d pixels, %d rounds; residual spread %.3f x the "
          "noise model\n",
          sb.planes, sb.pixels, sb.rounds, sb.noise_scale);
  TextTable surface_table({{35, Align::kLeft, ""}, {22}, {18}, {0, Align::kLeft, "  "}});
  surface_table.AddRow({"camera", "plane thickness (sigma)", "noise correlation"});
  for (const CameraReport& c : result.cameras) {
    std::string notes = DepthModelText(c.depth_model);
    if (c.surface_fallback)
      notes += (notes.empty() ? "" : "; ") + std::string("kept its joint pose");
    surface_table.AddRow(
        {c.serial,
         Fixed(c.surface_thickness_before, 2) + " -> " + Fixed(c.surface_thickness_after, 2),
         Fixed(c.surface_noise_correlation, 1), notes});
  }
  return text + surface_table.text();
}

/// The summary the command prints (and the report's page shows).
std::string Summary(const RefineResult& result, const RefineOptions& options, const RefineArgs& a,
                    const Timings& t) {
  std::string text = "\n" + CameraTable(result, options, a);
  if (!a.no_icp) text += RegistrationTables(result);
  Appendf(&text,
          "\ntime (s): load %.2f, leveling %.2f, preprocessing %.2f, registration %.2f, "
          "pose graph %.2f, output %.2f, total %.2f\n",
          t.load_s, t.solver.leveling_s, t.solver.preprocessing_s, t.solver.registration_s,
          t.solver.pose_graph_s, t.output_s, t.total_s);
  const int cameras = static_cast<int>(result.cameras.size());
  if (a.no_icp) {
    int leveled = 0;
    for (const CameraReport& c : result.cameras) {
      leveled += options.ground.enabled && c.ground.accepted ? 1 : 0;
    }
    Appendf(&text, "leveled %d of %d cameras (registration skipped) -> %s\n", leveled, cameras,
            a.out_path.c_str());
    return text;
  }
  int refined = 0;
  for (const CameraReport& c : result.cameras) refined += !c.reference && c.accepted ? 1 : 0;
  if (result.success) {
    Appendf(&text, "refined %d of %d non-reference cameras -> %s\n", refined, cameras - 1,
            a.out_path.c_str());
  } else {
    Appendf(&text, "refinement not applied: %s; wrote the %s poses -> %s\n", result.message.c_str(),
            options.ground.enabled ? "leveled" : "input", a.out_path.c_str());
  }
  return text;
}

int RunRefine(const RefineArgs& a) {
  const auto start = Clock::now();
  const Log log = StderrLog("refine: ", a.quiet     ? Verbosity::kQuiet
                                        : a.verbose ? Verbosity::kVerbose
                                                    : Verbosity::kNormal);
  CheckFlags(a);
  CheckOutputPath(a);
  if (!a.report_dir.empty()) CheckReportDirectory(a.report_dir, "refine: --report");
  RefineOptions options = EffectiveOptions(a);
  // The report's 3-D view draws the surface bundle's planes: the solver copies them out (the
  // poses are the same either way).
  options.icp.keep_surface_diagnostics = !a.report_dir.empty() && options.icp.surface_bundle;
  log.Info("loading " + a.capture_path + " and " + a.extrinsics_path);
  const RigCapture capture = ReadCaptureGuarded(a.capture_path);
  const ExtrinsicsDocument initial = ReadExtrinsics(a.extrinsics_path);
  CheckRefineInput(
      capture, initial.poses, options,
      {"refine", a.capture_path, a.extrinsics_path,
       a.reference_option->count() > 0 ? "--reference" : a.config_path + ": icp.reference"});
  std::vector<std::string> warnings = initial.warnings;
  for (const std::string& w : CaptureWarnings(capture, a.capture_path)) warnings.push_back(w);
  for (const std::string& w : warnings) log.Warning(w);
  Timings timings;
  timings.load_s = SecondsSince(start);
  log.Info("loaded " + std::to_string(capture.cameras.size()) + " cameras in " +
           Fixed(timings.load_s, 2) + " s");

  const RefineResult result = Refine(capture, initial.poses, options, log);
  timings.solver = result.times;
  for (const PoseMap* poses : {&result.leveled, &result.refined}) {
    for (const auto& [serial, T] : *poses) {
      if (!T.matrix().allFinite()) {
        throw std::runtime_error("refine: the solver produced a non-finite pose for " + serial);
      }
    }
  }

  const auto output_start = Clock::now();
  warnings.insert(warnings.end(), result.warnings.begin(), result.warnings.end());
  Json meta = RefineMetaJson(result, options, warnings, {a.no_ground, a.no_icp});
  for (const std::string& path : ReplaceNonFinite(meta, "_meta")) {
    const std::string warning = path + " was not finite and is written as null";
    log.Warning(warning);
    meta["icp_refined"]["warnings"].push_back(warning);
  }
  // The file cannot time its own writing: its "output" is the time to assemble the report,
  // its "total" runs up to the write; the summary on stdout includes the write.
  timings.output_s = SecondsSince(output_start);
  timings.total_s = SecondsSince(start);
  if (!a.no_timings) meta["icp_refined"]["timings_s"] = TimingsJson(timings);

  // Issue 4: when the refinement is not applied, the output is the leveled input.
  const PoseMap& poses = result.success ? result.refined : result.leveled;
  WriteExtrinsics(a.out_path, poses, initial.document, meta, InputFiles(a));
  timings.output_s = SecondsSince(output_start);
  timings.total_s = SecondsSince(start);
  const std::string summary = Summary(result, options, a, timings);
  std::fputs(summary.c_str(), stdout);
  if (!a.report_dir.empty()) {
    log.Info("writing the report to " + a.report_dir);
    for (const std::string& file :
         WriteRefineReport(a.report_dir, capture, result, poses, options, summary)) {
      std::printf("report: %s\n", file.c_str());
    }
  }
  return result.success ? kExitOk : kExitNotApplied;
}

}  // namespace

Command AddRefineCommand(CLI::App& app) {
  auto args = std::make_shared<RefineArgs>();
  RefineArgs& a = *args;
  CLI::App* sub = app.add_subcommand(
      "refine",
      "Refine the extrinsics of a rig from one capture: ground leveling (floor -> y = 0, +Y "
      "up), then registration of every camera's near-floor band. Writes OUT with the refined "
      "T_world_camera of every camera and a report in _meta. Exit codes: 0 refined; 3 ran but "
      "the refinement was not applied (OUT holds the leveled poses, success false); 2 bad "
      "input or usage (nothing written); 1 internal error.");
  sub->add_option("--capture", a.capture_path, "Rig capture (HDF5)")->required();
  sub->add_option("--extrinsics", a.extrinsics_path,
                  "Initial extrinsics (JSON): a pose for every camera of the capture")
      ->required();
  sub->add_option("--out", a.out_path,
                  "Output extrinsics (JSON); its directory must exist, and it must not be an "
                  "input file")
      ->required();
  sub->add_option("--config", a.config_path,
                  "Options (YAML, docs/config.md); the flags below override it");
  // Defaults in the help come from options/refine_options.h, the single source of truth.
  const Json defaults = ConfigToJson(RefineOptions{})["icp"];
  a.mode_option =
      sub->add_option("--mode", a.mode,
                      "Registration: joint (all cameras in one problem) or pairwise (pairwise "
                      "ICP + pose graph); overrides icp.mode (default " +
                          defaults["mode"].get<std::string>() + ")")
          ->check(CLI::IsMember({"joint", "pairwise"}));
  const std::vector<std::string> methods = RegistrationMethodNames();
  a.method_option =
      sub->add_option("--method", a.method,
                      "Registration residual: " + Join(methods, " or ") +
                          "; overrides icp.method (default " +
                          defaults["method"].get<std::string>() + ")")
          ->check(CLI::Validator(
              [methods](const std::string& v) {
                if (std::find(methods.begin(), methods.end(), v) != methods.end()) {
                  return std::string();
                }
                return "must be " + Join(methods, " or ") + ", got '" + v + "'" +
                       (v == "surface_bundle" ? " (the surface bundle is a stage of its own now: "
                                                "--surface-bundle)"
                                              : "");
              },
              Join(methods, "|"), "method"));
  a.surface_bundle_option = sub->add_flag(
      "--surface-bundle,!--no-surface-bundle", a.surface_bundle,
      "After the registration, refine every camera and the planes they see in one problem (the "
      "surface bundle); overrides icp.surface_bundle (default " +
          defaults["surface_bundle"].dump() + ")");
  a.voxel_size_option =
      sub->add_option("--voxel-size", a.voxel_size,
                      "Finest voxel size in metres (> 0); overrides icp.voxel_size (default " +
                          defaults["voxel_size"].dump() + ")");
  a.reference_option = sub->add_option(
      "--reference", a.reference,
      "Serial of the camera held fixed; overrides icp.reference (default: the first serial)");
  sub->add_option("--report", a.report_dir,
                  "Also write pictures of the result to this directory (created if missing; "
                  "its parent must exist): the near-floor band from above before and after, "
                  "a histogram of the correspondence residuals and an interactive 3-D view "
                  "before and after (view3d.html, opens offline; docs/usage.md)");
  sub->add_flag("--no-ground", a.no_ground, "Skip ground leveling (sets ground.enabled false)");
  sub->add_flag("--no-icp", a.no_icp, "Stop after ground leveling (no registration)");
  sub->add_flag("--no-timings", a.no_timings,
                "Leave timings out of _meta, so that outputs of identical runs are "
                "byte-identical");
  sub->add_option("--threads", a.threads, "Worker threads")->capture_default_str();
  CLI::Option* quiet =
      sub->add_flag("--quiet,-q", a.quiet, "Progress off: stderr shows only warnings and errors");
  sub->add_flag("--verbose,-v", a.verbose, "Also debug messages (per scale and iteration)")
      ->excludes(quiet);
  return {sub, [args] { return RunRefine(*args); }};
}

}  // namespace rigfit::cli
