#include "rgbd/projective_icp.h"

#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <utility>

#include "core/geometry.h"
#include "core/parallel.h"
#include "residuals/point_to_plane.h"

namespace rigfit {
namespace {

// The association of one source pixel, with what every pixel shares computed once.
class Associator {
 public:
  Associator(const FrameLevel& source, const FrameLevel& target, const Pose& T_target_source,
             const AssociationOptions& options)
      : source_(source),
        target_(target),
        R_(T_target_source.linear()),
        t_(T_target_source.translation()),
        max_distance2_(options.max_distance_m * options.max_distance_m),
        min_cos_(std::cos(options.max_normal_angle_deg * kDegToRad)) {}

  // On kMatched: *moved = R p + t, *target_index the target pixel.
  // Inlined into the per-pixel loops (GCC and Clang leave a call otherwise: 20% of the time).
  [[gnu::always_inline]] inline AssociationOutcome operator()(int i, Vec3* moved,
                                                              int* target_index) const {
    if (!source_.Valid(i)) return AssociationOutcome::kNoSourcePoint;
    const Vec3 p = R_ * source_.vertices[i].cast<double>() + t_;
    if (!(p.z() > 0.0)) return AssociationOutcome::kBehindCamera;
    const PinholeIntrinsics& K = target_.intrinsics;
    const double u = K.fx * p.x() / p.z() + K.cx;
    const double v = K.fy * p.y() / p.z() + K.cy;
    // The nearest pixel centre: u in [-0.5, W - 0.5) rounds into [0, W).
    if (!(u >= -0.5 && u < target_.width - 0.5 && v >= -0.5 && v < target_.height - 0.5)) {
      return AssociationOutcome::kOutsideImage;
    }
    // u + 0.5 >= 0 here, so truncation is the floor.
    const int j = static_cast<int>(v + 0.5) * target_.width + static_cast<int>(u + 0.5);
    if (!target_.Valid(j)) return AssociationOutcome::kNoTargetPoint;
    if ((p - target_.vertices[j].cast<double>()).squaredNorm() >= max_distance2_) {
      return AssociationOutcome::kTooFar;
    }
    const Vec3 n_p = R_ * source_.normals[i].cast<double>();
    if (!(n_p.dot(target_.normals[j].cast<double>()) > min_cos_)) {
      return AssociationOutcome::kNormalsDisagree;
    }
    *moved = p;
    *target_index = j;
    return AssociationOutcome::kMatched;
  }

 private:
  const FrameLevel& source_;
  const FrameLevel& target_;
  const Mat3 R_;
  const Vec3 t_;
  const double max_distance2_;
  const double min_cos_;
};

// Per-thread sums of the normal equations: the 21 entries of H's upper triangle and g, in
// plain arrays (a rank-one update of a 6x6 Eigen matrix per pair costs twice as much).
struct Accumulator {
  double h[21] = {};
  double g[6] = {};
  double squared_error = 0.0;
  double weighted_squares = 0.0;
  int count = 0;

