#include "solver/correspondences.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>

#include "core/pose.h"

namespace rigfit {
namespace {

/// A one-point level at depth z (camera frame, on the optical axis) whose normal is turned
/// by angle_deg about the camera's x axis from facing the camera.
ScaleLevel OnePointLevel(double z, double angle_deg) {
  ScaleLevel level;
  level.voxel_size = 0.02;
  level.normal_support = 0.05;
  level.points = {Vec3(0.0, 0.0, z)};
  level.tree = std::make_unique<KdTree>(level.points);
  const double a = angle_deg * kDegToRad;
  level.geometry.normals = {Vec3(0.0, std::sin(a), -std::cos(a))};
  level.geometry.covariances = {Mat3::Identity()};
  level.geometry.planarity = {1.0};
  return level;
}

/// Whether a source point and a target point at the same place (same pose, depth z), their
/// normals angle_deg apart, pair up under the 30-degree check with depth noise k.
bool Pairs(double z, double angle_deg, double k) {
  const ScaleLevel source = OnePointLevel(z, 0.0);
  const ScaleLevel target = OnePointLevel(z, angle_deg);
  const CameraView s{&source, Pose::Identity(), nullptr, k};
  const CameraView t{&target, Pose::Identity(), nullptr, k};
  return FindCorrespondences(s, t, 0.1, 30.0, 1).size() == 1;
}

TEST(FindCorrespondences, NoiseFreeNormalsMustAgreeWithinTheGivenAngle) {
  EXPECT_TRUE(Pairs(3.0, 28.0, 0.0));
  EXPECT_FALSE(Pairs(3.0, 32.0, 0.0));
}

TEST(FindCorrespondences, TheNormalCheckWidensWithTheDepthNoiseOfBothPoints) {
  // k z^2 = 0.0045 m over a 0.05 m support: atan(0.09) = 5.14 deg per point, 40.3 in all.
  EXPECT_TRUE(Pairs(3.0, 39.0, 0.0005));
  EXPECT_FALSE(Pairs(3.0, 42.0, 0.0005));
  // Nearer, less noise: 1.5 m gives 1.29 deg per point, 32.6 in all.
  EXPECT_TRUE(Pairs(1.5, 32.0, 0.0005));
  EXPECT_FALSE(Pairs(1.5, 34.0, 0.0005));
}

TEST(FindCorrespondences, NoNoiseWidensTheCheckBeyondSixtyDegrees) {
  // 2.3 cm of depth noise per point would add 48 deg; the check stops at 60 degrees, far
  // from the 90 degrees between the faces of a box corner.
  EXPECT_TRUE(Pairs(3.0, 58.0, 0.0025));
  EXPECT_FALSE(Pairs(3.0, 62.0, 0.0025));
  EXPECT_FALSE(Pairs(3.0, 90.0, 1.0));
}

TEST(StepConverged, CoarseScalesStopAtAFifthOfTheFinestScalesPrecision) {
  // At a 2 cm voxel the finest scale stops below 0.2 mm (and 0.2 mrad), a coarser one
  // below 1 mm (and 1 mrad).
  const auto step = [](double rotation_rad, double translation_m) {
    return (Vec6() << 0.0, rotation_rad, 0.0, translation_m, 0.0, 0.0).finished();
  };
  EXPECT_TRUE(StepConverged(step(0.0, 0.00015), 0.02, /*finest=*/true));
  EXPECT_FALSE(StepConverged(step(0.0, 0.00025), 0.02, /*finest=*/true));
  EXPECT_FALSE(StepConverged(step(0.00025, 0.0), 0.02, /*finest=*/true));
  EXPECT_TRUE(StepConverged(step(0.0009, 0.0009), 0.02, /*finest=*/false));
  EXPECT_FALSE(StepConverged(step(0.0, 0.0011), 0.02, /*finest=*/false));
  EXPECT_FALSE(StepConverged(step(0.0011, 0.0), 0.02, /*finest=*/false));
}

/// A level of the given points at the finest voxel (2 cm), every normal facing the camera.
ScaleLevel FacingLevel(const PointCloud& points) {
  ScaleLevel level;
  level.voxel_size = 0.02;
  level.normal_support = 0.05;
  level.points = points;
  level.tree = std::make_unique<KdTree>(level.points);
  level.geometry.normals.assign(points.size(), Vec3(0.0, 0.0, -1.0));
  level.geometry.covariances.assign(points.size(), Mat3::Identity());
  level.geometry.planarity.assign(points.size(), 1.0);
  return level;
}

TEST(MeasureOverlap, FitnessWithinTheCoarsestScalesDistanceRmseWithinTheViewsOwn) {
  // The target: a 2 cm grid on the wall z = 2. The source: points in front of grid points
  // at distances inside the finest scale's correspondence distance (1.4 x 2 cm), inside
  // only the coarsest one's (1.4 x 8 cm) and beyond both.
  PointCloud grid;
  for (int i = -10; i <= 10; ++i) {
    for (int j = -10; j <= 10; ++j) grid.emplace_back(0.02 * i, 0.02 * j, 2.0);
  }
  const std::vector<double> gaps = {0.01, 0.02, 0.05, 0.1, 0.2};
  PointCloud in_front;
  for (size_t i = 0; i < gaps.size(); ++i) in_front.emplace_back(0.04 * i, 0.0, 2.0 - gaps[i]);
  const ScaleLevel target = FacingLevel(grid);
  const ScaleLevel source = FacingLevel(in_front);
  const CameraView s{&source, Pose::Identity(), nullptr, 0.0};
  const CameraView t{&target, Pose::Identity(), nullptr, 0.0};
  const OverlapStats stats = MeasureOverlap(s, t, 0.08, IcpOptions(), 2);
  EXPECT_DOUBLE_EQ(stats.fitness, 4.0 / 5.0);
  EXPECT_NEAR(stats.rmse_m, std::sqrt((0.01 * 0.01 + 0.02 * 0.02) / 2.0), 1e-12);
  // No source point near the target: no fitness, no RMSE.
  const ScaleLevel far = FacingLevel({Vec3(0.0, 0.0, 1.0)});
  const CameraView f{&far, Pose::Identity(), nullptr, 0.0};
  EXPECT_EQ(MeasureOverlap(f, t, 0.08, IcpOptions(), 1).fitness, 0.0);
  EXPECT_EQ(MeasureOverlap(f, t, 0.08, IcpOptions(), 1).rmse_m, 0.0);
}

/// Two views of the three faces of a box corner (normals along the world axes), noisy depth
/// k = 0.003 /m, from two poses; point i of one is point i of the other (correspondence
/// i <-> i at distance 0).
class SharedNoiseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    std::mt19937 rng(5);
    std::uniform_real_distribution<double> u(0.1, 1.0);
    PointCloud world, normals;
    for (int face = 0; face < 3; ++face) {
      for (int i = 0; i < 40; ++i) {
        Vec3 p(u(rng), u(rng), u(rng));
        p(face) = 0.0;
        world.push_back(p + Vec3(-0.5, -0.5, 2.5));
        normals.push_back(-Vec3::Unit(face));
      }
    }
    const Pose T_source =
        PoseFromParameters(std::array<double, 7>{0.05, -0.1, 0.02, 0.99, 0.3, -0.1, 0.2}.data());
    const Pose T_target =
        PoseFromParameters(std::array<double, 7>{-0.03, 0.04, 0.1, 0.99, -0.2, 0.1, 0.05}.data());
    // The points and normals of the world in a camera at T.
    const auto seen_from = [&](const Pose& T, PointCloud* points, PointCloud* normals_in) {
      for (size_t i = 0; i < world.size(); ++i) {
        points->push_back(T.inverse() * world[i]);
        normals_in->push_back(T.linear().transpose() * normals[i]);
      }
    };
    PointCloud source_points, source_normals, target_points, target_normals;
    seen_from(T_source, &source_points, &source_normals);
    seen_from(T_target, &target_points, &target_normals);
    for (size_t i = 0; i < world.size(); ++i) {
      matches_.push_back({static_cast<int>(i), static_cast<int>(i), 0.0});
    }
    source_ = Level(source_points, source_normals);
    target_ = Level(target_points, target_normals);
    PoseToParameters(T_source, blocks_[0].data());
    PoseToParameters(T_target, blocks_[1].data());
    views_ = {{&source_, T_source, blocks_[0].data(), 0.003},
              {&target_, T_target, blocks_[1].data(), 0.003}};
  }

  static ScaleLevel Level(const PointCloud& points, const PointCloud& normals) {
    ScaleLevel level;
    level.voxel_size = 0.02;
    level.normal_support = 0.05;
    level.points = points;
    level.geometry.normals = normals;
    for (const Vec3& n : normals) {
      level.geometry.covariances.push_back(Mat3::Identity() - (1.0 - 1e-3) * n * n.transpose());
    }
    level.geometry.planarity.assign(points.size(), 1.0);
    return level;
  }

  /// SharedNoiseCovariance of the source pose (the target held) over `terms`.
  Eigen::MatrixXd Shared(const std::vector<MatchedViews>& terms, const IcpOptions& options) {
    return SharedNoiseCovariance(views_, {0, -1}, terms, options, Eigen::MatrixXd::Zero(6, 6), 2);
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
      ids.push_back(AddCorrespondenceTerms(problem.get(), options, *t.source, *t.target, *t.matches,
                                           nullptr, TermStorage::kStacked));
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

}  // namespace
}  // namespace rigfit
