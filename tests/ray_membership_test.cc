#include "registration/ray_membership.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/geometry.h"

namespace rigfit {
namespace {

constexpr double kCameraHeight = 1.5;  // m, looking 30 deg down along world +Z
constexpr double kWallZ = 3.0;         // the wall z = 3 m faces the camera
constexpr double kNoise = 0.0025;      // k of sigma_z = k z^2

/// A camera over a floor (y = 0) looking at a wall; its pixels of the near-floor band (world
/// height -0.05 .. 0.4 m), each with its true plane (0 floor, 1 wall, 2 the front of an object
/// standing `object_m` in front of the wall in image columns 200..239, none: no plane of the
/// model) and its ray.
struct Scene {
  SurfaceCamera camera;
  std::vector<PlanarFace> planes;
  std::vector<int> truth;  ///< per point: 0 floor, 1 wall, 2 the object
  std::vector<int> column;
  std::vector<Vec3> ray;  ///< world direction, unit camera z

  explicit Scene(double object_m = 0.0) {
    const double pitch = 30.0 * M_PI / 180.0;
    Mat3 R;
    R.col(1) = Vec3(0.0, -std::cos(pitch), -std::sin(pitch));  // image down
    R.col(2) = Vec3(0.0, -std::sin(pitch), std::cos(pitch));   // optical axis
    R.col(0) = R.col(1).cross(R.col(2));
    camera.T_world_camera.linear() = R;
    camera.T_world_camera.translation() = Vec3(0.0, kCameraHeight, 0.0);
    camera.depth_noise = kNoise;
    camera.band_bottom = -0.05;
    camera.band_top = 0.3;
    camera.points_top = 0.4;
    planes = {{Vec3::UnitY(), 0.0, true}, {Vec3(0.0, 0.0, -1.0), kWallZ, false}};
    const double f = 300.0, cx = 159.5, cy = 89.5;
    for (int v = 0; v < 180; ++v) {
      for (int u = 0; u < 320; ++u) {
        const Vec3 a((u - cx) / f, (v - cy) / f, 1.0);
        const Vec3 r = R * a;
        const Vec3& c = camera.T_world_camera.translation();
        const bool object = object_m > 0.0 && u >= 200 && u < 240;
        const double front = kWallZ - (object ? object_m : 0.0);
        const double floor = r.y() < 0.0 ? -c.y() / r.y() : INFINITY;
        const double wall = r.z() > 0.0 ? (front - c.z()) / r.z() : INFINITY;
        const double z = std::min(floor, wall);
        const double height = c.y() + z * r.y();
        if (!std::isfinite(z) || height < -0.05 || height > 0.4) continue;
        camera.points.push_back(z * a);
        truth.push_back(wall < floor ? (object ? 2 : 1) : 0);
        column.push_back(u);
        ray.push_back(r);
      }
    }
  }

