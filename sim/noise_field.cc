#include "sim/noise_field.h"

#include <cmath>

namespace rigfit {

std::vector<double> NoiseFieldKernel(double corr_px) {
  const int radius = static_cast<int>(std::ceil(3.0 * corr_px));
  std::vector<double> kernel(2 * radius + 1);
  double sum = 0.0;
  for (int k = -radius; k <= radius; ++k) {
    kernel[k + radius] = std::exp(-0.5 * k * k / (corr_px * corr_px));
    sum += kernel[k + radius];
  }
  for (double& k : kernel) k /= sum;
  return kernel;
}

std::vector<double> NoiseFieldCorrelation(double corr_px) {
  const std::vector<double> g = NoiseFieldKernel(corr_px);
  const int taps = static_cast<int>(g.size());
  std::vector<double> rho(taps);
  for (int d = 0; d < taps; ++d) {
    for (int k = 0; k + d < taps; ++k) rho[d] += g[k] * g[k + d];
  }
  const double norm2 = rho[0];
  for (double& r : rho) r /= norm2;
  return rho;
}

}  // namespace rigfit
