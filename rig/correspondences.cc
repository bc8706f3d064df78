#include "rig/correspondences.h"

#include <ceres/crs_matrix.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "core/parallel.h"
#include "residuals/compressed_cost.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"
#include "residuals/stacked_cost.h"

namespace rigfit {
namespace {

/// A normal angle that accepts every pair of normals (overlap statistics).
constexpr double kAnyNormalAngleDeg = 180.0;

/// The normal check never widens beyond this (degrees): far below the 90 degrees between
/// the faces of a box corner or a leg, which must not pair up.
constexpr double kWidestNoisyNormalAngleDeg = 60.0;

/// The noise of point p of a view (its camera frame), as the weights model it (docs/residuals.md,
/// "Weights"): its depth error along the ray, k^2 z^2 p p^T, plus its plane-error share,
/// (plane_noise_share k z^2)^2, isotropic; GICP puts half the residual floor into each point's
/// noise too (`floor_share`).
Mat3 PointNoise(const CameraView& view, const Vec3& p, const IcpOptions& options,
                double floor_share) {
  const double k2 = view.depth_noise * view.depth_noise;
  const double share2 = options.plane_noise_share * options.plane_noise_share;
  return k2 * p.z() * p.z() * p * p.transpose() +
         (share2 * k2 * std::pow(p.z(), 4) +
          floor_share * options.min_noise_m * options.min_noise_m) *
             Mat3::Identity();
}

/// The whitened point-to-plane term of a correspondence: r is linear in n, so a normal
/// scaled by 1 / sigma whitens it.
PointToPlaneTerm MakePointToPlaneTerm(const CameraView& source, const CameraView& target,
                                      const Correspondence& c, const IcpOptions& options) {
  const double variance = PointToPlaneVariance(source, target, c, options);
  return {source.level->points[c.source], target.level->points[c.target],
          target.level->geometry.normals[c.target] / std::sqrt(variance)};
}

/// The GICP term of a correspondence: the covariance of a point is its plane-regularised
/// shape, V diag(1, 1, eps) V^T (m^2: the in-plane freedom stays, 1 m^2 as in small_gicp; the
/// eps along the normal is replaced by the noise model), plus PointNoise with half the floor.
GicpTerm MakeGicpTerm(const CameraView& source, const CameraView& target, const Correspondence& c,
                      const IcpOptions& options) {
  const auto covariance = [&](const CameraView& view, int i) {
    const LocalGeometry& g = view.level->geometry;
    return Mat3(g.covariances[i] - kGicpPlaneEpsilon * g.normals[i] * g.normals[i].transpose() +
                PointNoise(view, view.level->points[i], options, 0.5));
  };
  return GicpCost::MakeTerm(source.level->points[c.source], target.level->points[c.target],
                            covariance(source, c.source), covariance(target, c.target),
                            source.T_world_camera.linear(), target.T_world_camera.linear());
}

}  // namespace

std::vector<Correspondence> FindCorrespondences(const CameraView& source, const CameraView& target,
                                                double max_distance, double max_normal_angle_deg,
                                                int num_threads) {
  const ScaleLevel& src = *source.level;
  const ScaleLevel& tgt = *target.level;
  const Pose T_target_source = target.T_world_camera.inverse() * source.T_world_camera;
  const double max_angle = max_normal_angle_deg * kDegToRad;
  const double widest_angle = std::max(max_angle, kWidestNoisyNormalAngleDeg * kDegToRad);
  const double cos_max_angle = std::cos(max_angle);
  const double cos_widest_angle = std::cos(widest_angle);
  // The normal error of a point, as an angle: its depth noise over its normal's support.
  const auto normal_error = [](const CameraView& view, const Vec3& p) {
    const double support = view.level->normal_support;
    return support > 0.0 ? std::atan(view.depth_noise * p.z() * p.z() / support) : 0.0;
  };
  const int n = static_cast<int>(src.points.size());
  std::vector<Correspondence> found(n);
  std::vector<char> ok(n, 0);
  ParallelFor(n, num_threads, [&](int i) {
    if (!src.geometry.IsValid(i)) return;
    int j = 0;
    double d2 = 0.0;
    if (!tgt.Nearest(T_target_source * src.points[i], max_distance, &j, &d2) ||
        !tgt.geometry.IsValid(j)) {
      return;
    }
    // The widened angle lies between max_angle and widest_angle: only normals between the
    // two need it.
    const double cos_between =
        (T_target_source.linear() * src.geometry.normals[i]).dot(tgt.geometry.normals[j]);
    if (cos_between < cos_widest_angle) return;
    if (cos_between < cos_max_angle) {
      const double angle = std::min(
          max_angle + normal_error(source, src.points[i]) + normal_error(target, tgt.points[j]),
          widest_angle);
      if (cos_between < std::cos(angle)) return;
    }
    found[i] = {i, j, d2};
    ok[i] = 1;
  });
  std::vector<Correspondence> out;
  out.reserve(n);
  for (int i = 0; i < n; ++i) {
    if (ok[i]) out.push_back(found[i]);
  }
  return out;
}

bool StepConverged(const Vec6& step, double voxel_size, bool finest) {
  // A coarser scale only has to bring the cameras well inside the next scale's
  // correspondence distance: 0.05 of its own voxel against 1.4 of the next one's (half as
  // large by default) is 14 times inside.
  constexpr double kConvergedStepVoxels = 0.01;
  constexpr double kCoarseConvergedStepVoxels = 0.05;
  const double limit = (finest ? kConvergedStepVoxels : kCoarseConvergedStepVoxels) * voxel_size;
  constexpr double kLeverM = 1.0;  // rotation as arc length at this radius
  return step.head<3>().norm() * kLeverM < limit && step.tail<3>().norm() < limit;
}

double PointToPlaneVariance(const CameraView& source, const CameraView& target,
                            const Correspondence& c, const IcpOptions& options) {
  const Vec3& p = source.level->points[c.source];
  const Vec3& q = target.level->points[c.target];
  const Vec3& n_t = target.level->geometry.normals[c.target];
  // The target normal in the source frame: R_s^T R_t n_t.
  const double np =
      (source.T_world_camera.linear().transpose() * (target.T_world_camera.linear() * n_t)).dot(p);
  const double nq = n_t.dot(q);
  const double k_s = source.depth_noise * p.z() * np;
  const double k_t = target.depth_noise * q.z() * nq;
  // The share of the whole depth noise that counts whatever the normal.
  const double f_s = options.plane_noise_share * source.depth_noise * p.z() * p.z();
  const double f_t = options.plane_noise_share * target.depth_noise * q.z() * q.z();
  return k_s * k_s + k_t * k_t + f_s * f_s + f_t * f_t + options.min_noise_m * options.min_noise_m;
}

ceres::LossFunction* MakeCorrespondenceLoss(const IcpOptions& options) {
  const double scale = options.robust_loss_scale;
  switch (options.robust_loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kTukey:
      return new ceres::TukeyLoss(scale);
    case RobustLoss::kNone:
      return nullptr;
  }
  return nullptr;
}

std::unique_ptr<ceres::CostFunction> CorrespondenceCost(
    const IcpOptions& options, const CameraView& source, const CameraView& target,
    const std::vector<Correspondence>& correspondences, const ceres::LossFunction* loss,
    TermStorage storage) {
  // term(c) of every correspondence c into `cost`, weighted by the loss at the views' poses
  // (the residuals from the poses' features, computed once).
  const auto add_terms = [&](auto* cost, const auto& term) {
    using Term = std::decay_t<decltype(term(correspondences.front()))>;
    double theta[Term::kFeatureSize];
    Term::Features(source.pose_block, target.pose_block, theta, nullptr, nullptr);
    for (const Correspondence& c : correspondences) {
      const Term t = term(c);
      double r[Term::kNumResiduals];
      t.ResidualAt(theta, r);
      cost->Add(t, RobustWeight(loss, r, Term::kNumResiduals));
    }
  };
  const auto add_block = [&](const auto& term) -> std::unique_ptr<ceres::CostFunction> {
    if (correspondences.empty()) return nullptr;
    using Term = std::decay_t<decltype(term(correspondences.front()))>;
    if (storage == TermStorage::kStacked) {
      auto stacked = std::make_unique<StackedCost<Term>>();
      stacked->Reserve(correspondences.size());
      add_terms(stacked.get(), term);
      return stacked;
    }
    auto compressed = std::make_unique<CompressedCost<Term>>();
    add_terms(compressed.get(), term);
    compressed->Compress();
    return compressed;
  };
  if (options.method == RegistrationMethod::kGicp) {
    return add_block(
        [&](const Correspondence& c) { return MakeGicpTerm(source, target, c, options); });
  }
  return add_block(
      [&](const Correspondence& c) { return MakePointToPlaneTerm(source, target, c, options); });
}

ceres::ResidualBlockId AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                                              const CameraView& source, const CameraView& target,
                                              const std::vector<Correspondence>& correspondences,
                                              const ceres::LossFunction* loss,
                                              TermStorage storage) {
  std::unique_ptr<ceres::CostFunction> cost =
      CorrespondenceCost(options, source, target, correspondences, loss, storage);
  if (cost == nullptr) return nullptr;
  return problem->AddResidualBlock(cost.release(), nullptr, source.pose_block, target.pose_block);
}

