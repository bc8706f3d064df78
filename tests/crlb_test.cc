#include "analysis/crlb.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <functional>
#include <stdexcept>

#include "analysis/face_oracle.h"
#include "core/evaluate.h"
#include "core/geometry.h"
#include "prepare/region.h"
#include "rig/refine.h"
#include "sim/noise_field.h"
#include "sim/scene.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

SimulatedRig SmallNoiseFreeRig() {
  SimOptions sim;
  sim.cameras = 3;
  sim.width = 320;
  sim.height = 180;
  sim.noise = 0.0;
  sim.seed = 5;
  return SimulateRig(sim);
}

TEST(CramerRaoBound, ScalesWithTheNoiseAndMatchesItsCovariance) {
  const SimulatedRig rig = SmallNoiseFreeRig();
  RefineOptions options;
  // The sensor noise alone, no prior of fixed weight: the bound is linear in the noise.
  options.icp.gravity_weight = 0.0;
  options.ground.enabled = false;  // floor normals are snapped within a noise-sized band
  const CramerRaoBound k =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.002, 1e-7, {500, 1, 2});
  const CramerRaoBound k2 =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.004, 1e-7, {500, 1, 2});
  ASSERT_TRUE(k.ok) << k.message;
  ASSERT_TRUE(k2.ok) << k2.message;
  ASSERT_EQ(k.serials.size(), 2u);
  EXPECT_EQ(k.reference, rig.capture.cameras.front().serial);
  // Same draws, twice the noise: twice the errors (to the first order of the small motions).
  EXPECT_NEAR(k2.rms.rotation_rad / k.rms.rotation_rad, 2.0, 0.01);
  EXPECT_NEAR(k2.rms.translation_m / k.rms.translation_m, 2.0, 0.01);
  EXPECT_NEAR(k2.covariance(3, 3) / k.covariance(3, 3), 4.0, 1e-6);
  // The sampled tilt error of a camera is its covariance's tilt: sqrt(C_xx + C_zz).
  // RMS over the three cameras, the reference's tilt being exact.
  const double tilt_variance =
      (k.covariance(0, 0) + k.covariance(2, 2) + k.covariance(6, 6) + k.covariance(8, 8)) / 3.0;
  EXPECT_NEAR(k.rms.tilt_rad / std::sqrt(tilt_variance), 1.0, 0.1);
}

TEST(CramerRaoBound, SampledErrorsAreTheCovariancesErrors) {
  // Two cameras: the only pair holds the reference, whose pose is exact, so the relative
  // error is the free camera's tangent error itself: the translation error is |d| and the
  // rotation error |w| (core/pose.h), whose mean squares are the traces of its covariance.
  SimulatedRig rig = SmallNoiseFreeRig();
  const std::string dropped = rig.capture.cameras[1].serial;
  rig.capture.cameras.erase(rig.capture.cameras.begin() + 1);
  rig.gt.erase(dropped);
  RefineOptions options;
  options.icp.gravity_weight = 0.0;
  options.ground.enabled = false;
  constexpr int kSamples = 2000;
  const CramerRaoBound k =
      ComputeCramerRaoBound(rig.capture, rig.gt, options, 0.002, 1e-7, {kSamples, 3, 2});
  ASSERT_TRUE(k.ok) << k.message;
  ASSERT_EQ(k.serials.size(), 1u);
  // A mean square of 2000 samples of a 3-dof quadratic form is within ~3% (1 sigma, less
  // with unequal eigenvalues): 10% is over three sigma.
  constexpr double kSamplingTolerance = 0.10;
  const double rotation_ms = k.covariance.topLeftCorner<3, 3>().trace();
  const double translation_ms = k.covariance.block<3, 3>(3, 3).trace();
  EXPECT_NEAR(k.rms.rotation_rad * k.rms.rotation_rad / rotation_ms, 1.0, kSamplingTolerance);
  EXPECT_NEAR(k.rms.translation_m * k.rms.translation_m / translation_ms, 1.0, kSamplingTolerance);
}

