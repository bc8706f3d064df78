#include "rig/joint.h"

#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <chrono>
#include <cmath>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <sstream>

#include "core/geometry.h"
#include "core/parallel.h"
#include "core/stopwatch.h"
#include "residuals/gravity_prior.h"
#include "residuals/relative_pose.h"
#include "rig/correspondences.h"
#include "rig/covariance.h"
#include "rig/degeneracy.h"
#include "rig/pose_graph.h"

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

/// A direction whose information is below this fraction of the best-constrained one's is
/// unobservable (a bare floor cannot fix yaw and horizontal shifts): it is held at the start
/// pose whatever icp.hold_weak_directions says. Levenberg-Marquardt would step along it freely
/// (measured on a floor-only rig: 14 deg and 5.9 m in one step).
constexpr double kUnobservableStrength = 1e-6;

/// The cameras of search direction m over `pairs`: pair m / 2, a -> b when m is even and
/// b -> a when it is odd (the order of every matches vector here).
struct Direction {
  int source;
  int target;
};
Direction PairDirection(const std::vector<CandidatePair>& pairs, size_t m) {
  const CandidatePair& pair = pairs[m / 2];
  return m % 2 == 0 ? Direction{pair.a, pair.b} : Direction{pair.b, pair.a};
}

/// Per camera, the constraint rows of the correspondences it is the source of (world
/// points and the target normals they are matched against, weighted by the inverse
/// variance of their residual), for the stability analysis. The cameras in parallel.
std::vector<StabilityAccumulator> Stability(const std::vector<CameraView>& views,
                                            const std::vector<CandidatePair>& pairs,
                                            const std::vector<std::vector<Correspondence>>& matches,
                                            const IcpOptions& options, int num_threads) {
  std::vector<StabilityAccumulator> stability(views.size());
  ParallelFor(
      static_cast<int>(views.size()), num_threads,
      [&](int source) {
        for (size_t k = 0; k < matches.size(); ++k) {
          const Direction d = PairDirection(pairs, k);
          if (d.source != source) continue;
          const CameraView& s = views[source];
          const CameraView& t = views[d.target];
          for (const Correspondence& c : matches[k]) {
            stability[source].Add(s.T_world_camera * s.level->points[c.source],
                                  t.T_world_camera.linear() * t.level->geometry.normals[c.target],
                                  1.0 / PointToPlaneVariance(s, t, c, options));
          }
        }
      },
      /*min_per_thread=*/1);
  return stability;
}

/// The cameras whose poses are free: connected, and not the reference.
std::vector<bool> FreeCameras(const std::vector<bool>& connected, int reference) {
  std::vector<bool> free = connected;
  if (reference >= 0 && reference < static_cast<int>(free.size())) free[reference] = false;
  return free;
}

/// Adds the gravity prior of every free camera to `problem` (its blocks already added).
/// Returns their residual blocks (none when options.gravity_weight is 0).
std::vector<ceres::ResidualBlockId> AddGravityPriors(ceres::Problem* problem,
                                                     const std::vector<RegistrationCamera>& cameras,
                                                     const std::vector<bool>& free,
                                                     const IcpOptions& options,
                                                     std::vector<PoseBlock>& blocks) {
  std::vector<ceres::ResidualBlockId> ids;
  if (options.gravity_weight <= 0.0) return ids;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (!free[i]) continue;
    ids.push_back(problem->AddResidualBlock(
        GravityPriorCost::Create(cameras[i].T_world_camera.linear(), options.gravity_weight),
        nullptr, blocks[i].data()));
  }
  return ids;
}

/// The pose blocks of the free cameras, in camera order.
std::vector<double*> FreeBlocks(std::vector<PoseBlock>& blocks, const std::vector<bool>& free) {
  std::vector<double*> out;
  for (size_t i = 0; i < blocks.size(); ++i) {
    if (free[i]) out.push_back(blocks[i].data());
  }
  return out;
}

