#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "io/ply.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

/// Coordinates are stored as float32: relative rounding error 2^-24.
constexpr double kFloatTolerance = 1e-6;

class PlyTest : public io_test::TempDirTest {
 protected:
  std::string ReadError(const std::string& bytes) {
    const std::string path = Path("cloud.ply");
    io_test::WriteText(path, bytes);
    return io_test::InputErrorMessage([&] { ReadPly(path); });
  }
};

template <typename T>
void Append(std::string& bytes, T value) {
  char raw[sizeof(T)];
  std::memcpy(raw, &value, sizeof(T));
  bytes.append(raw, sizeof(T));
}

PlyCloud SampleCloud() {
  PlyCloud cloud;
  for (int i = 0; i < 100; ++i) {
    cloud.points.emplace_back(0.01 * i, -2.5 + 0.1 * i, 3.0 - 0.02 * i);
    cloud.normals.push_back(Vec3(1.0, i, -2.0).normalized());
    cloud.colors.push_back({static_cast<std::uint8_t>(i), 255, static_cast<std::uint8_t>(2 * i)});
  }
  return cloud;
}

void ExpectNear(const PointCloud& a, const PointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_LT((a[i] - b[i]).norm(), kFloatTolerance * (1.0 + b[i].norm())) << i;
  }
}

TEST_F(PlyTest, BinaryRoundTripWithNormalsAndColors) {
  const PlyCloud cloud = SampleCloud();
  const std::string path = Path("cloud.ply");
  WritePly(path, cloud);
  EXPECT_THAT(io_test::ReadText(path),
              HasSubstr("ply\nformat binary_little_endian 1.0\ncomment written by rigfit\n"
                        "element vertex 100\nproperty float x\n"));
  const PlyCloud back = ReadPly(path);
  ExpectNear(back.points, cloud.points);
  ExpectNear(back.normals, cloud.normals);
  EXPECT_EQ(back.colors, cloud.colors);
  EXPECT_THAT(Listing(), ElementsAre("cloud.ply"));
}

TEST_F(PlyTest, PointsOnlyRoundTripAndSize) {
  PlyCloud cloud = SampleCloud();
  cloud.normals.clear();
  cloud.colors.clear();
  const std::string path = Path("cloud.ply");
  WritePly(path, cloud);
  const std::string bytes = io_test::ReadText(path);
  EXPECT_EQ(bytes.size() - bytes.find("end_header\n") - 11, 100u * 12u);  // 3 floats per point
  const PlyCloud back = ReadPly(path);
  ExpectNear(back.points, cloud.points);
  EXPECT_THAT(back.normals, IsEmpty());
  EXPECT_THAT(back.colors, IsEmpty());
}

TEST_F(PlyTest, AsciiWithOtherPropertiesAndElementsAroundTheVertices) {
  const std::string path = Path("ascii.ply");
  io_test::WriteText(path,
                     "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\n"
                     "element camera 1\r\nproperty list uchar float view\r\n"
                     "element vertex 3\r\nproperty double x\r\nproperty float intensity\r\n"
                     "property double y\r\nproperty double z\r\nproperty float nx\r\n"
                     "property float ny\r\nproperty float nz\r\nproperty uchar red\r\n"
                     "property uchar green\r\nproperty uchar blue\r\n"
                     "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
                     "4 1.5 2.5 3.5 4.5\r\n"
                     "0.1 7 0.2 0.3 0 0 1 10 20 30\r\n"
                     "-1e-3 7 +2 3 0 1 0 0 0 0\r\n"
                     "1 7 1 1 1 0 0 255 255 255\r\n"
                     "3 0 1 2\r\n");
  const PlyCloud cloud = ReadPly(path);
  ASSERT_THAT(cloud.points, SizeIs(3));
  EXPECT_EQ(cloud.points[0], Vec3(0.1, 0.2, 0.3));
  EXPECT_EQ(cloud.points[1], Vec3(-1e-3, 2, 3));
  EXPECT_EQ(cloud.normals[1], Vec3(0, 1, 0));
  EXPECT_EQ(cloud.colors[0], (std::array<std::uint8_t, 3>{10, 20, 30}));
  EXPECT_EQ(cloud.colors[2], (std::array<std::uint8_t, 3>{255, 255, 255}));
}

TEST_F(PlyTest, BinarySkipsListElementsBeforeTheVertices) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement face 2\n"
      "property list uchar int vertex_indices\nproperty ushort flags\n"
      "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property int label\nend_header\n";
  Append<std::uint8_t>(bytes, 3);
  for (int i : {0, 1, 2}) Append<std::int32_t>(bytes, i);
  Append<std::uint16_t>(bytes, 9);
  Append<std::uint8_t>(bytes, 1);
  Append<std::int32_t>(bytes, 5);
  Append<std::uint16_t>(bytes, 9);
  for (float v : {1.0f, 2.0f, 3.0f}) Append(bytes, v);
  Append<std::int32_t>(bytes, 42);
  for (float v : {-4.0f, 5.5f, 6.0f}) Append(bytes, v);
  Append<std::int32_t>(bytes, 43);
  const std::string path = Path("faces.ply");
  io_test::WriteText(path, bytes);
  const PlyCloud cloud = ReadPly(path);
  EXPECT_THAT(cloud.points, ElementsAre(Vec3(1, 2, 3), Vec3(-4, 5.5, 6)));
}

