// Time of one evaluation (residuals + the Jacobians of every parameter block) of each
// residual, analytic cost function against its autodiff functor. Results:
// docs/benchmarks.md, "Residuals".
#include <benchmark/benchmark.h>
#include <ceres/cost_function.h>

#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "residuals/gicp.h"
#include "residuals/gravity_prior.h"
#include "residuals/plane_cluster.h"
#include "residuals/point_to_plane.h"
#include "residuals/relative_pose.h"

namespace rigfit {
namespace {

enum class Residual { kPointToPlane, kGicp, kGravityPrior, kRelativePose, kPlaneCluster };
enum class Derivatives { kAnalytic, kAutoDiff };

Pose RandomPose(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng))
                   .normalized()
                   .toRotationMatrix();
  T.translation() = 3.0 * Vec3(normal(rng), normal(rng), normal(rng));
  return T;
}

Vec3 RandomVector(std::mt19937& rng) {
  std::normal_distribution<double> normal;
  return Vec3(normal(rng), normal(rng), normal(rng));
}

/// One cost function of the requested kind at two random poses, with typical inputs.
std::unique_ptr<ceres::CostFunction> MakeCost(Residual residual, Derivatives derivatives,
                                              const Pose& T_a, const Pose& T_b) {
  std::mt19937 rng(42);
  const bool analytic = derivatives == Derivatives::kAnalytic;
  const Vec3 X = T_a.translation() + RandomVector(rng);
  const Vec3 p = T_a.inverse() * X, q = T_b.inverse() * (X + 0.01 * RandomVector(rng));
  switch (residual) {
    case Residual::kPointToPlane: {
      const Vec3 n = RandomVector(rng).normalized();
      return std::unique_ptr<ceres::CostFunction>(
          analytic ? PointToPlaneCost::Create(p, q, n)
                   : PointToPlaneFunctor::CreateAutoDiff(p, q, n));
    }
    case Residual::kGicp: {
      const Mat3 cov = Vec3(25e-4, 9e-4, 4e-6).asDiagonal();
      const Mat3 W = GicpCost::SqrtInformation(cov, cov, T_a.linear(), T_b.linear());
      return std::unique_ptr<ceres::CostFunction>(
          analytic ? GicpCost::Create(p, q, cov, cov, T_a.linear(), T_b.linear())
                   : GicpFunctor::CreateAutoDiff(p, q, W));
    }
    case Residual::kGravityPrior: {
      const Mat3 R0 = ExpSO3(0.02 * RandomVector(rng)) * T_a.linear();
      return std::unique_ptr<ceres::CostFunction>(
          analytic ? GravityPriorCost::Create(R0, 50.0)
                   : GravityPriorFunctor::CreateAutoDiff(R0, 50.0));
    }
    case Residual::kRelativePose: {
      Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Identity();
      A.topRightCorner<3, 3>() = 0.1 * Mat3::Ones();
      const Mat6 information = A * A.transpose();
      const Pose T_ab = PosePlus(T_a.inverse() * T_b, 0.01 * Vec6::Ones());
      return std::unique_ptr<ceres::CostFunction>(
          analytic ? RelativePoseCost::Create(T_ab, information)
                   : RelativePoseFunctor::CreateAutoDiff(
                         T_ab, RelativePoseCost::SqrtInformation(information)));
    }
    case Residual::kPlaneCluster: {
      // 200 pixels of one camera on one plane; the second block is read as the plane [n; d]
      // (its cost does not depend on the values).
      PlaneCluster cluster;
      for (int i = 0; i < 200; ++i) {
        const Vec3 point = Vec3(0.3, -0.2, 3.0) + 0.5 * RandomVector(rng);
        cluster.AddRay(point, 1.0 / point.z(), 0.0025);
      }
      return std::unique_ptr<ceres::CostFunction>(
          analytic ? PlaneClusterCost::Create(cluster, true)
                   : PlaneClusterFunctor::CreateAutoDiff(cluster.SquareRoot(), true));
    }
  }
  return nullptr;
}

void BM_Evaluate(benchmark::State& state, Residual residual, Derivatives derivatives) {
  std::mt19937 rng(7);
  const Pose T_a = RandomPose(rng), T_b = RandomPose(rng);
  const auto cost = MakeCost(residual, derivatives, T_a, T_b);
  double x_a[kPoseAmbientSize], x_b[kPoseAmbientSize];
  PoseToParameters(T_a, x_a);
  PoseToParameters(T_b, x_b);
  const double* parameters[] = {x_a, x_b};
  const int num_blocks = static_cast<int>(cost->parameter_block_sizes().size());
  std::vector<double> residuals(cost->num_residuals());
  std::vector<std::vector<double>> jacobian_storage;
  std::vector<double*> jacobians;
  for (int i = 0; i < num_blocks; ++i) {
    jacobian_storage.emplace_back(cost->num_residuals() * kPoseAmbientSize);
    jacobians.push_back(jacobian_storage.back().data());
  }
  for (auto _ : state) {
    benchmark::DoNotOptimize(cost->Evaluate(parameters, residuals.data(), jacobians.data()));
    benchmark::ClobberMemory();
  }
  state.SetLabel(std::to_string(cost->num_residuals()) + " residuals x " +
                 std::to_string(num_blocks) + " pose blocks");
}

/// Registers BM_Evaluate/<residual>/<analytic|autodiff> for every residual.
const bool kRegistered = [] {
  const std::pair<const char*, Residual> residuals[] = {{"point_to_plane", Residual::kPointToPlane},
                                                        {"gicp", Residual::kGicp},
                                                        {"gravity_prior", Residual::kGravityPrior},
                                                        {"relative_pose", Residual::kRelativePose},
                                                        {"plane_cluster", Residual::kPlaneCluster}};
  for (const auto& [residual_name, residual] : residuals) {
    for (const auto& [derivatives_name, derivatives] :
         {std::pair{"analytic", Derivatives::kAnalytic},
          std::pair{"autodiff", Derivatives::kAutoDiff}}) {
      const std::string name = std::string("BM_Evaluate/") + residual_name + "/" + derivatives_name;
      benchmark::RegisterBenchmark(name.c_str(), BM_Evaluate, residual, derivatives);
    }
  }
  return true;
}();

}  // namespace
}  // namespace rigfit

BENCHMARK_MAIN();
