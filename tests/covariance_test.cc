// uncertainty/covariance.h: the shared-noise covariance against the inverse information where they
// must agree and against its dense definition; a free camera in no term has none. The
// poses' covariance with planes marginalised against ceres::Covariance, and its robust version
// against the scatter of the poses over draws of errors the noise model does not know. The
// inflation from the realised residuals: about 1 on independent errors, covering correlated ones.
#include "uncertainty/covariance.h"

#include <ceres/covariance.h>
#include <ceres/manifold.h>
#include <ceres/product_manifold.h>
#include <ceres/solver.h>
#include <ceres/sphere_manifold.h>
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <utility>
#include <vector>

#include "core/pose.h"
#include "residuals/gicp.h"
#include "residuals/plane_cluster.h"

namespace rigfit {
namespace {

/// The three faces of a box corner (normals along the world axes, towards the cameras) near
/// (0, 0, 2.5) m: per_face random points on each face.
struct BoxCorner {
  PointCloud points, normals;
  BoxCorner(int per_face, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.1, 1.0);
    for (int face = 0; face < 3; ++face) {
      for (int i = 0; i < per_face; ++i) {
        Vec3 p(u(rng), u(rng), u(rng));
        p(face) = 0.0;
        points.push_back(p + Vec3(-0.5, -0.5, 2.5));
        normals.push_back(-Vec3::Unit(face));
      }
    }
  }
};

/// The corner as the camera at T of view `view` sees it: a finest-scale level of its points,
/// normals and plane-shaped covariances. Point i moves by 0.001 ((view i) mod 7) m along x,
/// so that the views' points differ (view 0's do not move).
ScaleLevel CornerLevel(const BoxCorner& corner, const Pose& T, size_t view) {
  ScaleLevel level;
  level.voxel_size = 0.02;
  level.normal_support = 0.05;
  for (size_t i = 0; i < corner.points.size(); ++i) {
    level.points.push_back(T.inverse() * corner.points[i] +
                           Vec3(0.001 * ((view * i) % 7), 0.0, 0.0));
    const Vec3 n = T.linear().transpose() * corner.normals[i];
    level.geometry.normals.push_back(n);
    level.geometry.covariances.push_back(Mat3::Identity() - (1.0 - 1e-3) * n * n.transpose());
  }
  level.geometry.planarity.assign(corner.points.size(), 1.0);
  return level;
}

/// Two views of the three faces of a box corner (normals along the world axes), noisy depth
/// k = 0.003 /m, from two poses; point i of one is point i of the other (correspondence
/// i <-> i at distance 0).
class SharedNoiseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const BoxCorner corner(40, 5);
    const Pose T_source =
        PoseFromParameters(std::array<double, 7>{0.05, -0.1, 0.02, 0.99, 0.3, -0.1, 0.2}.data());
    const Pose T_target =
        PoseFromParameters(std::array<double, 7>{-0.03, 0.04, 0.1, 0.99, -0.2, 0.1, 0.05}.data());
    for (size_t i = 0; i < corner.points.size(); ++i) {
      matches_.push_back({static_cast<int>(i), static_cast<int>(i), 0.0});
    }
    source_ = CornerLevel(corner, T_source, 0);
    target_ = CornerLevel(corner, T_target, 0);
    PoseToParameters(T_source, blocks_[0].data());
    PoseToParameters(T_target, blocks_[1].data());
    views_ = {{&source_, T_source, blocks_[0].data(), 0.003},
              {&target_, T_target, blocks_[1].data(), 0.003}};
  }

  /// SharedNoiseCovariance of the source pose (the target held) over `terms`.
  Eigen::MatrixXd Shared(const std::vector<MatchedViews>& terms, const IcpOptions& options) {
    return SharedNoiseCovariance({views_, {0, -1}, terms}, options, Eigen::MatrixXd::Zero(6, 6), 2);
  }

  /// The inverse of the information of the same terms taken as independent.
  Eigen::MatrixXd InverseInformation(const std::vector<MatchedViews>& terms,
                                     const IcpOptions& options) {
    const std::unique_ptr<ceres::Problem> problem = NewProblem();
    for (auto& block : blocks_) {
      problem->AddParameterBlock(block.data(), kPoseAmbientSize, SharedPoseManifold());
    }
    std::vector<ceres::ResidualBlockId> ids;
    for (const MatchedViews& t : terms) {
      ids.push_back(
          AddCorrespondenceTerms(problem.get(), options, t, nullptr, TermStorage::kStacked));
    }
    return Information(problem.get(), {blocks_[0].data()}, ids, false).inverse();
  }

  ScaleLevel source_, target_;
  std::array<std::array<double, kPoseAmbientSize>, 2> blocks_;
  std::vector<CameraView> views_;
  std::vector<Correspondence> matches_;
};

/// Largest entry of |a - b| against the largest of |b|.
double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).cwiseAbs().maxCoeff() / b.cwiseAbs().maxCoeff();
}

TEST_F(SharedNoiseTest, EveryPointInOneTermGivesTheInverseInformation) {
  // Point-to-plane weights are exactly the noise the points carry: with each point in one
  // term the sandwich collapses to the inverse of the information.
  const std::vector<MatchedViews> one_way = {{&views_[0], &views_[1], &matches_}};
  IcpOptions options;
  const Eigen::MatrixXd shared = Shared(one_way, options);
  ASSERT_EQ(shared.rows(), 6);
  EXPECT_LT(RelativeDifference(shared, InverseInformation(one_way, options)), 1e-9);
  // Without depth noise or plane share (points cameras; the noise is all the floor's), the
  // points carry no noise of their own, which is no reason to lose the covariance.
  views_[0].depth_noise = views_[1].depth_noise = 0.0;
  const Eigen::MatrixXd floor_only = Shared(one_way, options);
  ASSERT_EQ(floor_only.rows(), 6);
  EXPECT_LT(RelativeDifference(floor_only, InverseInformation(one_way, options)), 1e-9);
  // Depth noise without plane share: each point's noise is along its ray only (rank 1,
  // factored by an eigen-decomposition, whose rounding is about 1e-8 here).
  views_[0].depth_noise = views_[1].depth_noise = 0.003;
  options.plane_noise_share = 0.0;
  const Eigen::MatrixXd ray_only = Shared(one_way, options);
  ASSERT_EQ(ray_only.rows(), 6);
  EXPECT_LT(RelativeDifference(ray_only, InverseInformation(one_way, options)), 1e-7);
}