  Pose T() const { return camera.T_world_camera; }
  double Height(int i) const { return (T() * camera.points[i]).y(); }
  /// Depth at which point i's ray meets plane j.
  double Depth(int i, int j) const {
    return RayPlaneDepth(T().translation(), ray[i], planes[j].normal, planes[j].offset);
  }
};

/// The pixels of plane j in the result (empty when it has no term).
std::vector<int> PixelsOn(const std::vector<SurfaceTerm>& terms, int plane) {
  for (const SurfaceTerm& t : terms) {
    if (t.plane == plane) return t.pixels;
  }
  return {};
}

TEST(RayMembership, TakesBackAFacesPixelsThatTheSegmentationLeftOutAndNoneOfAnotherFace) {
  const Scene s;
  // The segmentation: the whole floor; the wall between 12 and 25 cm with every third pixel
  // missing (cell borders, points another fragment fitted as well).
  SurfaceTerm floor{0, 0, {}}, wall{0, 1, {}};
  for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
    if (s.truth[i] == 0) floor.pixels.push_back(i);
    const double h = s.Height(i);
    if (s.truth[i] == 1 && h > 0.12 && h < 0.25 && i % 3 != 0) wall.pixels.push_back(i);
  }
  ASSERT_GT(wall.pixels.size(), 1000u);
  const PlaneSegmentationOptions segmentation;
  const std::vector<SurfaceTerm> terms =
      MembershipByRays({s.camera}, {s.T()}, s.planes, {floor, wall}, segmentation);
  for (const SurfaceTerm& t : terms) {
    for (const int i : t.pixels) ASSERT_EQ(s.truth[i], t.plane) << "pixel " << i;
  }
  // The gaps are inside the wall's extent: every one of them comes back.
  const std::vector<int> on_wall = PixelsOn(terms, 1);
  int gaps = 0;
  for (int i = 0; i < static_cast<int>(s.truth.size()); i += 3) {
    const double h = s.Height(i);
    if (s.truth[i] != 1 || h <= 0.12 || h >= 0.25) continue;
    ++gaps;
    EXPECT_TRUE(std::binary_search(on_wall.begin(), on_wall.end(), i)) << "pixel " << i;
  }
  EXPECT_GT(gaps, 500);
  // Where the floor and the wall are within the gate of each other along the ray, near the
  // wall's foot, the pixel is in neither: which one it sees depends on their estimates.
  const std::vector<int> on_floor = PixelsOn(terms, 0);
  int crease = 0;
  for (const int i : floor.pixels) {
    const double z = s.camera.points[i].z();
    const double sigma = std::hypot(kNoise * z * z, segmentation.min_noise_m);
    const double wall_foot = s.T().translation().y() + s.Depth(i, 1) * s.ray[i].y();
    if (s.Depth(i, 1) - z > 0.5 * segmentation.gate_sigmas * sigma || wall_foot < -0.02) continue;
    ++crease;
    EXPECT_EQ(std::count(on_floor.begin(), on_floor.end(), i), 0) << "pixel " << i;
  }
  EXPECT_GT(crease, 50);
  EXPECT_GT(on_floor.size(), 0.8 * floor.pixels.size());
}

TEST(RayMembership, ACameraClaimsAPlaneOnlyWhereItsOwnPixelsOfItAre) {
  // Two cameras at one pose: the segmentation gave the first the wall's pixels in image
  // columns < 100, the second those in columns >= 220. Where only the second has pixels of
  // the wall, the first does not take its own (an object in front of the wall that only the
  // first sees would otherwise join the wall within the depth gate).
  const Scene s;
  SurfaceTerm floor{0, 0, {}}, left{0, 1, {}}, right{1, 1, {}};
  double x_min = INFINITY, x_max = -INFINITY;
  for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
    if (s.truth[i] == 0) floor.pixels.push_back(i);
    const double h = s.Height(i);
    if (s.truth[i] != 1 || h < 0.12 || h > 0.25) continue;
    if (s.column[i] >= 220) right.pixels.push_back(i);
    if (s.column[i] >= 100) continue;
    left.pixels.push_back(i);
    const double x = (s.T() * s.camera.points[i]).x();
    x_min = std::min(x_min, x), x_max = std::max(x_max, x);
  }
  const std::vector<SurfaceTerm> terms =
      MembershipByRays({s.camera, s.camera}, {s.T(), s.T()}, s.planes, {floor, left, right}, {});
  std::vector<int> first_on_wall;
  for (const SurfaceTerm& t : terms) {
    if (t.camera == 0 && t.plane == 1) first_on_wall = t.pixels;
  }
  EXPECT_GE(first_on_wall.size(), left.pixels.size());
  // Within the ring it may grow by (kMembershipGrowCells cells of 4 cm) and a cell, of the
  // region its pixels cover: not the other camera's region.
  ASSERT_GT(left.pixels.size(), 500u);
  const double reach =
      (kMembershipGrowCells + 1) * kMembershipCellVoxels * PlaneSegmentationOptions{}.voxel_size;
  for (const int i : first_on_wall) {
    const double x = (s.T() * s.camera.points[i]).x();
    EXPECT_GT(x, x_min - reach);
    EXPECT_LT(x, x_max + reach);
  }
}

