// The report of `rigfit refine --report DIR`: pictures a person reads at a glance to judge
// a refinement (docs/usage.md, "Reading the report").
#pragma once

#include <string>
#include <vector>

#include "core/types.h"
#include "options/refine_options.h"
#include "report/compare.h"
#include "rig/refine.h"

namespace rigfit {

/// The report's files, in DIR.
inline constexpr const char* kTopDownBeforeFile = "topdown_before.png";
inline constexpr const char* kTopDownAfterFile = "topdown_after.png";
inline constexpr const char* kResidualsFile = "residuals.png";

/// Throws InputError (naming `what`, e.g. "refine: --report") unless dir is an existing
/// directory or can be created as one: its parent exists and nothing else has its name.
void CheckReportDirectory(const std::string& dir, const std::string& what);

/// Checks dir as CheckReportDirectory does ("report:") and creates it when missing; throws
/// InputError when it cannot. Every report writer starts with it.
void CreateReportDirectory(const std::string& dir);

/// Writes the report of a refine run into dir, creating dir if missing (its parent must
/// exist):
/// - kTopDownBeforeFile, kTopDownAfterFile: the near-floor band of every camera at the
///   finest voxel (rig/diagnostics.h), seen from above, coloured per camera
///   (report/palette.h), at the leveled poses (before registration) and at `after`;
/// - kResidualsFile: the histogram of the point-to-plane residuals of the finest-scale
///   correspondences of every candidate pair, at the leveled poses and at `after`;
/// - the 3-D view (report/view3d.h, RigView3dScene) at the leveled poses ("before") and at
///   `after`;
/// - kReportIndexFile (report/html.h): one page showing `summary` (the text the command
///   printed; may be empty), a link to the 3-D view and the three pictures.
/// `after` holds the poses written as the result (every camera of the capture); options.threads
/// threads. Returns the paths written, the page last. Throws InputError when a file cannot be
/// written.
std::vector<std::string> WriteRefineReport(const std::string& dir, const RigCapture& capture,
                                           const RefineResult& result, const PoseMap& after,
                                           const RefineOptions& options,
                                           const std::string& summary = "");

/// Writes the report of a comparison (`rigfit compare --report DIR`) into dir, created as
/// WriteRefineReport creates it: the 3-D view (report/view3d.h, RigView3dScene) at the
/// initial, the leveled ("before") and each run's output poses, the bands selected at the
/// leveled poses as Compare selects them (leveling run again on `capture` from
/// result.initial with `options`, its threads too), and kReportIndexFile showing `summary` and a
/// link to the view. Returns the paths written, the page last. Throws InputError when a file cannot
/// be written.
std::vector<std::string> WriteCompareReport(const std::string& dir, const RigCapture& capture,
                                            const CompareResult& result,
                                            const RefineOptions& options,
                                            const std::string& summary);

}  // namespace rigfit