TEST_F(SharedNoiseTest, CountingThePointsTwiceLeavesTheCovariance) {
  // Both directions pair the same points twice (i <-> i, the same world normal: the reverse
  // residual is minus the forward one), and so do the same terms given twice. Independent
  // terms would halve the covariance; the points' shared noise keeps it. The per-term
  // floor, independent by design, is made negligible (1e-6 m against millimetres).
  for (const RegistrationMethod method :
       {RegistrationMethod::kPointToPlane, RegistrationMethod::kGicp}) {
    IcpOptions options;
    options.method = method;
    options.min_noise_m = 1e-6;
    const MatchedViews forward = {&views_[0], &views_[1], &matches_};
    const MatchedViews reverse = {&views_[1], &views_[0], &matches_};
    const Eigen::MatrixXd once = Shared({forward}, options);
    ASSERT_EQ(once.rows(), 6);
    EXPECT_LT(RelativeDifference(Shared({forward, reverse}, options), once), 1e-7);
    EXPECT_LT(RelativeDifference(Shared({forward, forward}, options), once), 1e-7);
    EXPECT_LT(RelativeDifference(InverseInformation({forward, forward}, options),
                                 0.5 * InverseInformation({forward}, options)),
              1e-9);
  }
}

/// Three views of a box corner with their own depth noise, and four
/// pair directions with different matchings, for the dense reference below.
struct ThreeViews {
  std::vector<ScaleLevel> levels = std::vector<ScaleLevel>(3);
  std::array<std::array<double, kPoseAmbientSize>, 3> blocks;
  std::vector<CameraView> views = std::vector<CameraView>(3);
  std::vector<std::vector<Correspondence>> matches = std::vector<std::vector<Correspondence>>(4);
  std::vector<MatchedViews> terms;

  ThreeViews() {
    const BoxCorner corner(30, 7);
    const std::array<std::array<double, 7>, 3> poses = {{{0.05, -0.1, 0.02, 0.99, 0.3, -0.1, 0.2},
                                                         {-0.03, 0.04, 0.1, 0.99, -0.2, 0.1, 0.05},
                                                         {0.1, 0.02, -0.05, 0.99, 0.1, 0.3, -0.2}}};
    const std::array<double, 3> depth_noise = {0.003, 0.002, 0.004};
    for (size_t v = 0; v < 3; ++v) {
      const Pose T = PoseFromParameters(poses[v].data());
      levels[v] = CornerLevel(corner, T, v);
      PoseToParameters(T, blocks[v].data());
      views[v] = {&levels[v], T, blocks[v].data(), depth_noise[v]};
    }
    const int n = static_cast<int>(corner.points.size());
    for (int i = 0; i < n; ++i) {
      matches[0].push_back({i, i, 0.0});
      matches[1].push_back({i, (i + 3) % n, 0.0});
      if (i % 2 == 0) matches[2].push_back({i, i, 0.0});
      matches[3].push_back({i, (i * 7) % n, 0.0});
    }
    terms = {{&views[0], &views[1], &matches[0]},
             {&views[1], &views[0], &matches[1]},
             {&views[2], &views[0], &matches[2]},
             {&views[1], &views[2], &matches[3]}};
  }
};