TEST_F(PlyTest, NonFiniteVerticesOfAnOrganisedCloudAreSkippedAndCounted) {
  // PCL's savePLYFile writes the invalid pixels of an organised cloud as nan.
  const std::string path = Path("organised.ply");
  io_test::WriteText(path,
                     "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n"
                     "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
                     "property float nz\nend_header\n1 2 3 0 0 1\nnan nan nan nan nan nan\n"
                     "4 5 6 0 1 0\n7 8 9 nan 0 1\n");
  const PlyCloud cloud = ReadPly(path);
  EXPECT_EQ(cloud.points, (PointCloud{Vec3(1, 2, 3), Vec3(4, 5, 6)}));
  EXPECT_EQ(cloud.normals, (PointCloud{Vec3(0, 0, 1), Vec3(0, 1, 0)}));
  EXPECT_EQ(cloud.skipped_non_finite, 2);
}

TEST_F(PlyTest, MalformedFilesNameFileAndField) {
  const std::string path = Path("cloud.ply");
  const std::string binary_xyz =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  EXPECT_THAT(ReadError("solid cube\n"), HasSubstr(path + ": not a PLY file"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\n"),
              HasSubstr(path + ": PLY header has no end_header"));
  EXPECT_THAT(ReadError("ply\nformat binary_big_endian 1.0\nend_header\n"),
              HasSubstr(path + ": header line 2: unsupported format 'binary_big_endian'"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\nproperty flot x\nend_header\n"),
              HasSubstr(path + ": header line 4: unknown property type 'flot'"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "property float y\nend_header\n1 2\n"),
              HasSubstr(path + ": element vertex: needs all of x y z"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement face 1\nend_header\n"),
              HasSubstr(path + ": no element vertex"));
  EXPECT_THAT(ReadError(binary_xyz + std::string(16, '\0')),
              HasSubstr(path + ": element vertex: 2 records declared but the file is too short"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "property float y\nproperty float z\nend_header\n1 two 3\n"),
              HasSubstr(path + ": element vertex record 0: property y: truncated or malformed"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "property float y\nproperty float z\nproperty uchar red\n"
                        "property uchar green\nproperty uchar blue\nend_header\n1 2 3 4 300 6\n"),
              HasSubstr("element vertex record 0: property green: truncated or malformed"));
  EXPECT_THAT(ReadError("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                        "property float y\nproperty float z\nproperty float red\n"
                        "property float green\nproperty float blue\nend_header\n1 2 3 4 5 6\n"),
              HasSubstr("element vertex: property red must be uchar"));
  EXPECT_THAT(ReadError("ply\nformat binary_little_endian 1.0\nelement face 1\n"
                        "property list uchar int vertex_indices\nelement vertex 0\n"
                        "property float x\nproperty float y\nproperty float z\nend_header\n"
                        "\x05\x01"),  // 5 indices declared, 1 byte present
              HasSubstr("element face record 0: property vertex_indices"));
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadPly(Path("missing.ply")); }),
              HasSubstr(Path("missing.ply") + ": cannot open"));
}

TEST_F(PlyTest, WriteRejectsMismatchedAttributes) {
  PlyCloud cloud = SampleCloud();
  cloud.normals.pop_back();
  EXPECT_THAT(io_test::InputErrorMessage([&] { WritePly(Path("c.ply"), cloud); }),
              HasSubstr(Path("c.ply") + ": cannot write: 99 normals for 100 points"));
  EXPECT_THAT(Listing(), IsEmpty());
}

TEST(PlyRealData, StanfordBunnyAsciiScan) {
  // bun000.ply: "element vertex 40256" then a 204800-record range_grid of lists; metres.
  const std::string path = io_test::SharedDataPath("stanford_bunny/data/bun000.ply");
  RIGFIT_NEED_SHARED_DATA(path);
  const PlyCloud cloud = ReadPly(path);
  ASSERT_THAT(cloud.points, SizeIs(40256));
  EXPECT_THAT(cloud.normals, IsEmpty());
  Vec3 lo = cloud.points[0], hi = cloud.points[0];
  for (const Vec3& p : cloud.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Vec3 extent = hi - lo;
  // The bunny is about 15 cm across.
  EXPECT_GT(extent.minCoeff(), 0.03);
  EXPECT_LT(extent.maxCoeff(), 0.3);
}

TEST(PlyRealData, SmallGicpBinaryLidarScan) {
  // target.ply: binary_little_endian, "element vertex 69088", x y z scalar_intensity.
  const std::string path = io_test::SharedDataPath("small_gicp/target.ply");
  RIGFIT_NEED_SHARED_DATA(path);
  const PlyCloud cloud = ReadPly(path);
  ASSERT_THAT(cloud.points, SizeIs(69088));
  Vec3 lo = cloud.points[0], hi = cloud.points[0];
  for (const Vec3& p : cloud.points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  // An outdoor LiDAR scan: tens of metres across, not kilometres.
  EXPECT_GT((hi - lo).head<2>().minCoeff(), 10.0);
  EXPECT_LT((hi - lo).maxCoeff(), 1000.0);
}

}  // namespace
}  // namespace rigfit
