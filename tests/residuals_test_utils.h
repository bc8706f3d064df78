// Shared checks of the residuals tests: analytic cost functions against their autodiff
// reference and against ceres::GradientChecker with rigfit::PoseManifold on every block,
// at the poses the issue lists (identity, 1e-5 rad, near pi, 100 m, seeded random).
#pragma once

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/numeric_diff_options.h>
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/pose.h"

namespace rigfit::testing {

/// Analytic vs autodiff: |a - b| <= kAutodiffTolerance * max(1, max |b|), per residual
/// vector and per Jacobian matrix (relative to the matrix scale, so that structural zeros
/// that come out as 1e-17 on one side do not count as relative errors of 1).
inline constexpr double kAutodiffTolerance = 1e-9;
/// Analytic vs GradientChecker's Ridders finite differences, tangent space, same rule.
inline constexpr double kGradientTolerance = 1e-7;

using PoseBlock = Eigen::Matrix<double, kPoseAmbientSize, 1>;

inline PoseBlock ToBlock(const Pose& T) {
  PoseBlock x;
  PoseToParameters(T, x.data());
  return x;
}

inline Pose MakePose(const Vec3& rotation_vector, const Vec3& t) {
  Pose T = Pose::Identity();
  T.linear() = ExpSO3(rotation_vector);
  T.translation() = t;
  return T;
}

/// Uniform random rotation (normalised 4-D Gaussian quaternion) and a translation with
/// coordinates uniform in [-max_translation, max_translation].
inline Pose RandomPose(std::mt19937& rng, double max_translation) {
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> uniform(-max_translation, max_translation);
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng))
                   .normalized()
                   .toRotationMatrix();
  T.translation() = Vec3(uniform(rng), uniform(rng), uniform(rng));
  return T;
}

inline Vec3 RandomVector(std::mt19937& rng, double max_abs) {
  std::uniform_real_distribution<double> uniform(-max_abs, max_abs);
  return Vec3(uniform(rng), uniform(rng), uniform(rng));
}

/// How many fixed poses TestPoses puts before the random ones.
inline constexpr int kNumSpecialPoses = 8;

struct NamedPose {
  std::string name;
  Pose T;
};

/// The poses every Jacobian is checked at: identity, rotations of 1e-5 rad, rotations of
/// pi - 1e-3, pi - 1e-6 and pi, translations of 100 m, then `num_random` seeded poses.
inline std::vector<NamedPose> TestPoses(int num_random = 100, unsigned seed = 7) {
  const Vec3 axis = Vec3(1.0, -2.0, 3.0).normalized();
  const Vec3 axis2 = Vec3(-0.5, 0.3, 1.0).normalized();
  std::vector<NamedPose> poses = {
      {"identity", Pose::Identity()},
      {"rotation 1e-5 rad", MakePose(1e-5 * axis, Vec3(0.1, 1.5, -0.2))},
      {"rotation 1e-5 rad about y", MakePose(1e-5 * Vec3::UnitY(), Vec3(0.0, 1.2, 0.0))},
      {"rotation pi - 1e-3", MakePose((M_PI - 1e-3) * axis, Vec3(-0.3, 1.0, 0.4))},
      {"rotation pi - 1e-6", MakePose((M_PI - 1e-6) * axis2, Vec3(0.2, 0.9, 0.1))},
      {"rotation pi", MakePose(M_PI * Vec3::UnitX(), Vec3(0.0, 1.1, 0.0))},
      {"translation 100 m", MakePose(0.7 * axis, Vec3(100.0, 1.5, -100.0))},
      {"translation 100 m, rotation pi - 1e-6",
       MakePose((M_PI - 1e-6) * axis, Vec3(-100.0, 100.0, 100.0))},
  };
  std::mt19937 rng(seed);
  for (int i = 0; i < num_random; ++i) {
    poses.push_back({"random " + std::to_string(i), RandomPose(rng, 10.0)});
  }
  return poses;
}

/// Pairs (T_world_a, T_world_b) for two-block costs: each special pose of TestPoses with
/// its neighbour in the list (so identity meets 1e-5 rad, near pi meets near pi, ...),
/// and the random poses paired with a second random pose near them (within 2 m).
inline std::vector<std::pair<NamedPose, NamedPose>> TestPosePairs(unsigned seed = 11) {
  const std::vector<NamedPose> poses = TestPoses();
  std::vector<std::pair<NamedPose, NamedPose>> pairs;
  pairs.push_back({poses[0], poses[0]});
  std::mt19937 rng(seed);
  for (size_t i = 0; i < poses.size(); ++i) {
    if (i + 1 < kNumSpecialPoses) {
      pairs.push_back({poses[i], poses[i + 1]});
    } else {
      Pose T_b = RandomPose(rng, 2.0);
      T_b.translation() += poses[i].T.translation();
      pairs.push_back({poses[i], {poses[i].name + " / near", T_b}});
    }
  }
  return pairs;
}

/// Largest |entry|, NaN if any entry is NaN (so that unwritten Jacobian entries fail).
inline double MaxAbs(const Eigen::MatrixXd& m) {
  return m.size() ? m.cwiseAbs().maxCoeff<Eigen::PropagateNaN>() : 0.0;
}

/// |actual - expected| <= tolerance * max(1, max |expected|), elementwise.
inline ::testing::AssertionResult ScaledNear(const Eigen::MatrixXd& actual,
                                             const Eigen::MatrixXd& expected, double tolerance) {
  const double bound = tolerance * std::max(1.0, MaxAbs(expected));
  const double error = MaxAbs(actual - expected);
  if (error <= bound) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "max error " << error << " > " << bound << "\nactual\n"
                                       << actual << "\nexpected\n"
                                       << expected;
}

