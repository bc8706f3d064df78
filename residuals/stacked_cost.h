// Many residual blocks of the same parameter blocks evaluated as one: the cost functions
// of a set of correspondences stacked into a single Ceres residual block, each scaled by a
// fixed weight. Ceres then handles one block per camera pair instead of one per
// correspondence, which is what makes the joint problem cheap to build and to evaluate
// (docs/benchmarks.md). Its residuals and Jacobians are those of the stacked functions
// (each already proven against autodiff and ceres::GradientChecker), times their weights.
//
// Robust losses apply per residual block in Ceres, so a stacked block takes them as
// iteratively reweighted least squares: weight_i = sqrt(rho'(|r_i|^2)) at the poses where
// the correspondences were made (RobustWeight), as ICP implementations do between
// correspondence searches.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <memory>
#include <vector>

namespace rigfit {

class StackedCost final : public ceres::CostFunction {
 public:
  /// parameter_block_sizes: the blocks every stacked cost function shares.
  explicit StackedCost(const std::vector<int32_t>& parameter_block_sizes);

  /// Appends `cost` (taking ownership), its residuals multiplied by `weight`. Its
  /// parameter blocks must be the shared ones.
  void Add(ceres::CostFunction* cost, double weight);
  size_t size() const { return costs_.size(); }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  std::vector<std::unique_ptr<ceres::CostFunction>> costs_;
  std::vector<double> weights_;
};

/// The IRLS weight sqrt(rho'(s)) of a residual vector r with s = |r|^2 under `loss`
/// (1 for a null loss).
double RobustWeight(const ceres::LossFunction* loss, const double* residuals, int count);

}  // namespace rigfit
