#include "prepare/ground.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "core/geometry.h"

namespace rigfit {
namespace {

/// Noise is estimated from points within this multiple of the RANSAC distance of the floor.
constexpr double kNoiseWindowFactor = 5.0;
/// Points scored per RANSAC hypothesis; the final fit uses every candidate.
constexpr size_t kMaxScoredPoints = 4000;
/// Least-squares refits of the winning plane. Each refit re-collects inliers within 3x the
/// previous inlier RMS (never more than the RANSAC distance, never less than kMinRefitDistance),
/// so that the feet of walls, baseboards and boxes within the RANSAC distance of the floor
/// stop biasing the plane once the floor's own spread is known.
constexpr int kRefits = 5;
constexpr double kRefitSigmas = 3.0;
constexpr double kMinRefitDistance = 1e-3;
/// Noise-weighted refits after the inliers are settled.
constexpr int kWeightedRefits = 2;

/// The floor through points[indices] (FitPlane; weights empty: all 1), its normal up.
PlanarFace FitFloor(const PointCloud& points, const std::vector<int>& indices,
                    const std::vector<double>& weights) {
  PlanarFace plane = FitPlane(
      indices.size(), [&](size_t k) -> const Vec3& { return points[indices[k]]; },
      [&](size_t k) { return weights.empty() ? 1.0 : weights[k]; });
  if (plane.normal.y() < 0.0) {
    plane.normal = -plane.normal;
    plane.offset = -plane.offset;
  }
  return plane;
}

/// The world plane in the camera frame: n_w . (R p + t) + d = 0  =>  n_c = R^T n_w,
/// d_c = n_w . t + d.
PlanarFace PlaneInCameraFrame(const PlanarFace& plane_world, const Pose& T_world_camera) {
  return {T_world_camera.linear().transpose() * plane_world.normal,
          plane_world.normal.dot(T_world_camera.translation()) + plane_world.offset,
          plane_world.floor};
}

std::vector<int> Inliers(const PointCloud& points, const std::vector<int>& candidates,
                         const PlanarFace& plane, double distance) {
  std::vector<int> inliers;
  for (int i : candidates) {
    if (std::abs(plane.SignedDistance(points[i])) <= distance) inliers.push_back(i);
  }
  return inliers;
}

std::string Format(const char* what, double value, const char* unit, double limit) {
  std::ostringstream s;
  s.precision(3);
  s << what << " " << value << " " << unit << " exceeds the limit of " << limit << " " << unit;
  return s.str();
}

}  // namespace

double EstimateDepthNoise(const PointCloud& points_camera, const PlanarFace& plane_camera,
                          double window) {
  std::vector<double> ratios;
  for (const Vec3& p : points_camera) {
    const double r = plane_camera.SignedDistance(p);
    const double lever = p.z() * std::abs(plane_camera.normal.dot(p));
    if (std::abs(r) <= window && lever > 1e-9) ratios.push_back(std::abs(r) / lever);
  }
  if (ratios.empty()) return 0.0;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
  return 1.4826 * ratios[ratios.size() / 2];
}

Pose LevelingCorrection(const PlanarFace& plane_world, const Vec3& pivot) {
  // R takes the plane normal onto +Y about the horizontal axis n x e_y (no yaw change).
  const Mat3 R =
      Eigen::Quaterniond::FromTwoVectors(plane_world.normal, kWorldUp).toRotationMatrix();
  // x' = R (x - pivot) + (pivot_x, 0, pivot_z): the plane through the pivot lands on y = 0.
  Pose C = Pose::Identity();
  C.linear() = R;
  C.translation() = Vec3(pivot.x(), 0.0, pivot.z()) - R * pivot;
  return C;
}

namespace {

/// The points at most search_height_m above the lowest ones (2nd percentile, so that a few
/// outliers below the floor do not move the window).
std::vector<int> FloorCandidates(const PointCloud& points, double search_height_m) {
  std::vector<double> heights(points.size());
  for (size_t i = 0; i < points.size(); ++i) heights[i] = points[i].y();
  const size_t k = points.size() / 50;
  std::nth_element(heights.begin(), heights.begin() + k, heights.end());
  const double y_low = heights[k];
  std::vector<int> candidates;
  for (size_t i = 0; i < points.size(); ++i) {
    if (points[i].y() <= y_low + search_height_m) candidates.push_back(static_cast<int>(i));
  }
  return candidates;
}

/// RANSAC over a fixed subset of the candidates, hypotheses limited to near-horizontal
/// planes. Returns the number of scored points within the RANSAC distance of `best`.
size_t RansacFloor(const PointCloud& points, const std::vector<int>& candidates,
                   const GroundOptions& options, PlanarFace* best) {
  std::mt19937_64 rng(options.seed);
  std::vector<int> scored = candidates;
  if (scored.size() > kMaxScoredPoints) {
    for (size_t i = 0; i < kMaxScoredPoints; ++i) {
      std::swap(scored[i], scored[i + rng() % (scored.size() - i)]);
    }
    scored.resize(kMaxScoredPoints);
  }
  const double cos_max_angle = std::cos(options.max_normal_angle_deg * kDegToRad);
  size_t best_count = 0;
  for (int it = 0; it < options.ransac_iterations; ++it) {
    const Vec3& a = points[scored[rng() % scored.size()]];
    const Vec3& b = points[scored[rng() % scored.size()]];
    const Vec3& c = points[scored[rng() % scored.size()]];
    Vec3 n = (b - a).cross(c - a);
    const double norm = n.norm();
    if (norm < 1e-12) continue;
    n /= norm;
    if (n.y() < 0.0) n = -n;
    if (n.y() < cos_max_angle) continue;
    const PlanarFace hypothesis{n, -n.dot(a)};
    size_t count = 0;
    for (int i : scored)
      count += std::abs(hypothesis.SignedDistance(points[i])) <= options.ransac_distance_m;
    if (count > best_count) {
      best_count = count;
      *best = hypothesis;
    }
  }
  return best_count;
}

/// Least-squares refits of `best` on its inliers (kRefits): returns the settled inliers.
std::vector<int> RefitFloor(const PointCloud& points, const std::vector<int>& candidates,
                            double ransac_distance_m, PlanarFace* best) {
  std::vector<int> inliers = Inliers(points, candidates, *best, ransac_distance_m);
  double distance = ransac_distance_m;
  for (int refit = 0; refit < kRefits && inliers.size() >= 3; ++refit) {
    *best = FitFloor(points, inliers, {});
    double sum_sq = 0.0;
    for (int i : inliers) sum_sq += std::pow(best->SignedDistance(points[i]), 2);
    const double rms = std::sqrt(sum_sq / inliers.size());
    distance = std::clamp(kRefitSigmas * rms, kMinRefitDistance, ransac_distance_m);
    inliers = Inliers(points, candidates, *best, distance);
  }
  return inliers;
}

/// Depth noise grows as z^2 along the rays: refits with weights 1 / sigma_i^2, sigma_i the
/// distance-to-plane part of each point's noise (EstimateDepthNoise) plus the RANSAC floor, so
/// that far, noisy floor points no longer dominate the plane.
PlanarFace WeightedRefitFloor(const PointCloud& points, const PointCloud& points_camera,
                              const std::vector<int>& inliers, const Pose& T_world_camera,
                              double noise_window_m, PlanarFace best) {
  for (int refit = 0; refit < kWeightedRefits; ++refit) {
    const PlanarFace plane_camera = PlaneInCameraFrame(best, T_world_camera);
    const double k = EstimateDepthNoise(points_camera, plane_camera, noise_window_m);
    std::vector<double> weights(inliers.size());
    for (size_t j = 0; j < inliers.size(); ++j) {
      const Vec3& p = points_camera[inliers[j]];
      const double sigma = k * p.z() * std::abs(plane_camera.normal.dot(p));
      weights[j] = 1.0 / (sigma * sigma + kMinRefitDistance * kMinRefitDistance);
    }
    best = FitFloor(points, inliers, weights);
  }
  return best;
}

/// The floor's inlier RMS and the pivot of the correction: the inliers' mean, moved onto the
/// plane.
Vec3 FloorPivot(const PointCloud& points, const std::vector<int>& inliers, const PlanarFace& best,
                double* inlier_rms_m) {
  double sum_sq = 0.0;
  Vec3 pivot = Vec3::Zero();
  for (int i : inliers) {
    sum_sq += std::pow(best.SignedDistance(points[i]), 2);
    pivot += points[i];
  }
  *inlier_rms_m = std::sqrt(sum_sq / inliers.size());
  pivot /= static_cast<double>(inliers.size());
  pivot -= best.SignedDistance(pivot) * best.normal;  // exactly on the plane
  return pivot;
}

/// The correction that takes the found floor to y = 0, accepted within the options' limits.
void ApplyCorrection(const Pose& T_world_camera, const Vec3& pivot, const GroundOptions& options,
                     GroundResult* result) {
  const Pose C = LevelingCorrection(result->plane_world, pivot);
  const Pose leveled = C * T_world_camera;
  result->correction_rotation_deg = RotationAngle(C.linear()) / kDegToRad;
  result->correction_translation_m = (leveled.translation() - T_world_camera.translation()).norm();
  if (result->correction_rotation_deg > options.max_rotation_deg) {
    result->message = Format("leveling rotation", result->correction_rotation_deg, "deg",
                             options.max_rotation_deg);
    return;
  }
  if (result->correction_translation_m > options.max_translation_m) {
    result->message = Format("leveling translation", result->correction_translation_m, "m",
                             options.max_translation_m);
    return;
  }
  result->accepted = true;
  result->correction = C;
  result->T_world_camera = leveled;
}

}  // namespace

GroundResult LevelCamera(const PointCloud& points_camera, const Pose& T_world_camera,
                         const GroundOptions& options) {
  GroundResult result;
  result.T_world_camera = T_world_camera;
  if (points_camera.size() < 3) {
    result.message = "no floor: fewer than 3 valid points";
    return result;
  }
  const PointCloud points = Transform(T_world_camera, points_camera);
  const std::vector<int> candidates = FloorCandidates(points, options.search_height_m);
  if (static_cast<int>(candidates.size()) < std::max(3, options.min_inliers)) {
    result.message = "no floor: only " + std::to_string(candidates.size()) +
                     " points near the lowest ones (min_inliers " +
                     std::to_string(options.min_inliers) + ")";
    return result;
  }
  PlanarFace best;
  if (RansacFloor(points, candidates, options, &best) < 3) {
    result.message = "no floor: no plane within " + std::to_string(options.max_normal_angle_deg) +
                     " deg of horizontal among the lowest points";
    return result;
  }
  const std::vector<int> inliers = RefitFloor(points, candidates, options.ransac_distance_m, &best);
  result.inliers = static_cast<int>(inliers.size());
  const double cos_max_angle = std::cos(options.max_normal_angle_deg * kDegToRad);
  if (result.inliers < options.min_inliers || best.normal.y() < cos_max_angle) {
    result.message = "no floor: best near-horizontal plane has " + std::to_string(inliers.size()) +
                     " inliers (min_inliers " + std::to_string(options.min_inliers) + ")";
    return result;
  }
  result.found = true;
  const double noise_window_m = kNoiseWindowFactor * options.ransac_distance_m;
  best = WeightedRefitFloor(points, points_camera, inliers, T_world_camera, noise_window_m, best);
  const Vec3 pivot = FloorPivot(points, inliers, best, &result.inlier_rms_m);
  result.plane_world = best;
  result.plane_camera = PlaneInCameraFrame(best, T_world_camera);
  result.depth_noise = EstimateDepthNoise(points_camera, result.plane_camera, noise_window_m);
  ApplyCorrection(T_world_camera, pivot, options, &result);
  return result;
}

}  // namespace rigfit