/// SharedNoiseCovariance written out densely, from its definition: every whitened residual
/// and its derivatives with respect to the free poses (tangent) and to every point by central
/// differences, the points' noise covariance from docs/residuals.md (section 9), then
/// H^-1 (J^T (D Sigma D^T + F) J + P) H^-1.
Eigen::MatrixXd DenseSharedNoiseCovariance(ThreeViews& rig, const std::vector<int>& column,
                                           const IcpOptions& o, const Eigen::MatrixXd& P) {
  const bool gicp = o.method == RegistrationMethod::kGicp;
  const int rows_per_term = gicp ? 3 : 1;
  const int n = static_cast<int>(rig.levels[0].points.size());
  const double floor2 = o.min_noise_m * o.min_noise_m;
  // Depth noise along the ray, the plane share isotropic, and for GICP half the floor.
  const auto noise = [&](const CameraView& v, const Vec3& p) {
    const double k2 = v.depth_noise * v.depth_noise;
    return Mat3(k2 * p.z() * p.z() * p * p.transpose() +
                (o.plane_noise_share * o.plane_noise_share * k2 * std::pow(p.z(), 4) +
                 (gicp ? 0.5 * floor2 : 0.0)) *
                    Mat3::Identity());
  };
  int rows = 0;
  for (const MatchedViews& t : rig.terms) rows += rows_per_term * t.matches->size();
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(rows, P.rows());
  Eigen::MatrixXd D = Eigen::MatrixXd::Zero(rows, 9 * n);
  Eigen::VectorXd F = Eigen::VectorXd::Zero(rows);
  const auto index = [&](const CameraView* v) { return static_cast<int>(v - rig.views.data()); };
  constexpr double h = 1e-6;
  int row = 0;
  for (const MatchedViews& t : rig.terms) {
    const int s = index(t.source), g = index(t.target);
    for (const Correspondence& c : *t.matches) {
      const Vec3 p0 = t.source->level->points[c.source];
      const Vec3 q0 = t.target->level->points[c.target];
      const Vec3 n_t = t.target->level->geometry.normals[c.target];
      const double variance = PointToPlaneVariance(*t.source, *t.target, c, o);
      const auto covariance = [&](const CameraView& v, int i) {
        const LocalGeometry& geometry = v.level->geometry;
        return Mat3(geometry.covariances[i] -
                    kGicpPlaneEpsilon * geometry.normals[i] * geometry.normals[i].transpose() +
                    noise(v, v.level->points[i]));
      };
      const Mat3 L = gicp
                         ? GicpCost::SqrtInformation(
                               covariance(*t.source, c.source), covariance(*t.target, c.target),
                               t.source->T_world_camera.linear(), t.target->T_world_camera.linear())
                         : Mat3::Identity();
      const auto residual = [&](const double* xs, const double* xt, const Vec3& p, const Vec3& q) {
        const Pose Ts = PoseFromParameters(xs), Tt = PoseFromParameters(xt);
        const Vec3 d = Ts * p - Tt * q;
        Eigen::VectorXd r(rows_per_term);
        if (gicp) {
          r = L * d;
        } else {
          r(0) = (Tt.linear() * n_t).dot(d) / std::sqrt(variance);
        }
        return r;
      };
      for (int side = 0; side < 2; ++side) {
        const int v = side == 0 ? s : g;
        if (column[v] < 0) continue;
        for (int k = 0; k < 6; ++k) {
          std::array<double, 7> plus, minus;
          double delta[6] = {0.0, 0.0, 0.0, 0.0, 0.0, 0.0};
          delta[k] = h;
          SharedPoseManifold()->Plus(rig.blocks[v].data(), delta, plus.data());
          delta[k] = -h;
          SharedPoseManifold()->Plus(rig.blocks[v].data(), delta, minus.data());
          const double* xs_plus = side == 0 ? plus.data() : rig.blocks[s].data();
          const double* xt_plus = side == 0 ? rig.blocks[g].data() : plus.data();
          const double* xs_minus = side == 0 ? minus.data() : rig.blocks[s].data();
          const double* xt_minus = side == 0 ? rig.blocks[g].data() : minus.data();
          J.block(row, column[v] + k, rows_per_term, 1) +=
              (residual(xs_plus, xt_plus, p0, q0) - residual(xs_minus, xt_minus, p0, q0)) /
              (2.0 * h);
        }
      }
      const double* xs = rig.blocks[s].data();
      const double* xt = rig.blocks[g].data();
      for (int k = 0; k < 3; ++k) {
        const Vec3 e = h * Vec3::Unit(k);
        D.block(row, 3 * (s * n + c.source) + k, rows_per_term, 1) +=
            (residual(xs, xt, p0 + e, q0) - residual(xs, xt, p0 - e, q0)) / (2.0 * h);
        D.block(row, 3 * (g * n + c.target) + k, rows_per_term, 1) +=
            (residual(xs, xt, p0, q0 + e) - residual(xs, xt, p0, q0 - e)) / (2.0 * h);
      }
      if (!gicp) F(row) = floor2 / variance;
      row += rows_per_term;
    }
  }
  Eigen::MatrixXd Sigma = Eigen::MatrixXd::Zero(9 * n, 9 * n);
  for (int v = 0; v < 3; ++v) {
    for (int i = 0; i < n; ++i) {
      Sigma.block<3, 3>(3 * (v * n + i), 3 * (v * n + i)) =
          noise(rig.views[v], rig.levels[v].points[i]);
    }
  }
  const Eigen::MatrixXd H = J.transpose() * J + P;
  const Eigen::MatrixXd M =
      J.transpose() * (D * Sigma * D.transpose() + Eigen::MatrixXd(F.asDiagonal())) * J + P;
  const Eigen::MatrixXd H_inverse = H.inverse();
  return H_inverse * M * H_inverse;
}

TEST(SharedNoiseCovariance, EqualsItsDenseDefinitionWithTwoFreeCameras) {
  // Both methods, each camera held fixed in turn, one and two threads, a prior coupling
  // the two free cameras: the blockwise accumulation (cross blocks, scores per free camera)
  // against the dense formula, to the finite differences' precision.
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  Eigen::MatrixXd A(12, 12);
  for (int i = 0; i < A.size(); ++i) A(i) = normal(rng);
  const Eigen::MatrixXd prior = 1e-2 * A * A.transpose();
  for (const RegistrationMethod method :
       {RegistrationMethod::kPointToPlane, RegistrationMethod::kGicp}) {
    for (const std::vector<int>& column :
         {std::vector<int>{-1, 0, 6}, std::vector<int>{0, -1, 6}, std::vector<int>{6, 0, -1}}) {
      ThreeViews rig;
      IcpOptions options;
      options.method = method;
      const Eigen::MatrixXd want = DenseSharedNoiseCovariance(rig, column, options, prior);
      for (const int threads : {1, 2}) {
        const Eigen::MatrixXd got =
            SharedNoiseCovariance({rig.views, column, rig.terms}, options, prior, threads);
        ASSERT_EQ(got.rows(), 12);
        EXPECT_LT(RelativeDifference(got, want), 1e-5)
            << "method " << static_cast<int>(method) << ", columns " << column[0] << " "
            << column[1] << " " << column[2] << ", threads " << threads;
        EXPECT_LT(RelativeDifference(got, got.transpose()), 1e-12);
      }
    }
  }
}