TEST(CramerRaoBound, CamerasThatShareNothingHaveNoBound) {
  SimulatedRig rig = SmallNoiseFreeRig();
  // Move the second camera's data 100 m away: nothing overlaps at the true poses.
  rig.gt[rig.capture.cameras[1].serial].translation() += Vec3(100.0, 0.0, 0.0);
  const CramerRaoBound b =
      ComputeCramerRaoBound(rig.capture, rig.gt, {}, 0.002, kCramerRaoNoiseFloorM, {10, 1, 2});
  EXPECT_FALSE(b.ok);
  EXPECT_FALSE(b.message.empty());
}

}  // namespace
}  // namespace rigfit

namespace rigfit {
namespace {

/// The predicted inverse depth of the pixel with ray a on the world plane (n, d) seen from T.
double PredictedInverseDepth(const Pose& T, const Vec3& n, double d, const Vec3& a) {
  const Vec3 n_c = T.linear().transpose() * n;
  const double d_c = n.dot(T.translation()) + d;
  return -n_c.dot(a) / d_c;
}

/// A small noise-free rig's band pixels labelled with the simulator's faces, each with its
/// pixel, and the rows of the Fisher information built independently of the bound: per camera,
/// one row per pixel the bound counts, the central differences of its predicted inverse depth
/// in the free poses (6 per camera but the first) and the used faces' planes (parameterised
/// differently: two normal directions of our own and the offset; the floor's offset alone).
struct SmallSurfaceProblem {
  SimulatedRig rig;
  std::vector<FacePixels> cameras;
  std::vector<PlanarFace> faces;
  std::vector<Eigen::MatrixXd> rows;                 // per camera, gradients / k
  std::vector<std::vector<Eigen::Vector2i>> pixels;  // per camera, the rows' pixels
  int params = 0;
  static constexpr double kNoise = 0.0025;

