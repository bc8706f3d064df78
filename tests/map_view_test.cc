// The map seen from above (report/map_view.h): the view's axes (orthonormal, not mirrored),
// the up axis estimated from the normals and the cameras on synthetic rooms, and the picture:
// its size, where the points, the highest of them and the overlays land, and the report files.
#include "report/map_view.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "io/png.h"
#include "io_test_util.h"
#include "report/html.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

constexpr double kTolerance = 1e-12;
constexpr double kAngleToleranceDeg = 1.0;  ///< the estimate's: a mean of sampled normals

double AngleDeg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * kRadToDeg;
}

void ExpectOrthonormalAndRightHanded(const MapViewAxes& axes) {
  EXPECT_NEAR(axes.up.norm(), 1.0, kTolerance);
  EXPECT_NEAR(axes.right.norm(), 1.0, kTolerance);
  EXPECT_NEAR(axes.forward.norm(), 1.0, kTolerance);
  EXPECT_NEAR(axes.up.dot(axes.right), 0.0, kTolerance);
  EXPECT_NEAR(axes.up.dot(axes.forward), 0.0, kTolerance);
  EXPECT_TRUE(axes.right.cross(axes.forward).isApprox(axes.up, kTolerance));  // not mirrored
}

TEST(MapViewAxes, GivenUpIsTheRigReportsView) {
  const MapViewAxes axes = MapViewAxesFor(Vec3::UnitY(), Vec3::UnitX(), "world +Y");
  ExpectOrthonormalAndRightHanded(axes);
  EXPECT_TRUE(axes.right.isApprox(Vec3::UnitX()));
  EXPECT_TRUE(axes.forward.isApprox(-Vec3::UnitZ()));  // z downward in the picture
  EXPECT_EQ(axes.up_source, "world +Y");
  // A hint not perpendicular to up keeps only its perpendicular part.
  const MapViewAxes tilted = MapViewAxesFor(Vec3(0.0, 2.0, 0.0), Vec3(1.0, 5.0, 1.0), "");
  ExpectOrthonormalAndRightHanded(tilted);
  EXPECT_TRUE(tilted.right.isApprox(Vec3(1.0, 0.0, 1.0).normalized()));
}

/// A room in a world whose up axis is R * +Y: a floor of `floor` points (normals up, facing
/// the cameras above it), and `wall` points on each of four walls (normals horizontal, facing
/// the room's centre), positions spread over 4 x 2 m (x longer than z).
struct Room {
  std::vector<Vec3f> positions;
  std::vector<Vec3f> normals;
};

Room MakeRoom(const Mat3& R, int floor, int wall, std::uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.05);  // normals, about 3 degrees
  Room room;
  const auto add = [&](const Vec3& p, const Vec3& n) {
    room.positions.push_back((R * p).cast<float>());
    room.normals.push_back(
        (R * (n + Vec3(noise(rng), noise(rng), noise(rng)))).normalized().cast<float>());
  };
  for (int i = 0; i < floor; ++i) add(Vec3(2.0 * u(rng), 0.0, u(rng)), Vec3::UnitY());
  for (int i = 0; i < wall; ++i) {
    const double h = 1.25 * (1.0 + u(rng));
    add(Vec3(2.0, h, u(rng)), -Vec3::UnitX());
    add(Vec3(-2.0, h, u(rng)), Vec3::UnitX());
    add(Vec3(2.0 * u(rng), h, 1.0), -Vec3::UnitZ());
    add(Vec3(2.0 * u(rng), h, -1.0), Vec3::UnitZ());
  }
  return room;
}

