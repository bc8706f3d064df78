// How much a camera pose's 1-sigma was raised above the noise model's by what the residuals
// show (docs/uncertainty.md, "Inflation"): plain data for the results and reports.
#pragma once

#include <cmath>

#include "core/pose.h"

namespace rigfit {

/// Factors (at least 1) on the standard deviations of a pose's rotation and translation.
struct SigmaInflation {
  double rotation = 1.0;
  double translation = 1.0;
};

/// A 6 x 6 tangent covariance [rotation; translation] with its rotation rows and columns scaled
/// by f.rotation and its translation ones by f.translation (D C D, D = diag(f.rotation I,
/// f.translation I)): each half's 1-sigma times its factor, the correlations kept.
inline Mat6 Inflated(const Mat6& covariance, const SigmaInflation& f) {
  Vec6 scale;
  scale << Vec3::Constant(f.rotation), Vec3::Constant(f.translation);
  return scale.asDiagonal() * covariance * scale.asDiagonal();
}

/// The factors of `raised` over `model` (6 x 6 tangent covariances): per half, sqrt of the ratio
/// of their 3 x 3 blocks' traces, at least 1 (1 where `model`'s trace is 0).
inline SigmaInflation InflationBetween(const Mat6& model, const Mat6& raised) {
  const auto factor = [&](int k) {
    const double m = model.block<3, 3>(k, k).trace();
    const double r = raised.block<3, 3>(k, k).trace();
    return m > 0.0 && r > m ? std::sqrt(r / m) : 1.0;
  };
  return {factor(0), factor(3)};
}

}  // namespace rigfit
