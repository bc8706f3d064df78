// The comparison of `rigfit compare` and `rigfit.compare` as its JSON document and its text
// tables (the comparison itself: rig/compare.h).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "core/evaluate.h"
#include "rig/compare.h"

namespace rigfit {

/// The JSON document of `rigfit compare --json` (docs/usage.md): "modes" keyed by run name,
/// "before", "verdict" and the rest. Numbers may be non-finite (ReplaceNonFinite).
nlohmann::json CompareToJson(const CompareResult& result, const CompareSources& sources);

/// The comparison as `rigfit compare` prints it: a header, one table a view, the verdict.
std::string CompareText(const CompareResult& result, const CompareSources& sources);

/// The summary of gauge-free errors: {"rotation_deg": {"rms", "max"}, "translation_mm":
/// {...}, "tilt_deg": {...}}; rotation and translation are null without camera pairs
/// (`rigfit evaluate --json`'s "summary").
nlohmann::json RigErrorsSummaryJson(const RigErrors& errors);

/// The gauge-free errors as `rigfit evaluate --json` and `rigfit.evaluate` give them:
/// {"pairs": [{"serial_i", "serial_j", "rotation_deg", "translation_mm"}], "cameras":
/// [{"serial", "tilt_deg"}], "summary": RigErrorsSummaryJson}.
nlohmann::json RigErrorsJson(const RigErrors& errors);

}  // namespace rigfit
