#include "uncertainty/covariance.h"

#include <ceres/crs_matrix.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <stdexcept>
#include <type_traits>

#include "core/parallel.h"
#include "core/pose.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"

namespace rigfit {

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

Eigen::MatrixXd InverseOrEmpty(const Eigen::MatrixXd& H) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
  const Eigen::VectorXd& lambda = eig.eigenvalues();
  if (!(lambda.minCoeff() > 1e-12 * lambda.maxCoeff())) return {};
  return eig.eigenvectors() * lambda.cwiseInverse().asDiagonal() * eig.eigenvectors().transpose();
}

namespace {

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

/// The blocks of J^T J for poses and nuisance blocks: A (poses), B_j (poses x block j), D_j
/// (block j); each residual block holds at most one nuisance block. With `clusters`, also per
/// nuisance block its rows' pose information A_own_j and gradients g_pose_j (poses), g_block_j
/// (the block), and the information of the rows without one, P (for the robust covariance).
struct SchurBlocks {
  int p = 0;                  // pose columns
  std::vector<int> start;     // nuisance block j holds the columns [start[j], start[j + 1])
  std::vector<int> block_of;  // column - p -> its nuisance block
  Eigen::MatrixXd A, P;
  std::vector<Eigen::MatrixXd> B, D, A_own;
  std::vector<Eigen::VectorXd> g_pose, g_block;

  SchurBlocks(ceres::Problem* problem, int num_poses, const std::vector<double*>& nuisance,
              int num_cols, bool clusters);
  /// The row's only nuisance block, or -1 (throws when it holds two).
  int Cluster(const ceres::CRSMatrix& J, int row) const;
  void AddRow(const ceres::CRSMatrix& J, int row, double residual, bool clusters);
};

SchurBlocks::SchurBlocks(ceres::Problem* problem, int num_poses,
                         const std::vector<double*>& nuisance, int num_cols, bool clusters)
    : p(num_cols), block_of(num_cols) {
  // The pose columns come first: every column that no nuisance block holds.
  for (double* block : nuisance) p -= problem->ParameterBlockTangentSize(block);
  if (p < num_poses) throw std::logic_error("MarginalPoseCovariance: a pose block without columns");
  start.assign(nuisance.size() + 1, p);
  block_of.resize(num_cols - p);
  for (size_t j = 0; j < nuisance.size(); ++j) {
    start[j + 1] = start[j] + problem->ParameterBlockTangentSize(nuisance[j]);
    std::fill(block_of.begin() + (start[j] - p), block_of.begin() + (start[j + 1] - p), j);
  }
  A = Eigen::MatrixXd::Zero(p, p);
  P = Eigen::MatrixXd::Zero(p, p);
  B.resize(nuisance.size());
  D.resize(nuisance.size());
  A_own.resize(clusters ? nuisance.size() : 0);
  g_pose.resize(A_own.size());
  g_block.resize(A_own.size());
  for (size_t j = 0; j < nuisance.size(); ++j) {
    B[j] = Eigen::MatrixXd::Zero(p, start[j + 1] - start[j]);
    D[j] = Eigen::MatrixXd::Zero(start[j + 1] - start[j], start[j + 1] - start[j]);
    if (!clusters) continue;
    A_own[j] = Eigen::MatrixXd::Zero(p, p);
    g_pose[j] = Eigen::VectorXd::Zero(p);
    g_block[j] = Eigen::VectorXd::Zero(start[j + 1] - start[j]);
  }
}

int SchurBlocks::Cluster(const ceres::CRSMatrix& J, int row) const {
  int cluster = -1;
  for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
    if (J.cols[a] < p) continue;
    const int j = block_of[J.cols[a] - p];
    if (cluster >= 0 && j != cluster) {
      throw std::logic_error("MarginalPoseCovariance: a residual block holds two nuisance blocks");
    }
    cluster = j;
  }
  return cluster;
}

