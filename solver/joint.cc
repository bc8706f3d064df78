#include "solver/joint.h"

#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <memory>
#include <sstream>

#include "core/geometry.h"
#include "core/parallel.h"
#include "core/stopwatch.h"
#include "residuals/gravity_prior.h"
#include "residuals/relative_pose.h"
#include "solver/correspondences.h"
#include "solver/degeneracy.h"
#include "solver/pose_graph.h"

namespace rigfit {
namespace {

/// A pair with fewer correspondences does not link its cameras in this iteration.
constexpr size_t kMinPairCorrespondences = 30;
/// Levenberg-Marquardt iterations per outer iteration (correspondences fixed).
constexpr int kSolverIterationsPerStep = 3;

using PoseBlock = std::array<double, kPoseAmbientSize>;

/// Standard deviation of the prior that holds a weakly constrained direction at the start
/// pose (m; rotations as arc length at the radius of the camera's matched points).
constexpr double kHoldSigmaM = 1e-4;

/// Per camera, the constraint rows of the correspondences it is the source of (world
/// points and the target normals they are matched against, weighted by the inverse
/// variance of their residual), for the stability analysis.
std::vector<StabilityAccumulator> Stability(const std::vector<CameraView>& views,
                                            const std::vector<CandidatePair>& pairs,
                                            const std::vector<std::vector<Correspondence>>& matches,
                                            const IcpOptions& options) {
  std::vector<StabilityAccumulator> stability(views.size());
  for (size_t k = 0; k < matches.size(); ++k) {
    const int source = k % 2 == 0 ? pairs[k / 2].a : pairs[k / 2].b;
    const int target = k % 2 == 0 ? pairs[k / 2].b : pairs[k / 2].a;
    const CameraView& s = views[source];
    const CameraView& t = views[target];
    for (const Correspondence& c : matches[k]) {
      stability[source].Add(s.T_world_camera * s.level->points[c.source],
                            t.T_world_camera.linear() * t.level->geometry.normals[c.target],
                            1.0 / PointToPlaneVariance(s, t, c, options));
    }
  }
  return stability;
}

/// Side of the world cells that group correspondences into clusters for the covariance (m).
constexpr double kClusterCellM = 0.5;

/// The clusters of the covariance's residual rows: the world cells of side kClusterCellM
/// of the correspondences' source points, and one cluster per prior.
class RowClusters {
 public:
  /// `matches` split by the cell of their source point, with each group's cluster.
  std::vector<std::pair<int, std::vector<Correspondence>>> Split(
      const CameraView& source, const std::vector<Correspondence>& matches) {
    std::map<int, std::vector<Correspondence>> groups;
    for (const Correspondence& c : matches) {
      const Vec3 p = source.T_world_camera * source.level->points[c.source];
      const std::array<int64_t, 3> key = {static_cast<int64_t>(std::floor(p.x() / kClusterCellM)),
                                          static_cast<int64_t>(std::floor(p.y() / kClusterCellM)),
                                          static_cast<int64_t>(std::floor(p.z() / kClusterCellM))};
      groups[ids_.emplace(key, static_cast<int>(ids_.size())).first->second].push_back(c);
    }
    return {groups.begin(), groups.end()};
  }
  /// `rows` rows of cluster `id` (from Split).
  void AddRows(int id, int rows) { rows_.insert(rows_.end(), rows, id); }
  /// Rows that form a cluster of their own (a prior), after the last Split.
  void AddOwnCluster(int rows) {
    rows_.insert(rows_.end(), rows, static_cast<int>(ids_.size()) + own_++);
  }
  const std::vector<int>& rows() const { return rows_; }

 private:
  std::map<std::array<int64_t, 3>, int> ids_;
  std::vector<int> rows_;
  int own_ = 0;
};

/// Covariance of every free pose block (tangent space) from the cluster-robust estimator
/// over the given residual blocks. Returns false when it is not available.
bool PoseCovariances(ceres::Problem* problem, std::vector<PoseBlock>& blocks,
                     const std::vector<bool>& free,
                     const std::vector<ceres::ResidualBlockId>& residual_blocks,
                     const std::vector<int>& row_cluster, std::vector<Mat6>* out) {
  std::vector<double*> free_blocks;
  std::vector<size_t> index;
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (!free[i]) continue;
    free_blocks.push_back(blocks[i].data());
    index.push_back(i);
  }
  if (free_blocks.empty()) return false;
  const Eigen::MatrixXd covariance =
      ClusterRobustCovariance(problem, free_blocks, residual_blocks, row_cluster);
  if (covariance.size() == 0) return false;
  out->assign(blocks.size(), Mat6::Zero());
  for (size_t k = 0; k < index.size(); ++k) {
    (*out)[index[k]] = covariance.block<6, 6>(6 * k, 6 * k);
  }
  return true;
}

}  // namespace