/// Cameras at 1.5 m looking along +Z turned by `yaws` about +Y and pitched down by pitch_deg
/// (camera axes: x right, y down, z forward), in the world of MakeRoom(R, ...).
std::vector<Pose> Cameras(const Mat3& R, double pitch_deg, const std::vector<double>& yaws_deg) {
  std::vector<Pose> cameras;
  for (const double yaw : yaws_deg) {
    Pose T = Pose::Identity();
    // Level, looking along +Z with its y axis down (so its x axis is -X).
    Mat3 level;
    level.col(2) = Vec3::UnitZ();
    level.col(1) = -Vec3::UnitY();
    level.col(0) = level.col(1).cross(level.col(2));
    const Mat3 pitch = ExpSO3(level.col(0) * (-pitch_deg * kDegToRad));  // about camera x
    T.linear() = R * ExpSO3(Vec3::UnitY() * yaw * kDegToRad) * pitch * level;
    T.translation() = R * Vec3(0.0, 1.5, 0.0);
    cameras.push_back(T);
  }
  return cameras;
}

Mat3 SomeRotation() { return ExpSO3(Vec3(0.7, -0.3, 1.2)); }

TEST(EstimateMapViewAxes, FloorNormalIsUpEvenWithPitchedCameras) {
  const Mat3 R = SomeRotation();
  const Room room = MakeRoom(R, 20000, 4000);
  // Cameras pitched 40 degrees down: their mean image up is 39 degrees off the true up (the
  // three tilts point different ways).
  const std::vector<Pose> cameras = Cameras(R, 40.0, {-20.0, 0.0, 20.0});
  Vec3 image_up = Vec3::Zero();
  for (const Pose& T : cameras) image_up -= T.linear().col(1);
  ASSERT_GT(AngleDeg(image_up, R * Vec3::UnitY()), 38.0);  // the setup

  const MapViewAxes axes = EstimateMapViewAxes(room.positions, room.normals, cameras);
  ExpectOrthonormalAndRightHanded(axes);
  EXPECT_LT(AngleDeg(axes.up, R * Vec3::UnitY()), kAngleToleranceDeg);
  // The room is longer along its x: that is the picture's width.
  EXPECT_LT(
      std::min(AngleDeg(axes.right, R * Vec3::UnitX()), AngleDeg(axes.right, -(R * Vec3::UnitX()))),
      kAngleToleranceDeg);
  EXPECT_NE(axes.up_source.find("points share"), std::string::npos) << axes.up_source;
  EXPECT_NE(axes.up_source.find("39 deg from the cameras' mean image up"), std::string::npos)
      << axes.up_source;
}

TEST(EstimateMapViewAxes, AWallTheCamerasFaceIsNotTakenForTheFloor) {
  // Many more points on each wall than on the floor: the walls' normals are 90 degrees from
  // the level cameras' image up, outside kMaxUpTiltDeg.
  const Room room = MakeRoom(Mat3::Identity(), 2000, 6000);
  const MapViewAxes axes =
      EstimateMapViewAxes(room.positions, room.normals, Cameras(Mat3::Identity(), 0.0, {0.0}));
  EXPECT_LT(AngleDeg(axes.up, Vec3::UnitY()), kAngleToleranceDeg);
}

TEST(EstimateMapViewAxes, WithoutAHorizontalSurfaceUpIsTheCamerasImageUp) {
  const Mat3 R = SomeRotation();
  const Room room = MakeRoom(R, 0, 3000);
  const std::vector<Pose> cameras = Cameras(R, 10.0, {0.0, 30.0});
  const MapViewAxes axes = EstimateMapViewAxes(room.positions, room.normals, cameras);
  ExpectOrthonormalAndRightHanded(axes);
  Vec3 image_up = Vec3::Zero();
  for (const Pose& T : cameras) image_up -= T.linear().col(1);
  EXPECT_TRUE(axes.up.isApprox(image_up.normalized(), 1e-9));
  EXPECT_NE(axes.up_source.find("image up (no horizontal surface found)"), std::string::npos)
      << axes.up_source;
}

TEST(EstimateMapViewAxes, WithoutCamerasTheWholeSphereIsSearched) {
  const Mat3 R = SomeRotation();
  const Room room = MakeRoom(R, 20000, 4000);
  const MapViewAxes axes = EstimateMapViewAxes(room.positions, room.normals, {});
  EXPECT_LT(AngleDeg(axes.up, R * Vec3::UnitY()), kAngleToleranceDeg);
  const MapViewAxes empty = EstimateMapViewAxes({}, {}, {});
  ExpectOrthonormalAndRightHanded(empty);
  EXPECT_TRUE(empty.up.isApprox(Vec3::UnitY()));
}

