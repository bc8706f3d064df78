#include "analysis/correlated_noise.h"

#include <Eigen/Dense>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "core/parallel.h"
#include "sim/noise_field.h"

namespace rigfit {

namespace {

/// The whitening filter's blurs against corr_px.
constexpr std::array<double, 3> kBlurScales = {0.5, 1.0, 2.0};
/// Frequencies per axis over [0, 1/2] cycles per pixel for the filter's fit.
constexpr int kFrequencies = 65;

/// The 1-D spectrum at frequency f of a symmetric kernel given by its one side, k(0..R).
double Spectrum(const std::vector<double>& side, double f) {
  double sum = side[0];
  for (size_t d = 1; d < side.size(); ++d) sum += 2.0 * side[d] * std::cos(2.0 * M_PI * f * d);
  return sum;
}

/// An image region of `width` x `height` values, row-major.
struct Region {
  int width = 0;
  int height = 0;
  std::vector<double> values;
  double& at(int x, int y) { return values[static_cast<size_t>(y) * width + x]; }
  double at(int x, int y) const { return values[static_cast<size_t>(y) * width + x]; }
};

/// `image` blurred by `taps` along x then y, zero outside.
Region Blur(const Region& image, const std::vector<double>& taps) {
  const int radius = static_cast<int>(taps.size()) / 2;
  Region rows{image.width, image.height, std::vector<double>(image.values.size(), 0.0)};
  for (int y = 0; y < image.height; ++y) {
    const double* in = image.values.data() + static_cast<size_t>(y) * image.width;
    double* out = rows.values.data() + static_cast<size_t>(y) * image.width;
    for (int x = 0; x < image.width; ++x) {
      if (in[x] == 0.0) continue;
      const int lo = std::max(0, x - radius), hi = std::min(image.width - 1, x + radius);
      for (int k = lo; k <= hi; ++k) out[k] += taps[k - x + radius] * in[x];
    }
  }
  Region result{image.width, image.height, std::vector<double>(image.values.size(), 0.0)};
  for (int y = 0; y < image.height; ++y) {
    const int lo = std::max(0, y - radius), hi = std::min(image.height - 1, y + radius);
    const double* in = rows.values.data() + static_cast<size_t>(y) * image.width;
    for (int k = lo; k <= hi; ++k) {
      const double w = taps[k - y + radius];
      double* out = result.values.data() + static_cast<size_t>(k) * image.width;
      for (int x = 0; x < image.width; ++x) out[x] += w * in[x];
    }
  }
  return result;
}

/// A rectangle of the image, [x0, x1) x [y0, y1).
struct Box {
  int x0, y0, x1, y1;
  int Width() const { return x1 - x0; }
  int Height() const { return y1 - y0; }
};

/// One pixel's whitened row of one face's columns.
struct Entry {
  int pixel;  ///< index into the pixels
  int face;
  Eigen::Vector4d row;
};

/// The bounding box of the pixels and of each face's pixels.
struct FaceBoxes {
  Box image{0, 0, 0, 0};
  std::vector<Box> faces;
  std::vector<bool> seen;
};

FaceBoxes BoxesOf(const std::vector<FacePixelRow>& pixels, int faces) {
  FaceBoxes b;
  b.faces.assign(faces, Box{0, 0, 0, 0});
  b.seen.assign(faces, false);
  const auto grow = [](const Box& box, const Eigen::Vector2i& p) {
    return Box{std::min(box.x0, p.x()), std::min(box.y0, p.y()), std::max(box.x1, p.x() + 1),
               std::max(box.y1, p.y() + 1)};
  };
  const Eigen::Vector2i& first = pixels.front().pixel;
  b.image = {first.x(), first.y(), first.x() + 1, first.y() + 1};
  for (const FacePixelRow& p : pixels) {
    b.image = grow(b.image, p.pixel);
    Box& box = b.faces[p.face];
    box = b.seen[p.face] ? grow(box, p.pixel)
                         : Box{p.pixel.x(), p.pixel.y(), p.pixel.x() + 1, p.pixel.y() + 1};
    b.seen[p.face] = true;
  }
  return b;
}

/// The image of the pixels: their indices (-1: none) and the blurs of their mask.
struct PixelImage {
  Box box;
  Region index;
  std::array<Region, 3> mask_blur;
};

/// Into `entries`: the whitened rows (W B's rows in the face's columns) at every pixel within
/// the blurs' reach of the face's pixels.
void WhitenFace(const std::vector<FacePixelRow>& pixels, int face, const Box& face_box,
                const PixelImage& image, const std::array<std::vector<double>, 3>& taps,
                const WhiteningFilter& filter, std::vector<Entry>* entries) {
  int radius = 0;
  for (const std::vector<double>& t : taps)
    radius = std::max(radius, static_cast<int>(t.size()) / 2);
  const Box box{
      std::max(image.box.x0, face_box.x0 - radius), std::max(image.box.y0, face_box.y0 - radius),
      std::min(image.box.x1, face_box.x1 + radius), std::min(image.box.y1, face_box.y1 + radius)};
  const size_t area = static_cast<size_t>(box.Width()) * box.Height();
  std::array<Region, 4> channels;
  for (Region& c : channels) c = {box.Width(), box.Height(), std::vector<double>(area, 0.0)};
  for (const FacePixelRow& p : pixels) {
    if (p.face != face) continue;
    for (int k = 0; k < 4; ++k)
      channels[k].at(p.pixel.x() - box.x0, p.pixel.y() - box.y0) = p.row(k);
  }
  std::array<std::array<Region, 4>, 3> blurred;
  for (size_t m = 0; m < taps.size(); ++m) {
    for (int k = 0; k < 4; ++k) blurred[m][k] = Blur(channels[k], taps[m]);
  }
  for (int y = box.y0; y < box.y1; ++y) {
    for (int x = box.x0; x < box.x1; ++x) {
      const double at = image.index.at(x - image.box.x0, y - image.box.y0);
      if (at < 0.0) continue;
      Eigen::Vector4d row;
      for (int k = 0; k < 4; ++k) {
        row(k) = filter.identity * channels[k].at(x - box.x0, y - box.y0);
        for (size_t m = 0; m < taps.size(); ++m) {
          row(k) -= filter.weight[m] * blurred[m][k].at(x - box.x0, y - box.y0) /
                    image.mask_blur[m].at(x - image.box.x0, y - image.box.y0);
        }
      }
      if (!row.isZero()) entries->push_back({static_cast<int>(at), face, row});
    }
  }
}

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

WhiteningFilter FitWhiteningFilter(const CorrelatedNoiseModel& noise) {
  const double S = noise.share;
  WhiteningFilter filter;
  const std::vector<double> rho = NoiseFieldCorrelation(noise.corr_px);
  std::array<std::vector<double>, 3> sides;  // each blur's taps 0..r (NoiseFieldKernel: -r..r)
  for (size_t m = 0; m < kBlurScales.size(); ++m) {
    filter.sigma_px[m] = kBlurScales[m] * noise.corr_px;
    const std::vector<double> taps = NoiseFieldKernel(filter.sigma_px[m]);
    sides[m].assign(taps.begin() + static_cast<long>(taps.size() / 2), taps.end());
  }
  // Weighted least squares over the (fx, fy) grid: sqrt(s) (W - s^-1/2) -> 0.
  Eigen::MatrixXd A(kFrequencies * kFrequencies, 4);
  Eigen::VectorXd b(kFrequencies * kFrequencies);
  std::vector<double> kappa(kFrequencies);
  std::array<std::vector<double>, 3> beta;
  for (int i = 0; i < kFrequencies; ++i) {
    const double f = 0.5 * i / (kFrequencies - 1);
    kappa[i] = Spectrum(rho, f);
    for (size_t m = 0; m < sides.size(); ++m) beta[m].push_back(Spectrum(sides[m], f));
  }
  for (int i = 0; i < kFrequencies; ++i) {
    for (int j = 0; j < kFrequencies; ++j) {
      const int row = i * kFrequencies + j;
      const double s = (1.0 - S) + S * kappa[i] * kappa[j];
      const double w = std::sqrt(s);
      A(row, 0) = w;
      for (size_t m = 0; m < sides.size(); ++m) A(row, 1 + m) = -w * beta[m][i] * beta[m][j];
      b(row) = 1.0;  // w * s^-1/2
    }
  }
  const Eigen::Vector4d x = A.colPivHouseholderQr().solve(b);
  filter.identity = x(0);
  for (size_t m = 0; m < sides.size(); ++m) filter.weight[m] = x(1 + m);
  return filter;
}

Eigen::MatrixXd WhitenedGram(const std::vector<FacePixelRow>& pixels, int faces,
                             const WhiteningFilter& filter) {
  Eigen::MatrixXd gram = Eigen::MatrixXd::Zero(4 * faces, 4 * faces);
  if (pixels.empty()) return gram;
  const FaceBoxes boxes = BoxesOf(pixels, faces);
  std::array<std::vector<double>, 3> taps;
  for (size_t m = 0; m < taps.size(); ++m) taps[m] = NoiseFieldKernel(filter.sigma_px[m]);
  PixelImage image;
  image.box = boxes.image;
  const size_t area = static_cast<size_t>(image.box.Width()) * image.box.Height();
  image.index = {image.box.Width(), image.box.Height(), std::vector<double>(area, -1.0)};
  Region mask{image.box.Width(), image.box.Height(), std::vector<double>(area, 0.0)};
  for (size_t i = 0; i < pixels.size(); ++i) {
    const int x = pixels[i].pixel.x() - image.box.x0, y = pixels[i].pixel.y() - image.box.y0;
    image.index.at(x, y) = static_cast<double>(i);
    mask.at(x, y) = 1.0;
  }
  for (size_t m = 0; m < taps.size(); ++m) image.mask_blur[m] = Blur(mask, taps[m]);
  std::vector<Entry> entries;
  for (int face = 0; face < faces; ++face) {
    if (boxes.seen[face])
      WhitenFace(pixels, face, boxes.faces[face], image, taps, filter, &entries);
  }
  // Per pixel, the outer products of its rows on every face within reach.
  std::stable_sort(entries.begin(), entries.end(),
                   [](const Entry& a, const Entry& b) { return a.pixel < b.pixel; });
  for (size_t first = 0; first < entries.size();) {
    size_t last = first;
    while (last < entries.size() && entries[last].pixel == entries[first].pixel) ++last;
    for (size_t a = first; a < last; ++a) {
      for (size_t b = first; b < last; ++b) {
        gram.block<4, 4>(4 * entries[a].face, 4 * entries[b].face).noalias() +=
            entries[a].row * entries[b].row.transpose();
      }
    }
    first = last;
  }
  return gram;
}

}  // namespace rigfit
