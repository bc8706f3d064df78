// `rigfit evaluate`: gauge-free errors of estimated extrinsics against ground truth
// (core/evaluate.h): the relative pose of every camera pair and the tilt of every camera.
// A table on stdout, and optionally the same numbers as JSON (docs/usage.md).
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/json_output.h"
#include "core/errors.h"
#include "core/evaluate.h"
#include "core/format.h"
#include "io/atomic_file.h"
#include "io/extrinsics_json.h"
#include "io/text_table.h"
#include "report/compare.h"

namespace rigfit::cli {
namespace {

using Json = nlohmann::json;

constexpr double kMToMm = 1e3;

struct EvaluateArgs {
  std::string estimate_path;
  std::string ground_truth_path;
  std::string json_path;  ///< empty: no JSON output
};

Json ErrorsJson(const RigErrors& e, const EvaluateArgs& a,
                const std::vector<std::string>& ignored) {
  Json document = RigErrorsJson(e);
  document["estimate"] = a.estimate_path;
  document["ground_truth"] = a.ground_truth_path;
  document["ignored_cameras"] = ignored;
  return document;
}

void PrintTable(const RigErrors& e, const EvaluateArgs& a) {
  std::printf("%s against %s: %zu cameras (gauge-free)\n", a.estimate_path.c_str(),
              a.ground_truth_path.c_str(), e.tilt_rad.size());
  TextTable pairs({{35, Align::kLeft, ""}, {13}, {15}});
  pairs.AddRow({"pair", "rotation deg", "translation mm"});
  for (const PairError& p : e.pairs) {
    pairs.AddRow({p.serial_i + " - " + p.serial_j, Fixed(p.error.rotation_rad * kRadToDeg, 3),
                  Fixed(p.error.translation_m * kMToMm, 2)});
  }
  if (!e.pairs.empty()) {
    pairs.AddRow(
        {"RMS", Fixed(e.rms_rotation_rad * kRadToDeg, 3), Fixed(e.rms_translation_m * kMToMm, 2)});
    pairs.AddRow(
        {"max", Fixed(e.max_rotation_rad * kRadToDeg, 3), Fixed(e.max_translation_m * kMToMm, 2)});
  }
  std::printf("\n%s%s", pairs.text().c_str(), e.pairs.empty() ? "(one camera: no pairs)\n" : "");
  TextTable cameras({{35, Align::kLeft, ""}, {13}});
  cameras.AddRow({"camera", "tilt deg"});
  for (const auto& [serial, tilt] : e.tilt_rad)
    cameras.AddRow({serial, Fixed(tilt * kRadToDeg, 3)});
  cameras.AddRow({"RMS", Fixed(e.rms_tilt_rad * kRadToDeg, 3)});
  cameras.AddRow({"max", Fixed(e.max_tilt_rad * kRadToDeg, 3)});
  std::printf("\n%s", cameras.text().c_str());
}

int RunEvaluate(const EvaluateArgs& a) {
  if (!a.json_path.empty()) {
    RefuseToOverwriteInputs(a.json_path, {a.estimate_path, a.ground_truth_path},
                            "evaluate: --json");
  }
  const ExtrinsicsDocument est = ReadExtrinsics(a.estimate_path);
  const ExtrinsicsDocument gt = ReadExtrinsics(a.ground_truth_path);
  for (const std::vector<std::string>* w : {&est.warnings, &gt.warnings}) {
    for (const std::string& warning : *w) {
      std::fprintf(stderr, "evaluate: warning: %s\n", warning.c_str());
    }
  }
  const std::vector<std::string> ignored =
      CheckEvaluationCameras(est.poses, gt.poses, "evaluate", a.estimate_path, a.ground_truth_path);
  if (!ignored.empty()) {
    std::fprintf(stderr, "evaluate: note: camera(s) %s of %s are not in %s: ignored\n",
                 Join(ignored).c_str(), a.estimate_path.c_str(), a.ground_truth_path.c_str());
  }
  const RigErrors errors = EvaluateRig(est.poses, gt.poses);
  if (!a.json_path.empty()) WriteJsonFile(a.json_path, ErrorsJson(errors, a, ignored));
  PrintTable(errors, a);
  return kExitOk;
}

}  // namespace

Command AddEvaluateCommand(CLI::App& app) {
  auto args = std::make_shared<EvaluateArgs>();
  CLI::App* sub = app.add_subcommand(
      "evaluate",
      "Compare estimated extrinsics EST with ground truth GT, free of the gauge (the pose of "
      "the rig as a whole): the error of the relative pose of every camera pair (rotation "
      "deg, translation mm) and the tilt error of every camera (deg), with RMS and max. "
      "Every camera of GT must be in EST; cameras of EST not in GT are ignored. Exit codes: "
      "0 done; 2 bad input or usage (nothing written).");
  sub->add_option("EST", args->estimate_path, "Estimated extrinsics (JSON)")->required();
  sub->add_option("GT", args->ground_truth_path, "Ground-truth extrinsics (JSON)")->required();
  sub->add_option("--json", args->json_path,
                  "Also write the errors to this JSON file (replaced atomically; must not be "
                  "EST or GT)");
  return {sub, [args] { return RunEvaluate(*args); }};
}

}  // namespace rigfit::cli