TEST(SharedNoiseCovariance, AFreeCameraInNoTermHasNoCovariance) {
  // Nothing constrains camera 2: no covariance at all, rather than a 1-sigma of 0.
  ThreeViews rig;
  rig.terms.resize(1);  // 0 -> 1 only
  EXPECT_EQ(SharedNoiseCovariance({rig.views, {-1, 0, 6}, rig.terms}, IcpOptions(),
                                  Eigen::MatrixXd::Zero(12, 12), 1)
                .size(),
            0);
}

/// A residual tying two planes' offsets (not a plane-cluster term).
struct TiedPlanes {
  template <typename T>
  bool operator()(const T* a, const T* b, T* r) const {
    r[0] = a[3] - b[3];
    return true;
  }
};

/// Three cameras around a room corner (a floor, two walls and an oblique face), every camera
/// seeing every plane: poses and planes as parameter blocks of plane-cluster terms.
struct PlaneBundle {
  std::array<std::array<double, kPoseAmbientSize>, 3> poses;
  std::array<Vec4, 4> planes;
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold;
  ceres::SubsetManifold floor_manifold{4, {0, 1, 2}};
  std::unique_ptr<ceres::Problem> problem = NewProblem();

  PlaneBundle() {
    const Vec3 normals[4] = {Vec3::UnitY(), Vec3::UnitX(), Vec3::UnitZ(),
                             Vec3(1.0, 0.3, 1.0).normalized()};
    const double offsets[4] = {0.0, -3.0, -4.0, -4.5};
    for (int j = 0; j < 4; ++j) planes[j] << normals[j], offsets[j];
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    // Each camera looks at the corner (2.5, 0.5, 3.5) from its own place.
    const Vec3 corner(2.5, 0.5, 3.5);
    for (int c = 0; c < 3; ++c) {
      Pose T = Pose::Identity();
      T.translation() = Vec3(0.4 * c, 1.5 - 0.2 * c, 0.3 * c - 0.2);
      const Vec3 z = (corner - T.translation()).normalized();
      const Vec3 x = Vec3::UnitY().cross(z).normalized();
      T.linear().col(0) = x;
      T.linear().col(1) = z.cross(x);
      T.linear().col(2) = z;
      PoseToParameters(T, poses[c].data());
      problem->AddParameterBlock(poses[c].data(), kPoseAmbientSize, SharedPoseManifold());
    }
    problem->SetParameterBlockConstant(poses[0].data());
    for (int j = 0; j < 4; ++j) {
      problem->AddParameterBlock(
          planes[j].data(), 4,
          j == 0 ? static_cast<ceres::Manifold*>(&floor_manifold) : &plane_manifold);
    }
    for (int c = 0; c < 3; ++c) {
      const Pose T = PoseFromParameters(poses[c].data());
      for (int j = 0; j < 4; ++j) {
        // Points of plane j around the corner's foot on it, in the camera frame.
        const Vec3 n = normals[j];
        const Vec3 foot = corner - n * (n.dot(corner) + offsets[j]);
        const Vec3 e1 = n.unitOrthogonal(), e2 = n.cross(e1);
        PlaneCluster cluster;
        for (int i = 0; i < 40; ++i) {
          const Vec3 p = T.inverse() * (foot + u(rng) * e1 + u(rng) * e2);
          if (p.z() > 0.2) cluster.AddRay(p, 1.0 / p.z(), 0.002);
        }
        problem->AddResidualBlock(PlaneClusterCost::Create(cluster, true), nullptr, poses[c].data(),
                                  planes[j].data());
      }
    }
  }
};

TEST(MarginalPoseCovariance, EqualsCeresCovarianceOfThePoses) {
  constexpr double kRelativeTolerance = 1e-8;
  PlaneBundle bundle;
  std::vector<double*> free_poses = {bundle.poses[1].data(), bundle.poses[2].data()};
  std::vector<double*> planes;
  for (Vec4& plane : bundle.planes) planes.push_back(plane.data());
  const Eigen::MatrixXd C = MarginalPoseCovariance(bundle.problem.get(), free_poses, planes);
  ASSERT_EQ(C.rows(), 12);

  ceres::Covariance::Options options;
  options.algorithm_type = ceres::DENSE_SVD;
  ceres::Covariance covariance(options);
  const std::vector<std::pair<const double*, const double*>> pairs = {
      {free_poses[0], free_poses[0]},
      {free_poses[0], free_poses[1]},
      {free_poses[1], free_poses[1]}};
  ASSERT_TRUE(covariance.Compute(pairs, bundle.problem.get()));
  Eigen::Matrix<double, 12, 12, Eigen::RowMajor> expected;
  ASSERT_TRUE(covariance.GetCovarianceMatrixInTangentSpace({free_poses[0], free_poses[1]},
                                                           expected.data()));
  EXPECT_LE((C - expected).norm(), kRelativeTolerance * expected.norm()) << "ours\n"
                                                                         << C << "\nceres\n"
                                                                         << expected;
  // The order given, not the blocks' addresses: the poses swapped swap the blocks.
  const Eigen::MatrixXd swapped =
      MarginalPoseCovariance(bundle.problem.get(), {free_poses[1], free_poses[0]}, planes);
  EXPECT_LE((swapped.block(0, 0, 6, 6) - C.block(6, 6, 6, 6)).norm(),
            kRelativeTolerance * expected.norm());
}

