#include "registration/plane_segmentation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <tuple>

#include "core/geometry.h"
#include "core/parallel.h"

namespace rigfit {
namespace {

struct Box {
  Vec3 min = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 max = Vec3::Constant(-std::numeric_limits<double>::infinity());

  void Extend(const Box& other) {
    min = min.cwiseMin(other.min);
    max = max.cwiseMax(other.max);
  }
  bool Touches(const Box& other, double margin) const {
    for (int k = 0; k < 3; ++k) {
      if (min[k] > other.max[k] + margin || other.min[k] > max[k] + margin) return false;
    }
    return true;
  }
  bool Contains(const Vec3& p, double margin) const {
    return (p.array() >= min.array() - margin).all() && (p.array() <= max.array() + margin).all();
  }
};

struct PlaneFit {
  Vec3 normal = Vec3::UnitY();
  double offset = 0.0;
  double chi2 = 0.0;
  int dof = 0;
  /// Per camera: the chi-square and count of its points (a crease that a far, noisy camera
  /// cannot tell from a plane shows in a near camera's points).
  std::vector<double> camera_chi2;
  std::vector<int> camera_count;
};

/// A set of points with the plane fitted to them and the cells they came from.
struct Patch {
  PlaneFit fit;
  std::vector<int> points;
  Box box;
};

/// The patches whose boxes touch patch p's (within `margin`), bucketed by cells of the XZ plane
/// over p's box: At(x) lists those whose box, grown by the margin, may hold x (a superset;
/// the caller tests Box::Contains).
class NeighbourGrid {
 public:
  NeighbourGrid(const std::vector<Patch>& patches, size_t p, double margin)
      : min_(patches[p].box.min - Vec3::Constant(margin)) {
    const Vec3 extent = patches[p].box.max - patches[p].box.min + Vec3::Constant(2.0 * margin);
    cell_ = std::max({extent.x(), extent.z(), margin}) / kCells;
    nx_ = std::clamp(static_cast<int>(std::ceil(extent.x() / cell_)), 1, kCells);
    nz_ = std::clamp(static_cast<int>(std::ceil(extent.z() / cell_)), 1, kCells);
    buckets_.resize(static_cast<size_t>(nx_) * nz_);
    for (size_t q = 0; q < patches.size(); ++q) {
      const Box& box = patches[q].box;
      if (q == p || !patches[p].box.Touches(box, margin)) continue;
      const int x0 = Index(box.min.x() - margin, min_.x(), nx_);
      const int x1 = Index(box.max.x() + margin, min_.x(), nx_);
      const int z0 = Index(box.min.z() - margin, min_.z(), nz_);
      const int z1 = Index(box.max.z() + margin, min_.z(), nz_);
      for (int x = x0; x <= x1; ++x) {
        for (int z = z0; z <= z1; ++z)
          buckets_[static_cast<size_t>(x) * nz_ + z].push_back(&patches[q]);
      }
    }
  }
  const std::vector<const Patch*>& At(const Vec3& x) const {
    return buckets_[static_cast<size_t>(Index(x.x(), min_.x(), nx_)) * nz_ +
                    Index(x.z(), min_.z(), nz_)];
  }

 private:
  static constexpr int kCells = 32;  ///< along the box's longer horizontal side
  int Index(double v, double origin, int n) const {
    return std::clamp(static_cast<int>(std::floor((v - origin) / cell_)), 0, n - 1);
  }
  Vec3 min_;
  double cell_ = 1.0;
  int nx_ = 1;
  int nz_ = 1;
  std::vector<std::vector<const Patch*>> buckets_;
};

class Segmenter {
 public:
  Segmenter(const std::vector<SegmentPoint>& points, int num_cameras,
            const PlaneSegmentationOptions& options, int num_threads)
      : points_(points), num_cameras_(num_cameras), options_(options), num_threads_(num_threads) {
    base_variance_ = BaseVariance(options);
    min_cell_ = options.min_cell_voxels * options.voxel_size;
  }

  /// Variance of point i along the normal n.
  double Variance(int i, const Vec3& n) const {
    const SegmentPoint& p = points_[i];
    const double along = p.sigma_z * n.dot(p.ray_world);
    return along * along + base_variance_;
  }

