// Many residuals of the same parameter blocks evaluated as one: the terms of a set of
// correspondences (PointToPlaneTerm or GicpTerm) stacked into a single Ceres residual block,
// each scaled by a fixed weight. Ceres then handles one block per camera pair instead of one
// per correspondence, which is what makes the joint problem cheap to build and to evaluate
// (docs/benchmarks.md); the terms are plain data, with no cost object or virtual call per
// correspondence. Its residuals and Jacobians are those of the stacked terms (each the
// evaluation of a cost function proven against autodiff and ceres::GradientChecker), times
// their weights.
//
// Robust losses apply per residual block in Ceres, so a stacked block takes them as
// iteratively reweighted least squares: weight_i = sqrt(rho'(|r_i|^2)) at the poses where
// the correspondences were made (RobustWeight), as ICP implementations do between
// correspondence searches.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <vector>

#include "core/pose.h"

namespace rigfit {

/// Term: Term::kNumResiduals residuals of the pose blocks (T_world_a, T_world_b), evaluated
/// by Term::Evaluate(pose_a, pose_b, residuals, jacobian_a, jacobian_b) with row-major
/// kNumResiduals x 7 ambient Jacobians (either may be null).
template <class Term>
class StackedCost final : public ceres::CostFunction {
 public:
  StackedCost() {
    *mutable_parameter_block_sizes() = {kPoseAmbientSize, kPoseAmbientSize};
    set_num_residuals(0);
  }

  /// Appends `term`, its residuals multiplied by `weight`.
  void Add(const Term& term, double weight) {
    terms_.push_back(term);
    weights_.push_back(weight);
    set_num_residuals(num_residuals() + Term::kNumResiduals);
  }
  void Reserve(size_t terms) {
    terms_.reserve(terms);
    weights_.reserve(terms);
  }
  size_t size() const { return terms_.size(); }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    constexpr int m = Term::kNumResiduals;
    constexpr int row_size = m * kPoseAmbientSize;
    double* J_a = jacobians == nullptr ? nullptr : jacobians[0];
    double* J_b = jacobians == nullptr ? nullptr : jacobians[1];
    for (size_t c = 0; c < terms_.size(); ++c) {
      double* r = residuals + m * c;
      double* Ja = J_a == nullptr ? nullptr : J_a + row_size * c;
      double* Jb = J_b == nullptr ? nullptr : J_b + row_size * c;
      terms_[c].Evaluate(parameters[0], parameters[1], r, Ja, Jb);
      const double w = weights_[c];
      for (int i = 0; i < m; ++i) r[i] *= w;
      if (Ja != nullptr) {
        for (int i = 0; i < row_size; ++i) Ja[i] *= w;
      }
      if (Jb != nullptr) {
        for (int i = 0; i < row_size; ++i) Jb[i] *= w;
      }
    }
    return true;
  }

 private:
  std::vector<Term> terms_;
  std::vector<double> weights_;
};

/// The IRLS weight sqrt(rho'(s)) of a residual vector r with s = |r|^2 under `loss`
/// (1 for a null loss).
double RobustWeight(const ceres::LossFunction* loss, const double* residuals, int count);

}  // namespace rigfit