void SchurBlocks::AddRow(const ceres::CRSMatrix& J, int row, double residual, bool clusters) {
  const int cluster = Cluster(J, row);
  if (clusters && cluster >= 0) {
    for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
      const int ca = J.cols[a];
      if (ca < p) {
        g_pose[cluster](ca) += J.values[a] * residual;
      } else {
        g_block[cluster](ca - start[cluster]) += J.values[a] * residual;
      }
    }
  }
  // Where the row's pose information also goes for `robust`: its cluster's A_j, or P.
  Eigen::MatrixXd* own = !clusters ? nullptr : cluster >= 0 ? &A_own[cluster] : &P;
  for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
    const int ca = J.cols[a];
    for (int b = J.rows[row]; b < J.rows[row + 1]; ++b) {
      const int cb = J.cols[b];
      const double v = J.values[a] * J.values[b];
      if (cb < p) {
        if (ca < p) A(ca, cb) += v;  // ca >= p: the transpose of B's entry below
        if (ca < p && own != nullptr) (*own)(ca, cb) += v;
      } else if (ca < p) {
        const int j = block_of[cb - p];
        B[j](ca, cb - start[j]) += v;
      } else {
        const int j = block_of[ca - p];  // the row's only one (checked above)
        D[j](ca - start[j], cb - start[j]) += v;
      }
    }
  }
}

/// The cluster-robust sandwich: covariance P covariance plus, per cluster, its score d_j d_j^T
/// corrected for its leverage L_j.
Eigen::MatrixXd RobustSandwich(const Eigen::MatrixXd& covariance, const Eigen::MatrixXd& P,
                               const std::vector<Eigen::VectorXd>& scores,
                               const std::vector<Eigen::MatrixXd>& leverages) {
  const int p = static_cast<int>(covariance.rows());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> C(covariance);
  const Eigen::MatrixXd S = C.eigenvectors() *
                            C.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal() *
                            C.eigenvectors().transpose();
  Eigen::MatrixXd sum = covariance * P * covariance;
  for (size_t j = 0; j < scores.size(); ++j) {
    const Eigen::MatrixXd M = Eigen::MatrixXd::Identity(p, p) - S * leverages[j] * S;
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> m(0.5 * (M + M.transpose()));
    constexpr double kMinRemaining = 0.01;  // leverage at most 0.99
    const Eigen::VectorXd d =
        S *
        (m.eigenvectors() *
         m.eigenvalues().cwiseMax(kMinRemaining).cwiseSqrt().cwiseInverse().asDiagonal() *
         m.eigenvectors().transpose()) *
        S * scores[j];
    sum += d * d.transpose();
  }
  return sum;
}

}  // namespace

Eigen::MatrixXd MarginalPoseCovariance(ceres::Problem* problem, const std::vector<double*>& poses,
                                       const std::vector<double*>& nuisance,
                                       Eigen::MatrixXd* robust) {
  if (robust != nullptr) robust->resize(0, 0);
  if (poses.empty()) return {};
  std::vector<double*> blocks = poses;
  blocks.insert(blocks.end(), nuisance.begin(), nuisance.end());
  std::vector<ceres::ResidualBlockId> residual_blocks;
  problem->GetResidualBlocks(&residual_blocks);
  std::vector<double> residuals;
  ceres::CRSMatrix J;
  EvaluateJacobian(problem, blocks, residual_blocks, &residuals, &J);
  const bool clusters = robust != nullptr;
  SchurBlocks s(problem, static_cast<int>(poses.size()), nuisance, J.num_cols, clusters);
  for (int row = 0; row < J.num_rows; ++row) s.AddRow(J, row, residuals[row], clusters);
  std::vector<Eigen::VectorXd> scores;
  std::vector<Eigen::MatrixXd> leverages;  // L_j
  for (size_t j = 0; j < nuisance.size(); ++j) {
    if (s.D[j].isZero(0.0) && s.B[j].isZero(0.0)) continue;  // in no residual block
    const Eigen::MatrixXd D_inverse = InverseOrEmpty(s.D[j]);
    if (D_inverse.size() == 0) return {};
    const Eigen::MatrixXd reduction = s.B[j] * D_inverse * s.B[j].transpose();
    s.A -= reduction;
    // A block only fixed cameras see tells nothing of the poses: not a cluster.
    if (!clusters || s.B[j].isZero(0.0)) continue;
    scores.push_back(s.g_pose[j] - s.B[j] * (D_inverse * s.g_block[j]));
    leverages.push_back(s.A_own[j] - reduction);
  }
  const Eigen::MatrixXd covariance = InverseOrEmpty(s.A);
  if (!clusters || covariance.size() == 0 || scores.size() < 2) return covariance;
  *robust = RobustSandwich(covariance, s.P, scores, leverages);
  return covariance;
}

