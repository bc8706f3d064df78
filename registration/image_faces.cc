#include "registration/image_faces.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <queue>
#include <set>
#include <utility>

#include "core/geometry.h"
#include "core/parallel.h"

namespace rigfit {
namespace {

/// The options with one camera's depth noise k (the noise of each of its pixels' w).
struct Settings : ImageFacesOptions {
  double k = 0.0;
};

constexpr int kNone = -1;

/// A camera's band pixels on its image grid: per pixel the index of its point (kNone: none).
struct ImageGrid {
  int width = 0, height = 0;
  std::vector<int> index;
  std::vector<double> x, y, w;  ///< per point: normalised coordinates and inverse depth
  int At(int u, int v) const {
    return u < 0 || v < 0 || u >= width || v >= height ? kNone
                                                       : index[static_cast<size_t>(v) * width + u];
  }
};

ImageGrid GridOf(const ImageFaceCamera& camera, const PointCloud& points,
                 std::vector<Eigen::Vector2i>* pixels) {
  ImageGrid g;
  g.width = camera.width;
  g.height = camera.height;
  g.index.assign(static_cast<size_t>(g.width) * g.height, kNone);
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2i q = PixelOf(camera.intrinsics, points[i]);
    pixels->push_back(q);
    if (q.x() >= 0 && q.y() >= 0 && q.x() < g.width && q.y() < g.height) {  // else off the grid
      g.index[static_cast<size_t>(q.y()) * g.width + q.x()] = static_cast<int>(i);
    }
    g.x.push_back(points[i].x() / points[i].z());
    g.y.push_back(points[i].y() / points[i].z());
    g.w.push_back(1.0 / points[i].z());
  }
  return g;
}

/// Least squares of w = q0 + q1 (x - x0) + q2 (y - y0) (w about w0), accumulated point by point.
class AffineFit {
 public:
  AffineFit(double x0, double y0, double w0) : x0_(x0), y0_(y0), w0_(w0) {}
  void Add(double x, double y, double w) {
    const Eigen::Vector3d a(1.0, x - x0_, y - y0_);
    normal_ += a * a.transpose();
    rhs_ += a * (w - w0_);
    ++count_;
  }
  /// Solves; false (the model unchanged) when the points do not span a plane.
  bool Solve() {
    Eigen::LDLT<Eigen::Matrix3d> ldlt(normal_);
    if (count_ < 3 || ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() <= 0.0) {
      return false;
    }
    q_ = ldlt.solve(rhs_);
    return true;
  }
  double Predict(double x, double y) const {
    return w0_ + q_(0) + q_(1) * (x - x0_) + q_(2) * (y - y0_);
  }
  int count() const { return count_; }
  /// The camera-frame plane n^T X + d = 0 (d > 0: n towards the camera) of the model:
  /// w = p0 + p1 x + p2 y means p1 X + p2 Y + p0 Z = 1.
  PlanarFace Plane() const {
    const Eigen::Vector3d p(q_(1), q_(2), w0_ + q_(0) - q_(1) * x0_ - q_(2) * y0_);
    PlanarFace f;
    f.normal = -p.normalized();
    f.offset = 1.0 / p.norm();
    return f;
  }

