// Depth noise with a spatially correlated share: its model and the generalised least-squares
// Gram matrix over one camera's pixels, for the bound (analysis/crlb.h).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace rigfit {

/// Depth noise of which a share is spatially correlated, as `rigfit simulate --noise-corr-px
/// --noise-corr-share` draws it: between the pixels (u, v) and (u + du, v + dv) of one camera
/// the inverse-depth noise has the covariance
///   k^2 [(1 - share) delta + share rho(du) rho(dv)]
/// (rho: sim/noise_field.h NoiseFieldCorrelation of corr_px; to first order in the noise, for
/// sigma_z = k z^2); cameras independent. share 0: white.
struct CorrelatedNoiseModel {
  double corr_px = 0.0;
  double share = 0.0;
};

/// B^T S^-1 B for the pixels `pixels` of one camera (distinct) and the columns B (one row per
/// pixel), S = (1 - share) I + share C their noise correlation (CorrelatedNoiseModel; k = 1),
/// by conjugate gradients on S (C applied as the separable convolution with rho), one column
/// at a time over num_threads threads. Empty when a solve did not converge (relative residual
/// 1e-8). share in [0, 1), corr_px > 0.
Eigen::MatrixXd CorrelatedGram(const std::vector<Eigen::Vector2i>& pixels, const Eigen::MatrixXd& B,
                               const CorrelatedNoiseModel& noise, int num_threads);

}  // namespace rigfit