Eigen::MatrixXd MarginalPoseSandwiches(ceres::Problem* problem, const std::vector<double*>& poses,
                                       const std::vector<double*>& nuisance,
                                       const BlockClusters& clusters, ClusterSandwiches* sandwiches,
                                       Eigen::MatrixXd* unclustered) {
  sandwiches->fine = sandwiches->coarse = Eigen::MatrixXd();
  if (unclustered != nullptr) unclustered->resize(0, 0);
  if (poses.empty()) return {};
  std::vector<double*> blocks = poses;
  blocks.insert(blocks.end(), nuisance.begin(), nuisance.end());
  std::vector<ceres::ResidualBlockId> residual_blocks;
  problem->GetResidualBlocks(&residual_blocks);
  if (clusters.fine.size() != residual_blocks.size() ||
      clusters.coarse.size() != residual_blocks.size()) {
    throw std::invalid_argument("MarginalPoseSandwiches: one cluster per residual block expected");
  }
  std::vector<double> residuals;
  ceres::CRSMatrix J;
  EvaluateJacobian(problem, blocks, residual_blocks, &residuals, &J);
  // With clusters, SchurBlocks gathers the information of the rows without a nuisance block in
  // P (its per-block scores are not used: the clusters here are the caller's).
  const bool priors = unclustered != nullptr;
  SchurBlocks s(problem, static_cast<int>(poses.size()), nuisance, J.num_cols, priors);
  for (int row = 0; row < J.num_rows; ++row) s.AddRow(J, row, residuals[row], priors);
  if (priors) *unclustered = s.P;
  std::vector<Eigen::MatrixXd> K(nuisance.size());  // B_j D_j^-1
  for (size_t j = 0; j < nuisance.size(); ++j) {
    if (s.D[j].isZero(0.0) && s.B[j].isZero(0.0)) continue;  // in no residual block
    const Eigen::MatrixXd D_inverse = InverseOrEmpty(s.D[j]);
    if (D_inverse.size() == 0) return {};
    K[j] = s.B[j] * D_inverse;
    s.A -= K[j] * s.B[j].transpose();
  }
  const Eigen::MatrixXd covariance = InverseOrEmpty(s.A);
  if (covariance.size() == 0) return covariance;
  const auto count = [](const std::vector<int>& of) {
    return of.empty() ? 0 : *std::max_element(of.begin(), of.end()) + 1;
  };
  Eigen::MatrixXd fine = Eigen::MatrixXd::Zero(s.p, count(clusters.fine));
  Eigen::MatrixXd coarse = Eigen::MatrixXd::Zero(s.p, count(clusters.coarse));
  int row = 0;
  for (size_t b = 0; b < residual_blocks.size(); ++b) {
    const int rows = problem->GetCostFunctionForResidualBlock(residual_blocks[b])->num_residuals();
    for (const int end = row + rows; row < end; ++row) {
      if (clusters.fine[b] < 0 && clusters.coarse[b] < 0) continue;
      const int j = s.Cluster(J, row);
      Eigen::VectorXd score = Eigen::VectorXd::Zero(s.p);
      for (int a = J.rows[row]; a < J.rows[row + 1]; ++a) {
        const double v = J.values[a] * residuals[row];
        if (J.cols[a] < s.p) {
          score(J.cols[a]) += v;
        } else {
          score -= K[j].col(J.cols[a] - s.start[j]) * v;
        }
      }
      if (clusters.fine[b] >= 0) fine.col(clusters.fine[b]) += score;
      if (clusters.coarse[b] >= 0) coarse.col(clusters.coarse[b]) += score;
    }
  }
  sandwiches->fine = covariance * fine * fine.transpose() * covariance;
  sandwiches->coarse = covariance * coarse * coarse.transpose() * covariance;
  return covariance;
}

std::array<int64_t, 3> CellOf(const Vec3& world, double edge_m) {
  const Vec3 floor = ((world / edge_m).array() + 0.5).floor();
  return {static_cast<int64_t>(floor.x()), static_cast<int64_t>(floor.y()),
          static_cast<int64_t>(floor.z())};
}