TEST(MarginalPoseSandwiches, SameCovarianceAndSandwichesOfTheGivenClusters) {
  constexpr double kRelativeTolerance = 1e-10;
  PlaneBundle bundle;
  bundle.planes[1](3) += 0.01;  // residuals, so that the scores are not zero
  const std::vector<double*> free_poses = {bundle.poses[1].data(), bundle.poses[2].data()};
  std::vector<double*> planes;
  for (Vec4& plane : bundle.planes) planes.push_back(plane.data());
  const Eigen::MatrixXd C = MarginalPoseCovariance(bundle.problem.get(), free_poses, planes);
  // Blocks in camera-major order (3 cameras x 4 planes): fine each block, coarse each camera.
  BlockClusters clusters;
  for (int b = 0; b < 12; ++b) {
    clusters.fine.push_back(b);
    clusters.coarse.push_back(b / 4);
  }
  ClusterSandwiches sandwiches;
  Eigen::MatrixXd priors;
  const Eigen::MatrixXd same = MarginalPoseSandwiches(bundle.problem.get(), free_poses, planes,
                                                      clusters, &sandwiches, &priors);
  EXPECT_LE((same - C).norm(), kRelativeTolerance * C.norm());
  EXPECT_TRUE(priors.isZero(0.0));  // no residual block without a plane
  ASSERT_EQ(sandwiches.fine.rows(), 12);
  EXPECT_GT(sandwiches.fine.trace(), 0.0);
  EXPECT_GT(sandwiches.coarse.trace(), 0.0);
  // The same clusters twice: the same sandwich, no design effect.
  clusters.coarse = clusters.fine;
  MarginalPoseSandwiches(bundle.problem.get(), free_poses, planes, clusters, &sandwiches);
  EXPECT_LE((sandwiches.coarse - sandwiches.fine).norm(), 1e-12 * sandwiches.fine.norm());
  EXPECT_DOUBLE_EQ(InflationOf(sandwiches, 0).rotation, 1.0);
  clusters.fine.pop_back();
  EXPECT_THROW(
      MarginalPoseSandwiches(bundle.problem.get(), free_poses, planes, clusters, &sandwiches),
      std::invalid_argument);
}

TEST(MarginalPoseCovariance, APlaneInNoTermIsLeftOutAndAHalfSeenOneGivesNone) {
  PlaneBundle bundle;
  std::vector<double*> planes;
  for (Vec4& plane : bundle.planes) planes.push_back(plane.data());
  const std::vector<double*> poses = {bundle.poses[1].data()};
  const Eigen::MatrixXd C = MarginalPoseCovariance(bundle.problem.get(), poses, planes);
  ASSERT_EQ(C.rows(), 6);

  Vec4 alone(0.0, 0.0, 1.0, -9.0);  // in no residual block
  bundle.problem->AddParameterBlock(alone.data(), 4, &bundle.plane_manifold);
  planes.push_back(alone.data());
  EXPECT_EQ(MarginalPoseCovariance(bundle.problem.get(), poses, planes), C);

  // One pixel on a plane fixes one of its three directions.
  PlaneCluster one;
  one.AddRay(Vec3(0.1, 0.2, 5.0), 1.0 / 5.0, 0.002);
  bundle.problem->AddResidualBlock(PlaneClusterCost::Create(one, true), nullptr,
                                   bundle.poses[1].data(), alone.data());
  EXPECT_EQ(MarginalPoseCovariance(bundle.problem.get(), poses, planes).size(), 0);
}

/// A prior on a pose block's translation: (t - at) / sigma.
struct TranslationPrior {
  Vec3 at;
  double sigma;
  template <typename T>
  bool operator()(const T* pose, T* r) const {
    for (int k = 0; k < 3; ++k) r[k] = (pose[4 + k] - T(at(k))) / T(sigma);
    return true;
  }
};

/// One free camera beside a fixed one, both seeing `kPlanes` planes around them, whose every
/// (camera, plane) view is displaced along the plane's normal by its own error of `error` m
/// (a view's model error, wrong pixels or correlated noise: the same for all its pixels, so
/// not in the pixel noise model), each pixel with its own inverse-depth noise of `noise`, and,
/// with `prior_sigma` > 0, a prior on the free camera's translation (its truth moved by a draw
/// of that sigma). Solved from the truth.
struct DisplacedViews {
  static constexpr int kPlanes = 16;
  std::array<std::array<double, kPoseAmbientSize>, 2> poses;
  std::array<double, kPoseAmbientSize> truth;
  std::array<Vec4, kPlanes> planes;
  ceres::ProductManifold<ceres::SphereManifold<3>, ceres::EuclideanManifold<1>> plane_manifold;
  std::unique_ptr<ceres::Problem> problem = NewProblem();

  static constexpr double kSigma = 0.001;  ///< the pixels' modelled inverse-depth noise, 1/m
  int pixels = 0;

