#include "residuals/stacked_cost.h"

#include <algorithm>
#include <cmath>

namespace rigfit {

double RobustWeight(const ceres::LossFunction* loss, const double* residuals, int count) {
  if (loss == nullptr) return 1.0;
  double s = 0.0;
  for (int i = 0; i < count; ++i) s += residuals[i] * residuals[i];
  double rho[3];
  loss->Evaluate(s, rho);
  return std::sqrt(std::max(rho[1], 0.0));
}

}  // namespace rigfit
