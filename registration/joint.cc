#include "registration/joint.h"

#include <ceres/loss_function.h>
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
#include "prepare/correspondences.h"
#include "registration/pose_graph.h"
#include "residuals/gravity_prior.h"
#include "residuals/relative_pose.h"
#include "uncertainty/covariance.h"
#include "uncertainty/degeneracy.h"

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

/// What FreePoseCovariance takes the covariance over: the cameras' pose blocks and their views,
/// which cameras are free, and the terms between the views.
struct FreeTerms {
  std::vector<PoseBlock>& blocks;          ///< every camera's pose block
  const std::vector<CameraView>& views;    ///< every camera's view, at its block
  const std::vector<bool>& free;           ///< whether the camera's pose is free
  const std::vector<MatchedViews>& terms;  ///< the correspondences between the views
};

/// SharedNoiseCovariance of the free cameras (in camera order, 6 each) over `in.terms`, with
/// the free cameras' gravity priors as the independent prior information.
Eigen::MatrixXd FreePoseCovariance(const std::vector<RegistrationCamera>& cameras,
                                   const FreeTerms& in, const IcpOptions& options, int num_threads,
                                   ClusterSandwiches* sandwiches = nullptr,
                                   Eigen::MatrixXd* surface_bias = nullptr) {
  std::vector<PoseBlock>& blocks = in.blocks;
  const std::vector<bool>& free = in.free;
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
  return SharedNoiseCovariance({in.views, column, in.terms}, options, prior, num_threads,
                               sandwiches, surface_bias);
}

/// RegisterJoint's problem through its outer iterations: the cameras' pose blocks, the views
/// and correspondences of the current iteration, the Ceres problem built from them, and the
/// result so far.
class JointProblem {
 public:
  JointProblem(const std::vector<RegistrationCamera>& cameras,
               const std::vector<CandidatePair>& pairs, int reference, const IcpOptions& options,
               int num_threads, const Log& log)
      : cameras_(cameras),
        pairs_(pairs),
        reference_(reference),
        options_(options),
        num_threads_(num_threads),
        log_(log),
        n_(cameras.size()),
        // Held in the solve: the unobservable directions, and with hold_weak_directions the
        // weak ones (which are then also the reported ones).
        hold_threshold_(options.hold_weak_directions
                            ? std::max(options.degeneracy_threshold, kUnobservableStrength)
                            : kUnobservableStrength),
        blocks_(n_),
        views_(n_) {
    result_.poses.resize(n_);
    for (size_t i = 0; i < n_; ++i) result_.poses[i] = cameras_[i].T_world_camera;
    result_.connected.assign(n_, false);
    result_.pair_correspondences.assign(pairs_.size(), 0);
    result_.covariance.assign(n_, Mat6::Zero());
    result_.surface_bias.assign(n_, Mat6::Zero());
    result_.sigma_inflation.assign(n_, SigmaInflation{});
    result_.surfaces.assign(n_, 0);
    result_.weak.assign(n_, {});
  }

  /// Coarse to fine, outer iterations at each scale until the poses stop moving; then the
  /// poses, the weak directions and the covariance at the end.
  JointResult Run() {
    if (n_ == 0 || cameras_[0].pyramid == nullptr) return result_;
    for (size_t i = 0; i < n_; ++i) {
      PoseToParameters(cameras_[i].T_world_camera, blocks_[i].data());
    }
    initial_blocks_ = blocks_;  // copied into each problem, constant
    loss_.reset(MakeCorrespondenceLoss(options_));
    solver_options_.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options_.max_num_iterations = kSolverIterationsPerStep;
    solver_options_.num_threads = num_threads_;
    solver_options_.logging_type = ceres::SILENT;
    const size_t levels = cameras_[0].pyramid->levels.size();
    for (size_t s = 0; s < levels; ++s) {
      const int max_iterations =
          s < options_.max_iterations.size() ? options_.max_iterations[s] : 0;
      for (int it = 0; it < max_iterations; ++it) {
        const bool converged = Iterate(s, it, s + 1 == levels);
        if (!result_.usable) return result_;
        if (converged) break;
      }
    }
    Finish();
    return result_;
  }

