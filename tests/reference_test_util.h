// The surface bundle's contract for the reference camera: leveled again on the floor the
// cameras share, it turns about world X and Z through its centre (registration/surface_bundle.h),
// so its centre and yaw stay those of its leveled pose.
#pragma once

#include <gtest/gtest.h>

#include <cmath>

#include "core/geometry.h"
#include "core/pose.h"

namespace rigfit {

/// Whether `moved` keeps `leveled`'s centre (to 1e-9 m) and yaw (to 1e-8 rad: the Gauss-Newton
/// steps about X and Z compose to a yaw of their product's order, measured up to 1.4e-9) and
/// tilts by less than `max_tilt_deg`.
inline ::testing::AssertionResult YawAndCentreHeld(const Pose& leveled, const Pose& moved,
                                                   double max_tilt_deg) {
  const Vec6 change = PoseDifference(leveled, moved);
  const double centre_m = change.tail<3>().norm();
  const double yaw_rad = std::abs(change(1));
  const double tilt_deg = std::hypot(change(0), change(2)) * kRadToDeg;
  if (centre_m < 1e-9 && yaw_rad < 1e-8 && tilt_deg < max_tilt_deg) {
    return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "centre moved " << centre_m << " m, yaw " << yaw_rad
                                       << " rad, tilt " << tilt_deg << " deg";
}

}  // namespace rigfit