Eigen::MatrixXd CovarianceAtLeast(const Eigen::MatrixXd& model, const Eigen::MatrixXd& other) {
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> m(model);
  if (!(m.eigenvalues().minCoeff() > 0.0)) {
    throw std::invalid_argument("CovarianceAtLeast: the model covariance is not positive definite");
  }
  const Eigen::VectorXd root = m.eigenvalues().cwiseSqrt();
  const Eigen::MatrixXd half = m.eigenvectors() * root.asDiagonal();  // model = half half^T
  const Eigen::MatrixXd half_inverse =
      root.cwiseInverse().asDiagonal() * m.eigenvectors().transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> w(half_inverse * other *
                                                         half_inverse.transpose());
  const Eigen::MatrixXd raised = half * w.eigenvectors() *
                                 w.eigenvalues().cwiseMax(1.0).asDiagonal() *
                                 w.eigenvectors().transpose() * half.transpose();
  return 0.5 * (raised + raised.transpose());
}

namespace {

/// One term linearised at the views' poses: its whitened Jacobians with respect to the
/// tangents of the source and target poses, and with respect to the source and target points
/// (their camera frames).
template <typename Term>
struct Linearised {
  static constexpr int kRows = Term::kNumResiduals;
  Eigen::Matrix<double, kRows, 1> r;
  Eigen::Matrix<double, kRows, 6> J_source, J_target;
  Eigen::Matrix<double, kRows, 3> D_source, D_target;
};

/// A pose block's tangent at its value: the block's PlusJacobian and the pose's rotation.
struct PoseTangent {
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> plus;
  Mat3 R;
};

/// The term's linearisation at the views' pose blocks, whose tangents are `source_tangent`
/// and `target_tangent`.
template <typename Term>
Linearised<Term> Linearise(const Term& term, const CameraView& source, const CameraView& target,
                           const PoseTangent& source_tangent, const PoseTangent& target_tangent) {
  constexpr int kRows = Term::kNumResiduals;
  Eigen::Matrix<double, kRows, 7, Eigen::RowMajor> Ja, Jb;
  Linearised<Term> l;
  term.Evaluate(source.pose_block, target.pose_block, l.r.data(), Ja.data(), Jb.data());
  l.J_source = Ja * source_tangent.plus;
  l.J_target = Jb * target_tangent.plus;
  // r depends on p through T_source p and on q through T_target q only (both methods), so
  // its derivative with respect to a point is that with respect to the pose's translation
  // (the point in the world) times the pose's rotation.
  l.D_source = Ja.template rightCols<3>() * source_tangent.R;
  l.D_target = Jb.template rightCols<3>() * target_tangent.R;
  return l;
}

/// M_uw += A_u^T B_w for the free views u, w (6 x 6 blocks at their columns).
template <typename A, typename B>
void AddBlock(Eigen::MatrixXd* M, int u, int w, const A& a, const B& b) {
  if (u < 0 || w < 0) return;
  M->block<6, 6>(u, w) += a.transpose() * b;
}

/// World cells (cubes of one edge) -> the summed realised scores of the points in them.
using CellScores = std::map<std::array<int64_t, 3>, Eigen::VectorXd>;

/// The realised scores J_t^T r_t of the terms whose source is one view, summed per source point,
/// then per world cell (ClusterSandwiches' clusters).
class ClusterScores {
 public:
  ClusterScores(const CameraView& view, int dimension)
      : view_(view), by_point_(Eigen::MatrixXd::Zero(view.level->points.size(), dimension)) {}

  /// Adds a term's score J^T r for the free view at column c (none for a fixed view, c < 0) to
  /// its source point i.
  void Add(size_t i, int c, const Vec6& score) {
    if (c >= 0) by_point_.row(i).segment<6>(c) += score.transpose();
  }

  /// Adds the points' scores to the cubes of `edge` (world frame, CellOf) that hold them.
  void AddToCells(double edge, CellScores* cells) const {
    for (Eigen::Index i = 0; i < by_point_.rows(); ++i) {
      if (by_point_.row(i).isZero(0.0)) continue;
      const std::array<int64_t, 3> key =
          CellOf(view_.T_world_camera * view_.level->points[i], edge);
      const auto [it, added] = cells->try_emplace(key, Eigen::VectorXd::Zero(by_point_.cols()));
      it->second += by_point_.row(i).transpose();
    }
  }

