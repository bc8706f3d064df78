#include "rgbd/relocalise.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace rigfit {
namespace {

/// The held pose turned by `turn_rad` about n_world through the camera centre and slid by
/// (a, b) along the plane's axes.
Pose Candidate(const Pose& T_world_held, const Vec3& n_world, double turn_rad, double a, double b) {
  const Vec3 e1 = n_world.unitOrthogonal();
  const Vec3 e2 = n_world.cross(e1);
  Pose T = T_world_held;
  T.linear() = ExpSO3(turn_rad * n_world) * T_world_held.linear();
  T.translation() += a * e1 + b * e2;
  return T;
}

/// How many of the frame's coarsest structure pixels associate with the anchor's coarsest
/// level from T_world_candidate.
int Score(const FrameLevel& frame, const std::vector<int>& structure, const Anchor& anchor,
          const Pose& T_world_candidate, const AssociationOptions& association) {
  const Pose T_anchor_frame = anchor.T_world_camera.inverse() * T_world_candidate;
  const FrameLevel& target = anchor.pyramid.levels.back();
  int matched = 0;
  int j = 0;
  for (const int i : structure) {
    matched += AssociatePixel(frame, i, target, T_anchor_frame, association, &j) ==
               AssociationOutcome::kMatched;
  }
  return matched;
}

/// Whether `track` (onto an anchor) is good enough to relocalise by.
bool Accepted(const TrackResult& track, double reference_rmse_m, const RelocaliseOptions& o) {
  return track.success && track.weak_directions == 0 && !track.lone_plane &&
         track.matched_ratio >= o.min_matched_ratio &&
         track.rmse_m <= o.max_rmse_ratio * reference_rmse_m;
}

}  // namespace

Relocalisation Relocalise(const HeldFrame& held, const std::vector<Anchor>& anchors,
                          const ProjectiveIcpOptions& icp, const RelocaliseOptions& options,
                          int threads) {
  const FramePyramid& frame = *held.pyramid;
  const Pose& T_world_held = held.T_world_held;
  const Vec3& n_world = held.n_world;
  Relocalisation best;
  if (frame.levels.empty() || !(options.turn_step_deg > 0.0) || !(options.slide_step_m > 0.0)) {
    return best;
  }
  // The frame's structure pixels (normals in the world away from the plane's).
  const FrameLevel& coarse = frame.levels.back();
  const Mat3& R = T_world_held.linear();
  const double max_cos = std::cos(options.min_structure_angle_deg * kDegToRad);
  std::vector<int> structure;
  for (const int i : coarse.valid_pixels) {
    if (std::abs(n_world.dot(R * coarse.normals[i].cast<double>())) < max_cos)
      structure.push_back(i);
  }
  if (structure.empty()) return best;
  const int turns = static_cast<int>(options.max_turn_deg / options.turn_step_deg);
  const int slides = static_cast<int>(options.max_slide_m / options.slide_step_m + 1e-9);
  for (const Anchor& anchor : anchors) {
    std::vector<std::pair<int, Pose>> scored;  // (score, T_world_candidate)
    for (int t = -turns; t <= turns; ++t) {
      for (int a = -slides; a <= slides; ++a) {
        for (int b = -slides; b <= slides; ++b) {
          const Pose T = Candidate(T_world_held, n_world, t * options.turn_step_deg * kDegToRad,
                                   a * options.slide_step_m, b * options.slide_step_m);
          scored.emplace_back(Score(coarse, structure, anchor, T, icp.association), T);
        }
      }
    }
    best.candidates += static_cast<int>(scored.size());
    const int kept = std::min<int>(std::max(1, options.tracked_candidates), scored.size());
    std::partial_sort(scored.begin(), scored.begin() + kept, scored.end(),
                      [](const auto& x, const auto& y) { return x.first > y.first; });
    for (int c = 0; c < kept; ++c) {
      const Pose T_anchor_start = anchor.T_world_camera.inverse() * scored[c].second;
      const TrackResult track =
          TrackProjective(frame, anchor.pyramid, T_anchor_start, icp, threads);
      if (!Accepted(track, held.reference_rmse_m, options)) continue;
      if (best.success && track.matched_ratio <= best.track.matched_ratio) continue;
      best.success = true;
      best.track = track;
      best.anchor_index = anchor.index;
      best.T_world_camera = Reorthonormalized(anchor.T_world_camera * track.T_target_source);
    }
  }
  return best;
}

}  // namespace rigfit
