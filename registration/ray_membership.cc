#include "registration/ray_membership.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <unordered_set>
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
using Cells = std::unordered_set<CellKey>;

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

  PlaneGrid(const SurfacePlane& plane, double cell) : size(cell) {
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
      if (!out.insert(Pack(First(k), b)).second) break;  // the column below is there already
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
                                          const std::vector<SurfacePlane>& planes,
                                          const std::vector<SurfaceTerm>& segmented,
                                          const PlaneSegmentationOptions& segmentation,
                                          int num_threads) {
  const size_t n = cameras.size();
  const size_t m = planes.size();
  const double base = BaseVariance(segmentation);
  const double gate = segmentation.gate_sigmas;
  std::vector<PlaneGrid> grids;
  for (const SurfacePlane& plane : planes) {
    grids.emplace_back(plane, kMembershipCellVoxels * segmentation.voxel_size);
  }
  const auto ray_of = [&](size_t c, int i) {
    const Vec3& p = cameras[c].points[i];
    return Vec3(poses[c].linear() * (p / p.z()));
  };
  // A pixel's depth sigma at depth z, and whether a plane met at depth z along its ray is near
  // enough to its measured depth to be looked at (twice the gate).
  const auto sigma_z = [&](size_t c, double z) {
    const double s = cameras[c].depth_noise * z * z;
    return std::sqrt(s * s + base);
  };
  const auto within_reach = [&](size_t c, int i, double z) {
    const double measured = cameras[c].points[i].z();
    return std::isfinite(z) && z > 0.0 &&
           std::abs(z - measured) <= 2.0 * gate * sigma_z(c, measured);
  };

  // Each camera's extent of each plane (a camera at a time), then every plane's crease zone
  // (a plane at a time).
  std::vector<std::vector<Cells>> own(n, std::vector<Cells>(m));
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int c) {
        if (!cameras[c].ray_model) return;
        const Vec3& centre = poses[c].translation();
        for (const SurfaceTerm& t : segmented) {
          if (t.camera != c) continue;
          const SurfacePlane& plane = planes[t.plane];
          for (const int i : t.pixels) {
            const Vec3 ray = ray_of(c, i);
            const double z = RayPlaneDepth(centre, ray, plane.normal, plane.offset);
            // Not where a grazing ray meets the plane far from the pixel's own point.
            if (within_reach(c, i, z)) own[c][t.plane].insert(grids[t.plane].Key(centre + z * ray));
          }
        }
        for (Cells& cells : own[c]) cells = Eroded(Dilated(cells));
      },
      /*min_per_thread=*/1);
  std::vector<Cells> zone(m);
  ParallelFor(
      static_cast<int>(m), num_threads,
      [&](int j) {
        Cells all;
        for (size_t c = 0; c < n; ++c) all.insert(own[c][j].begin(), own[c][j].end());
        zone[j] = planes[j].floor ? Dilated(all) : DownToFloor(Dilated(all), grids[j]);
      },
      /*min_per_thread=*/1);

  // Each camera's ring of kMembershipGrowCells cells around its extent of each plane.
  std::vector<std::vector<Cells>> ring(n, std::vector<Cells>(m));
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int c) {
        for (size_t j = 0; j < m; ++j) {
          if (own[c][j].empty()) continue;
          Cells grown = own[c][j];
          for (int g = 0; g < kMembershipGrowCells; ++g) grown = Dilated(grown);
          for (const CellKey k : grown) {
            if (!own[c][j].count(k)) ring[c][j].insert(k);
          }
        }
      },
      /*min_per_thread=*/1);

  // Every pixel, a camera at a time.
  std::vector<std::vector<std::vector<int>>> pixels(n);
  ParallelFor(
      static_cast<int>(n), num_threads,
      [&](int c) {
        const SurfaceCamera& camera = cameras[c];
        if (!camera.ray_model) return;
        const Vec3& centre = poses[c].translation();
        pixels[c].resize(m);
        // The pixels in the ring, by (plane, cell), with their whitened depth residuals.
        std::map<std::pair<int, CellKey>, RingCell> ring_cells;
        std::vector<std::pair<double, int>> near;  // (depth, plane) of the crease zones met
        for (int i = 0; i < static_cast<int>(camera.points.size()); ++i) {
          const Vec3 ray = ray_of(c, i);
          const double measured = camera.points[i].z();
          double z1 = std::numeric_limits<double>::infinity();
          int j1 = -1;
          CellKey ring_key = 0;  // the ring's cell when the nearest plane is met in the ring
          bool in_ring = false;
          near.clear();
          for (size_t j = 0; j < m; ++j) {
            const double z = RayPlaneDepth(centre, ray, planes[j].normal, planes[j].offset);
            if (!within_reach(c, i, z)) continue;
            const CellKey key = grids[j].Key(centre + z * ray);
            if (zone[j].count(key)) near.emplace_back(z, static_cast<int>(j));
            if (z >= z1) continue;
            const bool own_cell = own[c][j].count(key) > 0;
            if (!own_cell && !ring[c][j].count(key)) continue;
            z1 = z, j1 = static_cast<int>(j), in_ring = !own_cell, ring_key = key;
          }
          if (j1 < 0) continue;
          const double sigma = sigma_z(c, z1);
          if (std::abs(measured - z1) > gate * sigma) continue;
          const bool crease = std::any_of(near.begin(), near.end(), [&](const auto& hit) {
            return hit.second != j1 && hit.first - z1 <= gate * sigma;
          });
          if (crease) continue;
          const double sigma_v = VerticalSigma(camera, z1, ray, base);
          if (planes[j1].floor) {
            const double height = (poses[c] * camera.points[i]).y();
            const double limit =
                std::min({gate * sigma_v, segmentation.floor_height_m, -camera.band_bottom});
            if (std::abs(height) > limit) continue;
          } else {
            const double height = centre.y() + z1 * ray.y();
            if (height < camera.band_bottom || height > PredictedTop(camera, sigma_v)) continue;
          }
          if (in_ring) {
            ring_cells[{j1, ring_key}].Add(i, (measured - z1) / sigma);
          } else {
            pixels[c][j1].push_back(i);
          }
        }
        for (const auto& [key, cell] : ring_cells) {
          if (!cell.OnThePlane(segmentation.chi2_sigmas)) continue;
          std::vector<int>& on_plane = pixels[c][key.first];
          on_plane.insert(on_plane.end(), cell.pixels.begin(), cell.pixels.end());
        }
        for (std::vector<int>& on_plane : pixels[c]) std::sort(on_plane.begin(), on_plane.end());
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
