#include <ceres/autodiff_cost_function.h>
#include <ceres/sized_cost_function.h>
#include <gtest/gtest.h>

#include <random>

#include "residuals/compressed_cost.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"
#include "residuals/stacked_cost.h"
#include "residuals_test_utils.h"

namespace rigfit {
namespace {

using namespace testing;  // NOLINT: the residual test helpers

/// Term::Features as a cost function (theta as the residuals), to prove its Jacobians.
template <class Term>
class FeaturesCost final
    : public ceres::SizedCostFunction<Term::kFeatureSize, kPoseAmbientSize, kPoseAmbientSize> {
 public:
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    Term::Features(parameters[0], parameters[1], residuals,
                   jacobians == nullptr ? nullptr : jacobians[0],
                   jacobians == nullptr ? nullptr : jacobians[1]);
    return true;
  }
};

/// Autodiff reference of PointToPlaneTerm::Features: [vec(R_b^T R_a); R_b^T (t_a - t_b); 1].
struct RelativeFeaturesFunctor {
  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* theta) const {
    using Vec3T = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_a(pose_a);
    const Eigen::Map<const Eigen::Quaternion<T>> q_b(pose_b);
    const Eigen::Map<const Vec3T> t_a(pose_a + 4), t_b(pose_b + 4);
    const Eigen::Matrix<T, 3, 3> R = q_b.conjugate().toRotationMatrix() * q_a.toRotationMatrix();
    Eigen::Map<Eigen::Matrix<T, 13, 1>> f(theta);
    for (int j = 0; j < 3; ++j) f.template segment<3>(3 * j) = R.col(j);
    f.template segment<3>(9) = q_b.conjugate() * (t_a - t_b);
    f(12) = T(1.0);
    return true;
  }
};

/// Autodiff reference of GicpTerm::Features: [vec(R_a); t_a; vec(R_b); t_b].
struct AbsoluteFeaturesFunctor {
  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* theta) const {
    const T* poses[2] = {pose_a, pose_b};
    for (int k = 0; k < 2; ++k) {
      const Eigen::Map<const Eigen::Quaternion<T>> q(poses[k]);
      const Eigen::Matrix<T, 3, 3> R = q.toRotationMatrix();
      for (int j = 0; j < 3; ++j) {
        for (int i = 0; i < 3; ++i) theta[12 * k + 3 * j + i] = R(i, j);
      }
      for (int i = 0; i < 3; ++i) theta[12 * k + 9 + i] = poses[k][4 + i];
    }
    return true;
  }
};

template <class Term, class Functor>
void ExpectFeaturesMatchAutodiff() {
  const FeaturesCost<Term> analytic;
  ceres::AutoDiffCostFunction<Functor, Term::kFeatureSize, kPoseAmbientSize, kPoseAmbientSize>
      autodiff(new Functor);
  for (const auto& [a, b] : TestPosePairs()) ExpectProvenAt(analytic, autodiff, a, b);
}

TEST(CompressedCost, PointToPlaneFeaturesMatchAutodiffAndPassTheGradientCheck) {
  ExpectFeaturesMatchAutodiff<PointToPlaneTerm, RelativeFeaturesFunctor>();
}

TEST(CompressedCost, GicpFeaturesMatchAutodiffAndPassTheGradientCheck) {
  ExpectFeaturesMatchAutodiff<GicpTerm, AbsoluteFeaturesFunctor>();
}

/// 0.5 |r|^2, the gradient J^T r and the Gauss-Newton matrix J^T J of a two-block cost in
/// the PoseManifold tangent (12 columns: block a, then block b).
struct Quadratic {
  double cost = 0.0;
  Eigen::VectorXd gradient;
  Eigen::MatrixXd hessian;
};

Quadratic TangentQuadratic(const ceres::CostFunction& cost, const PoseBlock& x_a,
                           const PoseBlock& x_b) {
  const Evaluation e = Evaluate(cost, {x_a.data(), x_b.data()}, {true, true});
  EXPECT_TRUE(e.ok);
  const PoseManifold manifold;
  Eigen::Matrix<double, kPoseAmbientSize, kPoseTangentSize, Eigen::RowMajor> P_a, P_b;
  manifold.PlusJacobian(x_a.data(), P_a.data());
  manifold.PlusJacobian(x_b.data(), P_b.data());
  Eigen::MatrixXd J(e.residuals.size(), 2 * kPoseTangentSize);
  J << e.jacobians[0] * P_a, e.jacobians[1] * P_b;
  return {0.5 * e.residuals.squaredNorm(), J.transpose() * e.residuals, J.transpose() * J};
}

