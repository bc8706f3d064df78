// The terms of a set of correspondences compressed, exactly, into a few residuals of the
// same parameter blocks (derivation: docs/residuals.md, "Compressed terms").
//
// Every term (PointToPlaneTerm, GicpTerm) is linear in a vector of pose features:
// r_k = w_k Phi_k theta(x_a, x_b) with Phi_k fixed by the correspondence and theta the same
// for all terms (Term::Features). So for every pose
//
//   sum_k |r_k|^2 = theta^T M theta,   M = sum_k w_k^2 Phi_k^T Phi_k   (D x D, D = kFeatureSize)
//
// (Term::AddNormal adds one term's w_k^2 Phi_k^T Phi_k), and with M = V Lambda V^T the D
// residuals e = Lambda^1/2 V^T theta have the same squared norm, the same gradient
// J_e^T e = sum_k J_k^T r_k and the same Gauss-Newton matrix J_e^T J_e = sum_k J_k^T J_k as
// the stack, at every pose. The solver therefore takes the same steps, but evaluates D
// residuals per camera pair instead of one row per correspondence. What it loses is the
// rows themselves: a residual variance needs their number (StackedCost), and sums over a
// subset of them (a cluster) need a block of their own.
//
// Build it with Add for every term, then Compress once, before the solver evaluates it.
#pragma once

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <cmath>

#include "core/pose.h"

namespace rigfit {

template <class Term>
class CompressedCost final : public ceres::CostFunction {
 public:
  static constexpr int kFeatures = Term::kFeatureSize;

  CompressedCost() {
    *mutable_parameter_block_sizes() = {kPoseAmbientSize, kPoseAmbientSize};
    set_num_residuals(kFeatures);
  }

  /// Adds `term`, its residuals multiplied by `weight` (Compress again before evaluating).
  void Add(const Term& term, double weight) {
    term.AddNormal(weight * weight, normal_.data());
    ++size_;
    compressed_ = false;
  }
  size_t size() const { return size_; }

  /// Factors M (lower triangle) into the residual map Lambda^1/2 V^T; eigenvalues that
  /// rounding made negative count as zero.
  void Compress() {
    // Dynamic sizes: a fixed-size 24 x 24 solver more than doubled the compile time of
    // every file that uses this header (prepare/correspondences.cc 34 s -> 18 s).
    const Eigen::MatrixXd normal = normal_;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(normal);
    const Eigen::VectorXd root = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    factor_ = root.asDiagonal() * eig.eigenvectors().transpose();
    compressed_ = true;
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    if (!compressed_) return false;
    Vector theta;
    Jacobian dtheta_a, dtheta_b;
    double* J_a = jacobians == nullptr ? nullptr : jacobians[0];
    double* J_b = jacobians == nullptr ? nullptr : jacobians[1];
    Term::Features(parameters[0], parameters[1], theta.data(),
                   J_a == nullptr ? nullptr : dtheta_a.data(),
                   J_b == nullptr ? nullptr : dtheta_b.data());
    Eigen::Map<Vector> r(residuals);
    r.noalias() = factor_ * theta;
    if (J_a != nullptr) Eigen::Map<Jacobian>{J_a}.noalias() = factor_ * dtheta_a;
    if (J_b != nullptr) Eigen::Map<Jacobian>{J_b}.noalias() = factor_ * dtheta_b;
    return true;
  }

 private:
  using Matrix = Eigen::Matrix<double, kFeatures, kFeatures>;
  using Vector = Eigen::Matrix<double, kFeatures, 1>;
  using Jacobian = Eigen::Matrix<double, kFeatures, kPoseAmbientSize, Eigen::RowMajor>;

  Matrix normal_ = Matrix::Zero();
  Matrix factor_ = Matrix::Zero();
  size_t size_ = 0;
  bool compressed_ = false;
};

}  // namespace rigfit