 private:
  /// One outer iteration at scale s: correspondences re-found at the current poses, the
  /// problem built and solved for a few iterations. Whether the step converged; false with
  /// result_.usable false when Ceres' solution is not usable.
  bool Iterate(size_t s, int it, bool finest) {
    const double voxel_size = cameras_[0].pyramid->levels[s].voxel_size;
    std::vector<Pose> current(n_);
    for (size_t i = 0; i < n_; ++i) {
      current[i] = PoseFromParameters(blocks_[i].data());
      views_[i] = {&cameras_[i].pyramid->levels[s], current[i], blocks_[i].data(),
                   cameras_[i].depth_noise, cameras_[i].surface_bias};
    }
    auto start = std::chrono::steady_clock::now();
    // The gate's overlaps (a finest-level search of every pair): at the start, and again at
    // the finest scale, where the poses are nearly final.
    if (it == 0 && (s == 0 || finest)) MeasureFitness(current);
    FindMatches(options_.max_correspondence_distance_factor * voxel_size);
    result_.correspondences_s += SecondsSince(start);
    start = std::chrono::steady_clock::now();
    const size_t total = BuildProblem();
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options_, problem_.get(), &summary);
    result_.solve_s += SecondsSince(start);
    ++result_.iterations;
    result_.usable = summary.IsSolutionUsable();
    if (!result_.usable) {
      result_.message = "joint solve: " + summary.message;
      return false;
    }
    double max_rotation = 0.0, max_translation = 0.0;
    bool converged = true;
    for (size_t i = 0; i < n_; ++i) {
      const Vec6 step = PoseDifference(current[i], PoseFromParameters(blocks_[i].data()));
      max_rotation = std::max(max_rotation, step.head<3>().norm());
      max_translation = std::max(max_translation, step.tail<3>().norm());
      converged = converged && StepConverged(step, voxel_size, finest);
    }
    std::ostringstream m;
    m << "joint: voxel " << voxel_size << " iteration " << it << ": " << total
      << " correspondences, cost " << summary.final_cost << ", step " << max_rotation * kRadToDeg
      << " deg " << max_translation * 1e3 << " mm";
    log_.Debug(m.str());
    return converged;
  }

  /// The correspondences of every pair in both directions at the views, one search per task:
  /// fewer thread starts than splitting each search.
  void FindMatches(double max_distance) {
    matches_.assign(2 * pairs_.size(), {});
    ParallelFor(
        static_cast<int>(matches_.size()), num_threads_,
        [&](int m) {
          const Direction d = PairDirection(pairs_, m);
          matches_[m] = FindCorrespondences(views_[d.source], views_[d.target], max_distance,
                                            options_.max_normal_angle_deg, 1);
        },
        /*min_per_thread=*/1);
    for (size_t k = 0; k < pairs_.size(); ++k) {
      // A pair below min_fitness does not link its cameras (as in pairwise ICP).
      result_.pair_correspondences[k] =
          fitness_[k] < options_.min_fitness
              ? 0
              : static_cast<int>(matches_[2 * k].size() + matches_[2 * k + 1].size());
    }
  }

  /// Each pair's overlap as pairwise ICP measures it (MeasureOverlap of b into a at the finest
  /// scale, within the coarsest scale's correspondence distance) at the poses `current`, into
  /// fitness_.
  void MeasureFitness(const std::vector<Pose>& current) {
    const std::vector<ScaleLevel>& levels = cameras_[0].pyramid->levels;
    const size_t finest = levels.size() - 1;
    fitness_.assign(pairs_.size(), 0.0);
    ParallelFor(
        static_cast<int>(pairs_.size()), num_threads_,
        [&](int k) {
          const int a = pairs_[k].a;
          const int b = pairs_[k].b;
          const CameraView source{&cameras_[b].pyramid->levels[finest], current[b],
                                  blocks_[b].data(), cameras_[b].depth_noise};
          const CameraView target{&cameras_[a].pyramid->levels[finest], current[a],
                                  blocks_[a].data(), cameras_[a].depth_noise};
          fitness_[k] =
              MeasureOverlap(source, target, levels.front().voxel_size, options_, 1).fitness;
        },
        /*min_per_thread=*/1);
  }

  /// A new problem over the pose blocks: the linked pairs' terms, the cameras they connect to
  /// the reference, the holding priors and the gravity priors, the reference and unconnected
  /// cameras constant. Returns the number of correspondences of the linked pairs.
  size_t BuildProblem() {
    problem_ = NewProblem();
    for (PoseBlock& b : blocks_) {
      problem_->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
    }
    start_blocks_ = initial_blocks_;
    for (PoseBlock& b : start_blocks_) {
      problem_->AddParameterBlock(b.data(), kPoseAmbientSize, SharedPoseManifold());
      problem_->SetParameterBlockConstant(b.data());
    }
    AddPairTerms();
    size_t total = 0;
    std::vector<std::pair<int, int>> links;
    for (size_t k = 0; k < pairs_.size(); ++k) {
      if (!Linked(k)) continue;
      links.emplace_back(pairs_[k].a, pairs_[k].b);
      total += result_.pair_correspondences[k];
    }
    result_.connected = ConnectedTo(reference_, n_, links);
    stability_ = Stability(views_, pairs_, matches_, options_, num_threads_);
    const std::vector<std::vector<WeakDirection>> held = WeakDirections(hold_threshold_);
    if (options_.hold_weak_directions) result_.weak = held;
    for (size_t i = 0; i < n_; ++i) {
      if (!result_.connected[i]) {
        problem_->SetParameterBlockConstant(blocks_[i].data());
        continue;
      }
      if (static_cast<int>(i) != reference_ && !held[i].empty()) {
        // Hold what the data barely constrain at the start pose (not counted in the
        // covariance, which reports what the data alone determine).
        problem_->AddResidualBlock(
            RelativePoseCost::Create(Pose::Identity(), EdgeInformationFromTangentInformation(
                                                           HoldInformation(held[i], kHoldSigmaM),
                                                           cameras_[i].T_world_camera)),
            nullptr, start_blocks_[i].data(), blocks_[i].data());
      }
    }
    AddGravityPriors(problem_.get(), cameras_, FreeCameras(result_.connected, reference_), options_,
                     blocks_);
    problem_->SetParameterBlockConstant(blocks_[reference_].data());
    return total;
  }

  /// The linked pairs' terms, compressed (CompressedCost), one block per direction, built in
  /// parallel.
  void AddPairTerms() {
    const std::vector<MatchedViews> terms = LinkedTerms();
    std::vector<std::unique_ptr<ceres::CostFunction>> costs(terms.size());
    ParallelFor(
        static_cast<int>(terms.size()), num_threads_,
        [&](int b) {
          costs[b] = CorrespondenceCost(options_, terms[b], loss_.get(), TermStorage::kCompressed);
        },
        /*min_per_thread=*/1);
    const std::vector<double> scales = ResidualScales(terms);
    scaled_losses_.clear();
    for (size_t b = 0; b < costs.size(); ++b) {
      if (costs[b] == nullptr) continue;
      ceres::LossFunction* scaled = nullptr;
      if (scales[b] != 1.0) {
        scaled_losses_.push_back(
            std::make_unique<ceres::ScaledLoss>(nullptr, scales[b], ceres::DO_NOT_TAKE_OWNERSHIP));
        scaled = scaled_losses_.back().get();
      }
      problem_->AddResidualBlock(costs[b].release(), scaled, terms[b].source->pose_block,
                                 terms[b].target->pose_block);
    }
  }

  /// Per term of LinkedTerms() (both directions of a pair alike), the factor on its cost: 1,
  /// except for point-to-plane pairs between two cameras without a depth noise model, whose
  /// metric sigma (min_noise_m) is a guess: 1 / s^2 with s^2 the pair's mean squared whitened
  /// residual at the views' poses, sum r^2 / (m - 6), as pairwise ICP scales the information
  /// of its pose-graph edge (docs/residuals.md, "Weights").
  std::vector<double> ResidualScales(const std::vector<MatchedViews>& terms) const {
    std::vector<double> scales(terms.size(), 1.0);
    if (options_.method != RegistrationMethod::kPointToPlane) return scales;
    for (size_t b = 0; b + 1 < terms.size(); b += 2) {
      if (terms[b].source->depth_noise > 0.0 || terms[b].target->depth_noise > 0.0) continue;
      double sum = 0.0;
      size_t m = 0;
      for (size_t t : {b, b + 1}) {
        const CameraView& source = *terms[t].source;
        const CameraView& target = *terms[t].target;
        for (const Correspondence& c : *terms[t].matches) {
          double r = 0.0;  // the whitened residual of the pair's term
          MakePointToPlaneTerm(source, target, c, options_)
              .Evaluate(source.pose_block, target.pose_block, &r, nullptr, nullptr);
          sum += r * r;
        }
        m += terms[t].matches->size();
      }
      if (m <= 6 || sum <= 0.0) continue;
      scales[b] = scales[b + 1] = (m - 6.0) / sum;
    }
    return scales;
  }

  /// The end: the connected cameras' poses, and after a solve the weak directions and the
  /// covariance.
  void Finish() {
    for (size_t i = 0; i < n_; ++i) {
      if (result_.connected[i]) result_.poses[i] = PoseFromParameters(blocks_[i].data());
    }
    if (problem_ == nullptr) return;
    const auto start = std::chrono::steady_clock::now();
    // Without holding, only the end matters: the analysis runs once, at the last
    // iteration's correspondences and poses (stability_, of the last problem).
    if (!options_.hold_weak_directions) {
      result_.weak = WeakDirections(options_.degeneracy_threshold);
    }
    // The covariance of the last iteration's terms and priors (not the holding ones: it
    // reports what the data alone determine) at the final poses, each point's depth noise
    // shared by every term it is in (SharedNoiseCovariance), the gravity priors independent.
    const std::vector<bool> free = FreeCameras(result_.connected, reference_);
    for (size_t i = 0; i < n_; ++i) {
      if (free[i]) views_[i].T_world_camera = PoseFromParameters(blocks_[i].data());
    }
    // Each camera's 1-sigma is raised by the design effect its terms' residuals show, and
    // widened by its surfaces' offsets (stereo cameras).
    ClusterSandwiches sandwiches;
    Eigen::MatrixXd bias;
    const Eigen::MatrixXd covariance =
        FreePoseCovariance(cameras_, {blocks_, views_, free, LinkedTerms()}, options_, num_threads_,
                           &sandwiches, &bias);
    result_.covariance_ok = covariance.size() > 0;
    int k = 0;  // the free cameras, in camera order
    for (size_t i = 0; i < n_ && result_.covariance_ok; ++i) {
      if (!free[i]) continue;
      result_.sigma_inflation[i] = InflationOf(sandwiches, 6 * k);
      result_.covariance[i] =
          Inflated(covariance.block<6, 6>(6 * k, 6 * k), result_.sigma_inflation[i]);
      result_.surface_bias[i] = bias.block<6, 6>(6 * k, 6 * k);
      ++k;
    }
    const std::vector<StabilityAccumulator> stability =
        Stability(views_, pairs_, matches_, options_, num_threads_);
    for (size_t i = 0; i < n_; ++i) {
      if (result_.connected[i]) result_.surfaces[i] = stability[i].Orientations();
    }
    result_.covariance_s = SecondsSince(start);
  }

  /// The directions below `threshold` of the connected cameras, from stability_ (the last
  /// problem's views and correspondences).
  std::vector<std::vector<WeakDirection>> WeakDirections(double threshold) const {
    std::vector<std::vector<WeakDirection>> weak(n_);
    for (size_t i = 0; i < n_; ++i) {
      if (result_.connected[i]) {
        weak[i] = stability_[i].WeakDirections(views_[i].T_world_camera.translation(), threshold);
      }
    }
    return weak;
  }

  /// Whether pair k has enough correspondences to link its cameras in this iteration.
  bool Linked(size_t k) const {
    return static_cast<size_t>(result_.pair_correspondences[k]) >= kMinPairCorrespondences;
  }

  /// The correspondences of every linked pair, both directions (pointing into views_ and
  /// matches_).
  std::vector<MatchedViews> LinkedTerms() const {
    std::vector<MatchedViews> terms;
    for (size_t k = 0; k < pairs_.size(); ++k) {
      if (!Linked(k)) continue;
      for (size_t m = 2 * k; m < 2 * k + 2; ++m) {
        const Direction d = PairDirection(pairs_, m);
        terms.push_back({&views_[d.source], &views_[d.target], &matches_[m]});
      }
    }
    return terms;
  }

  const std::vector<RegistrationCamera>& cameras_;
  const std::vector<CandidatePair>& pairs_;
  const int reference_;
  const IcpOptions& options_;
  const int num_threads_;
  const Log& log_;
  const size_t n_;
  const double hold_threshold_;
  std::unique_ptr<ceres::LossFunction> loss_;
  /// ResidualScales' factors on the problem's pair terms (the problem does not own losses).
  std::vector<std::unique_ptr<ceres::LossFunction>> scaled_losses_;
  ceres::Solver::Options solver_options_;
  std::vector<PoseBlock> blocks_;
  std::vector<PoseBlock> initial_blocks_;
  std::vector<PoseBlock> start_blocks_;  ///< the problem's constant copy of initial_blocks_
  std::vector<CameraView> views_;
  std::vector<std::vector<Correspondence>> matches_;  ///< pair k: 2k a -> b, 2k + 1 b -> a
  /// Per camera, the constraints of the last problem's correspondences at its views' poses.
  std::vector<StabilityAccumulator> stability_;
  /// Pair k's overlap at the start of the first and of the finest scale (MeasureFitness).
  std::vector<double> fitness_;
  std::unique_ptr<ceres::Problem> problem_;
  JointResult result_;
};

}  // namespace

JointResult RegisterJoint(const std::vector<RegistrationCamera>& cameras,
                          const std::vector<CandidatePair>& pairs, int reference,
                          const IcpOptions& options, int num_threads, const Log& log) {
  return JointProblem(cameras, pairs, reference, options, num_threads, log).Run();
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
        AddCorrespondenceTerms(problem.get(), options, t, nullptr, TermStorage::kCompressed);
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
  return FreePoseCovariance(cameras, {f->blocks, f->views, f->free, f->terms}, options,
                            num_threads);
}

}  // namespace rigfit
