#include "prepare/correspondences.h"

#include <algorithm>
#include <cmath>

#include "core/parallel.h"
#include "residuals/compressed_cost.h"
#include "residuals/gicp.h"
#include "residuals/point_to_plane.h"
#include "residuals/stacked_cost.h"

namespace rigfit {
namespace {

/// A normal angle that accepts every pair of normals (overlap statistics).
constexpr double kAnyNormalAngleDeg = 180.0;

/// The normal check never widens beyond this (degrees): far below the 90 degrees between
/// the faces of a box corner or a leg, which must not pair up.
constexpr double kWidestNoisyNormalAngleDeg = 60.0;

}  // namespace

Mat3 PointNoise(const CameraView& view, const Vec3& p, const IcpOptions& options,
                double floor_share) {
  const double k2 = view.depth_noise * view.depth_noise;
  const double share2 = options.plane_noise_share * options.plane_noise_share;
  return k2 * p.z() * p.z() * p * p.transpose() +
         (share2 * k2 * std::pow(p.z(), 4) +
          floor_share * options.min_noise_m * options.min_noise_m) *
             Mat3::Identity();
}

PointToPlaneTerm MakePointToPlaneTerm(const CameraView& source, const CameraView& target,
                                      const Correspondence& c, const IcpOptions& options) {
  const double variance = PointToPlaneVariance(source, target, c, options);
  return {source.level->points[c.source], target.level->points[c.target],
          target.level->geometry.normals[c.target] / std::sqrt(variance)};
}

GicpTerm MakeGicpTerm(const CameraView& source, const CameraView& target, const Correspondence& c,
                      const IcpOptions& options) {
  const auto covariance = [&](const CameraView& view, int i) {
    const LocalGeometry& g = view.level->geometry;
    return Mat3(g.covariances[i] - kGicpPlaneEpsilon * g.normals[i] * g.normals[i].transpose() +
                PointNoise(view, view.level->points[i], options, 0.5));
  };
  return GicpCost::MakeTerm(source.level->points[c.source], target.level->points[c.target],
                            covariance(source, c.source), covariance(target, c.target),
                            source.T_world_camera.linear(), target.T_world_camera.linear());
}

std::vector<Correspondence> FindCorrespondences(const CameraView& source, const CameraView& target,
                                                double max_distance, double max_normal_angle_deg,
                                                int num_threads) {
  const ScaleLevel& src = *source.level;
  const ScaleLevel& tgt = *target.level;
  const Pose T_target_source = target.T_world_camera.inverse() * source.T_world_camera;
  const double max_angle = max_normal_angle_deg * kDegToRad;
  const double widest_angle = std::max(max_angle, kWidestNoisyNormalAngleDeg * kDegToRad);
  const double cos_max_angle = std::cos(max_angle);
  const double cos_widest_angle = std::cos(widest_angle);
  // The normal error of a point, as an angle: its depth noise over its normal's support.
  const auto normal_error = [](const CameraView& view, const Vec3& p) {
    const double support = view.level->normal_support;
    return support > 0.0 ? std::atan(view.depth_noise * p.z() * p.z() / support) : 0.0;
  };
  const int n = static_cast<int>(src.points.size());
  std::vector<Correspondence> found(n);
  std::vector<char> ok(n, 0);
  ParallelFor(n, num_threads, [&](int i) {
    if (!src.geometry.IsValid(i)) return;
    int j = 0;
    double d2 = 0.0;
    if (!tgt.Nearest(T_target_source * src.points[i], max_distance, &j, &d2) ||
        !tgt.geometry.IsValid(j)) {
      return;
    }
    // The widened angle lies between max_angle and widest_angle: only normals between the
    // two need it.
    const double cos_between =
        (T_target_source.linear() * src.geometry.normals[i]).dot(tgt.geometry.normals[j]);
    if (cos_between < cos_widest_angle) return;
    if (cos_between < cos_max_angle) {
      const double angle = std::min(
          max_angle + normal_error(source, src.points[i]) + normal_error(target, tgt.points[j]),
          widest_angle);
      if (cos_between < std::cos(angle)) return;
    }
    found[i] = {i, j, d2};
    ok[i] = 1;
  });
  std::vector<Correspondence> out;
  out.reserve(n);
  for (int i = 0; i < n; ++i) {
    if (ok[i]) out.push_back(found[i]);
  }
  return out;
}

bool StepConverged(const Vec6& step, double voxel_size, bool finest) {
  // A coarser scale only has to bring the cameras well inside the next scale's
  // correspondence distance: 0.05 of its own voxel against 1.4 of the next one's (half as
  // large by default) is 14 times inside.
  constexpr double kConvergedStepVoxels = 0.01;
  constexpr double kCoarseConvergedStepVoxels = 0.05;
  const double limit = (finest ? kConvergedStepVoxels : kCoarseConvergedStepVoxels) * voxel_size;
  constexpr double kLeverM = 1.0;  // rotation as arc length at this radius
  return step.head<3>().norm() * kLeverM < limit && step.tail<3>().norm() < limit;
}

double PointToPlaneVariance(const CameraView& source, const CameraView& target,
                            const Correspondence& c, const IcpOptions& options) {
  const Vec3& p = source.level->points[c.source];
  const Vec3& q = target.level->points[c.target];
  const Vec3& n_t = target.level->geometry.normals[c.target];
  // The target normal in the source frame: R_s^T R_t n_t.
  const double np =
      (source.T_world_camera.linear().transpose() * (target.T_world_camera.linear() * n_t)).dot(p);
  const double nq = n_t.dot(q);
  const double k_s = source.depth_noise * p.z() * np;
  const double k_t = target.depth_noise * q.z() * nq;
  // The share of the whole depth noise that counts whatever the normal.
  const double f_s = options.plane_noise_share * source.depth_noise * p.z() * p.z();
  const double f_t = options.plane_noise_share * target.depth_noise * q.z() * q.z();
  return k_s * k_s + k_t * k_t + f_s * f_s + f_t * f_t + options.min_noise_m * options.min_noise_m;
}

ceres::LossFunction* MakeCorrespondenceLoss(const IcpOptions& options) {
  const double scale = options.robust_loss_scale;
  switch (options.robust_loss) {
    case RobustLoss::kHuber:
      return new ceres::HuberLoss(scale);
    case RobustLoss::kCauchy:
      return new ceres::CauchyLoss(scale);
    case RobustLoss::kTukey:
      return new ceres::TukeyLoss(scale);
    case RobustLoss::kNone:
      return nullptr;
  }
  return nullptr;
}

std::unique_ptr<ceres::CostFunction> CorrespondenceCost(const IcpOptions& options,
                                                        const MatchedViews& m,
                                                        const ceres::LossFunction* loss,
                                                        TermStorage storage) {
  const CameraView& source = *m.source;
  const CameraView& target = *m.target;
  const std::vector<Correspondence>& correspondences = *m.matches;
  // term(c) of every correspondence c into `cost`, weighted by the loss at the views' poses
  // (the residuals from the poses' features, computed once).
  const auto add_terms = [&](auto* cost, const auto& term) {
    using Term = std::decay_t<decltype(term(correspondences.front()))>;
    double theta[Term::kFeatureSize];
    Term::Features(source.pose_block, target.pose_block, theta, nullptr, nullptr);
    for (const Correspondence& c : correspondences) {
      const Term t = term(c);
      double r[Term::kNumResiduals];
      t.ResidualAt(theta, r);
      cost->Add(t, RobustWeight(loss, r, Term::kNumResiduals));
    }
  };
  const auto add_block = [&](const auto& term) -> std::unique_ptr<ceres::CostFunction> {
    if (correspondences.empty()) return nullptr;
    using Term = std::decay_t<decltype(term(correspondences.front()))>;
    if (storage == TermStorage::kStacked) {
      auto stacked = std::make_unique<StackedCost<Term>>();
      stacked->Reserve(correspondences.size());
      add_terms(stacked.get(), term);
      return stacked;
    }
    auto compressed = std::make_unique<CompressedCost<Term>>();
    add_terms(compressed.get(), term);
    compressed->Compress();
    return compressed;
  };
  if (options.method == RegistrationMethod::kGicp) {
    return add_block(
        [&](const Correspondence& c) { return MakeGicpTerm(source, target, c, options); });
  }
  return add_block(
      [&](const Correspondence& c) { return MakePointToPlaneTerm(source, target, c, options); });
}

ceres::ResidualBlockId AddCorrespondenceTerms(ceres::Problem* problem, const IcpOptions& options,
                                              const MatchedViews& m,
                                              const ceres::LossFunction* loss,
                                              TermStorage storage) {
  std::unique_ptr<ceres::CostFunction> cost = CorrespondenceCost(options, m, loss, storage);
  if (cost == nullptr) return nullptr;
  return problem->AddResidualBlock(cost.release(), nullptr, m.source->pose_block,
                                   m.target->pose_block);
}

std::unique_ptr<ceres::Problem> NewProblem() {
  ceres::Problem::Options options;
  options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return std::make_unique<ceres::Problem>(options);
}

ceres::Manifold* SharedPoseManifold() {
  static PoseManifold manifold;
  return &manifold;
}

OverlapStats MeasureOverlap(const CameraView& source, const CameraView& target,
                            double coarsest_voxel_size, const IcpOptions& options,
                            int num_threads) {
  OverlapStats stats;
  const size_t n = source.level->points.size();
  if (n == 0) return stats;
  const double factor = options.max_correspondence_distance_factor;
  const double fit_distance = factor * source.level->voxel_size;
  // One search at the wider distance serves both: a point's nearest neighbour within the
  // narrower one is its nearest neighbour within the wider one, when that is close enough.
  const std::vector<Correspondence> matches = FindCorrespondences(
      source, target, factor * std::max(coarsest_voxel_size, source.level->voxel_size),
      kAnyNormalAngleDeg, num_threads);
  stats.fitness = static_cast<double>(matches.size()) / n;
  double sum = 0.0;
  int fits = 0;
  for (const Correspondence& c : matches) {
    if (c.squared_distance >= fit_distance * fit_distance) continue;
    sum += c.squared_distance;
    ++fits;
  }
  stats.rmse_m = fits > 0 ? std::sqrt(sum / fits) : 0.0;
  return stats;
}

double FitRmse(const CameraView& source, const CameraView& target, const IcpOptions& options,
               int num_threads) {
  // A coarsest voxel of 0 makes the fitness distance the view's own, so the one search stays
  // within it.
  return MeasureOverlap(source, target, 0.0, options, num_threads).rmse_m;
}

}  // namespace rigfit
