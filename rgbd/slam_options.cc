#include "rgbd/slam_options.h"

#include "core/setting_error.h"

namespace rigfit {

void CheckSlamSettings(const SlamOptions& options) {
  const FusionOptions& fusion = options.fusion;
  if (!(fusion.max_distance_m > 0.0) ||
      !(fusion.max_normal_angle_deg > 0.0 && fusion.max_normal_angle_deg <= 180.0)) {
    throw SettingError("fuse_distance", "must be > 0 and {fuse_angle} in (0, 180]");
  }
  if (!(fusion.cover_radius_scale >= 0.0)) {
    throw SettingError("cover_radius", "must be >= 0");
  }
  if (fusion.dormant_frames < 0) {
    throw SettingError("dormant_frames", "must be >= 0 (0: off)");
  }
  if (!(options.render.min_weight >= 1.0f)) {
    throw SettingError("model_weight", "must be >= 1");
  }
  if (options.render.recent_frames < 0) {
    throw SettingError("model_recent", "must be >= 0");
  }
  if (options.halvings.value_or(0) < 0) throw SettingError("halve", "must be >= 0");
}

}  // namespace rigfit
