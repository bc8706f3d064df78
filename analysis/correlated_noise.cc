#include "analysis/correlated_noise.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/parallel.h"
#include "sim/noise_field.h"

namespace rigfit {

namespace {

/// S = (1 - share) I + share C on the pixels of one camera (CorrelatedGram), applied to
/// vectors over those pixels: C as the convolution with rho along the rows (scattered from
/// the pixels into a scratch image of their bounding box), then along the columns at the
/// pixels.
class CorrelationOperator {
 public:
  CorrelationOperator(const std::vector<Eigen::Vector2i>& pixels, const CorrelatedNoiseModel& noise)
      : pixels_(pixels), rho_(NoiseFieldCorrelation(noise.corr_px)), share_(noise.share) {
    Eigen::Vector2i lo = Eigen::Vector2i::Constant(std::numeric_limits<int>::max());
    Eigen::Vector2i hi = Eigen::Vector2i::Constant(std::numeric_limits<int>::min());
    for (const Eigen::Vector2i& p : pixels) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    origin_ = lo;
    width_ = pixels.empty() ? 0 : hi.x() - lo.x() + 1;
    height_ = pixels.empty() ? 0 : hi.y() - lo.y() + 1;
  }

  size_t ScratchSize() const { return static_cast<size_t>(width_) * height_; }

  /// y = S x; `rows` is scratch of ScratchSize().
  void Apply(const Eigen::VectorXd& x, Eigen::VectorXd* y, std::vector<double>* rows) const {
    std::fill(rows->begin(), rows->end(), 0.0);
    const int reach = static_cast<int>(rho_.size()) - 1;
    for (size_t k = 0; k < pixels_.size(); ++k) {
      const int u = pixels_[k].x() - origin_.x();
      double* row = rows->data() + static_cast<size_t>(pixels_[k].y() - origin_.y()) * width_;
      const int first = std::max(0, u - reach), last = std::min(width_ - 1, u + reach);
      for (int j = first; j <= last; ++j) row[j] += rho_[std::abs(j - u)] * x(k);
    }
    y->resize(x.size());
    for (size_t k = 0; k < pixels_.size(); ++k) {
      const int u = pixels_[k].x() - origin_.x();
      const int v = pixels_[k].y() - origin_.y();
      const int first = std::max(0, v - reach), last = std::min(height_ - 1, v + reach);
      double acc = 0.0;
      for (int j = first; j <= last; ++j)
        acc += rho_[std::abs(j - v)] * (*rows)[static_cast<size_t>(j) * width_ + u];
      (*y)(k) = (1.0 - share_) * x(k) + share_ * acc;
    }
  }

 private:
  const std::vector<Eigen::Vector2i>& pixels_;
  std::vector<double> rho_;
  double share_;
  Eigen::Vector2i origin_;
  int width_ = 0;
  int height_ = 0;
};

/// x = S^-1 b by conjugate gradients from 0; false unless the residual falls below
/// tolerance |b| within max_iterations.
bool SolveCorrelated(const CorrelationOperator& S, const Eigen::VectorXd& b, double tolerance,
                     int max_iterations, Eigen::VectorXd* x, std::vector<double>* scratch) {
  x->setZero(b.size());
  Eigen::VectorXd r = b, p = b, Sp;
  double rr = r.squaredNorm();
  const double stop = tolerance * tolerance * rr;
  for (int it = 0; it < max_iterations && rr > stop; ++it) {
    S.Apply(p, &Sp, scratch);
    const double alpha = rr / p.dot(Sp);
    *x += alpha * p;
    r -= alpha * Sp;
    const double rr_next = r.squaredNorm();
    p = r + (rr_next / rr) * p;
    rr = rr_next;
  }
  return rr <= stop;
}

}  // namespace

Eigen::MatrixXd CorrelatedGram(const std::vector<Eigen::Vector2i>& pixels, const Eigen::MatrixXd& B,
                               const CorrelatedNoiseModel& noise, int num_threads) {
  if (!(noise.corr_px > 0.0) || !(noise.share >= 0.0 && noise.share < 1.0) ||
      B.rows() != static_cast<Eigen::Index>(pixels.size())) {
    throw std::invalid_argument(
        "CorrelatedGram: needs corr_px > 0, share in [0, 1) and a row of B per pixel");
  }
  const CorrelationOperator S(pixels, noise);
  const int m = static_cast<int>(B.cols());
  Eigen::MatrixXd gram(m, m);
  std::atomic<bool> converged{true};
  ParallelFor(
      m, num_threads,
      [&](int j) {
        std::vector<double> scratch(S.ScratchSize());
        Eigen::VectorXd x;
        if (!SolveCorrelated(S, B.col(j), 1e-8, 20000, &x, &scratch)) converged = false;
        gram.col(j) = B.transpose() * x;
      },
      1);
  if (!converged) return {};
  return 0.5 * (gram + gram.transpose());
}

}  // namespace rigfit
