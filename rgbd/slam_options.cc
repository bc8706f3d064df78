#include "rgbd/slam_options.h"

#include "core/errors.h"

namespace rigfit {

void CheckSlamSettings(const std::string& command, OptionSpelling spelling,
                       const SlamOptions& options) {
  const std::string c = command + ": ";
  const auto name = [spelling](const char* key) { return OptionName(key, spelling); };
  const FusionOptions& fusion = options.fusion;
  if (!(fusion.max_distance_m > 0.0) ||
      !(fusion.max_normal_angle_deg > 0.0 && fusion.max_normal_angle_deg <= 180.0)) {
    throw InputError(c + name("fuse_distance") + " must be > 0 and " + name("fuse_angle") +
                     " in (0, 180]");
  }
  if (!(fusion.cover_radius_scale >= 0.0)) {
    throw InputError(c + name("cover_radius") + " must be >= 0");
  }
  if (fusion.dormant_frames < 0) {
    throw InputError(c + name("dormant_frames") + " must be >= 0 (0: off)");
  }
  if (!(options.render.min_weight >= 1.0f)) {
    throw InputError(c + name("model_weight") + " must be >= 1");
  }
  if (options.render.recent_frames < 0) {
    throw InputError(c + name("model_recent") + " must be >= 0");
  }
  if (options.halvings < 0) throw InputError(c + name("halve") + " must be >= 0");
}

}  // namespace rigfit
