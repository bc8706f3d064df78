#include "sim/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rigfit {

std::optional<RayHit> RaycastBox(const OrientedBox& box, const Vec3& origin, const Vec3& direction,
                                 double min_t) {
  // Slab method (Kay & Kajiya 1986) in box coordinates: on axis k the ray is inside the slab
  // |o_k + t d_k| <= h_k for t between (-h_k - o_k) / d_k and (h_k - o_k) / d_k; the box
  // is the intersection of the three intervals [t_near, t_far].
  // o = R^T (origin - center), d = R^T direction, on raw arrays: every pixel of every
  // simulated camera passes here for every box, and in the sanitizer build Eigen's small
  // products are not inlined (they took 90% of the simulator's time there).
  const double* R = box.R_world_box.data();  // column-major: R(i, k) = R[i + 3 k]
  const double rel[3] = {origin.x() - box.center.x(), origin.y() - box.center.y(),
                         origin.z() - box.center.z()};
  const double dir[3] = {direction.x(), direction.y(), direction.z()};
  double o[3], d[3];
  for (int k = 0; k < 3; ++k) {
    const double* column = R + 3 * k;
    o[k] = column[0] * rel[0] + column[1] * rel[1] + column[2] * rel[2];
    d[k] = column[0] * dir[0] + column[1] * dir[1] + column[2] * dir[2];
  }
  double t_near = -std::numeric_limits<double>::infinity();
  double t_far = std::numeric_limits<double>::infinity();
  int near_axis = -1;
  double near_sign = 0.0;
  for (int k = 0; k < 3; ++k) {
    const double h = box.half_extents[k];
    if (d[k] == 0.0) {
      if (std::abs(o[k]) > h) return std::nullopt;  // parallel to the slab, outside it
      continue;
    }
    const double inv = 1.0 / d[k];
    double t0 = (-h - o[k]) * inv;
    double t1 = (h - o[k]) * inv;
    // Entering through the -h face when d_k > 0, through the +h face otherwise.
    const double sign = d[k] > 0.0 ? -1.0 : 1.0;
    if (t0 > t1) std::swap(t0, t1);
    if (t0 > t_near) {
      t_near = t0;
      near_axis = k;
      near_sign = sign;
    }
    t_far = std::min(t_far, t1);
    if (t_near > t_far) return std::nullopt;
  }
  if (near_axis < 0 || t_near <= min_t) return std::nullopt;  // behind, or starts inside
  RayHit hit;
  hit.t = t_near;
  hit.normal_world = near_sign * box.R_world_box.col(near_axis);
  return hit;
}

double SignedDistance(const OrientedBox& box, const Vec3& p_world) {
  // Box SDF: with q = |p_box| - h per axis, |max(q, 0)| outside, max_k q_k (<= 0) inside.
  const Vec3 q =
      (box.R_world_box.transpose() * (p_world - box.center)).cwiseAbs() - box.half_extents;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

std::optional<RayHit> Scene::Raycast(const Vec3& origin, const Vec3& direction) const {
  std::optional<RayHit> best;
  for (size_t i = 0; i < boxes.size(); ++i) {
    std::optional<RayHit> hit = RaycastBox(boxes[i], origin, direction, 0.0);
    if (hit && (!best || hit->t < best->t)) {
      hit->box_index = static_cast<int>(i);
      best = hit;
    }
  }
  return best;
}

double Scene::DistanceToSurface(const Vec3& p_world) const {
  double distance = std::numeric_limits<double>::infinity();
  for (const OrientedBox& box : boxes) {
    distance = std::min(distance, std::abs(SignedDistance(box, p_world)));
  }
  return distance;
}

void LabelFaces(const Scene& scene, const Pose& T_world_camera, const std::vector<Vec3>& points,
                std::vector<PlanarFace>* faces, std::vector<int>* labels) {
  labels->assign(points.size(), -1);
  const Vec3 origin = T_world_camera.translation();
  for (size_t i = 0; i < points.size(); ++i) {
    const Vec3 world = T_world_camera * points[i];
    const std::optional<RayHit> hit = scene.Raycast(origin, world - origin);
    if (!hit) continue;
    const Vec3 n = hit->normal_world;
    const OrientedBox& box = scene.boxes[hit->box_index];
    // The face's plane passes through the box centre moved by the half extent along n.
    const Vec3 n_box = box.R_world_box.transpose() * n;
    const double offset = -n.dot(box.center + std::abs(n_box.dot(box.half_extents)) * n);
    int label = -1;
    for (size_t f = 0; f < faces->size() && label < 0; ++f) {
      if ((*faces)[f].normal.dot(n) > 1.0 - 1e-9 && std::abs((*faces)[f].offset - offset) < 1e-9) {
        label = static_cast<int>(f);
      }
    }
    if (label < 0) {
      label = static_cast<int>(faces->size());
      faces->push_back({n, offset, box.kind == SurfaceKind::kFloor && n.y() > 0.5});
    }
    (*labels)[i] = label;
  }
}

}  // namespace rigfit