 private:
  const CameraView& view_;
  Eigen::MatrixXd by_point_;
};

/// One view's realised scores per fine and per coarse world cell.
struct Meats {
  CellScores fine;
  CellScores coarse;
};

/// sum_g s_g s_g^T over the cells of every view's (the same cell's scores summed first).
Eigen::MatrixXd MeatOf(const std::vector<Meats>& meats, CellScores Meats::*cells, int dimension) {
  CellScores all;
  for (const Meats& m : meats) {
    for (const auto& [key, g] : m.*cells) {
      const auto [it, added] = all.try_emplace(key, Eigen::VectorXd::Zero(dimension));
      it->second += g;
    }
  }
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(dimension, dimension);
  for (const auto& [key, g] : all) meat += g * g.transpose();
  return meat;
}

/// How a method's terms share noise: each term's own floor (share of min_noise_m, whitened)
/// and each point's floor (PointNoise).
struct FloorShares {
  double term = 0.0;
  double point = 0.0;
};

/// The shared-noise covariance H^-1 M H^-1 of the joint estimate over `terms` (of type Term,
/// made by MakeTerm): per view v (in parallel) the information H and independent noise of the
/// terms whose source is v, and the shared noise of v's points: s_p per free view w, the sum
/// of J_w^T D_p over the terms of point p, then M += s_p C_p s_p^T blockwise, as
/// (s_p L)(s_p L)^T with L L^T = C_p = PointNoise.
template <typename Term, typename MakeTerm>
class SharedNoise {
 public:
  using Score = Eigen::Matrix<double, 6, 3>;

  SharedNoise(const ViewTerms& in, const IcpOptions& options, const MakeTerm& make_term,
              FloorShares floors, int free)
      : views_(in.views),
        column_(in.column),
        terms_(in.terms),
        options_(options),
        make_term_(make_term),
        floors_(floors),
        free_(free),
        tangents_(in.views.size()) {
    for (size_t v = 0; v < views_.size(); ++v) {
      SharedPoseManifold()->PlusJacobian(views_[v].pose_block, tangents_[v].plus.data());
      tangents_[v].R = PoseFromParameters(views_[v].pose_block).linear();
    }
  }

  /// Adds view v's terms' information to H and its terms' and points' noise to M, and the
  /// noise of its surfaces' offsets to B (SurfaceBias); with `meats`, the realised scores of
  /// the terms whose source is v to its cells, fine ones of the view's voxel and coarse ones
  /// of `cell_m`.
  void AddView(int v, Eigen::MatrixXd* H, Eigen::MatrixXd* M, Eigen::MatrixXd* B, Meats* meats,
               double cell_m) const {
    std::vector<Score> scores;  // [point * free + free index of the view]
    std::optional<ClusterScores> realised;
    if (meats != nullptr) realised.emplace(views_[v], static_cast<int>(H->rows()));
    for (const MatchedViews& m : terms_) {
      AddTerms(v, m, H, M, &scores, realised ? &*realised : nullptr);
    }
    if (!scores.empty()) {
      AddPointNoise(v, scores, M);
      AddSurfaceBias(v, scores, B);
    }
    if (realised) {
      realised->AddToCells(views_[v].level->voxel_size, &meats->fine);
      realised->AddToCells(cell_m, &meats->coarse);
    }
  }

 private:
  size_t Index(const CameraView* view) const { return static_cast<size_t>(view - views_.data()); }