/// The middle of the window (here the origin) lands at the plot's centre.
constexpr double kMidColumn = 0.5 * (kMapPlotLeft + kMapPlotRight - 1);
constexpr double kMidRow = 0.5 * (kMapPlotTop + kMapPlotBottom - 1);

class MapPicture : public ::testing::Test {
 protected:
  /// A 2 x 1 m red floor (y = 0, x in [-1, 1], z in [-0.5, 0.5]) on a 2 mm grid, and a blue
  /// 0.2 x 0.2 m box top at y = 0.5 over (0.6, 0.25): symmetric extent about the origin.
  void SetUp() override {
    for (int i = 0; i <= 1000; ++i) {
      for (int k = 0; k <= 500; ++k)
        Add(Vec3f(-1.0f + 0.002f * i, 0.0f, -0.5f + 0.002f * k), Vec3f(200.0f, 20.0f, 10.0f));
    }
    for (int i = 0; i <= 100; ++i) {
      for (int k = 0; k <= 100; ++k)
        Add(Vec3f(0.5f + 0.002f * i, 0.5f, 0.15f + 0.002f * k), Vec3f(10.0f, 20.0f, 200.0f));
    }
  }
  void Add(const Vec3f& p, const Vec3f& color) {
    positions_.push_back(p);
    normals_.push_back(Vec3f::UnitY());
    colors_.push_back(color);
    radii_.push_back(0.002f);
  }
  /// Pixel of world (x, z) in the view MapViewAxesFor(+Y, +X) of a window whose middle is the
  /// origin, at px_per_m.
  static std::pair<int, int> Pixel(double x, double z, double px_per_m) {
    return {static_cast<int>(std::lround(kMidColumn + x * px_per_m)),
            static_cast<int>(std::lround(kMidRow + z * px_per_m))};
  }

  std::vector<Vec3f> positions_, normals_, colors_;
  std::vector<float> radii_;
  const MapViewAxes axes_ = MapViewAxesFor(Vec3::UnitY(), Vec3::UnitX(), "world +Y");
};

TEST_F(MapPicture, PointsLandWhereTheyAreSeenFromAboveTheHighestOnTop) {
  const Image image =
      DrawMapFromAbove({positions_, normals_, colors_, radii_}, {}, axes_, "title", "subtitle");
  ASSERT_EQ(image.width, kMapViewWidth);
  ASSERT_EQ(image.height, kMapViewHeight);
  // The window is 2 m wide plus 5% of its span on each side over the plot's 1079 columns.
  const double px_per_m = (kMapViewWidth - 300 - 20 - 1) / (2.0 + 0.2);
  const Rgb red{200, 20, 10}, blue{10, 20, 200};
  // x to the right, z downward: the floor around the origin and its corners are red ...
  for (const auto& [x, z] : std::vector<std::pair<double, double>>{
           {0.0, 0.0}, {-0.9, -0.4}, {0.9, -0.4}, {-0.9, 0.4}, {0.3, 0.4}}) {
    const auto [c, r] = Pixel(x, z, px_per_m);
    EXPECT_EQ(image.At(c, r), red) << x << ", " << z;
  }
  // ... but under the box (x 0.5..0.7, z 0.15..0.35: right of and below the centre) blue: the
  // box top is higher than the floor.
  const auto [bc, br] = Pixel(0.6, 0.25, px_per_m);
  EXPECT_EQ(image.At(bc, br), blue);
  const auto [mc, mr] = Pixel(-0.6, -0.25, px_per_m);  // the mirrored place: floor
  EXPECT_EQ(image.At(mc, mr), red);
  // Above and below the floor (|z| > 0.5 m), inside the plot: nothing drawn.
  const auto [ec, er] = Pixel(0.0, 0.7, px_per_m);
  EXPECT_EQ(image.At(ec, er), kWhite);
  const auto [fc, fr] = Pixel(0.0, -0.7, px_per_m);
  EXPECT_EQ(image.At(fc, fr), kWhite);
}