std::unique_ptr<ceres::Problem> NewProblem() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return std::make_unique<ceres::Problem>(options);
}

ceres::Manifold* SharedPoseManifold() {
  static PoseManifold manifold;
  return &manifold;
}

OverlapStats MeasureOverlap(const CameraView& source, const CameraView& target,
                            double coarsest_voxel_size, const IcpOptions& options,
                            int num_threads) {
  OverlapStats stats;
  const size_t n = source.level->points.size();
  if (n == 0) return stats;
  const double factor = options.max_correspondence_distance_factor;
  const double fit_distance = factor * source.level->voxel_size;
  // One search at the wider distance serves both: a point's nearest neighbour within the
  // narrower one is its nearest neighbour within the wider one, when that is close enough.
  const std::vector<Correspondence> matches = FindCorrespondences(
      source, target, factor * std::max(coarsest_voxel_size, source.level->voxel_size),
      kAnyNormalAngleDeg, num_threads);
  stats.fitness = static_cast<double>(matches.size()) / n;
  double sum = 0.0;
  int fits = 0;
  for (const Correspondence& c : matches) {
    if (c.squared_distance >= fit_distance * fit_distance) continue;
    sum += c.squared_distance;
    ++fits;
  }
  stats.rmse_m = fits > 0 ? std::sqrt(sum / fits) : 0.0;
  return stats;
}

