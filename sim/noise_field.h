// The spatially correlated share of depth noise as `rigfit simulate --noise-corr-px L` draws it
// (sim/simulate_rig.h GaussianNoiseField): white noise blurred by a truncated Gaussian kernel,
// scaled to unit variance. Shared by the simulator and the bound that knows the correlation
// (analysis/crlb.h).
#pragma once

#include <vector>

namespace rigfit {

/// The blur kernel: taps k = -r..r, r = ceil(3 corr_px), proportional to
/// exp(-k^2 / (2 corr_px^2)), summing to 1. corr_px > 0.
std::vector<double> NoiseFieldKernel(double corr_px);

/// The field's correlation between pixels d apart along a row or a column, d = 0..2r (0
/// beyond): rho(d) = sum_k g_k g_{k+d} / sum_k g_k^2 for the kernel g above; between pixels
/// (du, dv) apart it is rho(|du|) rho(|dv|) (the blur is separable). About
/// exp(-d^2 / (4 corr_px^2)).
std::vector<double> NoiseFieldCorrelation(double corr_px);

}  // namespace rigfit
