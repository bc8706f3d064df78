#include "registration/pose_graph.h"

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <array>
#include <cmath>
#include <memory>

#include "prepare/correspondences.h"
#include "residuals/relative_pose.h"

namespace rigfit {
namespace {

/// Cauchy scale on the whitened 6-vector: sqrt of the 99% quantile of chi-square(6).
const double kEdgeLossScale = std::sqrt(16.81);
constexpr int kMaxIterations = 100;

}  // namespace

std::vector<bool> ConnectedTo(int reference, size_t n,
                              const std::vector<std::pair<int, int>>& links) {
  std::vector<bool> reached(n, false);
  if (reference < 0 || static_cast<size_t>(reference) >= n) return reached;
  reached[reference] = true;
  for (bool grew = true; grew;) {
    grew = false;
    for (const auto& [a, b] : links) {
      if (reached[a] != reached[b]) {
        reached[a] = reached[b] = true;
        grew = true;
      }
    }
  }
  return reached;
}

PoseGraphResult OptimizePoseGraph(const std::vector<Pose>& initial,
                                  const std::vector<PoseGraphEdge>& edges, int reference) {
  PoseGraphResult result;
  result.poses = initial;
  std::vector<std::pair<int, int>> links;
  for (const PoseGraphEdge& e : edges) links.emplace_back(e.a, e.b);
  result.connected = ConnectedTo(reference, initial.size(), links);
  std::vector<std::array<double, kPoseAmbientSize>> blocks(initial.size());
  for (size_t i = 0; i < initial.size(); ++i) PoseToParameters(initial[i], blocks[i].data());

  std::unique_ptr<ceres::Problem> problem = NewProblem();
  ceres::CauchyLoss loss(kEdgeLossScale);
  for (const PoseGraphEdge& e : edges) {
    if (!result.connected[e.a]) continue;  // both ends share connectivity
    for (int i : {e.a, e.b}) {
      problem->AddParameterBlock(blocks[i].data(), kPoseAmbientSize, SharedPoseManifold());
    }
    problem->AddResidualBlock(RelativePoseCost::Create(e.T_a_b, e.information),
                              e.robust ? &loss : nullptr, blocks[e.a].data(), blocks[e.b].data());
  }
  if (problem->NumResidualBlocks() == 0) {
    result.message = "no edges reach the reference camera";
    return result;
  }
  problem->SetParameterBlockConstant(blocks[reference].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = kMaxIterations;
  // One thread: a few edges of 6 residuals; Ceres' per-thread partial sums would make the
  // last bits of the result depend on the thread count.
  options.num_threads = 1;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, problem.get(), &summary);
  result.usable = summary.IsSolutionUsable();
  result.message = summary.message;
  result.cost = 2.0 * summary.final_cost;
  if (!result.usable) return result;
  for (size_t i = 0; i < initial.size(); ++i) {
    if (result.connected[i]) result.poses[i] = PoseFromParameters(blocks[i].data());
  }
  return result;
}

}  // namespace rigfit