/// SharedNoiseCovariance of the free cameras (in camera order, 6 each) over `terms`, with
/// the free cameras' gravity priors as the independent prior information.
Eigen::MatrixXd FreePoseCovariance(const std::vector<RegistrationCamera>& cameras,
                                   std::vector<PoseBlock>& blocks,
                                   const std::vector<CameraView>& views,
                                   const std::vector<bool>& free,
                                   const std::vector<MatchedViews>& terms,
                                   const IcpOptions& options, int num_threads) {
  std::vector<int> column(cameras.size(), -1);
  int count = 0;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (free[i]) column[i] = 6 * count++;
  }
  const std::unique_ptr<ceres::Problem> problem = NewProblem();
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (free[i])
      problem->AddParameterBlock(blocks[i].data(), kPoseAmbientSize, SharedPoseManifold());
  }
  const std::vector<ceres::ResidualBlockId> priors =
      AddGravityPriors(problem.get(), cameras, free, options, blocks);
  const Eigen::MatrixXd prior = priors.empty()
                                    ? Eigen::MatrixXd::Zero(6 * count, 6 * count)
                                    : Information(problem.get(), FreeBlocks(blocks, free), priors,
                                                  /*scale_by_residuals=*/false);
  return SharedNoiseCovariance(views, column, terms, options, prior, num_threads);
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
  // The directions below `threshold` of the connected cameras at the views' poses.
  const auto weak_directions = [&](double threshold) {
    const std::vector<StabilityAccumulator> stability =
        Stability(views, pairs, matches, options, num_threads);
    std::vector<std::vector<WeakDirection>> weak(n);
    for (size_t i = 0; i < n; ++i) {
      if (result.connected[i]) {
        weak[i] = stability[i].WeakDirections(views[i].T_world_camera.translation(), threshold);
      }
    }
    return weak;
  };
  // Held in the solve: the unobservable directions, and with hold_weak_directions the weak
  // ones (which are then also the reported ones).
  const double hold_threshold = options.hold_weak_directions
                                    ? std::max(options.degeneracy_threshold, kUnobservableStrength)
                                    : kUnobservableStrength;
  // Whether pair k has enough correspondences to link its cameras in this iteration.
  const auto linked = [&](size_t k) {
    return static_cast<size_t>(result.pair_correspondences[k]) >= kMinPairCorrespondences;
  };
  // The correspondences of every linked pair, both directions.
  const auto linked_terms = [&] {
    std::vector<MatchedViews> terms;
    for (size_t k = 0; k < pairs.size(); ++k) {
      if (!linked(k)) continue;
      for (size_t m = 2 * k; m < 2 * k + 2; ++m) {
        const Direction d = PairDirection(pairs, m);
        terms.push_back({&views[d.source], &views[d.target], &matches[m]});
      }
    }
    return terms;
  };
  // Their terms into `target`, compressed (CompressedCost), one block per direction, built
  // in parallel.
  const auto add_pair_terms = [&](ceres::Problem* target) {
    const std::vector<MatchedViews> terms = linked_terms();
    std::vector<std::unique_ptr<ceres::CostFunction>> costs(terms.size());
    ParallelFor(
        static_cast<int>(terms.size()), num_threads,
        [&](int b) {
          costs[b] = CorrespondenceCost(options, *terms[b].source, *terms[b].target,
                                        *terms[b].matches, loss.get(), TermStorage::kCompressed);
        },
        /*min_per_thread=*/1);
    for (size_t b = 0; b < costs.size(); ++b) {
      if (costs[b] == nullptr) continue;
      target->AddResidualBlock(costs[b].release(), nullptr, terms[b].source->pose_block,
                               terms[b].target->pose_block);
    }
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
      // Every pair in both directions, one search per task: fewer thread starts than
      // splitting each search.
      ParallelFor(
          static_cast<int>(matches.size()), num_threads,
          [&](int m) {
            const Direction d = PairDirection(pairs, m);
            matches[m] = FindCorrespondences(views[d.source], views[d.target], max_distance,
                                             options.max_normal_angle_deg, 1);
          },
          /*min_per_thread=*/1);
      for (size_t k = 0; k < pairs.size(); ++k) {
        result.pair_correspondences[k] =
            static_cast<int>(matches[2 * k].size() + matches[2 * k + 1].size());
      }
      result.correspondences_s += SecondsSince(start);
      start = std::chrono::steady_clock::now();
      problem = NewProblem();
      for (PoseBlock& b : blocks) {
        problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
      }
      start_blocks = initial_blocks;
      for (PoseBlock& b : start_blocks) {
        problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
        problem->SetParameterBlockConstant(b.data());
      }
      add_pair_terms(problem.get());
      size_t total = 0;
      std::vector<std::pair<int, int>> links;
      for (size_t k = 0; k < pairs.size(); ++k) {
        if (!linked(k)) continue;
        links.emplace_back(pairs[k].a, pairs[k].b);
        total += result.pair_correspondences[k];
      }
      result.connected = ConnectedTo(reference, n, links);
      const std::vector<std::vector<WeakDirection>> held = weak_directions(hold_threshold);
      if (options.hold_weak_directions) result.weak = held;
      for (size_t i = 0; i < n; ++i) {
        if (!result.connected[i]) {
          problem->SetParameterBlockConstant(blocks[i].data());
          continue;
        }
        if (static_cast<int>(i) != reference && !held[i].empty()) {
          // Hold what the data barely constrain at the start pose (not counted in the
          // covariance, which reports what the data alone determine).
          problem->AddResidualBlock(
              RelativePoseCost::Create(Pose::Identity(), EdgeInformationFromTangentInformation(
                                                             HoldInformation(held[i], kHoldSigmaM),
                                                             cameras[i].T_world_camera)),
              nullptr, start_blocks[i].data(), blocks[i].data());
        }
      }
      AddGravityPriors(problem.get(), cameras, FreeCameras(result.connected, reference), options,
                       blocks);
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
        << " correspondences, cost " << summary.final_cost << ", step " << max_rotation * kRadToDeg
        << " deg " << max_translation * 1e3 << " mm";
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
    if (!options.hold_weak_directions) result.weak = weak_directions(options.degeneracy_threshold);
    // The covariance of the last iteration's terms and priors (not the holding ones: it
    // reports what the data alone determine) at the final poses, each point's depth noise
    // shared by every term it is in (SharedNoiseCovariance), the gravity priors independent.
    const std::vector<bool> free = FreeCameras(result.connected, reference);
    for (size_t i = 0; i < n; ++i) {
      if (free[i]) views[i].T_world_camera = PoseFromParameters(blocks[i].data());
    }
    const Eigen::MatrixXd covariance =
        FreePoseCovariance(cameras, blocks, views, free, linked_terms(), options, num_threads);
    result.covariance_ok = covariance.size() > 0;
    int k = 0;  // the free cameras, in camera order
    for (size_t i = 0; i < n && result.covariance_ok; ++i) {
      if (!free[i]) continue;
      result.covariance[i] = covariance.block<6, 6>(6 * k, 6 * k);
      ++k;
    }
    result.covariance_s = SecondsSince(start);
  }
  return result;
}