  /// `error`: each view's displacement's sigma (m); `noise`: the pixels' own inverse-depth
  /// noise's sigma (1/m), the model's being kSigma.
  DisplacedViews(double error, double noise, unsigned seed, double prior_sigma = 0.0) {
    std::mt19937 rng(seed);
    std::mt19937 scene(7);  // the same planes and pixels in every draw
    std::normal_distribution<double> unit(0.0, 1.0);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    Pose T[2] = {Pose::Identity(), Pose::Identity()};
    T[1].linear() = ExpSO3(Vec3(0.05, 0.4, -0.03));
    T[1].translation() = Vec3(0.8, 0.1, -0.3);
    for (int c = 0; c < 2; ++c) {
      PoseToParameters(T[c], poses[c].data());
      problem->AddParameterBlock(poses[c].data(), kPoseAmbientSize, SharedPoseManifold());
    }
    truth = poses[1];
    problem->SetParameterBlockConstant(poses[0].data());
    for (int j = 0; j < kPlanes; ++j) {
      // A plane facing the cameras 3-5 m in front of them, tilted up to 40 degrees.
      const Vec3 foot(1.5 * u(scene), 0.8 * u(scene), 4.0 + u(scene));
      const Vec3 n = (Vec3(0.0, 0.0, -1.0) + 0.7 * Vec3(u(scene), u(scene), 0.0)).normalized();
      planes[j] << n, -n.dot(foot);
      problem->AddParameterBlock(planes[j].data(), 4, &plane_manifold);
      const Vec3 e1 = n.unitOrthogonal(), e2 = n.cross(e1);
      std::array<Vec3, 60> points;
      for (Vec3& x : points) x = foot + 0.4 * u(scene) * e1 + 0.4 * u(scene) * e2;
      for (int c = 0; c < 2; ++c) {
        const double shift = error * unit(rng);
        PlaneCluster cluster;
        for (const Vec3& x : points) {
          const Vec3 p = T[c].inverse() * (x + shift * n);
          cluster.AddRay(p, 1.0 / p.z() + noise * unit(rng), kSigma);
          ++pixels;
        }
        problem->AddResidualBlock(PlaneClusterCost::Create(cluster, true), nullptr, poses[c].data(),
                                  planes[j].data());
      }
    }
    if (prior_sigma > 0.0) {
      const Vec3 at = T[1].translation() + prior_sigma * Vec3(unit(rng), unit(rng), unit(rng));
      problem->AddResidualBlock(new ceres::AutoDiffCostFunction<TranslationPrior, 3, 7>(
                                    new TranslationPrior{at, prior_sigma}),
                                nullptr, poses[1].data());
    }
    ceres::Solver::Options options;
    options.linear_solver_type = ceres::DENSE_QR;
    options.max_num_iterations = 20;
    options.function_tolerance = 1e-14;
    options.gradient_tolerance = 1e-14;
    options.parameter_tolerance = 1e-14;
    ceres::Solver::Summary summary;
    ceres::Solve(options, problem.get(), &summary);
  }

  std::vector<double*> PlaneBlocks() {
    std::vector<double*> blocks;
    for (Vec4& plane : planes) blocks.push_back(plane.data());
    return blocks;
  }
};

TEST(MarginalPoseCovariance, RobustCovarianceFollowsErrorsTheNoiseModelDoesNotKnow) {
  // Over many draws of the views' errors, the mean robust covariance of the free pose
  // equals the scatter of its estimates (CR2 is unbiased for a linear model; the errors here
  // move the pose by a fraction of a millimetre), while the noise model's covariance, even
  // scaled by the residuals' spread, is a hundred times too small (0.006 / 0.010 of it): each
  // view's pixels share their error.
  constexpr int kDraws = 300;
  // The scatter's own relative error is ~0.08 (300 draws), and CR2 is exact only for errors
  // alike for all residuals of a cluster: 0.85 (rotation) and 0.92 (translation) of the
  // scatter here, the sandwich without its small-sample correction 0.46 and 0.58.
  constexpr double kTolerance = 0.3;
  Eigen::MatrixXd scatter = Eigen::MatrixXd::Zero(6, 6), robust_mean = scatter,
                  model_mean = scatter;
  for (int draw = 0; draw < kDraws; ++draw) {
    DisplacedViews views(0.002, 0.0, 100 + draw);
    Eigen::MatrixXd robust;
    const Eigen::MatrixXd model = MarginalPoseCovariance(
        views.problem.get(), {views.poses[1].data()}, views.PlaneBlocks(), &robust);
    ASSERT_EQ(model.rows(), 6);
    ASSERT_EQ(robust.rows(), 6);
    double cost = 0.0;
    views.problem->Evaluate(ceres::Problem::EvaluateOptions(), &cost, nullptr, nullptr, nullptr);
    const int parameters = 6 + 3 * DisplacedViews::kPlanes;
    model_mean += model * (2.0 * cost / (views.pixels - parameters)) / kDraws;
    robust_mean += robust / kDraws;
    Vec6 error;
    SharedPoseManifold()->Minus(views.poses[1].data(), views.truth.data(), error.data());
    scatter += error * error.transpose() / kDraws;
  }
  for (const int k : {0, 3}) {  // rotation, translation
    const double expected = scatter.block<3, 3>(k, k).trace();
    const double robust = robust_mean.block<3, 3>(k, k).trace();
    EXPECT_NEAR(robust, expected, kTolerance * expected) << "block " << k << "\nscatter\n"
                                                         << scatter << "\nrobust\n"
                                                         << robust_mean;
    const double model = model_mean.block<3, 3>(k, k).trace();
    EXPECT_LT(model, expected / 20.0) << "block " << k;
  }
}

TEST(MarginalPoseCovariance, RobustCovarianceIsTheModelsUnderTheModel) {
  // Without the views' errors, with each pixel's own noise as modelled, the robust
  // covariance averages to the model's (0.97 and 0.96 of it; without CR2's correction 0.66 and
  // 0.74), and so it does with a prior on the translation (a residual in no cluster, taken as
  // modelled) as strong as the planes (0.99 and 1.00).
  constexpr int kDraws = 200;
  constexpr double kTolerance = 0.15;  // 200 draws of 16 clusters
  for (const double prior_sigma : {0.0, 0.0005}) {
    Eigen::MatrixXd robust_mean = Eigen::MatrixXd::Zero(6, 6), model;
    for (int draw = 0; draw < kDraws; ++draw) {
      DisplacedViews views(0.0, DisplacedViews::kSigma, 100 + draw, prior_sigma);
      Eigen::MatrixXd robust;
      model = MarginalPoseCovariance(views.problem.get(), {views.poses[1].data()},
                                     views.PlaneBlocks(), &robust);
      ASSERT_EQ(robust.rows(), 6);
      robust_mean += robust / kDraws;
    }
    for (const int k : {0, 3}) {
      const double expected = model.block<3, 3>(k, k).trace();
      const double robust = robust_mean.block<3, 3>(k, k).trace();
      EXPECT_NEAR(robust, expected, kTolerance * expected)
          << "block " << k << ", prior sigma " << prior_sigma;
    }
  }
}

