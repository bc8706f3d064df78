#include "registration/ray_membership.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <utility>

#include "core/geometry.h"
#include "core/parallel.h"

namespace rigfit {
namespace {

/// A ring cell's pixels join the plane when there are this many, and their mean whitened
/// residual is within this many of its sigmas of zero.
constexpr int kRingMinPixels = 5;
constexpr double kRingMeanSigmas = 3.0;

/// A cell (a, b) of a plane's grid packed in 64 bits.
using CellKey = std::int64_t;

/// A set of cells: open addressing with linear probing over the keys kept in insertion order
/// (std::unordered_set's node per key made the membership a third of the surface bundle's
/// time). Iterates in insertion order; what is computed from a set does not depend on it.
class Cells {
 public:
  /// Inserts `key`; whether it was not there.
  bool insert(CellKey key) {
    if (2 * (keys_.size() + 1) > slots_.size()) Grow();
    int32_t& slot = slots_[Slot(key)];
    if (slot >= 0) return false;
    slot = static_cast<int32_t>(keys_.size());
    keys_.push_back(key);
    return true;
  }
  template <typename It>
  void insert(It first, It last) {
    for (; first != last; ++first) insert(*first);
  }
  size_t count(CellKey key) const { return !slots_.empty() && slots_[Slot(key)] >= 0 ? 1 : 0; }
  bool empty() const { return keys_.empty(); }
  std::vector<CellKey>::const_iterator begin() const { return keys_.begin(); }
  std::vector<CellKey>::const_iterator end() const { return keys_.end(); }

 private:
  /// The slot holding `key`, or the empty one where it would go (slots_ not full).
  size_t Slot(CellKey key) const {
    const std::uint64_t h = static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull;
    const size_t mask = slots_.size() - 1;
    size_t i = (h ^ (h >> 29)) & mask;
    while (slots_[i] >= 0 && keys_[slots_[i]] != key) i = (i + 1) & mask;
    return i;
  }
  void Grow() {
    slots_.assign(std::max<size_t>(16, 2 * slots_.size()), -1);
    for (size_t k = 0; k < keys_.size(); ++k) slots_[Slot(keys_[k])] = static_cast<int32_t>(k);
  }
  std::vector<CellKey> keys_;
  std::vector<int32_t> slots_;  ///< index into keys_, -1: empty
};

CellKey Pack(std::int64_t a, std::int64_t b) {
  return static_cast<CellKey>((static_cast<std::uint64_t>(a) << 32) |
                              static_cast<std::uint32_t>(b));
}
std::int64_t First(CellKey key) { return static_cast<std::int32_t>(key >> 32); }
std::int64_t Second(CellKey key) { return static_cast<std::int32_t>(key & 0xffffffff); }

/// Cells of `size` along two in-plane axes: e1 horizontal (unless the plane is near
/// horizontal), e2 = n x e1.
struct PlaneGrid {
  Vec3 origin;
  Vec3 e1;
  Vec3 e2;
  double size;

  PlaneGrid(const PlanarFace& plane, double cell) : size(cell) {
    origin = -plane.offset * plane.normal;
    const Vec3 helper = std::abs(plane.normal.y()) < 0.9 ? Vec3::UnitY() : Vec3::UnitX();
    e1 = helper.cross(plane.normal).normalized();
    e2 = plane.normal.cross(e1);
  }
  CellKey Key(const Vec3& x) const {
    const Vec3 r = x - origin;
    return Pack(static_cast<std::int64_t>(std::floor(r.dot(e1) / size)),
                static_cast<std::int64_t>(std::floor(r.dot(e2) / size)));
  }
  /// World height of the centre of cell (a, b).
  double Height(std::int64_t a, std::int64_t b) const {
    return (origin + (a + 0.5) * size * e1 + (b + 0.5) * size * e2).y();
  }
};

Cells Dilated(const Cells& cells) {
  Cells out;
  for (const CellKey k : cells) {
    for (int da = -1; da <= 1; ++da) {
      for (int db = -1; db <= 1; ++db) out.insert(Pack(First(k) + da, Second(k) + db));
    }
  }
  return out;
}

/// The cells whose eight neighbours are all in `cells`.
Cells Eroded(const Cells& cells) {
  Cells out;
  for (const CellKey k : cells) {
    bool inside = true;
    for (int da = -1; da <= 1 && inside; ++da) {
      for (int db = -1; db <= 1 && inside; ++db) {
        inside = cells.count(Pack(First(k) + da, Second(k) + db)) > 0;
      }
    }
    if (inside) out.insert(k);
  }
  return out;
}

/// A near-vertical plane's cells extended down to the floor (y = -size), column by column.
Cells DownToFloor(const Cells& cells, const PlaneGrid& grid) {
  if (std::abs(grid.e2.y()) < 0.9) return cells;
  const int down = grid.e2.y() > 0.0 ? -1 : 1;
  Cells out = cells;
  for (const CellKey k : cells) {
    for (std::int64_t b = Second(k) + down; grid.Height(First(k), b) >= -grid.size; b += down) {
      if (!out.insert(Pack(First(k), b))) break;  // the column below is there already
    }
  }
  return out;
}

/// The pixels of a camera whose rays meet a plane in one cell of its ring, and their whitened
/// depth residuals against the plane.
struct RingCell {
  std::vector<int> pixels;
  double sum = 0.0;
  double sum_squares = 0.0;

