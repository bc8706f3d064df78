#include "rgbd/photometric.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <utility>

#include "core/parallel.h"
#include "rgbd/projective_icp.h"

namespace rigfit {
namespace {

using MatK = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 6, 6>;
using VecK = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 6, 1>;
using Mat6K = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, 6>;

/// Central-difference gradients of level.grey (zero on the border).
void Gradients(GreyLevel* level) {
  const int w = level->width;
  const int h = level->height;
  level->gx.assign(level->grey.size(), 0.0f);
  level->gy.assign(level->grey.size(), 0.0f);
  for (int v = 1; v + 1 < h; ++v) {
    for (int u = 1; u + 1 < w; ++u) {
      const int i = v * w + u;
      level->gx[i] = 0.5f * (level->grey[i + 1] - level->grey[i - 1]);
      level->gy[i] = 0.5f * (level->grey[i + w] - level->grey[i - w]);
    }
  }
}

/// The 2x2 block means of `fine` at width x height.
GreyLevel Downsample(const GreyLevel& fine, int width, int height) {
  GreyLevel coarse;
  coarse.width = width;
  coarse.height = height;
  coarse.grey.resize(static_cast<size_t>(width) * height);
  for (int v = 0; v < height; ++v) {
    for (int u = 0; u < width; ++u) {
      const int i = 2 * v * fine.width + 2 * u;
      coarse.grey[v * width + u] =
          0.25f * (fine.grey[i] + fine.grey[i + 1] + fine.grey[i + fine.width] +
                   fine.grey[i + fine.width + 1]);
    }
  }
  return coarse;
}

/// The bilinear interpolation of `image` (width w) at (x, y), 0 <= x < w - 1 and likewise y.
float Bilinear(const std::vector<float>& image, int w, double x, double y) {
  const int u = static_cast<int>(x);
  const int v = static_cast<int>(y);
  const float a = static_cast<float>(x - u);
  const float b = static_cast<float>(y - v);
  const float* p = &image[static_cast<size_t>(v) * w + u];
  return (1 - b) * ((1 - a) * p[0] + a * p[1]) + b * ((1 - a) * p[w] + a * p[w + 1]);
}

/// The normal equations of one Gauss-Newton step in the free coordinates.
struct PhotometricSystem {
  MatK H;
  VecK g;
  double weighted_squares = 0.0;  ///< sum w r^2
  double squares = 0.0;           ///< sum r^2
  int pixels = 0;
};

/// Adds source pixel i's residual and Jacobian at level l for the estimate T (R, t) to s.
void AddPixel(const PhotometricProblem& problem, int l, const Mat3& R, const Vec3& t,
              const Mat6K& SF, const PhotometricOptions& options, int i, PhotometricSystem* s) {
  const FrameLevel& source = problem.source->levels[l];
  const GreyLevel& own = problem.source_grey->levels[l];
  const GreyLevel& reference = problem.reference_grey->levels[l];
  const PinholeIntrinsics& K = source.intrinsics;
  const Vec3 z = R * source.vertices[i].cast<double>() + t;
  if (z.z() <= 1e-3) return;
  const double x = K.fx * z.x() / z.z() + K.cx;
  const double y = K.fy * z.y() / z.z() + K.cy;
  if (!(x >= 0.0 && y >= 0.0 && x < reference.width - 1 && y < reference.height - 1)) return;
  const double r = Bilinear(reference.grey, reference.width, x, y) - own.grey[i];
  const double gx = Bilinear(reference.gx, reference.width, x, y);
  const double gy = Bilinear(reference.gy, reference.width, x, y);
  const double iz = 1.0 / z.z();
  const Vec3 Jz(gx * K.fx * iz, gy * K.fy * iz, -(gx * K.fx * z.x() + gy * K.fy * z.y()) * iz * iz);
  Vec6 Jx;
  Jx << z.cross(Jz), Jz;  // Jz [-[z]_x  I]: (Jz . (w x z)) = w . (z x Jz)
  const VecK J = SF.transpose() * Jx;
  const double w = std::abs(r) <= options.huber ? 1.0 : options.huber / std::abs(r);
  s->H.noalias() += w * J * J.transpose();
  s->g.noalias() += w * r * J;
  s->weighted_squares += w * r * r;
  s->squares += r * r;
  ++s->pixels;
}

/// The normal equations of a problem at any level and estimate (the header's J and r, SF =
/// S F): each level's textured source pixels (valid, with a grey-level gradient of at least
/// options.min_gradient) found once, summed in `threads` contiguous chunks, each on its own
/// thread's stack, then in chunk order.
class PhotometricSystems {
 public:
  PhotometricSystems(const PhotometricProblem& problem, const Mat6K& SF,
                     const PhotometricOptions& options, int levels, int threads)
      : problem_(problem), SF_(SF), options_(options), threads_(std::max(1, threads)) {
    for (int l = 0; l < levels; ++l) {
      const FrameLevel& source = problem.source->levels[l];
      const GreyLevel& own = problem.source_grey->levels[l];
      std::vector<int>& pixels = textured_.emplace_back();
      for (const int i : source.valid_pixels) {
        if (!(std::hypot(own.gx[i], own.gy[i]) < options.min_gradient)) pixels.push_back(i);
      }
    }
  }