 private:
  double x0_, y0_, w0_;
  Eigen::Matrix3d normal_ = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d q_ = Eigen::Vector3d::Zero();
  int count_ = 0;
};

/// The points of the (2 r + 1)^2 window around pixel q that `take` accepts.
template <typename Take>
std::vector<int> Window(const ImageGrid& g, const Eigen::Vector2i& q, int r, Take take) {
  std::vector<int> out;
  for (int v = q.y() - r; v <= q.y() + r; ++v) {
    for (int u = q.x() - r; u <= q.x() + r; ++u) {
      const int j = g.At(u, v);
      if (j != kNone && take(j)) out.push_back(j);
    }
  }
  return out;
}

AffineFit FitPoints(const ImageGrid& g, const std::vector<int>& points, int centre) {
  AffineFit fit(g.x[centre], g.y[centre], g.w[centre]);
  for (const int j : points) fit.Add(g.x[j], g.y[j], g.w[j]);
  fit.Solve();
  return fit;
}

/// The seeds: points whose full window is planar within seed_sigmas k (RMS), best first.
std::vector<int> Seeds(const ImageGrid& g, const std::vector<Eigen::Vector2i>& pixels,
                       const Settings& o) {
  const int r = o.seed_radius;
  const size_t full = static_cast<size_t>((2 * r + 1) * (2 * r + 1));
  std::vector<std::pair<double, int>> scored;
  for (size_t i = 0; i < pixels.size(); ++i) {
    const std::vector<int> window = Window(g, pixels[i], r, [](int) { return true; });
    if (window.size() < full) continue;
    const AffineFit fit = FitPoints(g, window, static_cast<int>(i));
    double ss = 0.0;
    for (const int j : window) ss += std::pow(g.w[j] - fit.Predict(g.x[j], g.y[j]), 2);
    const double rms = std::sqrt(ss / (window.size() - 3)) / o.k;
    if (rms <= o.seed_sigmas) scored.emplace_back(rms, static_cast<int>(i));
  }
  std::sort(scored.begin(), scored.end());
  std::vector<int> seeds;
  for (const auto& [rms, i] : scored) seeds.push_back(i);
  return seeds;
}

/// One face grown from a seed: breadth first over 4-neighbours within the gate of its model,
/// refitted each time it has grown by a quarter.
AffineFit Grow(const ImageGrid& g, const std::vector<Eigen::Vector2i>& pixels, int seed, int face,
               const Settings& o, std::vector<int>* label) {
  std::vector<int> start =
      Window(g, pixels[seed], o.seed_radius, [&](int j) { return (*label)[j] == kNone; });
  AffineFit fit = FitPoints(g, start, seed);
  const double gate = o.gate_sigmas * o.k;
  std::queue<int> frontier;
  for (const int j : start) {
    if (std::abs(g.w[j] - fit.Predict(g.x[j], g.y[j])) > gate) continue;
    (*label)[j] = face;
    frontier.push(j);
  }
  int fitted = fit.count();
  AffineFit sums(g.x[seed], g.y[seed], g.w[seed]);
  for (const int j : start) {
    if ((*label)[j] == face) sums.Add(g.x[j], g.y[j], g.w[j]);
  }
  constexpr int kSteps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
  while (!frontier.empty()) {
    const Eigen::Vector2i q = pixels[frontier.front()];
    frontier.pop();
    for (const auto& s : kSteps) {
      const int j = g.At(q.x() + s[0], q.y() + s[1]);
      if (j == kNone || (*label)[j] != kNone) continue;
      if (std::abs(g.w[j] - fit.Predict(g.x[j], g.y[j])) > gate) continue;
      (*label)[j] = face;
      frontier.push(j);
      sums.Add(g.x[j], g.y[j], g.w[j]);
      if (sums.count() * 4 >= fitted * 5 && sums.Solve()) {
        fit = sums;
        fitted = sums.count();
      }
    }
  }
  if (sums.Solve()) fit = sums;
  return fit;
}

int Root(std::vector<int>* parent, int i) {
  while ((*parent)[i] != i) i = (*parent)[i] = (*parent)[(*parent)[i]];
  return i;
}

/// Per face, its points.
std::vector<std::vector<int>> Members(const std::vector<int>& label, size_t faces) {
  std::vector<std::vector<int>> members(faces);
  for (size_t i = 0; i < label.size(); ++i) {
    if (label[i] != kNone) members[label[i]].push_back(static_cast<int>(i));
  }
  return members;
}

/// A camera's faces: the floor (the points `label` gives face 0, if any), then faces grown from
/// its seeds (best first), refitted on their points, those under min_pixels dropped. Returns the
/// models; `label` per point; *floor whether face 0 is the floor.
std::vector<AffineFit> CameraFaces(const ImageGrid& g, const std::vector<Eigen::Vector2i>& pixels,
                                   const Settings& o, std::vector<int>* label, bool* floor) {
  std::vector<AffineFit> models;
  const std::vector<int> floor_points = Members(*label, 1).front();
  if (!floor_points.empty()) models.push_back(FitPoints(g, floor_points, floor_points.front()));
  for (const int seed : Seeds(g, pixels, o)) {
    if ((*label)[seed] != kNone) continue;
    const int face = static_cast<int>(models.size());
    models.push_back(Grow(g, pixels, seed, face, o, label));
  }
  // Refit each face on its final pixels; drop the small ones.
  const std::vector<std::vector<int>> members = Members(*label, models.size());
  std::vector<int> renumber(models.size(), kNone);
  std::vector<AffineFit> kept;
  for (size_t f = 0; f < models.size(); ++f) {
    if (static_cast<int>(members[f].size()) < o.min_pixels) continue;
    renumber[f] = static_cast<int>(kept.size());
    kept.push_back(FitPoints(g, members[f], members[f].front()));
  }
  for (int& l : *label) l = l == kNone ? kNone : renumber[l];
  *floor = !floor_points.empty() && renumber[0] == 0;
  return kept;
}

/// Per point of a camera at pose T: 0 where its w lies within the gate and a pose error of
/// pose_tolerance_m of the leveled floor's (y = 0) along its ray, kNone elsewhere.
std::vector<int> FloorPoints(const ImageGrid& g, const Pose& T, const Settings& o) {
  std::vector<int> label(g.w.size(), kNone);
  for (size_t i = 0; i < g.w.size(); ++i) {
    const Vec3 ray = T.linear() * Vec3(g.x[i], g.y[i], 1.0);
    const double z = RayPlaneDepth(T.translation(), ray, Vec3::UnitY(), 0.0);
    if (!(z > 0.0) || !std::isfinite(z)) continue;
    const double w = g.w[i];
    if (std::abs(w - 1.0 / z) <= o.gate_sigmas * o.k + o.pose_tolerance_m * w * w) {
      label[i] = 0;
    }
  }
  return label;
}

/// The mean normalised coordinates of each face's points.
std::vector<Eigen::Vector2d> Centres(const ImageGrid& g, const std::vector<int>& label,
                                     size_t faces) {
  std::vector<Eigen::Vector2d> sum(faces, Eigen::Vector2d::Zero());
  std::vector<int> count(faces, 0);
  for (size_t i = 0; i < label.size(); ++i) {
    if (label[i] == kNone) continue;
    sum[label[i]] += Eigen::Vector2d(g.x[i], g.y[i]);
    ++count[label[i]];
  }
  for (size_t f = 0; f < faces; ++f) sum[f] /= std::max(count[f], 1);
  return sum;
}

/// Re-decides the points within seed_radius of another face: among the faces near it whose
/// model is within the gate of its w, the best fitting one, unless two such faces meet there
/// (their models within the gate of each other at the point) and the point lies on the other's
/// side of their intersection (the side each face's centre lies on).
int CreaseSidesOnce(const ImageGrid& g, const std::vector<Eigen::Vector2i>& pixels,
                    const std::vector<AffineFit>& models, const Settings& o,
                    std::vector<int>* label) {
  const double gate = o.gate_sigmas * o.k;
  const std::vector<Eigen::Vector2d> centre = Centres(g, *label, models.size());
  // Which side of the intersection of faces a and b point i is on: +1 a's, -1 b's, 0 neither.
  const auto side = [&](int a, int b, double x, double y) {
    const double s = models[a].Predict(x, y) - models[b].Predict(x, y);
    const double sa = models[a].Predict(centre[a].x(), centre[a].y()) -
                      models[b].Predict(centre[a].x(), centre[a].y());
    const double sb = models[b].Predict(centre[b].x(), centre[b].y()) -
                      models[a].Predict(centre[b].x(), centre[b].y());
    if ((sa > 0) != (sb > 0)) return 0;  // not a crease: one face in front of the other
    return (s > 0) == (sa > 0) ? 1 : -1;
  };
  std::vector<int> decided = *label;
  for (size_t i = 0; i < pixels.size(); ++i) {
    std::set<int> near;
    for (const int j : Window(g, pixels[i], o.seed_radius, [](int) { return true; })) {
      if ((*label)[j] != kNone) near.insert((*label)[j]);
    }
    if (near.empty() || (near.size() == 1 && *near.begin() == (*label)[i])) continue;
    int best = kNone;
    double best_r = gate;
    for (const int f : near) {
      const double r = std::abs(g.w[i] - models[f].Predict(g.x[i], g.y[i]));
      if (r <= best_r) best = f, best_r = r;
    }
    if (best == kNone) {
      decided[i] = best;
      continue;
    }
    for (const int f : near) {
      if (f == best) continue;
      const double gap = models[f].Predict(g.x[i], g.y[i]) - models[best].Predict(g.x[i], g.y[i]);
      const double r = std::abs(g.w[i] - models[f].Predict(g.x[i], g.y[i]));
      if (std::abs(gap) <= gate && r <= gate && side(best, f, g.x[i], g.y[i]) < 0) best = f;
    }
    decided[i] = best;
  }
  int changed = 0;
  for (size_t i = 0; i < decided.size(); ++i) changed += decided[i] != (*label)[i] ? 1 : 0;
  *label = decided;
  return changed;
}

/// CreaseSidesOnce until no point changes (at most kCreasePasses), each face refitted on its
/// points after each pass: a pass moves a boundary by up to seed_radius pixels, and a face that
/// grew first may have crept several pixels past its crease (as far as its gate reaches),
/// tilting its model towards the other face's.
void CreaseSides(const ImageGrid& g, const std::vector<Eigen::Vector2i>& pixels, const Settings& o,
                 std::vector<AffineFit>* models, std::vector<int>* label) {
  constexpr int kCreasePasses = 10;
  for (int pass = 0; pass < kCreasePasses; ++pass) {
    if (CreaseSidesOnce(g, pixels, *models, o, label) == 0) return;
    const std::vector<std::vector<int>> members = Members(*label, models->size());
    for (size_t f = 0; f < models->size(); ++f) {
      if (members[f].size() >= 3) (*models)[f] = FitPoints(g, members[f], members[f].front());
    }
  }
}

/// One camera's faces: its points' grid and pixels, their labels, and the faces' models.
struct CameraFaceSet {
  const ImageFaceCamera* camera = nullptr;
  ImageGrid grid;
  std::vector<Eigen::Vector2i> pixels;
  double k = 0.0;  ///< the camera's depth noise (its gates)
  std::vector<int> label;
  std::vector<AffineFit> models;
  bool floor = false;  ///< face 0 is the leveled floor
};

/// Votes of camera a's faces for camera b's: each labelled point of a, seen from b at the start
/// poses, votes for b's face at that pixel when b's measured w there agrees with it (within the
/// gate and a pose error of pose_tolerance_m along the ray). Returns, per face of a, the votes
/// per face of b and, under kNone, the points that agreed with any pixel of b.
std::vector<std::map<int, int>> Votes(const CameraFaceSet& a, const CameraFaceSet& b,
                                      const ImageFacesOptions& o) {
  std::vector<std::map<int, int>> votes(a.models.size());
  const Pose b_from_a = b.camera->T_world_camera.inverse() * a.camera->T_world_camera;
  const PointCloud& points = *a.camera->points;
  for (size_t i = 0; i < points.size(); ++i) {
    if (a.label[i] == kNone) continue;
    const Vec3 q = b_from_a * points[i];
    if (q.z() <= 0.0) continue;
    const Eigen::Vector2i px = PixelOf(b.camera->intrinsics, q);
    const int j = b.grid.At(px.x(), px.y());
    if (j == kNone) continue;
    const double w = 1.0 / q.z();
    if (std::abs(b.grid.w[j] - w) > o.gate_sigmas * b.k + o.pose_tolerance_m * w * w) {
      continue;
    }
    ++votes[a.label[i]][kNone];
    if (b.label[j] != kNone) ++votes[a.label[i]][b.label[j]];
  }
  return votes;
}

/// The faces of all cameras as one list: camera c's face f is number first[c] + f.
std::vector<int> FirstFaces(const std::vector<CameraFaceSet>& sets) {
  std::vector<int> first;
  int n = 0;
  for (const CameraFaceSet& s : sets) {
    first.push_back(n);
    n += static_cast<int>(s.models.size());
  }
  first.push_back(n);
  return first;
}

/// Per camera face, its face: camera faces are one face when min_overlap of one's points that
/// another camera sees agree with the other's (Votes) and their normals lie within
/// merge_angle_deg.
std::vector<int> Associate(const std::vector<CameraFaceSet>& sets, const ImageFacesOptions& o,
                           int* faces) {
  const std::vector<int> first = FirstFaces(sets);
  std::vector<int> parent(first.back());
  std::iota(parent.begin(), parent.end(), 0);
  const double cos_angle = std::cos(o.merge_angle_deg * kDegToRad);
  int floor = kNone;  // the leveled floor: one face
  for (size_t a = 0; a < sets.size(); ++a) {
    if (!sets[a].floor) continue;
    if (floor != kNone) parent[Root(&parent, first[a])] = Root(&parent, floor);
    floor = first[a];
  }
  for (size_t a = 0; a < sets.size(); ++a) {
    for (size_t b = 0; b < sets.size(); ++b) {
      if (a == b || sets[a].models.empty() || sets[b].models.empty()) continue;
      const std::vector<std::map<int, int>> votes = Votes(sets[a], sets[b], o);
      for (size_t fa = 0; fa < votes.size(); ++fa) {
        const auto seen = votes[fa].find(kNone);
        if (seen == votes[fa].end()) continue;
        const Vec3 na = sets[a].camera->T_world_camera.linear() * sets[a].models[fa].Plane().normal;
        for (const auto& [fb, n] : votes[fa]) {
          if (fb == kNone || n < o.min_pixels || n < o.min_overlap * seen->second) continue;
          const Vec3 nb =
              sets[b].camera->T_world_camera.linear() * sets[b].models[fb].Plane().normal;
          if (na.dot(nb) < cos_angle) continue;
          parent[Root(&parent, first[a] + fa)] = Root(&parent, first[b] + fb);
        }
      }
    }
  }
  std::map<int, int> face_of_root;
  std::vector<int> face_of(parent.size());
  for (size_t i = 0; i < parent.size(); ++i) {
    const int root = Root(&parent, static_cast<int>(i));
    face_of[i] = face_of_root.emplace(root, static_cast<int>(face_of_root.size())).first->second;
  }
  *faces = static_cast<int>(face_of_root.size());
  return face_of;
}

/// The world plane through points (core/geometry.h FitPlane), its normal on the side of
/// `towards`; the floor (+Y) when it lies within 3 degrees of level and 5 cm of y = 0.
PlanarFace FitWorldPlane(const std::vector<Vec3>& points, const Vec3& towards) {
  if (points.empty()) return PlanarFace{};
  PlanarFace f = FitPlane(
      points.size(), [&](size_t k) { return points[k]; }, [](size_t) { return 1.0; });
  if (f.normal.dot(towards) < 0.0) {
    f.normal = -f.normal;
    f.offset = -f.offset;
  }
  double mean_y = 0.0;
  for (const Vec3& p : points) mean_y += p.y();
  mean_y /= static_cast<double>(points.size());
  if (f.normal.y() > std::cos(3.0 * kDegToRad) && std::abs(mean_y) < 0.05) {
    f.floor = true;
    f.normal = Vec3::UnitY();
    f.offset = -mean_y;
  }
  return f;
}

/// A camera face: (camera, its face's index among the camera's).
using CameraFace = std::pair<int, int>;
/// Per camera, per camera face: its points.
using FaceMembers = std::vector<std::vector<std::vector<int>>>;

/// The world plane of camera faces (FitWorldPlane on their points).
PlanarFace FitFace(const std::vector<CameraFaceSet>& sets, const FaceMembers& members,
                   const std::vector<CameraFace>& parts) {
  std::vector<Vec3> points;
  Vec3 towards = Vec3::Zero();
  for (const auto& [c, f] : parts) {
    const Pose& T = sets[c].camera->T_world_camera;
    towards += T.linear() * sets[c].models[f].Plane().normal;
    for (const int i : members[c][f]) points.push_back(T * (*sets[c].camera->points)[i]);
  }
  return FitWorldPlane(points, towards);
}

/// How far camera face f's points lie from `plane` (world; RMS in w along their rays) against
/// their scatter about their camera's model of the face (RMS, at least k).
double ScatterRatio(const CameraFaceSet& set, int f, const std::vector<int>& members,
                    const PlanarFace& plane) {
  const Pose& T = set.camera->T_world_camera;
  const Vec3 n = T.linear().transpose() * plane.normal;  // camera frame
  const double d = plane.offset + plane.normal.dot(T.translation());
  double world = 0.0, own = 0.0;
  for (const int i : members) {
    // The plane n^T X + d = 0 along the ray (x, y, 1): w = -n^T (x, y, 1) / d.
    const double w = -n.dot(Vec3(set.grid.x[i], set.grid.y[i], 1.0)) / d;
    world += std::pow(set.grid.w[i] - w, 2);
    own += std::pow(set.grid.w[i] - set.models[f].Predict(set.grid.x[i], set.grid.y[i]), 2);
  }
  return std::sqrt(world / std::max(own, set.k * set.k * static_cast<double>(members.size())));
}

/// Each face's world plane (FitFace on its camera faces, face_of). Of a face other than the
/// leveled floor, the camera faces whose ScatterRatio exceeds max_ratio are made faces of their
/// own (a wrong association: two surfaces joined through a third, or normals within
/// merge_angle_deg that are not one plane), one at a time, the worst first, the face's plane
/// refitted after each; their planes are appended.
std::vector<PlanarFace> WorldPlanes(const std::vector<CameraFaceSet>& sets,
                                    const std::vector<int>& first, double max_ratio,
                                    std::vector<int>* face_of, int* faces) {
  FaceMembers members;
  std::vector<std::vector<CameraFace>> parts(*faces);
  for (size_t c = 0; c < sets.size(); ++c) {
    members.push_back(Members(sets[c].label, sets[c].models.size()));
    for (size_t f = 0; f < sets[c].models.size(); ++f) {
      parts[(*face_of)[first[c] + f]].push_back({static_cast<int>(c), static_cast<int>(f)});
    }
  }
  std::vector<PlanarFace> planes;
  std::vector<CameraFace> detached;
  for (std::vector<CameraFace>& p : parts) {
    planes.push_back(FitFace(sets, members, p));
    while (p.size() >= 2 && !planes.back().floor) {
      double worst = max_ratio;
      auto worst_part = p.end();
      for (auto it = p.begin(); it != p.end(); ++it) {
        const double ratio = ScatterRatio(sets[it->first], it->second,
                                          members[it->first][it->second], planes.back());
        if (ratio > worst) worst = ratio, worst_part = it;
      }
      if (worst_part == p.end()) break;
      (*face_of)[first[worst_part->first] + worst_part->second] = (*faces)++;
      detached.push_back(*worst_part);
      p.erase(worst_part);
      planes.back() = FitFace(sets, members, p);
    }
  }
  for (const CameraFace& part : detached) planes.push_back(FitFace(sets, members, {part}));
  return planes;
}

/// Camera c's faces found in its image: its points' labels and pixels (moved out of `set`) and
/// its faces' planes.
CameraImageFaces Found(CameraFaceSet* set, const std::vector<int>& face_of, int first) {
  CameraImageFaces out;
  out.label = std::move(set->label);
  out.pixels = std::move(set->pixels);
  for (size_t f = 0; f < set->models.size(); ++f) {
    out.planes.push_back(set->models[f].Plane());
    out.face.push_back(face_of[first + f]);
  }
  return out;
}

}  // namespace