  // One pair: A = [(p' x n)^T n^T], b = n^T (p' - q), weighed as PairWeighting says (z_p:
  // the source point's depth in its own camera).
  void Add(const Vec3& moved, double z_p, const Vec3& q, const Vec3& n,
           const PairWeighting& weighting) {
    const double b = n.dot(moved - q);
    const Vec3 c = moved.cross(n);
    const double A[6] = {c.x(), c.y(), c.z(), n.x(), n.y(), n.z()};
    double w =
        weighting.depth_noise ? DepthNoiseWeight(z_p, q.z(), weighting.noise_floor_depth_m) : 1.0;
    if (weighting.huber_delta_m > 0.0) {
      const double whitened = std::sqrt(w) * std::abs(b);
      if (whitened > weighting.huber_delta_m) w *= weighting.huber_delta_m / whitened;
    }
    int k = 0;
    for (int r = 0; r < 6; ++r) {
      const double wa = w * A[r];
      for (int col = r; col < 6; ++col) h[k++] += wa * A[col];
      g[r] += wa * b;
    }
    squared_error += b * b;
    weighted_squares += w * b * b;
    ++count;
  }
};

// Sums per-thread accumulators in chunk order (deterministic for a thread count).
NormalEquations Sum(const std::vector<Accumulator>& parts) {
  NormalEquations total;
  for (const Accumulator& part : parts) {
    int k = 0;
    for (int r = 0; r < 6; ++r) {
      for (int col = r; col < 6; ++col) total.H(r, col) += part.h[k++];
      total.g(r) += part.g[r];
    }
    total.squared_error += part.squared_error;
    total.weighted_squares += part.weighted_squares;
    total.count += part.count;
  }
  total.H.triangularView<Eigen::StrictlyLower>() = total.H.transpose();
  return total;
}

bool Converged(const Vec6& x, const ProjectiveIcpOptions& options) {
  return x.head<3>().norm() < options.converged_rotation_rad &&
         x.tail<3>().norm() < options.converged_translation_m;
}

}  // namespace

AssociationOutcome AssociatePixel(const FrameLevel& source, int i, const FrameLevel& target,
                                  const Pose& T_target_source, const AssociationOptions& options,
                                  int* target_index) {
  Vec3 moved;
  return Associator(source, target, T_target_source, options)(i, &moved, target_index);
}

double OverlapShare(const FrameLevel& source, const FrameLevel& target, const Pose& T_target_source,
                    const AssociationOptions& options) {
  if (source.valid_pixels.empty()) return 0.0;
  const Associator associate(source, target, T_target_source, options);
  int landed = 0;
  for (const int i : source.valid_pixels) {
    Vec3 moved;
    int j = 0;
    const AssociationOutcome outcome = associate(i, &moved, &j);
    landed += outcome == AssociationOutcome::kMatched || outcome == AssociationOutcome::kTooFar ||
              outcome == AssociationOutcome::kNormalsDisagree;
  }
  return static_cast<double>(landed) / static_cast<double>(source.valid_pixels.size());
}

std::vector<ProjectiveCorrespondence> FindCorrespondences(const FrameLevel& source,
                                                          const FrameLevel& target,
                                                          const Pose& T_target_source,
                                                          const AssociationOptions& options,
                                                          int threads) {
  const Associator associate(source, target, T_target_source, options);
  const std::vector<int>& pixels = source.valid_pixels;
  const int chunks = std::max(1, threads);
  std::vector<std::vector<ProjectiveCorrespondence>> parts(chunks);
  ParallelForChunks(static_cast<int>(pixels.size()), chunks, [&](int c, int begin, int end) {
    std::vector<ProjectiveCorrespondence> part;  // this thread's own: no cache line shared
    Vec3 moved;
    int j = 0;
    for (int k = begin; k < end; ++k) {
      const int i = pixels[k];
      if (associate(i, &moved, &j) == AssociationOutcome::kMatched) {
        part.push_back({source.vertices[i].cast<double>(), target.vertices[j].cast<double>(),
                        target.normals[j].cast<double>()});
      }
    }
    parts[c] = std::move(part);
  });
  std::vector<ProjectiveCorrespondence> pairs;
  for (const auto& part : parts) pairs.insert(pairs.end(), part.begin(), part.end());
  return pairs;
}

NormalEquations BuildNormalEquations(const std::vector<ProjectiveCorrespondence>& pairs,
                                     const Pose& T_target_source, const PairWeighting& weighting,
                                     int threads) {
  const int chunks = std::max(1, threads);
  std::vector<Accumulator> parts(chunks);
  ParallelForChunks(static_cast<int>(pairs.size()), chunks, [&](int c, int begin, int end) {
    Accumulator sum;  // on this thread's stack: threads never write to one cache line
    for (int k = begin; k < end; ++k) {
      sum.Add(T_target_source * pairs[k].p, pairs[k].p.z(), pairs[k].q, pairs[k].n, weighting);
    }
    parts[c] = sum;
  });
  return Sum(parts);
}

NormalEquations AccumulateProjective(const FrameLevel& source, const FrameLevel& target,
                                     const Pose& T_target_source, const AssociationOptions& options,
                                     const PairWeighting& weighting, int threads) {
  const Associator associate(source, target, T_target_source, options);
  const int chunks = std::max(1, threads);
  std::vector<Accumulator> parts(chunks);
  const std::vector<int>& pixels = source.valid_pixels;
  ParallelForChunks(static_cast<int>(pixels.size()), chunks, [&](int c, int begin, int end) {
    Accumulator sum;  // on this thread's stack: threads never write to one cache line
    Vec3 moved;
    int j = 0;
    for (int k = begin; k < end; ++k) {
      if (associate(pixels[k], &moved, &j) == AssociationOutcome::kMatched) {
        sum.Add(moved, source.vertices[pixels[k]].z(), target.vertices[j].cast<double>(),
                target.normals[j].cast<double>(), weighting);
      }
    }
    parts[c] = sum;
  });
  return Sum(parts);
}

StepSolution SolveStep(const NormalEquations& equations, double length_m, double ratio,
                       const std::vector<Vec6>& held) {
  StepSolution solution;
  if (equations.count < 6) return solution;
  // y = D x with D = diag(L, L, L, 1, 1, 1): H_y = D^-1 H D^-1, g_y = D^-1 g; the held
  // directions projected out, P = I - sum v v^T: H_y <- P H_y P, g_y <- P g_y.
  Vec6 d_inv;
  d_inv << 1.0 / length_m, 1.0 / length_m, 1.0 / length_m, 1.0, 1.0, 1.0;
  Mat6 P = Mat6::Identity();
  for (const Vec6& v : held) P -= v * v.transpose();
  const Mat6 H_y = P * d_inv.asDiagonal() * equations.H * d_inv.asDiagonal() * P;
  const Vec6 g_y = P * d_inv.asDiagonal() * equations.g;
  const Eigen::SelfAdjointEigenSolver<Mat6> eigen(H_y);
  const double largest = eigen.eigenvalues()(5);
  if (!(largest > 0.0)) return solution;
  solution.conditioning = std::max(0.0, eigen.eigenvalues()(0)) / largest;
  Vec6 y = Vec6::Zero();
  for (int k = 0; k < 6; ++k) {
    const double lambda = eigen.eigenvalues()(k);
    const Vec6 v = eigen.eigenvectors().col(k);
    if (lambda > ratio * largest) {
      y -= v * (v.dot(g_y) / lambda);
    } else {
      ++solution.weak_directions;
      solution.weak.push_back(v);
    }
  }
  solution.x = d_inv.asDiagonal() * y;
  return solution;
}

std::optional<Vec3> LonePlaneNormal(const FrameLevel& level, const LonePlaneOptions& options) {
  const std::vector<int>& pixels = level.valid_pixels;
  if (!(options.min_share > 0.0) || pixels.empty()) return std::nullopt;
  const double min_cos = std::cos(options.max_angle_deg * kDegToRad);
  Vec3 n = Vec3::Zero();
  for (const int i : pixels) n += level.normals[i].cast<double>();
  // Twice: the mean normal of the pixels near the last one in angle.
  for (int pass = 0; pass < 2 && n.norm() > 0.0; ++pass) {
    const Vec3 mean = n.normalized();
    n.setZero();
    for (const int i : pixels) {
      const Vec3 n_i = level.normals[i].cast<double>();
      if (n_i.dot(mean) > min_cos) n += n_i;
    }
  }
  if (!(n.norm() > 0.0)) return std::nullopt;
  n.normalize();
  std::vector<double> offsets;
  for (const int i : pixels) {
    if (level.normals[i].cast<double>().dot(n) > min_cos) {
      offsets.push_back(n.dot(level.vertices[i].cast<double>()));
    }
  }
  const double offset = Quantile(&offsets, 0.5);
  std::size_t on_plane = 0;
  for (const int i : pixels) {
    on_plane += level.normals[i].cast<double>().dot(n) > min_cos &&
                std::abs(n.dot(level.vertices[i].cast<double>()) - offset) < options.max_distance_m;
  }
  if (static_cast<double>(on_plane) < options.min_share * pixels.size()) return std::nullopt;
  return n;
}

std::optional<Vec3> LonePlaneNormal(const FramePyramid& pyramid, const LonePlaneOptions& options) {
  if (pyramid.levels.empty()) return std::nullopt;
  const std::optional<Vec3> n = LonePlaneNormal(pyramid.levels.back(), options);
  const FrameLevel& finest = pyramid.levels.front();
  if (!n || finest.valid_pixels.empty()) return n;
  std::vector<double> offsets;
  offsets.reserve(finest.valid_pixels.size());
  for (const int i : finest.valid_pixels)
    offsets.push_back(n->dot(finest.vertices[i].cast<double>()));
  // The median in place: the count below does not depend on the order.
  const double offset = Quantile(&offsets, 0.5);
  const auto near = std::count_if(offsets.begin(), offsets.end(), [&](double d) {
    return std::abs(d - offset) < options.max_distance_m;
  });
  if (static_cast<double>(near) < options.min_share * offsets.size()) return std::nullopt;
  return n;
}

std::vector<Vec6> LonePlaneDirections(const Vec3& n) {
  const Vec3 a = n.unitOrthogonal();
  const Vec3 b = n.cross(a);
  std::vector<Vec6> directions(3, Vec6::Zero());
  directions[0].head<3>() = n;
  directions[1].tail<3>() = a;
  directions[2].tail<3>() = b;
  return directions;
}

Pose ApplyLeftUpdate(const Vec6& x, const Pose& T) {
  Pose update = Pose::Identity();
  update.linear() = ExpSO3(x.head<3>());
  update.translation() = x.tail<3>();
  return update * T;
}

TrackResult TrackProjective(const FramePyramid& source, const FramePyramid& target,
                            const Pose& T_init, const ProjectiveIcpOptions& options, int threads) {
  return TrackProjective(source, target, LonePlaneNormal(target, options.lone_plane), T_init,
                         options, threads);
}

TrackResult TrackProjective(const FramePyramid& source, const FramePyramid& target,
                            const std::optional<Vec3>& n_target, const Pose& T_init,
                            const ProjectiveIcpOptions& options, int threads) {
  TrackResult result;
  const int levels = static_cast<int>(std::min(source.levels.size(), target.levels.size()));
  if (levels == 0 || options.iterations.empty()) {
    result.message = "no pyramid level to track";
    return result;
  }
  // Rotation weighs as the displacement it causes at the scene's depth: the mean source depth.
  const FrameLevel& finest = source.levels[0];
  const int valid = static_cast<int>(finest.valid_pixels.size());
  if (valid == 0) {
    result.message = "the source frame has no valid pixel";
    return result;
  }
  const double length_m = MeanDepth(finest);
  result.length_m = length_m;

  // A lone plane in the target (its axes) or the source (turned into them at each step).
  const std::optional<Vec3> n_source =
      n_target ? std::nullopt : LonePlaneNormal(source, options.lone_plane);
  result.lone_plane = n_target || n_source;
  Pose T = T_init;
  NormalEquations last;
  int last_level = -1;  // the level `last` was accumulated at
  const auto iterations_at = [&](int level) {
    return options.iterations[std::min<std::size_t>(level, options.iterations.size() - 1)];
  };
  // Convergence is judged at the finest level that runs steps (level 0 unless its iterations
  // are set to 0).
  int finest_run = 0;
  while (finest_run < levels - 1 && iterations_at(finest_run) <= 0) ++finest_run;
  for (int level = levels - 1; level >= 0; --level) {
    const int iterations = iterations_at(level);
    for (int it = 0; it < iterations; ++it) {
      last = AccumulateProjective(source.levels[level], target.levels[level], T,
                                  options.association, options.weighting, threads);
      last_level = level;
      const std::vector<Vec6> held =
          result.lone_plane ? LonePlaneDirections(n_target ? *n_target : T.linear() * *n_source)
                            : std::vector<Vec6>{};
      const StepSolution step = SolveStep(last, length_m, options.weak_direction_ratio, held);
      if (last.count < 6) break;
      T = ApplyLeftUpdate(step.x, T);
      ++result.iterations;
      result.weak_directions = step.weak_directions;
      result.weak = step.weak;
      result.conditioning = step.conditioning;
      if (Converged(step.x, options)) {
        result.converged = level == finest_run;
        break;
      }
    }
  }
  if (last_level != 0) {
    // No system at the finest level (its iterations set to 0): its pairs at the estimate.
    last = AccumulateProjective(source.levels[0], target.levels[0], T, options.association,
                                options.weighting, threads);
  }
  if (result.lone_plane) result.plane_normal = n_target ? *n_target : T.linear() * *n_source;
  result.T_target_source = Reorthonormalized(T);
  result.correspondences = last.count;
  result.matched_ratio = static_cast<double>(last.count) / valid;
  result.rmse_m = last.count > 0 ? std::sqrt(last.squared_error / last.count) : 0.0;
  if (last.count > 6 && last.weighted_squares > 0.0) {
    result.information = last.H * ((last.count - 6) / last.weighted_squares);
  }
  if (!T.matrix().allFinite()) {
    result.message = "the estimate is not finite";
  } else if (result.matched_ratio < options.min_matched_ratio) {
    result.message = "only " + std::to_string(last.count) + " of " + std::to_string(valid) +
                     " pixels matched (" + std::to_string(result.matched_ratio) + " < " +
                     std::to_string(options.min_matched_ratio) + ")";
  } else {
    result.success = true;
  }
  return result;
}

Pose SolvePairsGaussNewton(const std::vector<ProjectiveCorrespondence>& pairs, const Pose& T_init,
                           const PairWeighting& weighting, int max_iterations, int threads) {
  Pose T = T_init;
  for (int it = 0; it < max_iterations; ++it) {
    const NormalEquations equations = BuildNormalEquations(pairs, T, weighting, threads);
    // Every direction the pairs determine at all is solved: a ratio at rounding level.
    const Vec6 x = SolveStep(equations, 1.0, 1e-14).x;
    T = ApplyLeftUpdate(x, T);
    if (x.norm() < 1e-13) break;
  }
  return T;
}

Pose SolvePairsCeres(const std::vector<ProjectiveCorrespondence>& pairs, const Pose& T_init,
                     const PairWeighting& weighting, int threads) {
  if (pairs.empty()) return T_init;
  double pose[kPoseAmbientSize];
  double identity[kPoseAmbientSize];
  PoseToParameters(T_init, pose);
  PoseToParameters(Pose::Identity(), identity);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold manifold;
  // One loss object shared by every block: the problem deletes it once.
  ceres::LossFunction* loss =
      weighting.huber_delta_m > 0.0 ? new ceres::HuberLoss(weighting.huber_delta_m) : nullptr;
  for (const ProjectiveCorrespondence& pair : pairs) {
    const double scale =
        weighting.depth_noise
            ? std::sqrt(DepthNoiseWeight(pair.p.z(), pair.q.z(), weighting.noise_floor_depth_m))
            : 1.0;
    problem.AddResidualBlock(PointToPlaneCost::Create(pair.p, pair.q, scale * pair.n), loss, pose,
                             identity);
  }
  problem.SetManifold(pose, &manifold);
  problem.SetParameterBlockConstant(identity);
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  options.max_num_iterations = 100;
  options.function_tolerance = 1e-16;
  options.gradient_tolerance = 1e-16;
  options.parameter_tolerance = 1e-15;
  options.num_threads = threads;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return PoseFromParameters(pose);
}

}  // namespace rigfit