namespace {

/// The cameras at their poses at the finest scale, and the correspondences of every pair
/// in both directions there. The views point into `blocks`, the terms into `views` and
/// `matches`: moving the whole struct keeps them valid, changing its vectors does not.
struct FinestTerms {
  std::vector<PoseBlock> blocks;
  std::vector<CameraView> views;
  std::vector<std::vector<Correspondence>> matches;  ///< pair k: 2k a -> b, 2k + 1 b -> a
  std::vector<MatchedViews> terms;
  std::vector<bool> free;  ///< every camera but the reference (the gauge)
};

/// Empty with fewer than two cameras or no pyramid levels.
std::optional<FinestTerms> FindFinestTerms(const std::vector<RegistrationCamera>& cameras,
                                           const std::vector<CandidatePair>& pairs, int reference,
                                           const IcpOptions& options, int num_threads) {
  if (cameras.size() < 2 || cameras[0].pyramid == nullptr || cameras[0].pyramid->levels.empty()) {
    return std::nullopt;
  }
  const size_t n = cameras.size();
  const size_t finest = cameras[0].pyramid->levels.size() - 1;
  const double max_distance =
      options.max_correspondence_distance_factor * cameras[0].pyramid->levels[finest].voxel_size;
  FinestTerms f;
  f.free = FreeCameras(std::vector<bool>(n, true), reference);
  f.blocks.resize(n);
  f.views.resize(n);
  for (size_t i = 0; i < n; ++i) {
    PoseToParameters(cameras[i].T_world_camera, f.blocks[i].data());
    f.views[i] = {&cameras[i].pyramid->levels[finest], cameras[i].T_world_camera,
                  f.blocks[i].data(), cameras[i].depth_noise};
  }
  f.matches.resize(2 * pairs.size());
  for (size_t m = 0; m < f.matches.size(); ++m) {
    const Direction d = PairDirection(pairs, m);
    const CameraView& source = f.views[d.source];
    const CameraView& target = f.views[d.target];
    f.matches[m] = FindCorrespondences(source, target, max_distance, options.max_normal_angle_deg,
                                       num_threads);
    f.terms.push_back({&source, &target, &f.matches[m]});
  }
  return f;
}

}  // namespace

Eigen::MatrixXd JointInformation(const std::vector<RegistrationCamera>& cameras,
                                 const std::vector<CandidatePair>& pairs, int reference,
                                 const IcpOptions& options, int num_threads) {
  std::optional<FinestTerms> finest =
      FindFinestTerms(cameras, pairs, reference, options, num_threads);
  if (!finest) return {};
  FinestTerms& f = *finest;
  const std::unique_ptr<ceres::Problem> problem = NewProblem();
  for (PoseBlock& b : f.blocks) {
    problem->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
  }
  std::vector<ceres::ResidualBlockId> residual_blocks;
  for (const MatchedViews& t : f.terms) {
    const ceres::ResidualBlockId id =
        AddCorrespondenceTerms(problem.get(), options, *t.source, *t.target, *t.matches, nullptr,
                               TermStorage::kCompressed);
    if (id != nullptr) residual_blocks.push_back(id);
  }
  for (ceres::ResidualBlockId id :
       AddGravityPriors(problem.get(), cameras, f.free, options, f.blocks)) {
    residual_blocks.push_back(id);
  }
  if (residual_blocks.empty()) return {};
  return Information(problem.get(), FreeBlocks(f.blocks, f.free), residual_blocks,
                     /*scale_by_residuals=*/false);
}

Eigen::MatrixXd JointSharedNoiseCovariance(const std::vector<RegistrationCamera>& cameras,
                                           const std::vector<CandidatePair>& pairs, int reference,
                                           const IcpOptions& options, int num_threads) {
  std::optional<FinestTerms> f = FindFinestTerms(cameras, pairs, reference, options, num_threads);
  if (!f) return {};
  return FreePoseCovariance(cameras, f->blocks, f->views, f->free, f->terms, options, num_threads);
}

}  // namespace rigfit