  SmallSurfaceProblem(int width, int height) {
    SimOptions sim;
    sim.cameras = 3;
    sim.width = width;
    sim.height = height;
    sim.noise = 0.0;
    sim.dropout = 0.0;
    rig = SimulateRig(sim);
    RegionOptions every_pixel;
    every_pixel.pixel_stride = 1;
    for (const CameraCapture& camera : rig.capture.cameras) {
      FacePixels& c = cameras.emplace_back();
      c.serial = camera.serial;
      const Pose& T = rig.gt.at(camera.serial);
      c.points = NearFloorBand(RegistrationPoints(camera, every_pixel), T, RegionOptions{});
      LabelFaces(rig.scene, T, c.points, &faces, &c.faces);
      const PinholeIntrinsics& K = camera.intrinsics;
      for (const Vec3& p : c.points) {
        const Eigen::Vector2i px = PixelOf(K, p);
        // The pixel is the point's own: its depth there.
        EXPECT_NEAR(camera.depth_m[static_cast<size_t>(px.y()) * camera.width + px.x()], p.z(),
                    1e-5 * p.z());
        c.pixels.push_back(px);
      }
    }
    // The faces the bound uses: at least 3 pixels in each of at least two cameras.
    const size_t n = cameras.size();
    std::vector<std::vector<int>> count(faces.size(), std::vector<int>(n, 0));
    for (size_t c = 0; c < n; ++c) {
      for (const int f : cameras[c].faces) {
        if (f >= 0) ++count[f][c];
      }
    }
    std::vector<int> column(faces.size(), -1);  // first parameter of each used face
    params = 6 * static_cast<int>(n - 1);
    for (size_t f = 0; f < faces.size(); ++f) {
      int seen = 0;
      for (size_t c = 0; c < n; ++c) seen += count[f][c] >= 3 ? 1 : 0;
      if (seen < 2) continue;
      column[f] = params;
      params += faces[f].floor ? 1 : 3;
    }
    constexpr double kStep = 1e-6;
    for (size_t c = 0; c < n; ++c) {
      const Pose& T = rig.gt.at(cameras[c].serial);
      std::vector<Eigen::VectorXd> g_rows;
      pixels.emplace_back();
      for (size_t i = 0; i < cameras[c].points.size(); ++i) {
        const int f = cameras[c].faces[i];
        if (f < 0 || column[f] < 0 || count[f][c] < 3) continue;
        const Vec3 a = cameras[c].points[i] / cameras[c].points[i].z();
        const Vec3& nf = faces[f].normal;
        const double df = faces[f].offset;
        // Two directions orthogonal to the normal.
        const Vec3 u = nf.unitOrthogonal();
        const Vec3 v = nf.cross(u);
        Eigen::VectorXd g = Eigen::VectorXd::Zero(params);
        const auto h = [&](const Pose& Tc, const Vec3& nn, double dd) {
          return PredictedInverseDepth(Tc, nn.normalized(), dd, a);
        };
        if (c > 0) {
          for (int k = 0; k < 6; ++k) {
            Vec6 delta = Vec6::Zero();
            delta[k] = kStep;
            g[6 * (c - 1) + k] =
                (h(PosePlus(T, delta), nf, df) - h(PosePlus(T, -delta), nf, df)) / (2 * kStep);
          }
        }
        int col = column[f];
        if (!faces[f].floor) {
          g[col++] = (h(T, nf + kStep * u, df) - h(T, nf - kStep * u, df)) / (2 * kStep);
          g[col++] = (h(T, nf + kStep * v, df) - h(T, nf - kStep * v, df)) / (2 * kStep);
        }
        g[col] = (h(T, nf, df + kStep) - h(T, nf, df - kStep)) / (2 * kStep);
        g_rows.push_back(g / kNoise);
        pixels.back().push_back(cameras[c].pixels[i]);
      }
      Eigen::MatrixXd& G = rows.emplace_back(static_cast<Eigen::Index>(g_rows.size()), params);
      for (size_t k = 0; k < g_rows.size(); ++k) G.row(static_cast<Eigen::Index>(k)) = g_rows[k];
    }
  }