TEST_F(MapPicture, WithoutColoursHeightColoursTheHigherDifferently) {
  const std::vector<Vec3f> no_colors;
  const std::vector<float> no_radii;
  const Image image =
      DrawMapFromAbove({positions_, normals_, no_colors, no_radii}, {}, axes_, "title", "subtitle");
  const double px_per_m = (kMapViewWidth - 300 - 20 - 1) / (2.0 + 0.2);
  const auto [fc, fr] = Pixel(-0.5, 0.0, px_per_m);
  const auto [bc, br] = Pixel(0.6, 0.25, px_per_m);
  const Rgb floor = image.At(fc, fr), box = image.At(bc, br);
  EXPECT_NE(floor, kWhite);
  EXPECT_NE(box, kWhite);
  EXPECT_NE(floor, box);
  EXPECT_EQ(floor, (Rgb{68, 1, 84}));   // the lowest: viridis' first colour
  EXPECT_EQ(box, (Rgb{253, 231, 37}));  // the highest: its last
}

TEST_F(MapPicture, OverlaysAreDrawnOverThePointsAndWidenTheWindow) {
  MapOverlay path{"path", Rgb{0, 160, 0}, 5, {}, false};
  for (int i = 0; i <= 10; ++i) {
    Pose T = Pose::Identity();
    T.translation() = Vec3(-0.8 + 0.16 * i, 1.0, 0.0);
    path.poses.push_back(T);
  }
  MapOverlay camera{"camera", Rgb{230, 0, 230}, 3, {}, true};
  Pose T_camera = Pose::Identity();
  T_camera.translation() = Vec3(0.0, 1.5, -2.0);  // outside the map: the window grows
  camera.poses.push_back(T_camera);
  const Image image = DrawMapFromAbove({positions_, normals_, colors_, radii_}, {path, camera},
                                       axes_, "title", "subtitle");
  // The window now spans z in [-2, 0.5] (2.5 m + 10%): 2.75 m over the plot's 869 rows.
  const double px_per_m = (kMapPlotBottom - kMapPlotTop - 1) / 2.75;
  const double mid_z = -0.75;
  const auto pixel = [&](double x, double z) {
    return std::make_pair(static_cast<int>(std::lround(kMidColumn + x * px_per_m)),
                          static_cast<int>(std::lround(kMidRow + (z - mid_z) * px_per_m)));
  };
  const auto [pc, pr] = pixel(0.0, 0.0);
  EXPECT_EQ(image.At(pc, pr), (Rgb{0, 160, 0}));  // the path, over the floor
  const auto [cc, cr] = pixel(0.0, -2.0);
  EXPECT_EQ(image.At(cc, cr), (Rgb{230, 0, 230}));  // the camera's disc
  const auto [fc, fr] = pixel(-0.5, 0.3);
  EXPECT_EQ(image.At(fc, fr), (Rgb{200, 20, 10}));  // the floor, away from the path
}

TEST_F(MapPicture, ReportWritesThePictureAndThePage) {
  const fs::path dir =
      fs::temp_directory_path() / ("rigfit_map_view_test_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const std::vector<std::string> files = WriteMapReport(
      dir.string(), "a title", {positions_, normals_, colors_, radii_}, {}, axes_, "the summary");
  // The picture, the 3-D view (three.js, OrbitControls, its data, its page), the page.
  ASSERT_EQ(files.size(), 6u);
  EXPECT_EQ(files[0], (dir / kMapTopFile).string());
  EXPECT_EQ(files[4], (dir / kView3dFile).string());
  EXPECT_EQ(files.back(), (dir / kReportIndexFile).string());
  const RgbRaster png = ReadPng(files[0]);
  EXPECT_EQ(png.width, kMapViewWidth);
  EXPECT_EQ(png.height, kMapViewHeight);
  const std::string text = io_test::ReadText(files.back());
  EXPECT_NE(text.find("the summary"), std::string::npos);
  EXPECT_NE(text.find("up axis (world +Y)"), std::string::npos);
  EXPECT_NE(text.find(std::to_string(positions_.size()) + " map points"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rigfit
