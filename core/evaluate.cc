#include "core/evaluate.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "core/errors.h"
#include "core/format.h"

namespace rigfit {

std::vector<std::string> CheckEvaluationCameras(const PoseMap& est, const PoseMap& gt,
                                                const std::string& what,
                                                const std::string& est_name,
                                                const std::string& gt_name) {
  if (gt.empty()) throw InputError(what + ": " + gt_name + " holds no camera");
  std::vector<std::string> missing, ignored;
  for (const auto& [serial, pose] : gt) {
    if (est.count(serial) == 0) missing.push_back(serial);
  }
  if (!missing.empty()) {
    throw InputError(what + ": " + est_name + " has no pose for camera(s) " + Join(missing) +
                     " of " + gt_name);
  }
  for (const auto& [serial, pose] : est) {
    if (gt.count(serial) == 0) ignored.push_back(serial);
  }
  return ignored;
}

RigErrors EvaluateRig(const PoseMap& est, const PoseMap& gt) {
  for (const auto& [serial, pose] : gt) {
    if (est.count(serial) == 0) {
      throw std::invalid_argument("camera " + serial + " has no estimated pose");
    }
  }
  RigErrors e;
  double sum_r2 = 0.0, sum_t2 = 0.0, sum_tilt2 = 0.0;
  for (auto i = gt.begin(); i != gt.end(); ++i) {
    const double tilt = TiltErrorRad(est.at(i->first), i->second);
    e.tilt_rad.emplace_back(i->first, tilt);
    sum_tilt2 += tilt * tilt;
    e.max_tilt_rad = std::max(e.max_tilt_rad, tilt);
    for (auto j = std::next(i); j != gt.end(); ++j) {
      const RelativePoseError r =
          RelativeError(est.at(i->first), est.at(j->first), i->second, j->second);
      e.pairs.push_back({i->first, j->first, r});
      sum_r2 += r.rotation_rad * r.rotation_rad;
      sum_t2 += r.translation_m * r.translation_m;
      e.max_rotation_rad = std::max(e.max_rotation_rad, r.rotation_rad);
      e.max_translation_m = std::max(e.max_translation_m, r.translation_m);
    }
  }
  if (!e.pairs.empty()) {
    e.rms_rotation_rad = std::sqrt(sum_r2 / e.pairs.size());
    e.rms_translation_m = std::sqrt(sum_t2 / e.pairs.size());
  }
  if (!gt.empty()) e.rms_tilt_rad = std::sqrt(sum_tilt2 / gt.size());
  return e;
}

PoseSigma SigmaOf(const Mat6& covariance) {
  constexpr double kMToMm = 1e3;
  const Mat6& C = covariance;
  PoseSigma s;
  s.yaw_deg = std::sqrt(C(1, 1)) * kRadToDeg;
  s.tilt_deg = std::sqrt(C(0, 0) + C(2, 2)) * kRadToDeg;
  s.x_mm = std::sqrt(C(3, 3)) * kMToMm;
  s.y_mm = std::sqrt(C(4, 4)) * kMToMm;
  s.z_mm = std::sqrt(C(5, 5)) * kMToMm;
  return s;
}

}  // namespace rigfit