/// A pair of cameras 3 m apart seeing points up to 8 m away, whose correspondences fit
/// their poses to about 1 mm: terms at the scale and with the cancellation of a real
/// registration (whitened residuals near 1, features of metres over millimetres).
struct RigScene {
  Pose T_a, T_b;
  std::vector<Vec3> p, q, n;
};

RigScene MakeRigScene(std::mt19937& rng, int count) {
  RigScene s;
  s.T_a = MakePose(Vec3(0.3, 1.2, -0.1), Vec3(0.5, 1.4, -2.0));
  s.T_b = MakePose(Vec3(-0.2, -0.9, 0.2), Vec3(2.5, 1.1, 1.0));
  std::normal_distribution<double> noise(0.0, 1e-3);
  std::uniform_real_distribution<double> depth(0.5, 8.0);
  for (int k = 0; k < count; ++k) {
    const Vec3 p = depth(rng) * (Vec3(0.0, 0.0, 1.0) + RandomVector(rng, 0.6)).normalized();
    s.p.push_back(p);
    s.q.push_back(s.T_b.inverse() * (s.T_a * p) + Vec3(noise(rng), noise(rng), noise(rng)));
    s.n.push_back(RandomVector(rng, 1.0).normalized());
  }
  return s;
}

/// The compressed cost and the stack of the same weighted terms have the same cost,
/// gradient and Gauss-Newton matrix (tangent space) at `poses`, each within `tolerance`
/// relative to its own scale.
template <class Term>
void ExpectCompressionIsExact(const std::vector<Term>& terms, const std::vector<double>& weights,
                              const std::vector<std::pair<Pose, Pose>>& poses, double tolerance) {
  StackedCost<Term> stacked;
  CompressedCost<Term> compressed;
  for (size_t k = 0; k < terms.size(); ++k) {
    stacked.Add(terms[k], weights[k]);
    compressed.Add(terms[k], weights[k]);
  }
  EXPECT_EQ(compressed.size(), terms.size());
  EXPECT_EQ(compressed.num_residuals(), Term::kFeatureSize);
  const double* parameters[2] = {nullptr, nullptr};
  double residuals[Term::kFeatureSize];
  EXPECT_FALSE(compressed.Evaluate(parameters, residuals, nullptr)) << "evaluated before Compress";
  compressed.Compress();
  for (const auto& [T_a, T_b] : poses) {
    const PoseBlock x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    const Quadratic expected = TangentQuadratic(stacked, x_a, x_b);
    const Quadratic actual = TangentQuadratic(compressed, x_a, x_b);
    EXPECT_NEAR(actual.cost, expected.cost, tolerance * expected.cost);
    EXPECT_TRUE(ScaledNear(actual.gradient / MaxAbs(expected.gradient),
                           expected.gradient / MaxAbs(expected.gradient), tolerance));
    EXPECT_TRUE(ScaledNear(actual.hessian / MaxAbs(expected.hessian),
                           expected.hessian / MaxAbs(expected.hessian), tolerance));
  }
}

/// The poses to compare at: the scene's, and the scene's moved by up to 3 degrees and 5 cm
/// (where ICP starts), with the GradientChecker's pose pairs.
std::vector<std::pair<Pose, Pose>> ComparisonPoses(const RigScene& s, std::mt19937& rng) {
  std::vector<std::pair<Pose, Pose>> poses = {{s.T_a, s.T_b}};
  for (int i = 0; i < 5; ++i) {
    const Vec6 d_a = (Vec6() << RandomVector(rng, 0.05), RandomVector(rng, 0.05)).finished();
    const Vec6 d_b = (Vec6() << RandomVector(rng, 0.05), RandomVector(rng, 0.05)).finished();
    poses.push_back({PosePlus(s.T_a, d_a), PosePlus(s.T_b, d_b)});
  }
  for (const auto& [a, b] : TestPosePairs()) poses.push_back({a.T, b.T});
  return poses;
}

/// ExpectCompressionIsExact on 2000 terms of a rig scene made with `seed`: make(scene, k,
/// sigma) gives correspondence k's term, sigma its noise, drawn in 1-20 mm; weights in
/// [0.2, 1].
template <class Term, class Make>
void ExpectRigSceneCompressionIsExact(unsigned seed, Make make) {
  std::mt19937 rng(seed);
  const RigScene s = MakeRigScene(rng, 2000);
  std::uniform_real_distribution<double> sigma(1e-3, 2e-2), weight(0.2, 1.0);
  std::vector<Term> terms;
  std::vector<double> weights;
  for (size_t k = 0; k < s.p.size(); ++k) {
    terms.push_back(make(s, k, sigma(rng)));
    weights.push_back(weight(rng));
  }
  ExpectCompressionIsExact(terms, weights, ComparisonPoses(s, rng), 1e-7);
}

