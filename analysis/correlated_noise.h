// Depth noise with a spatially correlated share: its model and the generalised least-squares
// Gram matrix over one camera's pixels, exact for the bound (analysis/crlb.h) and through a
// whitening filter for the face oracle's estimator (analysis/face_oracle.h).
#pragma once

#include <Eigen/Core>
#include <array>
#include <vector>

namespace rigfit {

/// Depth noise of which a share is spatially correlated, as `rigfit simulate --noise-corr-px
/// --noise-corr-share` draws it: between the pixels (u, v) and (u + du, v + dv) of one camera
/// the inverse-depth noise has the covariance
///   k^2 [(1 - share) delta + share rho(du) rho(dv)]
/// (rho: sim/noise_field.h NoiseFieldCorrelation of corr_px; to first order in the noise, for
/// sigma_z = k z^2); cameras independent. share 0: white.
struct CorrelatedNoiseModel {
  double corr_px = 0.0;
  double share = 0.0;
};

/// B^T S^-1 B for the pixels `pixels` of one camera (distinct) and the columns B (one row per
/// pixel), S = (1 - share) I + share C their noise correlation (CorrelatedNoiseModel; k = 1),
/// by conjugate gradients on S (C applied as the separable convolution with rho), one column
/// at a time over num_threads threads. Empty when a solve did not converge (relative residual
/// 1e-8). share in [0, 1), corr_px > 0.
Eigen::MatrixXd CorrelatedGram(const std::vector<Eigen::Vector2i>& pixels, const Eigen::MatrixXd& B,
                               const CorrelatedNoiseModel& noise, int num_threads);

/// A whitening filter W ~ S^(-1/2) for CorrelatedNoiseModel's S (docs/residuals.md,
/// "Correlated noise"): the identity times `identity` less three normalised Gaussian blurs
/// (sim/noise_field.h NoiseFieldKernel) of 0.5, 1 and 2 corr_px, weighted so that W^2 times S's
/// spectrum is flat: least squares over the frequencies, weighted by S's spectrum (the low
/// frequencies, where a pose's signal and the field's power are, count most).
struct WhiteningFilter {
  double identity = 1.0;
  std::array<double, 3> sigma_px{};
  std::array<double, 3> weight{};
};

/// The filter for `noise` (share in (0, 1), corr_px > 0).
WhiteningFilter FitWhiteningFilter(const CorrelatedNoiseModel& noise);

/// One pixel of a camera on one of its faces: its pixel, the face (0 .. faces - 1) and its row
/// of B, which is nonzero in that face's four columns only (residuals/camera_planes.h: b_i^T /
/// sigma_i).
struct FacePixelRow {
  Eigen::Vector2i pixel = Eigen::Vector2i::Zero();
  int face = 0;
  Eigen::Vector4d row = Eigen::Vector4d::Zero();
};

/// B^T W^T W B, (4 faces) x (4 faces), for the pixels (distinct) with their rows of B: the
/// GLS Gram of CorrelatedGram through the filter, in one pass of blurs per face over that face's
/// part of the image instead of a solve per column (seconds per camera against minutes). Off the
/// pixels (holes, clutter) each blur is a normalised convolution: the blur of the values over
/// the blur of the pixels' mask, the local mean of what is there.
Eigen::MatrixXd WhitenedGram(const std::vector<FacePixelRow>& pixels, int faces,
                             const WhiteningFilter& filter);

}  // namespace rigfit
