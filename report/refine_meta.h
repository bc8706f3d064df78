// The `_meta` report of a refine output (docs/usage.md, "The output file"): what `rigfit refine`
// writes beside the refined extrinsics, for the CLI and for library callers alike.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "options/refine_options.h"
#include "rig/refine.h"

namespace rigfit {

/// How the run was asked for, where the report says why a stage was skipped.
struct RefineMetaFlags {
  bool no_ground = false;  ///< leveling skipped by the caller (`--no-ground`)
  bool no_icp = false;     ///< registration skipped by the caller (`--no-icp`)
};

/// {"ground_refined": ..., "icp_refined": ...} of a refine run: per-camera leveling, the
/// registration's mode, method, config echo, warnings, pairs, cameras (with 1-sigma and weak
/// directions) and, with the surface bundle, its planes and plane thickness. Timings are the
/// caller's to add (`icp_refined.timings_s`). Numbers may be non-finite: ReplaceNonFinite.
nlohmann::json RefineMetaJson(const RefineResult& result, const RefineOptions& options,
                              const std::vector<std::string>& warnings,
                              const RefineMetaFlags& flags = {});

/// Calls f(name, value) for every field of a camera's surface-bundle depth model, named as the
/// `_meta` JSON and Python's rigfit.DepthModel name them, in the struct's order.
template <typename F>
void ForEachDepthModelField(const DepthModelEstimate& d, F&& f) {
  f("solved", d.solved);
  f("observable", d.observable);
  f("scale", d.scale);
  f("offset", d.offset);
  f("offset_px", d.offset_px);
  f("scale_sigma", d.scale_sigma);
  f("offset_sigma", d.offset_sigma);
  f("scale_prior_sigma", d.scale_prior_sigma);
  f("offset_prior_sigma", d.offset_prior_sigma);
  f("pose_correlation", d.pose_correlation);
}

/// Whether the solver reached a verdict on the camera's registration change (applied, or a
/// reason not to), so that the change was measured.
bool ChangeMeasured(const RefineResult& result, const CameraReport& camera);

/// JSON cannot hold NaN or infinity (nlohmann would write null silently): replaces each by
/// null and returns where, as "_meta.a.b[2]" paths.
std::vector<std::string> ReplaceNonFinite(nlohmann::json& value, const std::string& path);

}  // namespace rigfit
