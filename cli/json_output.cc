#include "cli/json_output.h"

#include <cmath>

#include "io/atomic_file.h"

namespace rigfit::cli {
namespace {

using Json = nlohmann::json;

/// {"rms": ..., "max": ...}, null for both when there is nothing to summarise.
Json RmsMax(bool defined, double rms, double max) {
  if (!defined) return {{"rms", nullptr}, {"max", nullptr}};
  return {{"rms", rms}, {"max", max}};
}

}  // namespace

void WriteJsonFile(const std::string& path, const Json& json) {
  const std::string text = json.dump(2) + "\n";
  WriteTextFileAtomically(path, text);
}

Json RigErrorsSummaryJson(const RigErrors& e) {
  constexpr double kMToMm = 1e3;
  const bool has_pairs = !e.pairs.empty();
  return {{"rotation_deg",
           RmsMax(has_pairs, e.rms_rotation_rad * kRadToDeg, e.max_rotation_rad * kRadToDeg)},
          {"translation_mm",
           RmsMax(has_pairs, e.rms_translation_m * kMToMm, e.max_translation_m * kMToMm)},
          {"tilt_deg", RmsMax(true, e.rms_tilt_rad * kRadToDeg, e.max_tilt_rad * kRadToDeg)}};
}

}  // namespace rigfit::cli
