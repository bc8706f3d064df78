// The settings `rigfit slam` takes as flags and rigfit.slam as keywords (docs/python.md) beyond
// the tracking ones (rgbd/tracking_options.h): the fusion gates and rules, the model rendering
// and the halving, checked in one place so that the CLI and the Python module accept the same
// values with the same messages.
#pragma once

#include <string>

#include "core/setting_error.h"
#include "rgbd/slam.h"

namespace rigfit {

/// Checks, after ApplyTrackingSettings: fuse_distance > 0 and fuse_angle in (0, 180]
/// (options.fusion's gates), cover_radius >= 0, dormant_frames >= 0, model_weight >= 1,
/// model_recent >= 0 (options.render) and halve >= 0 when set (options.halvings). Throws
/// SettingError (core/setting_error.h) on a bad value.
void CheckSlamSettings(const SlamOptions& options);

}  // namespace rigfit