  /// Noise-weighted least squares: weights from the worst direction first, then from the
  /// fitted normal, and the chi-square of the whitened distances.
  PlaneFit Fit(const std::vector<int>& indices) const {
    PlaneFit fit;
    std::vector<double> weight(indices.size());
    for (size_t k = 0; k < indices.size(); ++k) {
      const SegmentPoint& p = points_[indices[k]];
      weight[k] = 1.0 / (p.sigma_z * p.sigma_z * p.ray_world.squaredNorm() + base_variance_);
    }
    for (int pass = 0; pass < 2; ++pass) {
      const PlanarFace plane = FitPlane(
          indices.size(), [&](size_t k) -> const Vec3& { return points_[indices[k]].world; },
          [&](size_t k) { return weight[k]; });
      fit.normal = plane.normal;
      fit.offset = plane.offset;
      for (size_t k = 0; k < indices.size(); ++k) {
        weight[k] = 1.0 / Variance(indices[k], fit.normal);
      }
    }
    fit.chi2 = 0.0;
    fit.camera_chi2.assign(num_cameras_, 0.0);
    fit.camera_count.assign(num_cameras_, 0);
    for (size_t k = 0; k < indices.size(); ++k) {
      const double r = fit.normal.dot(points_[indices[k]].world) + fit.offset;
      fit.chi2 += weight[k] * r * r;
      const int camera = points_[indices[k]].camera;
      fit.camera_chi2[camera] += weight[k] * r * r;
      ++fit.camera_count[camera];
    }
    fit.dof = static_cast<int>(indices.size()) - 3;
    return fit;
  }

  /// Whether point i's ray meets the planes a and b within gate_sigmas of its depth noise of
  /// each other: near their crease, where its measured position (which its noise moves)
  /// cannot say which plane it lies on. Unlike a test of the measured position, the choice
  /// does not depend on the point's own noise. False for points without a ray.
  bool NearCrease(int i, const PlaneFit& a, const PlaneFit& b) const {
    const SegmentPoint& s = points_[i];
    if (!(s.depth > 0.0)) return false;
    const Vec3 centre = s.world - s.depth * s.ray_world;
    const double difference = RayPlaneDepth(centre, s.ray_world, a.normal, a.offset) -
                              RayPlaneDepth(centre, s.ray_world, b.normal, b.offset);
    const double gate = options_.gate_sigmas;
    return difference * difference <= gate * gate * (s.sigma_z * s.sigma_z + base_variance_);
  }

  /// The plane explains all the points, and the points of each camera that sees it.
  bool Planar(const PlaneFit& fit) const {
    if (!WithinNoise(fit.chi2, fit.dof, options_.chi2_sigmas)) return false;
    for (int c = 0; c < num_cameras_; ++c) {
      if (fit.camera_count[c] >= options_.min_points_per_camera &&
          !WithinNoise(fit.camera_chi2[c], fit.camera_count[c], options_.chi2_sigmas)) {
        return false;
      }
    }
    return true;
  }

  /// Whether at least `cameras` cameras have min_points_per_camera of the points each.
  bool SeenByCameras(const std::vector<int>& indices, int cameras) const {
    std::vector<int> count(num_cameras_, 0);
    for (const int i : indices) ++count[points_[i].camera];
    return std::count_if(count.begin(), count.end(),
                         [&](int c) { return c >= options_.min_points_per_camera; }) >= cameras;
  }

  /// The octree below one cell: kept when planar, else split in eight while the children are
  /// at least the smallest cell.
  void Split(const std::vector<int>& indices, const Vec3& corner, double size,
             std::vector<Patch>* cells) const {
    if (!SeenByCameras(indices, 1)) return;  // splitting cannot add points
    const PlaneFit fit = Fit(indices);
    if (Planar(fit)) {
      Patch& patch = cells->emplace_back();
      patch.fit = fit;
      patch.points = indices;
      patch.box.min = corner;
      patch.box.max = corner + Vec3::Constant(size);
      return;
    }
    const double half = 0.5 * size;
    if (half < min_cell_ * (1.0 - 1e-9)) return;
    std::array<std::vector<int>, 8> children;
    const Vec3 middle = corner + Vec3::Constant(half);
    for (const int i : indices) {
      const Vec3& x = points_[i].world;
      children[(x.x() >= middle.x()) | (x.y() >= middle.y()) << 1 | (x.z() >= middle.z()) << 2]
          .push_back(i);
    }
    for (int c = 0; c < 8; ++c) {
      const Vec3 child(c & 1 ? middle.x() : corner.x(), c & 2 ? middle.y() : corner.y(),
                       c & 4 ? middle.z() : corner.z());
      Split(children[c], child, half, cells);
    }
  }