ImageFaces FindImageFaces(const std::vector<ImageFaceCamera>& cameras,
                          const ImageFacesOptions& options, int num_threads) {
  std::vector<CameraFaceSet> sets(cameras.size());
  ParallelFor(
      static_cast<int>(cameras.size()), num_threads,
      [&](int c) {
        CameraFaceSet& set = sets[c];
        set.camera = &cameras[c];
        if (cameras[c].points == nullptr) return;
        Settings settings;
        static_cast<ImageFacesOptions&>(settings) = options;
        settings.k = set.k = std::max(cameras[c].depth_noise, kMinImageFaceNoise);
        set.grid = GridOf(cameras[c], *cameras[c].points, &set.pixels);
        set.label = options.leveled_floor
                        ? FloorPoints(set.grid, cameras[c].T_world_camera, settings)
                        : std::vector<int>(set.pixels.size(), kNone);
        set.models = CameraFaces(set.grid, set.pixels, settings, &set.label, &set.floor);
        if (options.crease_sides) {
          CreaseSides(set.grid, set.pixels, settings, &set.models, &set.label);
        }
      },
      1);
  int faces = 0;
  std::vector<int> face_of = Associate(sets, options, &faces);
  const std::vector<int> first = FirstFaces(sets);
  std::vector<PlanarFace> planes =
      WorldPlanes(sets, first, options.max_scatter_ratio, &face_of, &faces);
  ImageFaces found;
  found.camera_faces = first.back();
  found.faces = std::move(planes);
  for (size_t c = 0; c < sets.size(); ++c) {
    found.cameras.push_back(Found(&sets[c], face_of, first[c]));
  }
  return found;
}

}  // namespace rigfit