  void AddTerms(int v, const MatchedViews& m, Eigen::MatrixXd* H, Eigen::MatrixXd* M,
                std::vector<Score>* scores, ClusterScores* realised) const {
    const size_t s = Index(m.source), t = Index(m.target);
    if (s != static_cast<size_t>(v) && t != static_cast<size_t>(v)) return;
    if (scores->empty()) scores->assign(views_[v].level->points.size() * free_, Score::Zero());
    const int cs = column_[s], ct = column_[t];
    // Adds J^T D to the score of point i for the free view at column c.
    const auto score = [&](size_t i, int c, const auto& J, const auto& D) {
      if (c >= 0) (*scores)[i * free_ + c / 6] += J.transpose() * D;
    };
    const double floor2 = options_.min_noise_m * options_.min_noise_m;
    for (const Correspondence& c : *m.matches) {
      const Term term = make_term_(*m.source, *m.target, c);
      const Linearised<Term> l = Linearise(term, *m.source, *m.target, tangents_[s], tangents_[t]);
      if (s == static_cast<size_t>(v)) {
        // Each term once, with its source's view.
        AddBlock(H, cs, cs, l.J_source, l.J_source);
        AddBlock(H, cs, ct, l.J_source, l.J_target);
        AddBlock(H, ct, cs, l.J_target, l.J_source);
        AddBlock(H, ct, ct, l.J_target, l.J_target);
        if constexpr (std::is_same_v<Term, PointToPlaneTerm>) {
          // The term's own floor, whitened: floor^2 / sigma^2, sigma = 1 / |n| of the
          // whitened normal.
          const double f = floors_.term * floor2 * term.normal_b.squaredNorm();
          AddBlock(M, cs, cs, f * l.J_source, l.J_source);
          AddBlock(M, cs, ct, f * l.J_source, l.J_target);
          AddBlock(M, ct, cs, f * l.J_target, l.J_source);
          AddBlock(M, ct, ct, f * l.J_target, l.J_target);
        }
        score(c.source, cs, l.J_source, l.D_source);
        score(c.source, ct, l.J_target, l.D_source);
        if (realised != nullptr) {
          realised->Add(c.source, cs, l.J_source.transpose() * l.r);
          realised->Add(c.source, ct, l.J_target.transpose() * l.r);
        }
      }
      if (t == static_cast<size_t>(v)) {
        score(c.target, cs, l.J_source, l.D_target);
        score(c.target, ct, l.J_target, l.D_target);
      }
    }
  }

  void AddPointNoise(int v, const std::vector<Score>& scores, Eigen::MatrixXd* M) const {
    const CameraView& view = views_[v];
    std::vector<Score> factors(free_);
    std::vector<int> used;
    for (size_t i = 0; i < view.level->points.size(); ++i) {
      const Mat3 C = PointNoise(view, view.level->points[i], options_, floors_.point);
      const Eigen::LLT<Mat3> llt(C);
      Mat3 L = llt.matrixL();
      if (llt.info() != Eigen::Success || !L.allFinite()) {
        // Singular (no depth noise, or no plane share): L = V sqrt(lambda).
        Eigen::SelfAdjointEigenSolver<Mat3> eig;
        eig.computeDirect(C);
        L = eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
      }
      used.clear();
      for (int w = 0; w < free_; ++w) {
        if (scores[i * free_ + w].isZero(0.0)) continue;
        factors[w] = scores[i * free_ + w] * L;
        used.push_back(w);
      }
      for (int u : used) {
        for (int w : used) M->block<6, 6>(6 * u, 6 * w) += factors[u] * factors[w].transpose();
      }
    }
  }

  /// B += sum over the cubes of kCovarianceCellM holding view v's points of g g^T, g the sum of
  /// its points' scores times the shift -z p that one sigma of an offset of the view's inverse
  /// depth (its surface_bias) gives each point p: the points of a cube, of one or two surfaces,
  /// share one offset, which the terms do not average away.
  void AddSurfaceBias(int v, const std::vector<Score>& scores, Eigen::MatrixXd* B) const {
    const CameraView& view = views_[v];
    if (!(view.surface_bias > 0.0)) return;
    ClusterScores shifts(view, static_cast<int>(B->rows()));
    for (size_t i = 0; i < view.level->points.size(); ++i) {
      const Vec3& p = view.level->points[i];
      const Vec3 shift = -view.surface_bias * p.z() * p;
      for (int w = 0; w < free_; ++w) shifts.Add(i, 6 * w, scores[i * free_ + w] * shift);
    }
    CellScores cubes;
    shifts.AddToCells(kCovarianceCellM, &cubes);
    for (const auto& [key, g] : cubes) *B += g * g.transpose();
  }