/// Two views of a box corner (300 points a face, the source free, the target held, point i
/// matched to point i), both with depth errors along their rays of sigma k z^2 that a share
/// `correlated` of the variance takes from a smooth field (kBumps Gaussian bumps of kBumpM about
/// random points of each camera, one field per view and draw), the rest independent per point.
/// Per draw: the point-to-plane least-squares step from the true poses, and the shared-noise
/// covariance and cluster sandwiches (cells of kCellM) at the estimate.
class CorrelatedCorner {
 public:
  static constexpr double kDepthNoise = 0.003;
  static constexpr double kCellM = 0.25;
  static constexpr double kBumpM = 0.08;
  static constexpr int kBumps = 150;

  explicit CorrelatedCorner(double correlated) : corner_(300, 11), correlated_(correlated) {
    truth_[0] = {0.05, -0.1, 0.02, 0.99, 0.3, -0.1, 0.2};
    truth_[1] = {-0.03, 0.04, 0.1, 0.99, -0.2, 0.1, 0.05};
    for (size_t i = 0; i < corner_.points.size(); ++i) {
      matches_.push_back({static_cast<int>(i), static_cast<int>(i), 0.0});
    }
  }

  /// One draw: its error (the estimate's tangent from the truth) and, at the estimate, the
  /// model's covariance and the inflated one.
  struct Draw {
    Vec6 error;
    Mat6 model, inflated;
  };

  Draw Run(unsigned seed) {
    std::mt19937 rng(seed);
    for (size_t v = 0; v < 2; ++v) {
      blocks_[v] = truth_[v];
      const Pose T = PoseFromParameters(truth_[v].data());
      levels_[v] = CornerLevel(corner_, T, 0);
      Displace(&levels_[v], &rng);
      views_[v] = {&levels_[v], T, blocks_[v].data(), kDepthNoise};
    }
    IcpOptions options;
    options.min_noise_m = 1e-6;  // the noise is the points' only
    const std::unique_ptr<ceres::Problem> problem = NewProblem();
    for (auto& block : blocks_) {
      problem->AddParameterBlock(block.data(), kPoseAmbientSize, SharedPoseManifold());
    }
    const ceres::ResidualBlockId id =
        AddCorrespondenceTerms(problem.get(), options, {&views_[0], &views_[1], &matches_}, nullptr,
                               TermStorage::kStacked);
    std::vector<double> r;
    ceres::CRSMatrix crs;
    EvaluateJacobian(problem.get(), {blocks_[0].data()}, {id}, &r, &crs);
    Eigen::MatrixXd J = Eigen::MatrixXd::Zero(crs.num_rows, 6);
    for (int row = 0; row < crs.num_rows; ++row) {
      for (int a = crs.rows[row]; a < crs.rows[row + 1]; ++a) J(row, crs.cols[a]) = crs.values[a];
    }
    const Eigen::Map<const Eigen::VectorXd> residuals(r.data(),
                                                      static_cast<Eigen::Index>(r.size()));
    Draw draw;
    draw.error = -(J.transpose() * J).ldlt().solve(J.transpose() * residuals);
    SharedPoseManifold()->Plus(truth_[0].data(), draw.error.data(), blocks_[0].data());
    views_[0].T_world_camera = PoseFromParameters(blocks_[0].data());
    const std::vector<MatchedViews> terms = {{&views_[0], &views_[1], &matches_}};
    ClusterSandwiches sandwiches;
    sandwiches.cell_m = kCellM;
    draw.model = SharedNoiseCovariance({views_, {0, -1}, terms}, options,
                                       Eigen::MatrixXd::Zero(6, 6), 1, &sandwiches);
    draw.inflated = Inflated(draw.model, InflationOf(sandwiches, 0));
    return draw;
  }

 private:
  /// Moves every point of `level` along its ray by its depth error.
  void Displace(ScaleLevel* level, std::mt19937* rng) const {
    std::normal_distribution<double> gauss;
    std::uniform_int_distribution<size_t> any(0, level->points.size() - 1);
    std::vector<std::pair<Vec3, double>> bumps(kBumps);
    for (auto& [c, a] : bumps) {
      c = level->points[any(*rng)] + kBumpM * Vec3(gauss(*rng), gauss(*rng), gauss(*rng));
      a = gauss(*rng);
    }
    std::vector<double> field(level->points.size(), 0.0);
    double sum2 = 0.0;
    for (size_t i = 0; i < level->points.size(); ++i) {
      for (const auto& [c, a] : bumps) {
        field[i] += a * std::exp(-(level->points[i] - c).squaredNorm() / (2.0 * kBumpM * kBumpM));
      }
      sum2 += field[i] * field[i];
    }
    const double rms = std::sqrt(sum2 / static_cast<double>(field.size()));
    for (size_t i = 0; i < level->points.size(); ++i) {
      Vec3& p = level->points[i];
      const double z = p.z();
      const double unit =
          std::sqrt(1.0 - correlated_) * gauss(*rng) + std::sqrt(correlated_) * field[i] / rms;
      // Along the ray by the depth error, and the plane-error share in every direction.
      const Vec3 plane(gauss(*rng), gauss(*rng), gauss(*rng));
      p += kDepthNoise * z * (unit * p + IcpOptions().plane_noise_share * z * plane);
    }
  }

  BoxCorner corner_;
  double correlated_;
  std::array<std::array<double, kPoseAmbientSize>, 2> truth_, blocks_;
  std::array<ScaleLevel, 2> levels_;
  std::vector<CameraView> views_ = std::vector<CameraView>(2);
  std::vector<Correspondence> matches_;
};

/// Over draws: RMS error, and the RMS 1-sigma of the model and the inflated covariance, for
/// rotation (k = 0) and translation (k = 3).
struct Coverage {
  double error2[2] = {0, 0}, model2[2] = {0, 0}, inflated2[2] = {0, 0};
  int draws = 0;