  PhotometricSystem At(int l, const Pose& T) const {
    const int k = static_cast<int>(SF_.cols());
    const PhotometricSystem zero{MatK::Zero(k, k), VecK::Zero(k)};
    const std::vector<int>& pixels = textured_[l];
    const Mat3 R = T.linear();
    const Vec3 t = T.translation();
    std::vector<PhotometricSystem> partial(threads_, zero);
    ParallelForChunks(static_cast<int>(pixels.size()), threads_, [&](int c, int begin, int end) {
      PhotometricSystem s = zero;
      for (int p = begin; p < end; ++p) AddPixel(problem_, l, R, t, SF_, options_, pixels[p], &s);
      partial[c] = s;
    });
    PhotometricSystem sum = zero;
    for (const PhotometricSystem& s : partial) {
      sum.H += s.H;
      sum.g += s.g;
      sum.weighted_squares += s.weighted_squares;
      sum.squares += s.squares;
      sum.pixels += s.pixels;
    }
    return sum;
  }

 private:
  const PhotometricProblem& problem_;
  const Mat6K& SF_;
  const PhotometricOptions& options_;
  int threads_;
  std::vector<std::vector<int>> textured_;
};

double Rmse(const PhotometricSystem& s) {
  return s.pixels > 0 ? std::sqrt(s.squares / s.pixels) : 0.0;
}

/// Below any grey-level noise (levels in [0, 1]): what a perfect fit's variance is taken as.
constexpr double kVarianceFloor = 1e-12;

/// The weighted residual variance sum w r^2 / (pixels - k) (infinite without enough pixels).
double Variance(const PhotometricSystem& s) {
  const int k = static_cast<int>(s.g.size());
  if (s.pixels <= k) return std::numeric_limits<double>::infinity();
  return s.weighted_squares / (s.pixels - k);
}

/// The largest standard deviation of the free coordinates: sigma^2 H^-1, sigma^2 the weighted
/// residual variance, or with a prior P_a the inverse of H / sigma^2 + P_a.
double LargestSigma(const PhotometricSystem& s, const MatK* P_a) {
  const double variance = Variance(s);
  if (!std::isfinite(variance)) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<MatK> eigen(
      P_a ? MatK(s.H / std::max(variance, kVarianceFloor) + *P_a) : s.H);
  const double smallest = eigen.eigenvalues()(0);
  if (!(smallest > 0.0)) return std::numeric_limits<double>::infinity();
  return P_a ? std::sqrt(1.0 / smallest) : std::sqrt(variance / smallest);
}

/// One Gauss-Newton step in the free coordinates (the header's), a_0 the move so far.
VecK Step(const PhotometricSystem& s, const MatK* P_a, const VecK& a_0) {
  if (P_a == nullptr) return -s.H.ldlt().solve(s.g);
  const double variance = std::max(Variance(s), kVarianceFloor);
  return -(s.H / variance + *P_a).ldlt().solve(s.g / variance + *P_a * a_0);
}

/// Why the finest level's alignment is not kept, empty when it is (PhotometricOptions).
std::string Rejection(const PhotometricResult& result, double start_rmse,
                      const PhotometricOptions& options) {
  if (result.pixels < options.min_pixels) {
    return std::to_string(result.pixels) + " textured pixels (fewer than " +
           std::to_string(options.min_pixels) + ")";
  }
  if (!(result.sigma_m <= options.max_sigma_m)) return "the texture does not fix every direction";
  if (result.rmse > start_rmse) return "the residual rose";
  if (!(result.change_m <= options.max_change_m)) return "moved too far from the prediction";
  return "";
}

/// Throws std::invalid_argument (naming `caller`) unless the problem has 1 to 6 free
/// directions and grey pyramids of the source's levels and sizes.
void CheckProblem(const PhotometricProblem& problem, const std::string& caller) {
  const int k = static_cast<int>(problem.free.size());
  const std::size_t levels = problem.source->levels.size();
  if (k < 1 || k > 6 || levels == 0 || problem.source_grey->levels.size() != levels ||
      problem.reference_grey->levels.size() != levels) {
    throw std::invalid_argument(
        caller + ": 1 to 6 free directions and grey pyramids of the source's levels");
  }
  for (std::size_t l = 0; l < levels; ++l) {
    const FrameLevel& level = problem.source->levels[l];
    for (const GreyPyramid* grey : {problem.source_grey, problem.reference_grey}) {
      if (grey->levels[l].width != level.width || grey->levels[l].height != level.height) {
        throw std::invalid_argument(caller + ": a grey level's size is not the source's");
      }
    }
  }
}

/// The free directions as columns of the left update [w; dt] (rotation unscaled).
Mat6K FreeBasis(const PhotometricProblem& problem) {
  const int k = static_cast<int>(problem.free.size());
  Mat6K SF(6, k);
  for (int j = 0; j < k; ++j) {
    SF.col(j) = problem.free[j];
    SF.col(j).head<3>() /= problem.length_m;
  }
  return SF;
}

}  // namespace

std::vector<Vec6> AllDirections() {
  std::vector<Vec6> all;
  for (int i = 0; i < 6; ++i) all.push_back(Vec6::Unit(i));
  return all;
}

double PhotometricRmse(const PhotometricProblem& problem, const Pose& T,
                       const PhotometricOptions& options, int threads) {
  CheckProblem(problem, "PhotometricRmse");
  const Mat6K SF = FreeBasis(problem);
  return Rmse(PhotometricSystems(problem, SF, options, 1, threads).At(0, T));
}

GreyPyramid BuildGreyPyramid(const std::vector<std::uint8_t>& color, const FramePyramid& pyramid) {
  if (pyramid.levels.empty()) throw std::invalid_argument("BuildGreyPyramid: empty pyramid");
  GreyLevel level0;
  level0.width = pyramid.levels[0].width;
  level0.height = pyramid.levels[0].height;
  const size_t n = static_cast<size_t>(level0.width) * level0.height;
  if (color.size() != 3 * n) {
    throw std::invalid_argument("BuildGreyPyramid: colour of " + std::to_string(color.size()) +
                                " bytes for a " + std::to_string(level0.width) + "x" +
                                std::to_string(level0.height) + " frame");
  }
  level0.grey.resize(n);
  for (size_t i = 0; i < n; ++i) {
    level0.grey[i] = static_cast<float>(
        (0.299 * color[3 * i] + 0.587 * color[3 * i + 1] + 0.114 * color[3 * i + 2]) / 255.0);
  }
  GreyPyramid grey;
  grey.levels.push_back(std::move(level0));
  for (size_t l = 1; l < pyramid.levels.size(); ++l) {
    grey.levels.push_back(
        Downsample(grey.levels.back(), pyramid.levels[l].width, pyramid.levels[l].height));
  }
  for (GreyLevel& level : grey.levels) Gradients(&level);
  return grey;
}

PhotometricResult AlignPhotometric(const PhotometricProblem& problem, const Pose& T_init,
                                   const PhotometricOptions& options, int threads) {
  CheckProblem(problem, "AlignPhotometric");
  const std::size_t levels = problem.source->levels.size();
  const int k = static_cast<int>(problem.free.size());
  const Mat6K SF = FreeBasis(problem);
  const PhotometricSystems systems(problem, SF, options, static_cast<int>(levels), threads);
  PhotometricResult result;
  result.T_reference_source = T_init;
  const PhotometricSystem start = systems.At(0, T_init);
  const MatK P_a = problem.prior ? MatK(SF.transpose() * *problem.prior * SF) : MatK::Zero(k, k);
  VecK total = VecK::Zero(k);  // the move from T_init, free coordinates
  for (int l = static_cast<int>(levels) - 1; l >= 0; --l) {
    for (int it = 0; it < options.iterations; ++it) {
      const PhotometricSystem s = systems.At(l, result.T_reference_source);
      if (s.pixels <= k) break;
      const VecK a = Step(s, problem.prior ? &P_a : nullptr, total);
      if (!a.allFinite()) break;
      total += a;
      result.T_reference_source = ApplyLeftUpdate(SF * a, result.T_reference_source);
      if (a.norm() < options.converged_m) break;
    }
  }
  const PhotometricSystem end = systems.At(0, result.T_reference_source);
  result.pixels = end.pixels;
  result.rmse = Rmse(end);
  result.sigma_m = LargestSigma(end, problem.prior ? &P_a : nullptr);
  result.change_m = total.norm();
  result.message = Rejection(result, Rmse(start), options);
  result.success = result.message.empty();
  return result;
}

}  // namespace rigfit