/// Residuals and ambient Jacobians of one evaluation; `with_jacobian[i]` false passes a
/// null pointer for block i, as Ceres does for a constant block, and an empty
/// `with_jacobian` passes jacobians = nullptr (residuals only).
struct Evaluation {
  bool ok = false;
  Eigen::VectorXd residuals;
  std::vector<Eigen::MatrixXd> jacobians;
};

inline Evaluation Evaluate(const ceres::CostFunction& cost,
                           const std::vector<const double*>& parameters,
                           const std::vector<bool>& with_jacobian) {
  using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  const auto& sizes = cost.parameter_block_sizes();
  Evaluation out;
  out.residuals.resize(cost.num_residuals());
  std::vector<RowMajor> storage(sizes.size());
  std::vector<double*> pointers(sizes.size(), nullptr);
  for (size_t i = 0; i < with_jacobian.size(); ++i) {
    if (!with_jacobian[i]) continue;
    storage[i].setConstant(cost.num_residuals(), sizes[i], std::nan(""));
    pointers[i] = storage[i].data();
  }
  out.ok = cost.Evaluate(parameters.data(), out.residuals.data(),
                         with_jacobian.empty() ? nullptr : pointers.data());
  for (const auto& s : storage) out.jacobians.push_back(s);
  return out;
}

/// The analytic cost's residuals and Jacobians equal the autodiff functor's, with
/// jacobians = nullptr and with every block's Jacobian pointer null, all set, or set for
/// one block alone.
inline void ExpectAnalyticMatchesAutodiff(const ceres::CostFunction& analytic,
                                          const ceres::CostFunction& autodiff,
                                          const std::vector<const double*>& parameters) {
  const size_t num_blocks = analytic.parameter_block_sizes().size();
  ASSERT_EQ(analytic.num_residuals(), autodiff.num_residuals());
  ASSERT_EQ(analytic.parameter_block_sizes(), autodiff.parameter_block_sizes());
  const Evaluation reference = Evaluate(autodiff, parameters, std::vector<bool>(num_blocks, true));
  ASSERT_TRUE(reference.ok);

  std::vector<std::vector<bool>> masks = {
      {}, std::vector<bool>(num_blocks, false), std::vector<bool>(num_blocks, true)};
  if (num_blocks > 1) {
    for (size_t i = 0; i < num_blocks; ++i) {
      std::vector<bool> mask(num_blocks, false);
      mask[i] = true;
      masks.push_back(mask);
    }
  }
  for (const auto& mask : masks) {
    const Evaluation actual = Evaluate(analytic, parameters, mask);
    ASSERT_TRUE(actual.ok);
    EXPECT_TRUE(ScaledNear(actual.residuals, reference.residuals, kAutodiffTolerance));
    for (size_t i = 0; i < mask.size(); ++i) {
      if (!mask[i]) continue;
      EXPECT_TRUE(ScaledNear(actual.jacobians[i], reference.jacobians[i], kAutodiffTolerance))
          << "block " << i;
    }
  }
}

/// ceres::GradientChecker with rigfit::PoseManifold on every (pose) block: the analytic
/// tangent Jacobians J_ambient * PlusJacobian equal Ridders finite differences mapped the
/// same way. GradientChecker's own verdict is a per-entry relative error, which fails on
/// structural zeros (e.g. the gravity prior's yaw column: 1e-17 analytic against 1e-11
/// numeric); the check below applies kGradientTolerance relative to the Jacobian's scale
/// to the matrices the checker computed, and also reports its worst per-entry error.
/// With `manifolds` given, block i uses manifolds[i] (nullptr: Euclidean) instead; `numeric`
/// sets the finite differences (a cost with a pole near the parameters needs a first step
/// smaller than Ridders' default of 1% of the parameter).
inline void ExpectGradientCheckPasses(const ceres::CostFunction& cost,
                                      const std::vector<const double*>& parameters,
                                      std::vector<const ceres::Manifold*> manifolds = {},
                                      const ceres::NumericDiffOptions& numeric = {}) {
  const PoseManifold manifold;
  if (manifolds.empty()) manifolds.assign(cost.parameter_block_sizes().size(), &manifold);
  const ceres::GradientChecker checker(&cost, &manifolds, numeric);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(parameters.data(), kGradientTolerance, &results);
  ASSERT_TRUE(results.return_value) << results.error_log;
  for (size_t i = 0; i < manifolds.size(); ++i) {
    EXPECT_TRUE(ScaledNear(results.local_jacobians[i], results.local_numeric_jacobians[i],
                           kGradientTolerance))
        << "block " << i << ", checker's worst per-entry relative error "
        << results.maximum_relative_error;
  }
}

/// Both proofs of a two-block cost at a pose pair (named in the failure trace): the
/// analytic cost against its autodiff reference, and against GradientChecker.
inline void ExpectProvenAt(const ceres::CostFunction& analytic, const ceres::CostFunction& autodiff,
                           const NamedPose& a, const NamedPose& b) {
  const PoseBlock x_a = ToBlock(a.T), x_b = ToBlock(b.T);
  const std::vector<const double*> parameters = {x_a.data(), x_b.data()};
  SCOPED_TRACE(a.name + " | " + b.name);
  ExpectAnalyticMatchesAutodiff(analytic, autodiff, parameters);
  ExpectGradientCheckPasses(analytic, parameters);
}

}  // namespace rigfit::testing
