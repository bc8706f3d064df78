#include "uncertainty/degeneracy.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/pose.h"

namespace rigfit {
namespace {

/// A world axis named when the unit vector a lies within about 25 deg of it.
constexpr double kAxisCosine = 0.9;

/// "world X" for a unit vector along +-X, otherwise "world direction (x, y, z)".
std::string AxisName(const Vec3& a) {
  const char* names[3] = {"world X", "world Y", "world Z"};
  for (int k = 0; k < 3; ++k) {
    if (std::abs(a(k)) >= kAxisCosine) return names[k];
  }
  char buffer[64];
  const Vec3 s = a.x() + a.z() < 0.0 ? Vec3(-a) : a;  // one sign per direction
  std::snprintf(buffer, sizeof(buffer), "world direction (%.2f, %.2f, %.2f)", s.x(), s.y(), s.z());
  return buffer;
}

/// Name and reason of an eigen-direction u = [L w; v] of the constraint matrix.
void Describe(const Vec6& u, WeakDirection* d) {
  const Vec3 rotation = u.head<3>();
  const Vec3 translation = u.tail<3>();
  if (translation.squaredNorm() >= rotation.squaredNorm()) {
    const Vec3 axis = translation.normalized();
    d->name = "translation along " + AxisName(axis);
    d->reason = std::abs(axis.y()) >= kAxisCosine
                    ? "the near-floor band lacks a floor or other horizontal surfaces"
                    : "the near-floor band lacks vertical structure across that direction";
    return;
  }
  const Vec3 axis = rotation.normalized();
  if (std::abs(axis.y()) >= kAxisCosine) {
    d->name = "yaw (rotation about world Y)";
    d->reason = "the near-floor band lacks vertical structure";
  } else {
    d->name = "rotation about " + AxisName(axis);
    d->reason = "the near-floor band lacks horizontal surfaces";
  }
}

}  // namespace

void StabilityAccumulator::Add(const Vec3& p_world, const Vec3& n_world, double weight) {
  Vec6 row;
  row << p_world.cross(n_world), n_world;
  moments_.selfadjointView<Eigen::Lower>().rankUpdate(row, weight);
  sum_w_ += weight;
  sum_p_ += weight * p_world;
  sum_p2_ += weight * p_world.squaredNorm();
  ++count_;
  orientations_.Add(n_world, 1.0);
}

void SurfaceOrientations::Add(const Vec3& n_any, double weight) {
  // One sign per orientation: the largest coordinate positive.
  Eigen::Index largest = 0;
  n_any.cwiseAbs().maxCoeff(&largest);
  const Vec3 n = n_any(largest) < 0.0 ? Vec3(-n_any) : n_any;
  const std::array<int, 3> key = {static_cast<int>(std::lround(10.0 * n.x())),
                                  static_cast<int>(std::lround(10.0 * n.y())),
                                  static_cast<int>(std::lround(10.0 * n.z()))};
  auto& [w, sum] = normals_.try_emplace(key, 0.0, Vec3::Zero()).first->second;
  w += weight;
  sum += weight * n;
  sum_w_ += weight;
}

int SurfaceOrientations::Count() const {
  if (!(sum_w_ > 0.0)) return 0;
  std::vector<std::pair<double, Vec3>> cells;  // weight, mean normal
  for (const auto& [key, cell] : normals_) {
    if (cell.first > 0.0) cells.emplace_back(cell.first, cell.second.normalized());
  }
  std::sort(cells.begin(), cells.end(),
            [](const auto& a, const auto& b) { return a.first > b.first; });
  const double cosine = std::cos(kOrientationAngleDeg * kDegToRad);
  std::vector<bool> taken(cells.size(), false);
  int orientations = 0;
  for (size_t first = 0; first < cells.size(); ++first) {
    if (taken[first]) continue;
    double weight = 0.0;
    for (size_t k = first; k < cells.size(); ++k) {
      if (taken[k] || std::abs(cells[k].second.dot(cells[first].second)) < cosine) continue;
      taken[k] = true;
      weight += cells[k].first;
    }
    if (weight >= kOrientationMinShare * sum_w_) ++orientations;
  }
  return orientations;
}

std::vector<WeakDirection> StabilityAccumulator::WeakDirections(const Vec3& camera_center_world,
                                                                double threshold) const {
  std::vector<WeakDirection> weak;
  if (count_ < 6 || threshold <= 0.0 || !(sum_w_ > 0.0)) return weak;
  const Vec3 c = sum_p_ / sum_w_;
  const double L = std::sqrt(std::max(sum_p2_ / sum_w_ - c.squaredNorm(), 0.0));
  if (!(L > 0.0)) return weak;
  // Rows about the centroid, rotation scaled by L: j = B [p x n; n] with
  // B = [[I / L, -[c]x / L], [0, I]], since (p - c) x n = p x n - c x n.
  Mat6 B = Mat6::Identity();
  B.topLeftCorner<3, 3>() /= L;
  B.topRightCorner<3, 3>() = -Hat(c) / L;
  const Mat6 moments = moments_.selfadjointView<Eigen::Lower>();
  const Mat6 M = B * moments * B.transpose() / sum_w_;
  const Eigen::SelfAdjointEigenSolver<Mat6> eig(M);
  const double largest = eig.eigenvalues()(5);
  if (!(largest > 0.0)) return weak;
  // Scaled coordinates s = [L w; v_c] of a tangent delta = [w; d] (rotation about the
  // camera centre t): the centroid moves by v_c = d + w x (c - t), so s = A delta with
  // A = [[L I, 0], [-[c - t]x, I]], and u . s = (A^T u) . delta.
  Mat6 A = Mat6::Identity();
  A.topLeftCorner<3, 3>() *= L;
  A.bottomLeftCorner<3, 3>() = -Hat(c - camera_center_world);
  for (int k = 0; k < 6; ++k) {
    const double strength = eig.eigenvalues()(k) / largest;
    if (strength >= threshold) break;
    WeakDirection d;
    d.strength = std::max(strength, 0.0);
    d.constraint = A.transpose() * eig.eigenvectors().col(k);
    Describe(eig.eigenvectors().col(k), &d);
    weak.push_back(d);
  }
  return weak;
}

Mat6 HoldInformation(const std::vector<WeakDirection>& weak, double sigma_m) {
  Mat6 information = Mat6::Zero();
  for (const WeakDirection& d : weak) {
    information += d.constraint * d.constraint.transpose() / (sigma_m * sigma_m);
  }
  return information;
}

}  // namespace rigfit