JointResult RegisterJoint(const std::vector<RegistrationCamera>& cameras,
                          const std::vector<CandidatePair>& pairs, int reference,
                          const IcpOptions& options, int num_threads, const Log& log) {
  const size_t n = cameras.size();
  JointResult result;
  result.poses.resize(n);
  for (size_t i = 0; i < n; ++i) result.poses[i] = cameras[i].T_world_camera;
  result.connected.assign(n, false);
  result.pair_correspondences.assign(pairs.size(), 0);
  result.covariance.assign(n, Mat6::Zero());
  result.weak.assign(n, {});
  if (n == 0 || cameras[0].pyramid == nullptr) return result;
  const size_t levels = cameras[0].pyramid->levels.size();

  std::vector<PoseBlock> blocks(n);
  for (size_t i = 0; i < n; ++i) PoseToParameters(cameras[i].T_world_camera, blocks[i].data());
  const std::vector<PoseBlock> initial_blocks = blocks;  // copied into each problem, constant
  std::vector<PoseBlock> start_blocks;
  const std::unique_ptr<ceres::LossFunction> loss(MakeCorrespondenceLoss(options));
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = kSolverIterationsPerStep;
  solver_options.num_threads = num_threads;
  solver_options.logging_type = ceres::SILENT;

  std::unique_ptr<ceres::Problem> problem;
  std::vector<CameraView> views(n);
  std::vector<std::vector<Correspondence>> matches;
  // The weak directions of the connected cameras at the views' poses.
  const auto find_weak_directions = [&] {
    const std::vector<StabilityAccumulator> stability = Stability(views, pairs, matches, options);
    for (size_t i = 0; i < n; ++i) {
      result.weak[i] = result.connected[i]
                           ? stability[i].WeakDirections(views[i].T_world_camera.translation(),
                                                         options.degeneracy_threshold)
                           : std::vector<WeakDirection>();
    }
  };
  // Whether pair k has enough correspondences to link its cameras in this iteration.
  const auto linked = [&](size_t k) {
    return static_cast<size_t>(result.pair_correspondences[k]) >= kMinPairCorrespondences;
  };
  // The correspondence terms of every linked pair, both directions, into `target`,
  // compressed (CompressedCost): one block per direction, or with `clusters`, one per
  // direction and cluster, built in parallel. Returns their residual blocks.
  const auto add_pair_terms = [&](ceres::Problem* target, RowClusters* clusters) {
    struct Block {
      const CameraView* source;
      const CameraView* target;
      const std::vector<Correspondence>* matches;
      int cluster;
    };
    std::vector<Block> blocks_to_add;
    std::deque<std::vector<Correspondence>> groups;  // the clusters' matches (stable addresses)
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (!linked(k)) continue;
      for (size_t d = 0; d < 2; ++d) {
        const CameraView* source = &views[d == 0 ? pairs[k].a : pairs[k].b];
        const CameraView* target_view = &views[d == 0 ? pairs[k].b : pairs[k].a];
        const std::vector<Correspondence>& m = matches[2 * k + d];
        if (clusters == nullptr) {
          blocks_to_add.push_back({source, target_view, &m, -1});
          continue;
        }
        for (auto& [cluster, group] : clusters->Split(*source, m)) {
          groups.push_back(std::move(group));
          blocks_to_add.push_back({source, target_view, &groups.back(), cluster});
        }
      }
    }
    std::vector<std::unique_ptr<ceres::CostFunction>> costs(blocks_to_add.size());
    ParallelFor(
        static_cast<int>(blocks_to_add.size()), num_threads,
        [&](int b) {
          costs[b] =
              CorrespondenceCost(options, *blocks_to_add[b].source, *blocks_to_add[b].target,
                                 *blocks_to_add[b].matches, loss.get(), TermStorage::kCompressed);
        },
        /*min_per_thread=*/1);
    std::vector<ceres::ResidualBlockId> ids;
    for (size_t b = 0; b < costs.size(); ++b) {
      if (costs[b] == nullptr) continue;
      const int rows = costs[b]->num_residuals();
      ids.push_back(target->AddResidualBlock(costs[b].release(), nullptr,
                                             blocks_to_add[b].source->pose_block,
                                             blocks_to_add[b].target->pose_block));
      if (clusters != nullptr) clusters->AddRows(blocks_to_add[b].cluster, rows);
    }
    return ids;
  };
  for (size_t s = 0; s < levels; ++s) {
    const double voxel_size = cameras[0].pyramid->levels[s].voxel_size;
    const double max_distance = options.max_correspondence_distance_factor * voxel_size;
    const int max_iterations = s < options.max_iterations.size() ? options.max_iterations[s] : 0;
    for (int it = 0; it < max_iterations; ++it) {
      std::vector<Pose> current(n);
      for (size_t i = 0; i < n; ++i) {
        current[i] = PoseFromParameters(blocks[i].data());
        views[i] = {&cameras[i].pyramid->levels[s], current[i], blocks[i].data(),
                    cameras[i].depth_noise};
      }
      auto start = std::chrono::steady_clock::now();
      matches.assign(2 * pairs.size(), {});
      for (size_t k = 0; k < pairs.size(); ++k) {
        const CameraView& a = views[pairs[k].a];
        const CameraView& b = views[pairs[k].b];
        matches[2 * k] =
            FindCorrespondences(a, b, max_distance, options.max_normal_angle_deg, num_threads);
        matches[2 * k + 1] =
            FindCorrespondences(b, a, max_distance, options.max_normal_angle_deg, num_threads);
        result.pair_correspondences[k] =
            static_cast<int>(matches[2 * k].size() + matches[2 * k + 1].size());
      }
      result.correspondences_s += SecondsSince(start);
      start = std::chrono::steady_clock::now();
      problem = NewProblem();
      for (PoseBlock& b : blocks) {
        problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
      }
      if (options.hold_weak_directions) {
        start_blocks = initial_blocks;
        for (PoseBlock& b : start_blocks) {
          problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
          problem->SetParameterBlockConstant(b.data());
        }
      }
      add_pair_terms(problem.get(), nullptr);
      size_t total = 0;
      std::vector<std::pair<int, int>> links;
      for (size_t k = 0; k < pairs.size(); ++k) {
        if (!linked(k)) continue;
        links.emplace_back(pairs[k].a, pairs[k].b);
        total += result.pair_correspondences[k];
      }
      result.connected = ConnectedTo(reference, n, links);
      if (options.hold_weak_directions) find_weak_directions();
      for (size_t i = 0; i < n; ++i) {
        if (!result.connected[i]) {
          problem->SetParameterBlockConstant(blocks[i].data());
          continue;
        }
        if (options.hold_weak_directions && static_cast<int>(i) != reference &&
            !result.weak[i].empty()) {
          // Hold what the data barely constrain at the start pose (not counted in the
          // covariance, which reports what the data alone determine).
          problem->AddResidualBlock(
              RelativePoseCost::Create(
                  Pose::Identity(),
                  EdgeInformationFromTangentInformation(
                      HoldInformation(result.weak[i], kHoldSigmaM), cameras[i].T_world_camera)),
              nullptr, start_blocks[i].data(), blocks[i].data());
        }
        if (static_cast<int>(i) != reference && options.gravity_weight > 0.0) {
          problem->AddResidualBlock(
              GravityPriorCost::Create(cameras[i].T_world_camera.linear(), options.gravity_weight),
              nullptr, blocks[i].data());
        }
      }
      problem->SetParameterBlockConstant(blocks[reference].data());
      ceres::Solver::Summary summary;
      ceres::Solve(solver_options, problem.get(), &summary);
      result.solve_s += SecondsSince(start);
      ++result.iterations;
      result.usable = summary.IsSolutionUsable();
      if (!result.usable) {
        result.message = "joint solve: " + summary.message;
        return result;
      }
      double max_rotation = 0.0, max_translation = 0.0;
      bool converged = true;
      for (size_t i = 0; i < n; ++i) {
        const Vec6 step = PoseDifference(current[i], PoseFromParameters(blocks[i].data()));
        max_rotation = std::max(max_rotation, step.head<3>().norm());
        max_translation = std::max(max_translation, step.tail<3>().norm());
        converged = converged && StepConverged(step, voxel_size, s + 1 == levels);
      }
      std::ostringstream m;
      m << "joint: voxel " << voxel_size << " iteration " << it << ": " << total
        << " correspondences, cost " << summary.final_cost << ", step "
        << max_rotation * 180.0 / M_PI << " deg " << max_translation * 1e3 << " mm";
      log.Debug(m.str());
      if (converged) break;
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (result.connected[i]) result.poses[i] = PoseFromParameters(blocks[i].data());
  }
  if (problem != nullptr) {
    const auto start = std::chrono::steady_clock::now();
    // Without holding, only the end matters: the analysis runs once, at the last
    // iteration's correspondences and poses.
    if (!options.hold_weak_directions) find_weak_directions();
    // The covariance of the last iteration's terms and priors (not the holding ones: it
    // reports what the data alone determine) at the final poses, the terms compressed per
    // cluster: the cluster-robust estimator needs only each cluster's sum of J^T r and the
    // sum of J^T J, which compression keeps exactly.
    const std::unique_ptr<ceres::Problem> rows = NewProblem();
    for (PoseBlock& b : blocks) {
      rows->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
    }
    RowClusters clusters;
    std::vector<ceres::ResidualBlockId> residual_blocks = add_pair_terms(rows.get(), &clusters);
    std::vector<bool> free = result.connected;
    free[reference] = false;
    for (size_t i = 0; i < n; ++i) {
      if (!free[i] || options.gravity_weight <= 0.0) continue;
      ceres::CostFunction* prior =
          GravityPriorCost::Create(cameras[i].T_world_camera.linear(), options.gravity_weight);
      residual_blocks.push_back(rows->AddResidualBlock(prior, nullptr, blocks[i].data()));
      clusters.AddOwnCluster(prior->num_residuals());
    }
    result.covariance_ok = PoseCovariances(rows.get(), blocks, free, residual_blocks,
                                           clusters.rows(), &result.covariance);
    result.covariance_s = SecondsSince(start);
  }
  return result;
}