  /// The poses' block of the inverse of sum over cameras of rows^T S^-1 rows, S the given
  /// noise correlation between the rows' pixels (dense).
  Eigen::MatrixXd DenseCovariance(
      const std::function<double(const Eigen::Vector2i&, const Eigen::Vector2i&)>& S) const {
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(params, params);
    for (size_t c = 0; c < rows.size(); ++c) {
      const Eigen::Index m = rows[c].rows();
      Eigen::MatrixXd Sc(m, m);
      for (Eigen::Index i = 0; i < m; ++i) {
        for (Eigen::Index j = 0; j < m; ++j) Sc(i, j) = S(pixels[c][i], pixels[c][j]);
      }
      H += rows[c].transpose() * Sc.llt().solve(rows[c]);
    }
    const int p = 6 * static_cast<int>(rows.size() - 1);
    return H.inverse().topLeftCorner(p, p);
  }
};

TEST(SurfaceCramerRaoBound, PoseBlockOfTheSchurComplementEqualsTheDenseInverse) {
  // The bound's covariance (Ceres computes it with the planes eliminated) against the poses'
  // block of the dense inverse of the independently built information.
  const SmallSurfaceProblem problem(64, 36);
  const CramerRaoBound bound =
      ComputeSurfaceCramerRaoBound(problem.cameras, problem.faces, problem.rig.gt,
                                   problem.cameras.front().serial, {problem.kNoise}, {10, 1});
  ASSERT_TRUE(bound.ok) << bound.message;
  const Eigen::MatrixXd dense = problem.DenseCovariance(
      [](const Eigen::Vector2i& a, const Eigen::Vector2i& b) { return a == b ? 1.0 : 0.0; });
  ASSERT_EQ(bound.covariance.rows(), dense.rows());
  EXPECT_LT((bound.covariance - dense).cwiseAbs().maxCoeff(), 1e-5 * dense.cwiseAbs().maxCoeff())
      << "bound\n"
      << bound.covariance << "\ndense\n"
      << dense;
}

TEST(SurfaceCramerRaoBound, CorrelatedNoiseEqualsTheDenseGeneralisedLeastSquaresInverse) {
  // The noise correlated over 1.5 px (share 0.8): the bound's covariance against the dense
  // inverse of sum_c G_c^T S_c^-1 G_c with S_c written out pixel pair by pixel pair.
  const SmallSurfaceProblem problem(48, 27);
  const CorrelatedNoiseModel noise{1.5, 0.8};
  const std::vector<double> rho = NoiseFieldCorrelation(noise.corr_px);
  const auto rho_at = [&](int d) {
    return std::abs(d) < static_cast<int>(rho.size()) ? rho[std::abs(d)] : 0.0;
  };
  const CramerRaoBound bound = ComputeSurfaceCramerRaoBound(
      problem.cameras, problem.faces, problem.rig.gt, problem.cameras.front().serial,
      {problem.kNoise, noise}, {10, 1, 2});
  ASSERT_TRUE(bound.ok) << bound.message;
  const Eigen::MatrixXd dense =
      problem.DenseCovariance([&](const Eigen::Vector2i& a, const Eigen::Vector2i& b) {
        return (a == b ? 1.0 - noise.share : 0.0) +
               noise.share * rho_at(a.x() - b.x()) * rho_at(a.y() - b.y());
      });
  ASSERT_EQ(bound.covariance.rows(), dense.rows());
  EXPECT_LT((bound.covariance - dense).cwiseAbs().maxCoeff(), 1e-5 * dense.cwiseAbs().maxCoeff())
      << "bound\n"
      << bound.covariance << "\ndense\n"
      << dense;
  // A vanishing share is white noise: the per-(camera, face) clusters' bound.
  const CramerRaoBound white =
      ComputeSurfaceCramerRaoBound(problem.cameras, problem.faces, problem.rig.gt,
                                   problem.cameras.front().serial, {problem.kNoise}, {10, 1});
  const CramerRaoBound nearly_white = ComputeSurfaceCramerRaoBound(
      problem.cameras, problem.faces, problem.rig.gt, problem.cameras.front().serial,
      {problem.kNoise, {noise.corr_px, 1e-9}}, {10, 1, 2});
  ASSERT_TRUE(white.ok && nearly_white.ok);
  // All of the noise correlated leaves no white share to invert: no bound, said so.
  const CramerRaoBound smooth = ComputeSurfaceCramerRaoBound(
      problem.cameras, problem.faces, problem.rig.gt, problem.cameras.front().serial,
      {problem.kNoise, {noise.corr_px, 1.0}}, {10, 1, 2});
  EXPECT_FALSE(smooth.ok);
  EXPECT_THAT(smooth.message, ::testing::HasSubstr("white share"));
  EXPECT_LT((nearly_white.covariance - white.covariance).cwiseAbs().maxCoeff(),
            1e-6 * white.covariance.cwiseAbs().maxCoeff());
}

TEST(CorrelatedGram, EqualsTheDenseSolveOnAnIrregularMask) {
  // 30 x 20 pixels with holes, three columns: B^T S^-1 B against a dense Cholesky solve.
  const CorrelatedNoiseModel noise{2.0, 0.9};
  const std::vector<double> rho = NoiseFieldCorrelation(noise.corr_px);
  std::vector<Eigen::Vector2i> pixels;
  for (int v = 0; v < 20; ++v) {
    for (int u = 0; u < 30; ++u) {
      if ((u * 7 + v * 13) % 5 != 0) pixels.emplace_back(u + 100, v + 50);
    }
  }
  const Eigen::Index m = static_cast<Eigen::Index>(pixels.size());
  Eigen::MatrixXd B(m, 3);
  for (Eigen::Index i = 0; i < m; ++i) {
    B(i, 0) = 1.0;
    B(i, 1) = pixels[i].x() * 0.01;
    B(i, 2) = pixels[i].y() > 60 ? 1.0 : 0.0;
  }
  Eigen::MatrixXd S(m, m);
  for (Eigen::Index i = 0; i < m; ++i) {
    for (Eigen::Index j = 0; j < m; ++j) {
      const int du = std::abs(pixels[i].x() - pixels[j].x());
      const int dv = std::abs(pixels[i].y() - pixels[j].y());
      const double c = du < static_cast<int>(rho.size()) && dv < static_cast<int>(rho.size())
                           ? rho[du] * rho[dv]
                           : 0.0;
      S(i, j) = (i == j ? 1.0 - noise.share : 0.0) + noise.share * c;
    }
  }
  const Eigen::MatrixXd dense = B.transpose() * S.llt().solve(B);
  const Eigen::MatrixXd gram = CorrelatedGram(pixels, B, noise, 2);
  ASSERT_EQ(gram.rows(), 3);
  EXPECT_LT((gram - dense).cwiseAbs().maxCoeff(), 1e-7 * dense.cwiseAbs().maxCoeff())
      << gram << "\n\n"
      << dense;
  EXPECT_THROW(CorrelatedGram(pixels, B, {0.0, 0.5}, 1), std::invalid_argument);
  EXPECT_THROW(CorrelatedGram(pixels, B, {2.0, 1.0}, 1), std::invalid_argument);
}

/// Two faces meeting at a vertical crease of a 48 x 36 image with a hole: each pixel's row of
/// the camera-planes residual (residuals/camera_planes.h), b = [a; w] / sigma_w.
std::vector<FacePixelRow> TwoFacesWithAHole() {
  std::vector<FacePixelRow> pixels;
  for (int v = 0; v < 36; ++v) {
    for (int u = 0; u < 48; ++u) {
      if (std::abs(u - 16) < 3 && std::abs(v - 18) < 4) continue;
      FacePixelRow& p = pixels.emplace_back();
      p.pixel = Eigen::Vector2i(u + 200, v + 100);
      p.face = u < 24 ? 0 : 1;
      const double x = (u - 24) / 100.0, y = (v - 18) / 100.0;
      p.row << x, y, 1.0, (p.face == 0 ? 0.4 - 0.1 * x : 0.4 + 0.2 * x) + 0.05 * y;
      p.row /= 0.0025;
    }
  }
  return pixels;
}

/// The variances of the faces' normal-over-offset entries (the first three columns of each
/// face; the fourth multiplies the measured w, which the plane does not scale) under a Gram.
Eigen::VectorXd SlopeVariances(const Eigen::MatrixXd& gram) {
  const std::vector<int> kept = {0, 1, 2, 4, 5, 6};
  Eigen::MatrixXd sub(6, 6);
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) sub(i, j) = gram(kept[i], kept[j]);
  }
  return sub.inverse().diagonal();
}