TEST(RayMembership, GrowsWhereTheCamerasPixelsAgreeWithThePlaneNotOverAnObjectInFront) {
  // The segmentation gave the camera the wall between 12 and 20 cm only, and not the object's
  // front, which stands 5 cm in front of the wall in some columns: within the depth gate (8 cm
  // at 3 m) but not a plane of the model.
  const Scene s(0.05);
  SurfaceTerm floor{0, 0, {}}, wall{0, 1, {}};
  int object = 0;
  for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
    if (s.truth[i] == 0) floor.pixels.push_back(i);
    object += s.truth[i] == 2 ? 1 : 0;
    const double h = s.Height(i);
    if (s.truth[i] == 1 && h > 0.12 && h < 0.20) wall.pixels.push_back(i);
  }
  ASSERT_GT(object, 500);
  const std::vector<SurfaceTerm> terms =
      MembershipByRays({s.camera}, {s.T()}, s.planes, {floor, wall}, PlaneSegmentationOptions{});
  int grown = 0, leaked = 0;
  for (const int i : PixelsOn(terms, 1)) {
    leaked += s.truth[i] == 2 ? 1 : 0;
    const double h = s.Height(i);
    grown += s.truth[i] == 1 && (h > 0.22 || h < 0.10) ? 1 : 0;  // beyond the segmented strip
  }
  EXPECT_GT(grown, 300);
  // Only cells that straddle the object's edge, with more wall pixels than the object's, let a
  // few of its pixels in (33 of 1360 here); the ring reaches 16 cm into it from each side.
  EXPECT_LT(leaked, 0.05 * object);
}

TEST(RayMembership, FloorPixelsAreGatedAlikeAboveAndBelowTheFloorInsideTheBand) {
  // The points were taken above 2 cm under the floor (band_bottom): a floor pixel that its
  // noise moved 2.5 cm up is left out as one moved 2.5 cm down is (it is not among the points;
  // its noise gate is 3.3-3.6 cm here); one moved 1 cm up or down is kept.
  Scene s;
  s.camera.band_bottom = -0.02;
  SurfaceTerm floor{0, 0, {}};
  std::vector<int> up1, up3, down1;  // moved 1 and 2.5 cm up, 1 cm down
  for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
    if (s.truth[i] != 0 || s.camera.points[i].z() < 2.4 || s.camera.points[i].z() > 2.7) continue;
    floor.pixels.push_back(i);
    const int kind = s.column[i] % 3;
    const double rise = kind == 0 ? 0.025 : kind == 1 ? 0.01 : -0.01;  // measured height, m
    (kind == 0 ? up3 : kind == 1 ? up1 : down1).push_back(i);
    const Vec3 a = s.camera.points[i] / s.camera.points[i].z();
    s.camera.points[i] += rise / s.ray[i].y() * a;  // along the ray, which goes down
  }
  const PlaneSegmentationOptions segmentation;
  const std::vector<SurfaceTerm> terms =
      MembershipByRays({s.camera}, {s.T()}, s.planes, {floor}, segmentation);
  const std::vector<int> on_floor = PixelsOn(terms, 0);
  const auto kept = [&](const std::vector<int>& pixels) {
    return std::count_if(pixels.begin(), pixels.end(), [&](int i) {
      return std::find(on_floor.begin(), on_floor.end(), i) != on_floor.end();
    });
  };
  ASSERT_GT(up3.size(), 500u);
  // This test's premise: the noise gate alone would keep the 2.5 cm pixels.
  const double base = BaseVariance(segmentation);
  for (const int i : up3) {
    const double z = s.Depth(i, 0);
    ASSERT_GT(segmentation.gate_sigmas * VerticalSigma(s.camera, z, s.ray[i], base), 0.03);
  }
  EXPECT_EQ(kept(up3), 0);
  EXPECT_GT(kept(up1), 0.9 * up1.size());
  EXPECT_GT(kept(down1), 0.9 * down1.size());
}

TEST(RayMembership, TheSameWhateverTheThreads) {
  const Scene s;
  SurfaceTerm floor{0, 0, {}}, wall{1, 1, {}};
  for (int i = 0; i < static_cast<int>(s.truth.size()); ++i) {
    (s.truth[i] == 0 ? floor : wall).pixels.push_back(i);
  }
  const auto run = [&](int threads) {
    return MembershipByRays({s.camera, s.camera, s.camera}, {s.T(), s.T(), s.T()}, s.planes,
                            {floor, wall}, PlaneSegmentationOptions{}, threads);
  };
  const std::vector<SurfaceTerm> one = run(1), three = run(3);
  ASSERT_EQ(one.size(), three.size());
  ASSERT_GE(one.size(), 2u);
  for (size_t k = 0; k < one.size(); ++k) {
    EXPECT_EQ(one[k].camera, three[k].camera);
    EXPECT_EQ(one[k].plane, three[k].plane);
    EXPECT_EQ(one[k].pixels, three[k].pixels);
  }
}

}  // namespace
}  // namespace rigfit