double FitRmse(const CameraView& source, const CameraView& target, const IcpOptions& options,
               int num_threads) {
  // A coarsest voxel of 0 makes the fitness distance the view's own, so the one search stays
  // within it.
  return MeasureOverlap(source, target, 0.0, options, num_threads).rmse_m;
}

namespace {

/// The Jacobian (PoseManifold tangents of `blocks`, in order) and residuals of the given
/// residual blocks, loss functions not applied; constant blocks are evaluated as variables.
void EvaluateJacobian(ceres::Problem* problem, const std::vector<double*>& blocks,
                      const std::vector<ceres::ResidualBlockId>& residual_blocks,
                      std::vector<double>* residuals, ceres::CRSMatrix* J) {
  ceres::Problem::EvaluateOptions eval;
  eval.parameter_blocks = blocks;
  eval.residual_blocks = residual_blocks;
  eval.apply_loss_function = false;
  std::vector<double*> made_variable;
  for (double* block : blocks) {
    if (!problem->IsParameterBlockConstant(block)) continue;
    problem->SetParameterBlockVariable(block);
    made_variable.push_back(block);
  }
  problem->Evaluate(eval, nullptr, residuals, nullptr, J);
  for (double* block : made_variable) problem->SetParameterBlockConstant(block);
}

/// J^T J of a sparse Jacobian (dense, J.num_cols square).
Eigen::MatrixXd Gram(const ceres::CRSMatrix& J) {
  Eigen::MatrixXd JtJ = Eigen::MatrixXd::Zero(J.num_cols, J.num_cols);
  for (int row = 0; row < J.num_rows; ++row) {
    for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
      for (int b = J.rows[row]; b < J.rows[row + 1]; ++b) {
        JtJ(J.cols[a], J.cols[b]) += J.values[a] * J.values[b];
      }
    }
  }
  return JtJ;
}

/// The inverse of a symmetric positive semi-definite matrix; empty when it is singular or
/// nearly so (an eigenvalue at most 1e-12 of the largest): a direction nothing constrains has
/// no finite covariance, and reporting it as 0 would read as "known exactly".
Eigen::MatrixXd InverseOrEmpty(const Eigen::MatrixXd& H) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  if (!(lambda.minCoeff() > 1e-12 * lambda.maxCoeff())) return {};
  return eig.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

}  // namespace