  /// Planar cells of the whole cloud, top cells of max_cell_voxels.
  void FindCells() {
    if (points_.empty()) return;
    const double top = options_.max_cell_voxels * options_.voxel_size;
    Vec3 origin = points_.front().world;
    for (const SegmentPoint& p : points_) origin = origin.cwiseMin(p.world);
    std::map<std::array<long long, 3>, std::vector<int>> cells;
    const double gate2 = options_.gate_sigmas * options_.gate_sigmas;
    Patch floor;
    for (int i = 0; i < static_cast<int>(points_.size()); ++i) {
      const double y = points_[i].world.y();
      if (options_.leveled_floor && std::abs(y) <= options_.floor_height_m &&
          y * y <= gate2 * Variance(i, Vec3::UnitY())) {
        floor.points.push_back(i);
        floor.box.Extend({points_[i].world, points_[i].world});
        continue;
      }
      const double margin =
          std::min(options_.floor_margin_m,
                   options_.floor_margin_sigmas * std::sqrt(Variance(i, Vec3::UnitY())));
      if (options_.leveled_floor && std::abs(y) <= margin) continue;
      const Vec3 cell = ((points_[i].world - origin) / top).array().floor();
      cells[{static_cast<long long>(cell.x()), static_cast<long long>(cell.y()),
             static_cast<long long>(cell.z())}]
          .push_back(i);
    }
    // The top cells in parallel, their planar cells in the order of the top cells.
    std::vector<std::pair<std::array<long long, 3>, std::vector<int>>> tops;
    for (auto& [key, indices] : cells) tops.emplace_back(key, std::move(indices));
    std::vector<std::vector<Patch>> found(tops.size());
    ParallelFor(
        static_cast<int>(tops.size()), num_threads_,
        [&](int k) {
          const std::array<long long, 3>& key = tops[k].first;
          Split(tops[k].second, origin + top * Vec3(key[0], key[1], key[2]), top, &found[k]);
        },
        /*min_per_thread=*/1);
    for (std::vector<Patch>& patches : found) {
      for (Patch& patch : patches) cells_.push_back(std::move(patch));
    }
    // The floor joins the near-horizontal patches near y = 0 in JoinFloor; it is not merged
    // with its neighbours before (MergeCells skips it: floor_cell_).
    if (!floor.points.empty()) {
      floor.fit.normal = Vec3::UnitY();
      floor_cell_ = static_cast<int>(cells_.size());
      cells_.push_back(std::move(floor));
    }
  }

  /// Merges touching cells whose planes agree (the merged fit passes the planarity test),
  /// most parallel pairs first.
  std::vector<Patch> MergeCells() const {
    const double cos_merge = std::cos(options_.merge_angle_deg * M_PI / 180.0);
    std::vector<std::tuple<double, int, int>> candidates;
    for (size_t i = 0; i < cells_.size(); ++i) {
      for (size_t j = i + 1; j < cells_.size(); ++j) {
        const double c = std::abs(cells_[i].fit.normal.dot(cells_[j].fit.normal));
        if (static_cast<int>(i) == floor_cell_ || static_cast<int>(j) == floor_cell_) continue;
        if (c >= cos_merge && cells_[i].box.Touches(cells_[j].box, 1e-9)) {
          candidates.emplace_back(-c, static_cast<int>(i), static_cast<int>(j));
        }
      }
    }
    std::sort(candidates.begin(), candidates.end());
    std::vector<int> parent(cells_.size());
    std::iota(parent.begin(), parent.end(), 0);
    const auto root = [&](int i) {
      while (parent[i] != i) i = parent[i] = parent[parent[i]];
      return i;
    };
    std::vector<Patch> merged = cells_;
    for (const auto& [angle, i, j] : candidates) {
      const int a = root(i), b = root(j);
      if (a == b) continue;
      std::vector<int> both = merged[a].points;
      both.insert(both.end(), merged[b].points.begin(), merged[b].points.end());
      const PlaneFit fit = Fit(both);
      if (!Planar(fit)) continue;
      parent[b] = a;
      merged[a].fit = fit;
      merged[a].points = std::move(both);
      merged[a].box.Extend(merged[b].box);
    }
    std::vector<Patch> out;
    for (size_t i = 0; i < merged.size(); ++i) {
      if (root(static_cast<int>(i)) == static_cast<int>(i)) out.push_back(std::move(merged[i]));
    }
    return out;
  }

  /// The floor patches (near-horizontal, near y = 0) as one plane with normal +Y.
  std::vector<Patch> JoinFloor(std::vector<Patch> patches) {
    const double cos_floor = std::cos(options_.floor_angle_deg * M_PI / 180.0);
    Patch floor;
    std::vector<Patch> out;
    for (Patch& patch : patches) {
      const Vec3& n = patch.fit.normal;
      if (std::abs(n.y()) >= cos_floor &&
          std::abs(patch.fit.offset / n.y()) <= options_.floor_height_m) {
        floor.points.insert(floor.points.end(), patch.points.begin(), patch.points.end());
        floor.box.Extend(patch.box);
      } else {
        out.push_back(std::move(patch));
      }
    }
    if (floor.points.empty()) return out;
    double sum_w = 0.0, sum_wy = 0.0;
    for (const int i : floor.points) {
      const double w = 1.0 / Variance(i, Vec3::UnitY());
      sum_w += w;
      sum_wy += w * points_[i].world.y();
    }
    floor.fit.normal = Vec3::UnitY();
    floor.fit.offset = -sum_wy / sum_w;
    floor_index_ = static_cast<int>(out.size());
    out.push_back(std::move(floor));
    return out;
  }

