#include "residuals/stacked_cost.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace rigfit {

StackedCost::StackedCost(const std::vector<int32_t>& parameter_block_sizes) {
  *mutable_parameter_block_sizes() = parameter_block_sizes;
  set_num_residuals(0);
}

void StackedCost::Add(ceres::CostFunction* cost, double weight) {
  if (cost->parameter_block_sizes() != parameter_block_sizes()) {
    delete cost;
    throw std::invalid_argument("StackedCost::Add: parameter blocks differ");
  }
  set_num_residuals(num_residuals() + cost->num_residuals());
  costs_.emplace_back(cost);
  weights_.push_back(weight);
}

bool StackedCost::Evaluate(double const* const* parameters, double* residuals,
                           double** jacobians) const {
  const std::vector<int32_t>& sizes = parameter_block_sizes();
  const size_t blocks = sizes.size();
  std::vector<double*> item_jacobians(blocks, nullptr);
  int row = 0;
  for (size_t c = 0; c < costs_.size(); ++c) {
    const int m = costs_[c]->num_residuals();
    if (jacobians != nullptr) {
      for (size_t b = 0; b < blocks; ++b) {
        item_jacobians[b] = jacobians[b] == nullptr ? nullptr : jacobians[b] + row * sizes[b];
      }
    }
    if (!costs_[c]->Evaluate(parameters, residuals + row,
                             jacobians == nullptr ? nullptr : item_jacobians.data())) {
      return false;
    }
    const double w = weights_[c];
    for (int i = 0; i < m; ++i) residuals[row + i] *= w;
    if (jacobians != nullptr) {
      for (size_t b = 0; b < blocks; ++b) {
        if (jacobians[b] == nullptr) continue;
        double* J = jacobians[b] + row * sizes[b];
        for (int i = 0; i < m * sizes[b]; ++i) J[i] *= w;
      }
    }
    row += m;
  }
  return true;
}

double RobustWeight(const ceres::LossFunction* loss, const double* residuals, int count) {
  if (loss == nullptr) return 1.0;
  double s = 0.0;
  for (int i = 0; i < count; ++i) s += residuals[i] * residuals[i];
  double rho[3];
  loss->Evaluate(s, rho);
  return std::sqrt(std::max(rho[1], 0.0));
}

}  // namespace rigfit