TEST(WhitenedGram, NearTheExactGeneralisedLeastSquares) {
  // The filter's Gram against CorrelatedGram's exact B^T S^-1 B: the variances they imply for
  // the faces' parameters. Measured ratios (filter / exact): 1.00-1.80 at 4 px, share 0.8
  // (the simulator's correlated family); 0.83-1.03 at 2 px, 0.5; 0.98-1.09 at 1.5 px, 0.3.
  // White weighting is 28-39, 11-12 and 6 times too optimistic.
  const std::vector<FacePixelRow> pixels = TwoFacesWithAHole();
  std::vector<Eigen::Vector2i> positions;
  Eigen::MatrixXd B = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(pixels.size()), 8);
  for (size_t i = 0; i < pixels.size(); ++i) {
    positions.push_back(pixels[i].pixel);
    B.block<1, 4>(static_cast<Eigen::Index>(i), 4 * pixels[i].face) = pixels[i].row.transpose();
  }
  for (const CorrelatedNoiseModel noise :
       {CorrelatedNoiseModel{4.0, 0.8}, CorrelatedNoiseModel{2.0, 0.5},
        CorrelatedNoiseModel{1.5, 0.3}}) {
    SCOPED_TRACE(std::to_string(noise.corr_px) + " px, share " + std::to_string(noise.share));
    const Eigen::VectorXd exact = SlopeVariances(CorrelatedGram(positions, B, noise, 2));
    const Eigen::VectorXd filtered =
        SlopeVariances(WhitenedGram(pixels, 2, FitWhiteningFilter(noise)));
    const Eigen::VectorXd white = SlopeVariances(B.transpose() * B);
    const Eigen::ArrayXd ratio = filtered.array() / exact.array();
    EXPECT_GT(ratio.minCoeff(), 0.7) << ratio.transpose();
    EXPECT_LT(ratio.maxCoeff(), 2.0) << ratio.transpose();
    EXPECT_GT((exact.array() / white.array()).minCoeff(), 5.0);
  }
}