  void Add(const CorrelatedCorner::Draw& d) {
    for (int h = 0; h < 2; ++h) {
      error2[h] += d.error.segment<3>(3 * h).squaredNorm();
      model2[h] += d.model.block<3, 3>(3 * h, 3 * h).trace();
      inflated2[h] += d.inflated.block<3, 3>(3 * h, 3 * h).trace();
    }
    ++draws;
  }
  double ErrorOverModel(int h) const { return std::sqrt(error2[h] / model2[h]); }
  double ErrorOverInflated(int h) const { return std::sqrt(error2[h] / inflated2[h]); }
  double InflatedOverModel(int h) const { return std::sqrt(inflated2[h] / model2[h]); }
};

/// The coverage over 60 draws of the corner with `correlated` of its depth variance smooth.
Coverage CoverageOf60Draws(double correlated) {
  Coverage c;
  CorrelatedCorner corner(correlated);
  for (unsigned draw = 0; draw < 60; ++draw) c.Add(corner.Run(100 + draw));
  return c;
}

TEST(SharedNoiseCovariance, InflationLeavesTheModelOnIndependentErrors) {
  // Errors as the noise model says (each point's own): the cells' sandwich is the points' one,
  // the inflation about 1 and the model's 1-sigma kept. Measured over 60 draws: the inflated
  // 1-sigma 1.10 times the model's in rotation and translation (the floor at 1 of a noisy
  // ratio); the errors 0.97 / 0.91 of the model's 1-sigma.
  const Coverage c = CoverageOf60Draws(0.0);
  for (int h = 0; h < 2; ++h) {
    EXPECT_LT(c.InflatedOverModel(h), 1.2) << "half " << h;
    EXPECT_NEAR(c.ErrorOverModel(h), 1.0, 0.2) << "half " << h;
  }
}

TEST(SharedNoiseCovariance, InflationCoversErrorsCorrelatedOverNeighbours) {
  // 80% of the depth variance from a field smooth over 8 cm (cells of 25 cm): the model's
  // 1-sigma is 2.46 (rotation) and 2.62 (translation) times too small over 60 draws; inflated
  // by 1.69 / 1.79, the errors are 1.46 / 1.47 of it (a cell does not hold the field's
  // correlation across its faces). Tolerances about twice those misses.
  const Coverage c = CoverageOf60Draws(0.8);
  for (int h = 0; h < 2; ++h) {
    EXPECT_GT(c.ErrorOverModel(h), 2.0) << "half " << h;
    EXPECT_GT(c.ErrorOverInflated(h), 0.5) << "half " << h;
    EXPECT_LT(c.ErrorOverInflated(h), 1.9) << "half " << h;
  }
}

TEST(CovarianceAtLeast, RaisesEachDirectionWhereTheOtherIsSmaller) {
  const Mat3 R = ExpSO3(Vec3(0.3, -0.5, 0.2));
  const Eigen::MatrixXd model = R * Vec3(1.0, 4.0, 9.0).asDiagonal() * R.transpose();
  // In the model's whitened frame: 2 (kept), 0.5 (raised to 1) and 1 (kept) along its axes.
  const Eigen::MatrixXd other = R * Vec3(2.0, 2.0, 9.0).asDiagonal() * R.transpose();
  const Eigen::MatrixXd expected = R * Vec3(2.0, 4.0, 9.0).asDiagonal() * R.transpose();
  EXPECT_LE((CovarianceAtLeast(model, other) - expected).norm(), 1e-12 * expected.norm());
  EXPECT_LE((CovarianceAtLeast(model, 0.5 * model) - model).norm(), 1e-12 * model.norm());
  EXPECT_LE((CovarianceAtLeast(model, 3.0 * model) - 3.0 * model).norm(), 1e-12 * model.norm());
  // Not sharing the model's axes: at least both, and equal to neither.
  const Mat3 Q = ExpSO3(Vec3(-0.7, 0.1, 0.9));
  const Eigen::MatrixXd tilted = Q * Vec3(0.3, 12.0, 5.0).asDiagonal() * Q.transpose();
  const Eigen::MatrixXd raised = CovarianceAtLeast(model, tilted);
  EXPECT_EQ(raised, raised.transpose());
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> above_model(raised - model);
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> above_other(raised - tilted);
  EXPECT_GE(above_model.eigenvalues().minCoeff(), -1e-12 * raised.norm());
  EXPECT_GE(above_other.eigenvalues().minCoeff(), -1e-12 * raised.norm());
  EXPECT_GT((raised - model).norm(), 0.1);
  EXPECT_GT((raised - tilted).norm(), 0.1);
  EXPECT_THROW(CovarianceAtLeast(Eigen::MatrixXd::Zero(3, 3), tilted), std::invalid_argument);
}

TEST(MarginalPoseCovariance, RefusesTermsTyingTwoNuisanceBlocks) {
  PlaneBundle bundle;
  // Two planes tied by one residual: their information is no longer block diagonal.
  bundle.problem->AddResidualBlock(
      new ceres::AutoDiffCostFunction<TiedPlanes, 1, 4, 4>(new TiedPlanes), nullptr,
      bundle.planes[1].data(), bundle.planes[2].data());
  std::vector<double*> planes;
  for (Vec4& plane : bundle.planes) planes.push_back(plane.data());
  Eigen::MatrixXd robust;
  EXPECT_THROW(
      MarginalPoseCovariance(bundle.problem.get(), {bundle.poses[1].data()}, planes, &robust),
      std::logic_error);
  EXPECT_THROW(MarginalPoseCovariance(bundle.problem.get(), {bundle.poses[1].data()}, planes),
               std::logic_error);
}

}  // namespace
}  // namespace rigfit