  const std::vector<CameraView>& views_;
  const std::vector<int>& column_;
  const std::vector<MatchedViews>& terms_;
  const IcpOptions& options_;
  const MakeTerm& make_term_;
  FloorShares floors_;
  int free_;
  std::vector<PoseTangent> tangents_;
};

/// A term type as a value (for a generic lambda).
template <typename T>
struct TermType {
  using type = T;
};

/// Sums the views' H and M over the prior and returns H^-1 M H^-1 (empty when H is singular
/// or the result not finite); with `sandwiches`, also the realised ones.
template <typename Term, typename MakeTerm>
Eigen::MatrixXd SharedNoiseOf(const SharedNoise<Term, MakeTerm>& shared, size_t n,
                              const Eigen::MatrixXd& prior_information, int num_threads,
                              ClusterSandwiches* sandwiches, Eigen::MatrixXd* surface_bias) {
  const Eigen::MatrixXd zero =
      Eigen::MatrixXd::Zero(prior_information.rows(), prior_information.cols());
  std::vector<Eigen::MatrixXd> H(n, zero), M(n, zero), B(n, zero);
  std::vector<Meats> meats(sandwiches != nullptr ? n : 0);
  const double cell_m = sandwiches != nullptr ? sandwiches->cell_m : 0.0;
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int v) {
        shared.AddView(v, &H[v], &M[v], &B[v], meats.empty() ? nullptr : &meats[v], cell_m);
      },
      /*min_per_thread=*/1);
  Eigen::MatrixXd H_total = prior_information;
  Eigen::MatrixXd M_total = prior_information;
  Eigen::MatrixXd B_total = zero;
  for (size_t v = 0; v < n; ++v) {
    H_total += H[v];
    M_total += M[v];
    B_total += B[v];
  }
  const Eigen::MatrixXd H_inverse = InverseOrEmpty(H_total);
  if (H_inverse.size() == 0) return {};
  Eigen::MatrixXd covariance = H_inverse * M_total * H_inverse;
  if (!covariance.allFinite()) return {};
  if (surface_bias != nullptr) *surface_bias = H_inverse * B_total * H_inverse;
  if (sandwiches != nullptr) {
    const int dimension = static_cast<int>(zero.rows());
    sandwiches->fine = H_inverse * MeatOf(meats, &Meats::fine, dimension) * H_inverse;
    sandwiches->coarse = H_inverse * MeatOf(meats, &Meats::coarse, dimension) * H_inverse;
  }
  return covariance;
}

}  // namespace

Eigen::MatrixXd SharedNoiseCovariance(const ViewTerms& in, const IcpOptions& options,
                                      const Eigen::MatrixXd& prior_information, int num_threads,
                                      ClusterSandwiches* sandwiches,
                                      Eigen::MatrixXd* surface_bias) {
  if (sandwiches != nullptr) sandwiches->fine = sandwiches->coarse = Eigen::MatrixXd();
  if (surface_bias != nullptr) *surface_bias = Eigen::MatrixXd();
  if (prior_information.rows() == 0 || in.terms.empty()) return {};
  const int free = static_cast<int>(prior_information.rows()) / 6;
  const auto run = [&](const auto& make_term, FloorShares floors, auto term_type) {
    using Term = typename decltype(term_type)::type;
    const SharedNoise<Term, std::decay_t<decltype(make_term)>> shared(in, options, make_term,
                                                                      floors, free);
    return SharedNoiseOf(shared, in.views.size(), prior_information, num_threads, sandwiches,
                         surface_bias);
  };
  if (options.method == RegistrationMethod::kGicp) {
    return run([&](const CameraView& s, const CameraView& t,
                   const Correspondence& c) { return MakeGicpTerm(s, t, c, options); },
               FloorShares{/*term=*/0.0, /*point=*/0.5}, TermType<GicpTerm>{});
  }
  return run([&](const CameraView& s, const CameraView& t,
                 const Correspondence& c) { return MakePointToPlaneTerm(s, t, c, options); },
             FloorShares{/*term=*/1.0, /*point=*/0.0}, TermType<PointToPlaneTerm>{});
}

SigmaInflation InflationOf(const ClusterSandwiches& sandwiches, int column) {
  const auto factor = [&](int offset) {
    const double fine = sandwiches.fine.block<3, 3>(column + offset, column + offset).trace();
    const double coarse = sandwiches.coarse.block<3, 3>(column + offset, column + offset).trace();
    return fine > 0.0 ? std::sqrt(std::max(1.0, coarse / fine)) : 1.0;
  };
  return {factor(0), factor(3)};
}

}  // namespace rigfit