/// Correspondence k of a rig scene as a point-to-plane term, whitened by sigma (m).
PointToPlaneTerm ScenePointToPlaneTerm(const RigScene& s, size_t k, double sigma) {
  return PointToPlaneTerm{s.p[k], s.q[k], s.n[k] / sigma};
}

/// Correspondence k of a rig scene as a GICP term with a plane-like covariance: 1 m^2 in the
/// plane, sigma^2 along the normal.
GicpTerm SceneGicpTerm(const RigScene& s, size_t k, double sigma) {
  const Mat3 C = Mat3::Identity() - (1.0 - sigma * sigma) * s.n[k] * s.n[k].transpose();
  return GicpCost::MakeTerm(s.p[k], s.q[k], C, C, s.T_a.linear(), s.T_b.linear());
}

TEST(CompressedCost, PointToPlaneEqualsItsStackToRounding) {
  ExpectRigSceneCompressionIsExact<PointToPlaneTerm>(5, ScenePointToPlaneTerm);
}

TEST(CompressedCost, GicpEqualsItsStackToRounding) {
  ExpectRigSceneCompressionIsExact<GicpTerm>(6, SceneGicpTerm);
}

/// Term::ResidualAt at the features of the poses equals Term::Evaluate there, on 200
/// terms of a rig scene at every comparison pose, to 1e-9 of the residuals' scale (whitened
/// residuals of metres over millimetres).
template <class Term, class Make>
void ExpectResidualAtMatchesEvaluate(unsigned seed, Make make) {
  std::mt19937 rng(seed);
  const RigScene s = MakeRigScene(rng, 200);
  std::uniform_real_distribution<double> sigma(1e-3, 2e-2);
  std::vector<Term> terms;
  for (size_t k = 0; k < s.p.size(); ++k) terms.push_back(make(s, k, sigma(rng)));
  for (const auto& [T_a, T_b] : ComparisonPoses(s, rng)) {
    const PoseBlock x_a = ToBlock(T_a), x_b = ToBlock(T_b);
    double theta[Term::kFeatureSize];
    Term::Features(x_a.data(), x_b.data(), theta, nullptr, nullptr);
    for (const Term& term : terms) {
      Eigen::Matrix<double, Term::kNumResiduals, 1> expected, actual;
      term.Evaluate(x_a.data(), x_b.data(), expected.data(), nullptr, nullptr);
      term.ResidualAt(theta, actual.data());
      EXPECT_TRUE(ScaledNear(actual, expected, 1e-9))
          << actual.transpose() << " vs " << expected.transpose();
    }
  }
}

TEST(CompressedCost, PointToPlaneResidualAtFeaturesMatchesEvaluate) {
  ExpectResidualAtMatchesEvaluate<PointToPlaneTerm>(7, ScenePointToPlaneTerm);
}

TEST(CompressedCost, GicpResidualAtFeaturesMatchesEvaluate) {
  ExpectResidualAtMatchesEvaluate<GicpTerm>(8, SceneGicpTerm);
}

TEST(CompressedCost, PassesTheGradientCheck) {
  std::mt19937 rng(8);
  CompressedCost<PointToPlaneTerm> point_to_plane;
  CompressedCost<GicpTerm> gicp;
  for (int k = 0; k < 20; ++k) {
    const Vec3 p = RandomVector(rng, 3.0), q = RandomVector(rng, 3.0);
    const Vec3 n = RandomVector(rng, 1.0).normalized();
    point_to_plane.Add({p, q, n}, 0.5 + 0.1 * k);
    const Mat3 C = Mat3::Identity() - 0.999 * n * n.transpose();
    gicp.Add(GicpCost::MakeTerm(p, q, C, C, Mat3::Identity(), Mat3::Identity()), 1.0);
  }
  point_to_plane.Compress();
  gicp.Compress();
  for (const auto& [a, b] : TestPosePairs()) {
    const PoseBlock x_a = ToBlock(a.T), x_b = ToBlock(b.T);
    SCOPED_TRACE(a.name + " | " + b.name);
    ExpectGradientCheckPasses(point_to_plane, {x_a.data(), x_b.data()});
    ExpectGradientCheckPasses(gicp, {x_a.data(), x_b.data()});
  }
}

}  // namespace
}  // namespace rigfit