  void Add(int pixel, double residual) {
    pixels.push_back(pixel);
    sum += residual;
    sum_squares += residual * residual;
  }
  /// Enough pixels, their mean within kRingMeanSigmas of its spread of zero, and their
  /// chi-square within chi2_sigmas of its degrees of freedom (the segmentation's test).
  bool OnThePlane(double chi2_sigmas) const {
    const int count = static_cast<int>(pixels.size());
    return count >= kRingMinPixels && std::abs(sum) <= kRingMeanSigmas * std::sqrt(count) &&
           WithinNoise(sum_squares, count, chi2_sigmas);
  }
};

/// What every step of MembershipByRays reads: the cameras at their poses, the planes with
/// their grids, and the segmentation's noise floor and gate.
struct RayContext {
  const std::vector<SurfaceCamera>& cameras;
  const std::vector<Pose>& poses;
  const std::vector<PlanarFace>& planes;
  std::vector<PlaneGrid> grids;
  double base;  // BaseVariance of the segmentation
  double gate;  // its gate, sigmas

  /// Pixel i's ray in the world (not normalised: unit camera z).
  Vec3 Ray(size_t c, int i) const {
    const Vec3& p = cameras[c].points[i];
    return Vec3(poses[c].linear() * (p / p.z()));
  }
  /// A pixel's depth sigma at depth z.
  double SigmaZ(size_t c, double z) const {
    const double s = cameras[c].depth_noise * z * z;
    return std::sqrt(s * s + base);
  }
  /// How far from pixel i's measured depth a plane met along its ray is looked at (twice the
  /// gate).
  double Reach(size_t c, int i) const { return 2.0 * gate * SigmaZ(c, cameras[c].points[i].z()); }
  /// Whether a plane met at depth z along pixel i's ray is within `reach` of its measured depth.
  bool WithinReach(size_t c, int i, double z, double reach) const {
    return std::isfinite(z) && z > 0.0 && std::abs(z - cameras[c].points[i].z()) <= reach;
  }
};

using CellsPerPlane = std::vector<Cells>;

/// Camera c's extent of each plane: the cells where its segmented pixels' rays meet the plane,
/// closed (dilated, then eroded).
CellsPerPlane OwnCells(const RayContext& ctx, const std::vector<SurfaceTerm>& segmented, int c) {
  CellsPerPlane own(ctx.planes.size());
  if (!ctx.cameras[c].ray_model) return own;
  const Vec3& centre = ctx.poses[c].translation();
  for (const SurfaceTerm& t : segmented) {
    if (t.camera != c) continue;
    const PlanarFace& plane = ctx.planes[t.plane];
    for (const int i : t.pixels) {
      const Vec3 ray = ctx.Ray(c, i);
      const double z = RayPlaneDepth(centre, ray, plane.normal, plane.offset);
      // Not where a grazing ray meets the plane far from the pixel's own point.
      if (ctx.WithinReach(c, i, z, ctx.Reach(c, i)))
        own[t.plane].insert(ctx.grids[t.plane].Key(centre + z * ray));
    }
  }
  for (Cells& cells : own) cells = Eroded(Dilated(cells));
  return own;
}

/// Camera c's ring of kMembershipGrowCells cells around its extent of each plane.
CellsPerPlane RingCells(const CellsPerPlane& own) {
  CellsPerPlane ring(own.size());
  for (size_t j = 0; j < own.size(); ++j) {
    if (own[j].empty()) continue;
    Cells grown = own[j];
    for (int g = 0; g < kMembershipGrowCells; ++g) grown = Dilated(grown);
    for (const CellKey k : grown) {
      if (!own[j].count(k)) ring[j].insert(k);
    }
  }
  return ring;
}

/// The nearest plane along a pixel's ray met in the camera's own cells or ring, and the crease
/// zones it meets on the way (depth, plane).
struct RayHit {
  int plane = -1;
  double z = std::numeric_limits<double>::infinity();
  bool in_ring = false;
  CellKey ring_key = 0;  // the ring's cell when the nearest plane is met in the ring
  std::vector<std::pair<double, int>> near;
};

/// Where a camera looks for each plane along its pixels' rays.
struct CameraCells {
  const CellsPerPlane& own;   ///< the camera's extent of each plane (OwnCells)
  const CellsPerPlane& ring;  ///< its ring around that extent (RingCells)
  const CellsPerPlane& zone;  ///< each plane's crease zone (of every camera's extents)
};

/// Into `hit`: the nearest plane along pixel i's ray (camera c) met in the camera's own cells or
/// ring, and the crease zones met within reach.
void NearestPlane(const RayContext& ctx, int c, int i, const Vec3& ray, const CameraCells& cells,
                  RayHit* hit) {
  const Vec3& centre = ctx.poses[c].translation();
  hit->plane = -1;
  hit->z = std::numeric_limits<double>::infinity();
  hit->in_ring = false;
  hit->ring_key = 0;
  hit->near.clear();
  const double reach = ctx.Reach(c, i);
  for (size_t j = 0; j < ctx.planes.size(); ++j) {
    const double z = RayPlaneDepth(centre, ray, ctx.planes[j].normal, ctx.planes[j].offset);
    if (!ctx.WithinReach(c, i, z, reach)) continue;
    const CellKey key = ctx.grids[j].Key(centre + z * ray);
    if (cells.zone[j].count(key)) hit->near.emplace_back(z, static_cast<int>(j));
    if (z >= hit->z) continue;
    const bool own_cell = cells.own[j].count(key) > 0;
    if (!own_cell && !cells.ring[j].count(key)) continue;
    hit->z = z, hit->plane = static_cast<int>(j), hit->in_ring = !own_cell, hit->ring_key = key;
  }
}

/// Whether pixel i belongs to the plane it hit: within the gate of it, not at a crease with
/// another plane, and at a height inside the band (the floor: near y = 0).
bool KeepHit(const RayContext& ctx, const PlaneSegmentationOptions& segmentation, int c, int i,
             const Vec3& ray, const RayHit& hit) {
  const SurfaceCamera& camera = ctx.cameras[c];
  const double measured = camera.points[i].z();
  const double sigma = ctx.SigmaZ(c, hit.z);
  if (std::abs(measured - hit.z) > ctx.gate * sigma) return false;
  const bool crease = std::any_of(hit.near.begin(), hit.near.end(), [&](const auto& other) {
    return other.second != hit.plane && other.first - hit.z <= ctx.gate * sigma;
  });
  if (crease) return false;
  const double sigma_v = VerticalSigma(camera, hit.z, ray, ctx.base);
  if (ctx.planes[hit.plane].floor) {
    const double height = (ctx.poses[c] * camera.points[i]).y();
    const double limit =
        std::min({ctx.gate * sigma_v, segmentation.floor_height_m, -camera.band_bottom});
    return !(std::abs(height) > limit);
  }
  const double height = ctx.poses[c].translation().y() + hit.z * ray.y();
  return !(height < camera.band_bottom || height > PredictedTop(camera, sigma_v));
}

/// Camera c's pixels of each plane: those whose nearest plane is met in the camera's own cells,
/// and the ring cells whose pixels as a whole lie on the plane.
std::vector<std::vector<int>> CameraPixels(const RayContext& ctx,
                                           const PlaneSegmentationOptions& segmentation, int c,
                                           const CameraCells& cells) {
  const SurfaceCamera& camera = ctx.cameras[c];
  std::vector<std::vector<int>> pixels(ctx.planes.size());
  // The pixels in the ring, by (plane, cell), with their whitened depth residuals.
  std::map<std::pair<int, CellKey>, RingCell> ring_cells;
  RayHit hit;
  for (int i = 0; i < static_cast<int>(camera.points.size()); ++i) {
    const Vec3 ray = ctx.Ray(c, i);
    NearestPlane(ctx, c, i, ray, cells, &hit);
    if (hit.plane < 0 || !KeepHit(ctx, segmentation, c, i, ray, hit)) continue;
    if (hit.in_ring) {
      ring_cells[{hit.plane, hit.ring_key}].Add(
          i, (camera.points[i].z() - hit.z) / ctx.SigmaZ(c, hit.z));
    } else {
      pixels[hit.plane].push_back(i);
    }
  }
  for (const auto& [key, cell] : ring_cells) {
    if (!cell.OnThePlane(segmentation.chi2_sigmas)) continue;
    std::vector<int>& on_plane = pixels[key.first];
    on_plane.insert(on_plane.end(), cell.pixels.begin(), cell.pixels.end());
  }
  for (std::vector<int>& on_plane : pixels) std::sort(on_plane.begin(), on_plane.end());
  return pixels;
}

}  // namespace

double VerticalSigma(const SurfaceCamera& camera, double z, const Vec3& ray, double base_variance) {
  const double along = camera.depth_noise * z * z * ray.y();
  return std::sqrt(along * along + base_variance);
}

double PredictedTop(const SurfaceCamera& camera, double sigma_v) {
  return std::min(camera.band_top, camera.points_top - kWindowSigmas * sigma_v);
}

std::vector<SurfaceTerm> MembershipByRays(const std::vector<SurfaceCamera>& cameras,
                                          const std::vector<Pose>& poses,
                                          const std::vector<PlanarFace>& planes,
                                          const std::vector<SurfaceTerm>& segmented,
                                          const PlaneSegmentationOptions& segmentation,
                                          int num_threads) {
  const size_t n = cameras.size();
  const size_t m = planes.size();
  RayContext ctx{cameras, poses, planes, {}, BaseVariance(segmentation), segmentation.gate_sigmas};
  for (const PlanarFace& plane : planes) {
    ctx.grids.emplace_back(plane, kMembershipCellVoxels * segmentation.voxel_size);
  }
  // Each camera's extent of each plane (a camera at a time), then every plane's crease zone
  // (a plane at a time), then each camera's ring around its extent.
  std::vector<CellsPerPlane> own(n), ring(n);
  ParallelFor(
      static_cast<int>(n), num_threads, [&](int c) { own[c] = OwnCells(ctx, segmented, c); },
      /*min_per_thread=*/1);
  CellsPerPlane zone(m);
  ParallelFor(
      static_cast<int>(m), num_threads,
      [&](int j) {
        Cells all;
        for (size_t c = 0; c < n; ++c) all.insert(own[c][j].begin(), own[c][j].end());
        zone[j] = planes[j].floor ? Dilated(all) : DownToFloor(Dilated(all), ctx.grids[j]);
      },
      /*min_per_thread=*/1);
  ParallelFor(
      static_cast<int>(n), num_threads, [&](int c) { ring[c] = RingCells(own[c]); },
      /*min_per_thread=*/1);
  // Every pixel, a camera at a time.
  std::vector<std::vector<std::vector<int>>> pixels(n);
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int c) {
        if (cameras[c].ray_model)
          pixels[c] = CameraPixels(ctx, segmentation, c, {own[c], ring[c], zone});
      },
      /*min_per_thread=*/1);

  std::vector<SurfaceTerm> out;
  for (size_t c = 0; c < n; ++c) {
    if (!cameras[c].ray_model) {
      for (const SurfaceTerm& t : segmented) {
        if (t.camera == static_cast<int>(c)) out.push_back(t);
      }
      continue;
    }
    for (size_t j = 0; j < m; ++j) {
      if (static_cast<int>(pixels[c][j].size()) < segmentation.min_points_per_camera) continue;
      out.push_back({static_cast<int>(c), static_cast<int>(j), std::move(pixels[c][j])});
    }
  }
  return out;
}

}  // namespace rigfit