Eigen::MatrixXd Information(ceres::Problem* problem, const std::vector<double*>& blocks,
                            const std::vector<ceres::ResidualBlockId>& residual_blocks,
                            bool scale_by_residuals) {
  std::vector<double> residuals;
  ceres::CRSMatrix J;
  EvaluateJacobian(problem, blocks, residual_blocks, &residuals, &J);
  const Eigen::MatrixXd JtJ = Gram(J);
  if (!scale_by_residuals) return JtJ;
  double sum_sq = 0.0;
  for (double r : residuals) sum_sq += r * r;
  const double dof = static_cast<double>(residuals.size()) - J.num_cols;
  if (dof <= 0.0 || sum_sq <= 0.0) return JtJ;
  return JtJ / (sum_sq / dof);
}

namespace {

/// One term linearised at the views' poses: its whitened Jacobians with respect to the
/// tangents of the source and target poses, and with respect to the source and target points
/// (their camera frames).
template <typename Term>
struct Linearised {
  static constexpr int kRows = Term::kNumResiduals;
  Eigen::Matrix<double, kRows, 6> J_source, J_target;
  Eigen::Matrix<double, kRows, 3> D_source, D_target;
};

/// The term's linearisation at the views' pose blocks; plus_* are the blocks' PlusJacobians
/// and R_* their rotations.
template <typename Term>
Linearised<Term> Linearise(const Term& term, const CameraView& source, const CameraView& target,
                           const Eigen::Matrix<double, 7, 6, Eigen::RowMajor>& plus_source,
                           const Eigen::Matrix<double, 7, 6, Eigen::RowMajor>& plus_target,
                           const Mat3& R_source, const Mat3& R_target) {
  constexpr int kRows = Term::kNumResiduals;
  double r[kRows];
  Eigen::Matrix<double, kRows, 7, Eigen::RowMajor> Ja, Jb;
  term.Evaluate(source.pose_block, target.pose_block, r, Ja.data(), Jb.data());
  Linearised<Term> l;
  l.J_source = Ja * plus_source;
  l.J_target = Jb * plus_target;
  // r depends on p through T_source p and on q through T_target q only (both methods), so
  // its derivative with respect to a point is that with respect to the pose's translation
  // (the point in the world) times the pose's rotation.
  l.D_source = Ja.template rightCols<3>() * R_source;
  l.D_target = Jb.template rightCols<3>() * R_target;
  return l;
}

/// M_uw += A_u^T B_w for the free views u, w (6 x 6 blocks at their columns).
template <typename A, typename B>
void AddBlock(Eigen::MatrixXd* M, int u, int w, const A& a, const B& b) {
  if (u < 0 || w < 0) return;
  M->block<6, 6>(u, w) += a.transpose() * b;
}

template <typename Term, typename MakeTerm>
Eigen::MatrixXd SharedNoise(const std::vector<CameraView>& views, const std::vector<int>& column,
                            const std::vector<MatchedViews>& terms, const IcpOptions& options,
                            const Eigen::MatrixXd& prior_information, const MakeTerm& make_term,
                            double term_floor_share, double point_floor_share, int num_threads) {
  using Plus = Eigen::Matrix<double, 7, 6, Eigen::RowMajor>;
  using Score = Eigen::Matrix<double, 6, 3>;
  const size_t n = views.size();
  std::vector<Plus> plus(n);
  std::vector<Mat3> rotation(n);
  for (size_t v = 0; v < n; ++v) {
    SharedPoseManifold()->PlusJacobian(views[v].pose_block, plus[v].data());
    rotation[v] = PoseFromParameters(views[v].pose_block).linear();
  }
  const auto index = [&](const CameraView* view) {
    return static_cast<size_t>(view - views.data());
  };
  const double floor2 = options.min_noise_m * options.min_noise_m;
  const int free = static_cast<int>(prior_information.rows()) / 6;
  // Per view v (in parallel): the information H and independent noise of the terms whose
  // source is v, and the points' shared noise of v's points: s_p per free view w, the sum of
  // J_w^T D_p over the terms of point p, then M += s_p C_p s_p^T blockwise, as
  // (s_p L)(s_p L)^T with L L^T = C_p = PointNoise.
  std::vector<Eigen::MatrixXd> H(
      n, Eigen::MatrixXd::Zero(prior_information.rows(), prior_information.cols()));
  std::vector<Eigen::MatrixXd> M = H;
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int v) {
        const CameraView& view = views[v];
        const size_t count = view.level->points.size();
        std::vector<Score> scores;  // [point * free + free index of the view]
        for (const MatchedViews& m : terms) {
          const size_t s = index(m.source), t = index(m.target);
          if (s != static_cast<size_t>(v) && t != static_cast<size_t>(v)) continue;
          if (scores.empty()) scores.assign(count * free, Score::Zero());
          const int cs = column[s], ct = column[t];
          // Adds J^T D to the score of point i for the free view at column c.
          const auto score = [&](size_t i, int c, const auto& J, const auto& D) {
            if (c >= 0) scores[i * free + c / 6] += J.transpose() * D;
          };
          for (const Correspondence& c : *m.matches) {
            const Term term = make_term(*m.source, *m.target, c);
            const Linearised<Term> l =
                Linearise(term, *m.source, *m.target, plus[s], plus[t], rotation[s], rotation[t]);
            if (s == static_cast<size_t>(v)) {
              // Each term once, with its source's view.
              AddBlock(&H[v], cs, cs, l.J_source, l.J_source);
              AddBlock(&H[v], cs, ct, l.J_source, l.J_target);
              AddBlock(&H[v], ct, cs, l.J_target, l.J_source);
              AddBlock(&H[v], ct, ct, l.J_target, l.J_target);
              if constexpr (std::is_same_v<Term, PointToPlaneTerm>) {
                // The term's own floor, whitened: floor^2 / sigma^2, sigma = 1 / |n| of the
                // whitened normal.
                const double f = term_floor_share * floor2 * term.normal_b.squaredNorm();
                AddBlock(&M[v], cs, cs, f * l.J_source, l.J_source);
                AddBlock(&M[v], cs, ct, f * l.J_source, l.J_target);
                AddBlock(&M[v], ct, cs, f * l.J_target, l.J_source);
                AddBlock(&M[v], ct, ct, f * l.J_target, l.J_target);
              }
              score(c.source, cs, l.J_source, l.D_source);
              score(c.source, ct, l.J_target, l.D_source);
            }
            if (t == static_cast<size_t>(v)) {
              score(c.target, cs, l.J_source, l.D_target);
              score(c.target, ct, l.J_target, l.D_target);
            }
          }
        }
        if (scores.empty()) return;
        std::vector<Score> factors(free);
        std::vector<int> used;
        for (size_t i = 0; i < count; ++i) {
          const Mat3 C = PointNoise(view, view.level->points[i], options, point_floor_share);
          const Eigen::LLT<Mat3> llt(C);
          Mat3 L = llt.matrixL();
          if (llt.info() != Eigen::Success || !L.allFinite()) {
            // Singular (no depth noise, or no plane share): L = V sqrt(lambda).
            Eigen::SelfAdjointEigenSolver<Mat3> eig;
            eig.computeDirect(C);
            L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
          }
          used.clear();
          for (int w = 0; w < free; ++w) {
            if (scores[i * free + w].isZero(0.0)) continue;
            factors[w] = scores[i * free + w] * L;
            used.push_back(w);
          }
          for (int u : used) {
            for (int w : used)
              M[v].block<6, 6>(6 * u, 6 * w) += factors[u] * factors[w].transpose();
          }
        }
      },
      /*min_per_thread=*/1);
  Eigen::MatrixXd H_total = prior_information;
  Eigen::MatrixXd M_total = prior_information;
  for (size_t v = 0; v < n; ++v) {
    H_total += H[v];
    M_total += M[v];
  }
  const Eigen::MatrixXd H_inverse = InverseOrEmpty(H_total);
  if (H_inverse.size() == 0) return {};
  Eigen::MatrixXd covariance = H_inverse * M_total * H_inverse;
  if (!covariance.allFinite()) return {};
  return covariance;
}

}  // namespace

Eigen::MatrixXd SharedNoiseCovariance(const std::vector<CameraView>& views,
                                      const std::vector<int>& column,
                                      const std::vector<MatchedViews>& terms,
                                      const IcpOptions& options,
                                      const Eigen::MatrixXd& prior_information, int num_threads) {
  if (prior_information.rows() == 0 || terms.empty()) return {};
  if (options.method == RegistrationMethod::kGicp) {
    return SharedNoise<GicpTerm>(
        views, column, terms, options, prior_information,
        [&](const CameraView& s, const CameraView& t, const Correspondence& c) {
          return MakeGicpTerm(s, t, c, options);
        },
        /*term_floor_share=*/0.0, /*point_floor_share=*/0.5, num_threads);
  }
  return SharedNoise<PointToPlaneTerm>(
      views, column, terms, options, prior_information,
      [&](const CameraView& s, const CameraView& t, const Correspondence& c) {
        return MakePointToPlaneTerm(s, t, c, options);
      },
      /*term_floor_share=*/1.0, /*point_floor_share=*/0.0, num_threads);
}

}  // namespace rigfit