  /// Patch p keeps the points within gate_sigmas of its plane that neither fit a touching
  /// plane as well nor lie near its crease with it (NearCrease), and the cameras with enough
  /// of them; false when too few cameras see it (then `plane` is not to be used).
  bool AssignPatch(const std::vector<Patch>& patches, size_t p, SegmentedPlane* plane) const {
    // Seen by too few cameras before any point is left out: it goes.
    if (!SeenByCameras(patches[p].points, options_.min_cameras)) return false;
    const double gate2 = options_.gate_sigmas * options_.gate_sigmas;
    const auto fits = [&](int i, const PlaneFit& fit) {
      const double r = fit.normal.dot(points_[i].world) + fit.offset;
      return r * r <= gate2 * Variance(i, fit.normal);
    };
    const NeighbourGrid neighbours(patches, p, min_cell_);
    const std::vector<int>& points = patches[p].points;
    std::vector<char> keep(points.size(), 0);
    // The points in parallel: the floor holds most of them.
    ParallelFor(static_cast<int>(points.size()), num_threads_, [&](int k) {
      const int i = points[k];
      if (!fits(i, patches[p].fit)) return;
      const std::vector<const Patch*>& near = neighbours.At(points_[i].world);
      keep[k] = std::none_of(near.begin(), near.end(), [&](const Patch* q) {
        return q->box.Contains(points_[i].world, min_cell_) &&
               (fits(i, q->fit) || NearCrease(i, patches[p].fit, q->fit));
      });
    });
    std::vector<int> kept;
    std::vector<int> count(num_cameras_, 0);
    for (size_t k = 0; k < points.size(); ++k) {
      if (!keep[k]) continue;
      kept.push_back(points[k]);
      ++count[points_[points[k]].camera];
    }
    plane->normal = patches[p].fit.normal;
    plane->offset = patches[p].fit.offset;
    plane->floor = static_cast<int>(p) == floor_index_;
    for (const int i : kept) {
      if (count[points_[i].camera] >= options_.min_points_per_camera) plane->points.push_back(i);
    }
    const int cameras = static_cast<int>(std::count_if(
        count.begin(), count.end(), [&](int c) { return c >= options_.min_points_per_camera; }));
    return cameras >= options_.min_cameras;
  }

  /// Each patch's points (AssignPatch); patches seen by too few cameras go.
  std::vector<SegmentedPlane> Assign(const std::vector<Patch>& patches) const {
    std::vector<SegmentedPlane> planes;
    for (size_t p = 0; p < patches.size(); ++p) {
      SegmentedPlane plane;
      if (AssignPatch(patches, p, &plane)) planes.push_back(std::move(plane));
    }
    return planes;
  }

  std::vector<SegmentedPlane> Run() {
    { FindCells(); }
    std::vector<Patch> m;
    { m = MergeCells(); }
    { m = JoinFloor(std::move(m)); }
    return Assign(m);
  }

 private:
  const std::vector<SegmentPoint>& points_;
  int num_cameras_;
  PlaneSegmentationOptions options_;
  int num_threads_;
  double base_variance_ = 0.0;
  double min_cell_ = 0.0;
  std::vector<Patch> cells_;
  int floor_index_ = -1;  ///< the floor's index among JoinFloor's patches, -1 if none
  int floor_cell_ = -1;   ///< the leveled floor's index among cells_, -1 if none
};

}  // namespace

bool WithinNoise(double chi2, int dof, double sigmas) {
  return dof > 0 && chi2 / dof <= 1.0 + sigmas * std::sqrt(2.0 / dof);
}

double BaseVariance(const PlaneSegmentationOptions& options) {
  const double model = options.model_sigma_voxels * options.voxel_size;
  return model * model + options.min_noise_m * options.min_noise_m;
}

std::vector<SegmentedPlane> SegmentPlanes(const std::vector<SegmentPoint>& points, int num_cameras,
                                          const PlaneSegmentationOptions& options,
                                          int num_threads) {
  return Segmenter(points, num_cameras, options, num_threads).Run();
}

}  // namespace rigfit