TEST(FaceOracle, WhitenedReachesWhatIndependentPixelsMissOnCorrelatedNoise) {
  // A 320 x 180 rig with correlated noise (80% of the variance over 4 px, seed 3: the default
  // registers it to 15.3 mm, rig_accuracy_test.cc), solved from its start with the true faces.
  // Measured: independent pixels 0.1164 deg / 6.72 mm, whitened 0.0593 deg / 4.42 mm (ratios
  // 0.51 / 0.66; an identity filter would give 1).
  SimOptions sim;
  sim.seed = 3;
  sim.width = 320;
  sim.height = 180;
  sim.noise_corr_px = 4.0;
  sim.noise_corr_share = 0.8;
  const SimulatedRig rig = SimulateRig(sim);
  SimOptions clean = sim;
  clean.noise = 0.0;
  const SimulatedRig truth = SimulateRig(clean);
  std::vector<PlanarFace> faces;
  const std::vector<FacePixels> labelled = RigFacePixels(
      truth.capture, truth.gt, RefineOptions{}.region,
      [&](const Pose& T, const PointCloud& p, std::vector<PlanarFace>* f, std::vector<int>* l) {
        LabelFaces(truth.scene, T, p, f, l);
      },
      &faces);
  const std::string reference = rig.capture.cameras.front().serial;
  PoseMap start = rig.init;
  start[reference] = rig.gt.at(reference);
  FaceOracleOptions options;
  options.depth_noise = sim.noise;
  const FaceOracleResult independent =
      SolveWithTrueFaces(rig.capture, labelled, faces, start, reference, options);
  options.correlated = {sim.noise_corr_px, sim.noise_corr_share};
  const FaceOracleResult whitened =
      SolveWithTrueFaces(rig.capture, labelled, faces, start, reference, options);
  ASSERT_TRUE(independent.ok && whitened.ok) << independent.message << whitened.message;
  EXPECT_EQ(whitened.pixels, independent.pixels);
  EXPECT_EQ(whitened.gated, 0);  // Gaussian noise: nothing beyond 5 sigma in practice
  const RigErrors e_independent = EvaluateRig(independent.poses, rig.gt);
  const RigErrors e_whitened = EvaluateRig(whitened.poses, rig.gt);
  EXPECT_LT(e_whitened.rms_rotation_rad, 0.7 * e_independent.rms_rotation_rad);
  EXPECT_LT(e_whitened.rms_translation_m, 0.85 * e_independent.rms_translation_m);
  EXPECT_LT(e_whitened.rms_rotation_rad * kRadToDeg, 0.12);
  EXPECT_LT(e_whitened.rms_translation_m, 0.0088);
}

}  // namespace
}  // namespace rigfit
