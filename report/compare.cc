#include "report/compare.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <stdexcept>

#include "core/errors.h"
#include "core/format.h"
#include "core/peak_memory.h"
#include "core/stopwatch.h"
#include "io/config_yaml.h"
#include "io/extrinsics_json.h"
#include "io/text_table.h"

namespace rigfit {
namespace {

using Json = nlohmann::json;

constexpr double kMToMm = 1e3;

// --- What the tables and the JSON show.

/// The change a run made to a camera, from the leveled pose.
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

/// What a run did, in one phrase.
std::string Outcome(const CompareRun& run) {
  if (!run.success) return "not applied: " + run.message;
  int refined = 0, kept = 0;
  for (const CameraReport& c : run.cameras) {
    refined += !c.reference && c.accepted ? 1 : 0;
    kept += c.surface_fallback ? 1 : 0;
  }
  std::string text = "refined " + std::to_string(refined) + " of " +
                     std::to_string(run.cameras.size() - 1) + " non-reference cameras";
  if (kept > 0) text += ", " + std::to_string(kept) + " kept their joint pose";
  return text;
}

}  // namespace

namespace {

const CompareRun* RunNamed(const CompareResult& c, const std::string& name) {
  for (const CompareRun& run : c.runs) {
    if (run.name == name) return &run;
  }
  return nullptr;
}

/// Per camera: each run's change (and error against the truth).
std::string CameraTable(const CompareResult& c) {
  std::vector<TextColumn> columns = {{16, Align::kLeft, ""}};
  std::vector<TextSpan> runs = {{"", 1}}, parts = {{"", 1}};
  std::vector<std::string> units = {"camera"};
  for (const CompareRun& run : c.runs) {
    columns.insert(columns.end(), {{6, Align::kRight, " | "}, {7}});
    parts.push_back({"change", 2});
    units.insert(units.end(), {"deg", "mm"});
    if (c.has_gt) {
      columns.insert(columns.end(), {{6}, {7}, {6}});
      parts.push_back({"error vs gt", 3});
      units.insert(units.end(), {"deg", "mm", "tilt"});
    }
    runs.push_back({run.name, c.has_gt ? 5 : 2});
  }
  TextTable table(columns);
  table.AddSpans(runs);
  table.AddSpans(parts);
  table.AddRow(units);
  for (const std::string& serial : c.serials) {
    std::vector<std::string> row = {serial};
    for (const CompareRun& run : c.runs) {
      const Change change = ChangeOf(c.leveled, run.output, serial);
      row.insert(row.end(), {Fixed(change.rotation_deg, 3), Fixed(change.translation_mm, 1)});
      if (c.has_gt) {
        const CameraError e = CameraErrorOf(run.errors, serial, c.reference);
        row.insert(row.end(),
                   {FixedOrDash(e.has_relative, e.rotation_deg, 3),
                    FixedOrDash(e.has_relative, e.translation_mm, 1), Fixed(e.tilt_deg, 3)});
      }
    }
    table.AddRow(row);
  }
  return table.text();
}

/// A run's inflation of a camera's 1-sigma, "rotation/translation" ("-" without a covariance).
std::string InflationText(const CameraReport* c) {
  if (c == nullptr || !c->has_covariance) return "-";
  return Fixed(c->sigma_inflation.rotation, 1) + "/" + Fixed(c->sigma_inflation.translation, 1);
}

/// The surface orientations under a camera's joint pose, "few" when too few.
std::string SurfacesText(const CameraReport* c) {
  if (c == nullptr || c->reference || !c->connected) return "-";
  return std::to_string(c->surfaces) + (c->few_surfaces ? " few" : "");
}

/// A camera's 1-sigma as "rotation deg / translation mm" (square roots of its blocks' traces).
std::string SigmaText(const CameraReport* c) {
  if (c == nullptr || !c->has_covariance) return "-";
  return Fixed(std::sqrt(c->covariance.topLeftCorner<3, 3>().trace()) * kRadToDeg, 3) + "/" +
         Fixed(std::sqrt(c->covariance.bottomRightCorner<3, 3>().trace()) * 1e3, 1);
}

/// Per camera: the joint run's 1-sigma, its inflation and the surfaces under the pose, and the
/// surface bundle's plane thickness, noise correlation and 1-sigma (a camera that kept its joint
/// pose: the joint covariance).
std::string UncertaintyTable(const CompareResult& c) {
  const CompareRun* joint = RunNamed(c, "joint");
  const CompareRun* surface = RunNamed(c, "surface_bundle");
  const bool bundled = surface != nullptr && surface->surface.ran;
  std::string text;
  if (bundled) {
    const SurfaceBundleReport& sb = surface->surface;
    Appendf(&text,
            "surface bundle: %d planes, %d pixels, %d rounds; residual spread %.3f x the noise "
            "model\n",
            sb.planes, sb.pixels, sb.rounds, sb.noise_scale);
  }
  TextTable table({{16, Align::kLeft, ""},
                   {7, Align::kRight, " | "},
                   {8},
                   {6},
                   {6},
                   {6},
                   {8},
                   {8},
                   {23, Align::kRight, " | "},
                   {17},
                   {15},
                   {8},
                   {0, Align::kLeft, "  "}});
  table.AddSpans({{"", 1}, {"joint 1-sigma", 7}, {"surface bundle", 5}});
  table.AddRow({"camera", "yaw deg", "tilt deg", "x mm", "y mm", "z mm", "inflated", "surfaces",
                "plane thickness (sigma)", "noise correlation", "1-sigma deg/mm", "inflated"});
  for (size_t i = 0; i < c.serials.size(); ++i) {
    std::vector<std::string> row = {c.serials[i]};
    const CameraReport* j = joint != nullptr ? &joint->cameras[i] : nullptr;
    const bool shown = j != nullptr && j->has_covariance;
    const PoseSigma s = shown ? SigmaOf(j->covariance) : PoseSigma{};
    row.insert(row.end(), {FixedOrDash(shown, s.yaw_deg, 3), FixedOrDash(shown, s.tilt_deg, 3),
                           FixedOrDash(shown, s.x_mm, 2), FixedOrDash(shown, s.y_mm, 2),
                           FixedOrDash(shown, s.z_mm, 2), InflationText(j), SurfacesText(j)});
    const CameraReport* b = bundled ? &surface->cameras[i] : nullptr;
    row.insert(row.end(), {b == nullptr ? "-"
                                        : Fixed(b->surface_thickness_before, 2) + " -> " +
                                              Fixed(b->surface_thickness_after, 2),
                           FixedOrDash(b != nullptr, b ? b->surface_noise_correlation : 0.0, 1),
                           SigmaText(b), InflationText(b)});
    std::vector<std::string> notes;
    if (j != nullptr && j->reference) notes.push_back("(reference)");
    if (b != nullptr && b->surface_fallback) notes.push_back("kept its joint pose");
    if (b != nullptr && b->few_surfaces) notes.push_back("few surfaces");
    row.push_back(Join(notes, ", "));
    table.AddRow(row);
  }
  text += table.text();
  if (surface != nullptr && !bundled) text += "(the surface bundle did not run)\n";
  return text;
}

/// Per pair: the fit before and after each run, and all pairs pooled.
std::string FitTable(const CompareResult& c) {
  std::vector<TextColumn> columns = {{35, Align::kLeft, ""}};
  std::vector<TextSpan> spans = {{"pair fit (finest scale, both ways)", 1}, {"before", 3}};
  std::vector<std::string> heads = {"pair: RMSE mm (all, off-floor)"};
  std::vector<const std::vector<PairDiagnostics>*> fits = {&c.fit_before};
  for (const CompareRun& run : c.runs) {
    spans.push_back({run.name, 3});
    fits.push_back(&run.fit);
  }
  for (size_t f = 0; f < fits.size(); ++f) {
    columns.insert(columns.end(), {{7, Align::kRight, " | "}, {7}, {8}});
    heads.insert(heads.end(), {"all", "off", "inliers"});
  }
  TextTable table(columns);
  table.AddSpans(spans);
  table.AddRow(heads);
  // A pair's fit or the pooled one (PairDiagnostics, PooledFit): RMSE, off-floor, inliers.
  const auto add_fit = [](const auto& fit, std::vector<std::string>* row) {
    row->insert(row->end(), {Fixed(fit.rmse_m * kMToMm, 2), Fixed(fit.off_floor_rmse_m * kMToMm, 2),
                             Fixed(fit.inlier_fraction, 3)});
  };
  for (size_t k = 0; k < c.fit_before.size(); ++k) {
    const PairDiagnostics& pair = c.fit_before[k];
    std::vector<std::string> row = {c.pair_serials[pair.a] + " - " + c.pair_serials[pair.b]};
    for (const std::vector<PairDiagnostics>* fit : fits) add_fit((*fit)[k], &row);
    table.AddRow(row);
  }
  if (c.fit_before.empty()) return table.text() + "(no candidate pairs)\n";
  std::vector<std::string> row = {"all pairs"};
  for (const std::vector<PairDiagnostics>* fit : fits) add_fit(PoolFits(*fit), &row);
  table.AddRow(row);
  return table.text();
}

/// RMS and max over camera pairs of the gauge-free errors: input, leveled, each run.
std::string ErrorTable(const CompareResult& c) {
  TextTable table({{35, Align::kLeft, ""},
                   {9, Align::kRight, " | "},
                   {9},
                   {9, Align::kRight, " | "},
                   {9},
                   {9, Align::kRight, " | "}});
  table.AddRow(
      {"errors vs gt (gauge-free)", "rot RMS", "rot max", "trans RMS", "trans max", "tilt RMS"});
  table.AddRow({"", "deg", "deg", "mm", "mm", "deg"});
  std::vector<std::pair<std::string, const RigErrors*>> rows = {{"input", &c.errors_initial},
                                                                {"leveled", &c.errors_leveled}};
  for (const CompareRun& run : c.runs) rows.emplace_back(run.name, &run.errors);
  for (const auto& [name, e] : rows) {
    const bool pairs_shown = !e->pairs.empty();
    table.AddRow({name, FixedOrDash(pairs_shown, e->rms_rotation_rad * kRadToDeg, 3),
                  FixedOrDash(pairs_shown, e->max_rotation_rad * kRadToDeg, 3),
                  FixedOrDash(pairs_shown, e->rms_translation_m * kMToMm, 2),
                  FixedOrDash(pairs_shown, e->max_translation_m * kMToMm, 2),
                  Fixed(e->rms_tilt_rad * kRadToDeg, 3)});
  }
  return table.text();
}

/// Each run's method, wall time, peak memory and outcome, and what the numbers cover.
std::string ResourceTable(const CompareResult& c) {
  TextTable table(
      {{16, Align::kLeft, ""}, {14, Align::kLeft, "  "}, {8}, {12}, {0, Align::kLeft, "  "}});
  table.AddRow({"run", "method", "wall s", "peak RSS MB", "result"});
  bool per_run = true;
  for (const CompareRun& run : c.runs) {
    table.AddRow({run.name, RegistrationMethodName(run.method), Fixed(run.wall_s, 2),
                  Fixed(run.peak_rss_mb, 0), Outcome(run)});
    per_run = per_run && run.peak_per_run;
  }
  std::string text = table.text();
  const std::string baseline = Fixed(c.baseline_rss_mb, 0);
  if (per_run) {
    Appendf(&text,
            "(wall s: the refinement alone, loading excluded; peak RSS: the high-water mark of "
            "this process, which holds the loaded capture (%s MB before the runs), during that "
            "run)\n",
            baseline.c_str());
  } else {
    Appendf(&text,
            "(wall s: the refinement alone, loading excluded; peak RSS: the high-water mark of "
            "this process since it started, loading included (%s MB before the runs): the mark "
            "could not be reset per run through /proc/self/clear_refs)\n",
            baseline.c_str());
  }
  return text;
}

Json FitJson(const std::vector<PairDiagnostics>& fits, const std::vector<std::string>& serials) {
  Json pairs = Json::array();
  for (const PairDiagnostics& f : fits) {
    pairs.push_back({{"serial_a", serials[f.a]},
                     {"serial_b", serials[f.b]},
                     {"rmse_mm", f.rmse_m * kMToMm},
                     {"off_floor_rmse_mm", f.off_floor_rmse_m * kMToMm},
                     {"inlier_fraction", f.inlier_fraction},
                     {"correspondences", f.correspondences},
                     {"off_floor_correspondences", f.off_floor_correspondences}});
  }
  const PooledFit all = PoolFits(fits);
  return {{"pairs", pairs},
          {"all_pairs",
           {{"rmse_mm", all.rmse_m * kMToMm},
            {"off_floor_rmse_mm", all.off_floor_rmse_m * kMToMm},
            {"inlier_fraction", all.inlier_fraction},
            {"correspondences", all.correspondences},
            {"off_floor_correspondences", all.off_floor_correspondences}}}};
}

Json CameraJson(const CompareResult& c, const CompareRun& run, size_t i) {
  const std::string& serial = c.serials[i];
  const CameraReport& outcome = run.cameras[i];
  const Change change = ChangeOf(c.leveled, run.output, serial);
  Json camera = {{"reference", outcome.reference},
                 {"accepted", outcome.accepted},
                 {"message", outcome.message},
                 {"change_rotation_deg", change.rotation_deg},
                 {"change_translation_mm", change.translation_mm},
                 {"T_world_camera", PoseToJson(run.output.at(serial))}};
  if (c.has_gt) {
    const CameraError e = CameraErrorOf(run.errors, serial, c.reference);
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
    camera["sigma_inflation"] = {{"rotation", outcome.sigma_inflation.rotation},
                                 {"translation", outcome.sigma_inflation.translation}};
  }
  if (run.mode == RefineMode::kJoint && outcome.connected && !outcome.reference) {
    camera["surfaces"] = outcome.surfaces;
    camera["few_surfaces"] = outcome.few_surfaces;
  }
  if (run.surface.ran) {
    camera["surface"] = {{"thickness_before", outcome.surface_thickness_before},
                         {"thickness_after", outcome.surface_thickness_after},
                         {"fallback", outcome.surface_fallback},
                         {"noise_correlation", outcome.surface_noise_correlation}};
  }
  return camera;
}

Json RunJson(const CompareResult& c, const CompareRun& run) {
  Json cameras = Json::object();
  for (size_t i = 0; i < c.serials.size(); ++i) cameras[c.serials[i]] = CameraJson(c, run, i);
  RefineOptions options;
  options.icp.mode = run.mode;
  Json out = {{"mode", ConfigToJson(options)["icp"]["mode"]},
              {"method", RegistrationMethodName(run.method)},
              {"surface_bundle", run.surface_bundle},
              {"success", run.success},
              {"message", run.message},
              {"warnings", run.warnings},
              {"wall_s", run.wall_s},
              {"peak_rss_mb", run.peak_rss_mb},
              {"peak_rss_per_mode", run.peak_per_run},
              {"cameras", cameras},
              {"fit", FitJson(run.fit, c.pair_serials)},
              {"errors", c.has_gt ? RigErrorsSummaryJson(run.errors) : Json()}};
  if (run.surface_bundle) {
    const SurfaceBundleReport& sb = run.surface;
    out["surface"] = {{"ran", sb.ran},
                      {"planes", sb.planes},
                      {"pixels", sb.pixels},
                      {"rounds", sb.rounds},
                      {"noise_scale", sb.noise_scale}};
  }
  return out;
}

/// {"rms": ..., "max": ...}, null for both when there is nothing to summarise.
Json RmsMax(bool defined, double rms, double max) {
  if (!defined) return {{"rms", nullptr}, {"max", nullptr}};
  return {{"rms", rms}, {"max", max}};
}

Json NullIfEmpty(const std::string& text) { return text.empty() ? Json() : Json(text); }

}  // namespace

Json CompareToJson(const CompareResult& c, const CompareSources& sources) {
  Json modes = Json::object();
  Json runs = Json::array();
  for (const CompareRun& run : c.runs) {
    modes[run.name] = RunJson(c, run);
    runs.push_back(run.name);
  }
  return {{"capture", NullIfEmpty(sources.capture)},
          {"extrinsics", NullIfEmpty(sources.extrinsics)},
          {"ground_truth", c.has_gt ? NullIfEmpty(sources.ground_truth) : Json()},
          {"config", NullIfEmpty(sources.config)},
          {"method", RegistrationMethodName(c.method)},
          {"reference", c.reference},
          {"runs", runs},
          {"before",
           {{"fit", FitJson(c.fit_before, c.pair_serials)},
            {"errors_input", c.has_gt ? RigErrorsSummaryJson(c.errors_initial) : Json()},
            {"errors_leveled", c.has_gt ? RigErrorsSummaryJson(c.errors_leveled) : Json()}}},
          {"modes", modes},
          {"baseline_rss_mb", c.baseline_rss_mb},
          {"verdict", c.verdict}};
}

std::string CompareText(const CompareResult& c, const CompareSources& sources) {
  std::string text;
  const std::string method = RegistrationMethodName(c.method);
  const std::string capture = sources.capture.empty() ? "" : sources.capture + ", ";
  Appendf(&text, "\ncompare: %s%zu cameras, reference %s\n", capture.c_str(), c.serials.size(),
          c.reference.c_str());
  Appendf(&text,
          "Three runs: pairwise (pairwise ICP + pose graph, %s), joint (joint registration, "
          "%s), surface_bundle (joint registration, %s, then the surface bundle). All start "
          "from the same leveled poses; \"change\" is each run's move from there%s.\n",
          method.c_str(), method.c_str(), method.c_str(),
          c.has_gt ? ", \"error\" the camera's pose relative to the reference against the truth "
                     "(and its tilt)"
                   : "");
  text += "\n" + CameraTable(c);
  text += "\n" + UncertaintyTable(c);
  text += "\n" + FitTable(c);
  if (c.has_gt) text += "\n" + ErrorTable(c);
  text += "\n" + ResourceTable(c);
  Appendf(&text, "\nverdict: %s\n", c.verdict.c_str());
  return text;
}

Json RigErrorsSummaryJson(const RigErrors& e) {
  const bool has_pairs = !e.pairs.empty();
  return {{"rotation_deg",
           RmsMax(has_pairs, e.rms_rotation_rad * kRadToDeg, e.max_rotation_rad * kRadToDeg)},
          {"translation_mm",
           RmsMax(has_pairs, e.rms_translation_m * kMToMm, e.max_translation_m * kMToMm)},
          {"tilt_deg", RmsMax(true, e.rms_tilt_rad * kRadToDeg, e.max_tilt_rad * kRadToDeg)}};
}

Json RigErrorsJson(const RigErrors& e) {
  Json pairs = Json::array();
  for (const PairError& p : e.pairs) {
    pairs.push_back({{"serial_i", p.serial_i},
                     {"serial_j", p.serial_j},
                     {"rotation_deg", p.error.rotation_rad * kRadToDeg},
                     {"translation_mm", p.error.translation_m * kMToMm}});
  }
  Json cameras = Json::array();
  for (const auto& [serial, tilt] : e.tilt_rad) {
    cameras.push_back({{"serial", serial}, {"tilt_deg", tilt * kRadToDeg}});
  }
  return {{"pairs", pairs}, {"cameras", cameras}, {"summary", RigErrorsSummaryJson(e)}};
}

}  // namespace rigfit