Eigen::MatrixXd JointInformation(const std::vector<RegistrationCamera>& cameras,
                                 const std::vector<CandidatePair>& pairs, int reference,
                                 const IcpOptions& options, int num_threads) {
  const size_t n = cameras.size();
  if (n < 2 || cameras[0].pyramid == nullptr || cameras[0].pyramid->levels.empty()) return {};
  const size_t finest = cameras[0].pyramid->levels.size() - 1;
  const double max_distance =
      options.max_correspondence_distance_factor * cameras[0].pyramid->levels[finest].voxel_size;
  std::vector<PoseBlock> blocks(n);
  std::vector<CameraView> views(n);
  const std::unique_ptr<ceres::Problem> problem = NewProblem();
  for (size_t i = 0; i < n; ++i) {
    PoseToParameters(cameras[i].T_world_camera, blocks[i].data());
    problem->AddParameterBlock(blocks[i].data(), kPoseAmbientSize, SharedPoseManifold());
    views[i] = {&cameras[i].pyramid->levels[finest], cameras[i].T_world_camera, blocks[i].data(),
                cameras[i].depth_noise};
  }
  std::vector<ceres::ResidualBlockId> residual_blocks;
  const auto add_terms = [&](const CameraView& source, const CameraView& target) {
    const std::vector<Correspondence> matches = FindCorrespondences(
        source, target, max_distance, options.max_normal_angle_deg, num_threads);
    const ceres::ResidualBlockId id = AddCorrespondenceTerms(
        problem.get(), options, source, target, matches, nullptr, TermStorage::kCompressed);
    if (id != nullptr) residual_blocks.push_back(id);
  };
  for (const CandidatePair& pair : pairs) {
    add_terms(views[pair.a], views[pair.b]);
    add_terms(views[pair.b], views[pair.a]);
  }
  std::vector<double*> free_blocks;
  for (size_t i = 0; i < n; ++i) {
    if (static_cast<int>(i) == reference) continue;
    free_blocks.push_back(blocks[i].data());
    if (options.gravity_weight > 0.0) {
      residual_blocks.push_back(problem->AddResidualBlock(
          GravityPriorCost::Create(cameras[i].T_world_camera.linear(), options.gravity_weight),
          nullptr, blocks[i].data()));
    }
  }
  if (residual_blocks.empty()) return {};
  return Information(problem.get(), free_blocks, residual_blocks, /*scale_by_residuals=*/false);
}

}  // namespace rigfit
