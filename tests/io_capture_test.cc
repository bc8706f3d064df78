#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <hdf5.h>

#include <cmath>
#include <functional>
#include <limits>
#include <random>
#include <stdexcept>

#include "io/capture_h5.h"
#include "io_h5_builder.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;
using ::testing::IsEmpty;
using ::testing::SizeIs;

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

using io_test::H5Builder;

class CaptureTest : public io_test::TempDirTest {};

CameraCapture DepthCamera(const std::string& serial, int width, int height, std::mt19937& rng) {
  std::uniform_real_distribution<float> z(0.3f, 6.0f);
  CameraCapture c;
  c.serial = serial;
  c.width = width;
  c.height = height;
  c.intrinsics = {520.5, 519.25, 0.5 * width - 0.5, 0.5 * height + 3.25};
  for (int i = 0; i < width * height; ++i) c.depth_m.push_back(i % 7 == 3 ? kNaN : z(rng));
  return c;
}

void ExpectSameDepth(const std::vector<float>& actual, const std::vector<float>& expected,
                     double tolerance) {
  ASSERT_EQ(actual.size(), expected.size());
  for (size_t i = 0; i < actual.size(); ++i) {
    if (std::isnan(expected[i])) {
      EXPECT_TRUE(std::isnan(actual[i])) << i;
    } else {
      EXPECT_NEAR(actual[i], expected[i], tolerance) << i;
    }
  }
}

TEST_F(CaptureTest, Float32RoundTripOfEveryDatasetSortedBySerial) {
  std::mt19937 rng(3);
  RigCapture capture;
  CameraCapture b = DepthCamera("31002234", 8, 6, rng);
  b.confidence.resize(48);
  b.color.resize(3 * 48);
  for (size_t i = 0; i < b.confidence.size(); ++i) b.confidence[i] = 0.5f * i;
  for (size_t i = 0; i < b.color.size(); ++i) b.color[i] = static_cast<std::uint8_t>(7 * i);
  CameraCapture a;
  a.serial = "31001117";
  for (int i = 0; i < 5; ++i) {
    a.points.emplace_back(0.1 * i, -1.0, 2.0 + i);
    a.normals.push_back(Vec3(i, 1.0, 0.0).normalized());
  }
  const CameraCapture c = DepthCamera("kinect-2", 5, 4, rng);
  capture.cameras = {b, a, c};

  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const RigCapture back = ReadCapture(path);
  ASSERT_THAT(back.cameras, SizeIs(3));
  EXPECT_EQ(back.cameras[0].serial, "31001117");
  EXPECT_EQ(back.cameras[1].serial, "31002234");
  EXPECT_EQ(back.cameras[2].serial, "kinect-2");

  const CameraCapture& b2 = back.cameras[1];
  EXPECT_EQ(b2.width, 8);
  EXPECT_EQ(b2.height, 6);
  io_test::ExpectSameCamera(b2, b);  // float32 depth stored as float32: exact
  EXPECT_FALSE(b2.HasPoints());

  const CameraCapture& a2 = back.cameras[0];
  EXPECT_FALSE(a2.HasDepth());
  ASSERT_THAT(a2.points, SizeIs(5));
  ASSERT_THAT(a2.normals, SizeIs(5));
  for (size_t i = 0; i < 5; ++i) {
    EXPECT_LT((a2.points[i] - a.points[i]).norm(), 1e-6);  // stored as float32
    EXPECT_LT((a2.normals[i] - a.normals[i]).norm(), 1e-6);
  }
  EXPECT_THAT(back.cameras[2].confidence, IsEmpty());
  EXPECT_THAT(back.cameras[2].color, IsEmpty());
  EXPECT_THAT(Listing(), ElementsAre("capture.h5"));
}

TEST_F(CaptureTest, StereoBaselineRoundTripsAndIsOnlyWrittenWhenKnown) {
  std::mt19937 rng(4);
  RigCapture capture;
  CameraCapture stereo = DepthCamera("zed", 8, 6, rng);
  stereo.baseline_m = 0.12;
  capture.cameras = {stereo, DepthCamera("kinect", 5, 4, rng)};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const RigCapture back = ReadCapture(path);
  ASSERT_THAT(back.cameras, SizeIs(2));
  EXPECT_EQ(back.cameras[0].serial, "kinect");
  EXPECT_EQ(back.cameras[0].baseline_m, 0.0);   // not recorded
  EXPECT_EQ(back.cameras[1].baseline_m, 0.12);  // float64: exact
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  EXPECT_GT(H5Lexists(file, "/cameras/zed/baseline_m", H5P_DEFAULT), 0);
  EXPECT_EQ(H5Lexists(file, "/cameras/kinect/baseline_m", H5P_DEFAULT), 0);
  H5Fclose(file);
  // From memory and through the guarded reader's bytes too.
  const std::string bytes = io_test::ReadText(path);
  EXPECT_EQ(ReadCaptureFromMemory(bytes.data(), bytes.size(), "mem.h5").cameras[1].baseline_m,
            0.12);

  capture.cameras[0].baseline_m = -0.12;
  EXPECT_THAT(io_test::InputErrorMessage([&] { WriteCapture(path, capture); }),
              HasSubstr("camera zed: baseline_m: must be > 0 and finite"));
}

TEST_F(CaptureTest, Uint16RoundTripWithinHalfAUnit) {
  std::mt19937 rng(5);
  RigCapture capture;
  capture.cameras = {DepthCamera("cam", 16, 9, rng)};
  capture.cameras[0].depth_m[1] = 0.0002f;  // rounds to 0 units: invalid
  CaptureWriteOptions options;
  options.depth_as_uint16 = true;
  options.depth_scale = 0.0005;
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture, options);
  const RigCapture back = ReadCapture(path);
  std::vector<float> expected = capture.cameras[0].depth_m;
  expected[1] = kNaN;
  // Half a unit of quantisation, plus float32 rounding of the product.
  ExpectSameDepth(back.cameras[0].depth_m, expected, options.depth_scale / 2 + 1e-6);

  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t depth = H5Dopen2(file, "/cameras/cam/depth", H5P_DEFAULT);
  const hid_t type = H5Dget_type(depth);
  EXPECT_GT(H5Tequal(type, H5T_STD_U16LE), 0);
  double scale = 0.0;
  const hid_t attribute = H5Aopen(depth, "depth_scale", H5P_DEFAULT);
  H5Aread(attribute, H5T_NATIVE_DOUBLE, &scale);
  EXPECT_EQ(scale, 0.0005);
  H5Aclose(attribute);
  H5Tclose(type);
  H5Dclose(depth);
  H5Fclose(file);
}

TEST_F(CaptureTest, WrittenFileIsTheContractAndCompressed) {
  std::mt19937 rng(9);
  RigCapture capture;
  capture.cameras = {DepthCamera("cam", 64, 48, rng)};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  const hid_t format = H5Aopen(file, "format", H5P_DEFAULT);
  const hid_t format_type = H5Aget_type(format);
  EXPECT_EQ(H5Tget_class(format_type), H5T_STRING);
  char text[32] = {};
  const hid_t memory_type = H5Tcopy(H5T_C_S1);
  H5Tset_size(memory_type, sizeof(text) - 1);
  H5Aread(format, memory_type, text);
  EXPECT_STREQ(text, "rig-capture");
  long long version = 0;
  const hid_t version_attribute = H5Aopen(file, "version", H5P_DEFAULT);
  H5Aread(version_attribute, H5T_NATIVE_LLONG, &version);
  EXPECT_EQ(version, 1);
  const hid_t depth = H5Dopen2(file, "/cameras/cam/depth", H5P_DEFAULT);
  const hid_t depth_type = H5Dget_type(depth);
  EXPECT_GT(H5Tequal(depth_type, H5T_IEEE_F32LE), 0);
  const hid_t dcpl = H5Dget_create_plist(depth);
  if (H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0) {
    EXPECT_EQ(H5Pget_nfilters(dcpl), 2);  // shuffle + deflate
  }
  H5Pclose(dcpl);
  H5Tclose(depth_type);
  H5Dclose(depth);
  H5Aclose(version_attribute);
  H5Tclose(memory_type);
  H5Tclose(format_type);
  H5Aclose(format);
  H5Fclose(file);
}

TEST_F(CaptureTest, FailedWriteKeepsThePreviousFileAndLeavesNoTemporary) {
  std::mt19937 rng(1);
  RigCapture capture;
  capture.cameras = {DepthCamera("cam", 8, 6, rng)};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const std::string before = io_test::ReadText(path);
  // 70 m does not fit uint16 millimetres: detected while the temporary is being written.
  capture.cameras[0].depth_m[5] = 70.0f;
  CaptureWriteOptions options;
  options.depth_as_uint16 = true;
  EXPECT_THAT(io_test::InputErrorMessage([&] { WriteCapture(path, capture, options); }),
              HasSubstr(path + ": camera cam: depth: value 70"));
  EXPECT_EQ(io_test::ReadText(path), before);
  EXPECT_THAT(Listing(), ElementsAre("capture.h5"));
  // Invalid captures are refused before anything is written.
  capture.cameras[0].depth_m.pop_back();
  EXPECT_THAT(io_test::InputErrorMessage([&] { WriteCapture(path, capture); }),
              HasSubstr(path + ": cannot write: camera cam: depth: 47 values for 8x6"));
  EXPECT_EQ(io_test::ReadText(path), before);
  EXPECT_THAT(Listing(), ElementsAre("capture.h5"));
}

TEST_F(CaptureTest, WhatWouldNotReadBackIsNotWritten) {
  std::mt19937 rng(2);
  const std::string path = Path("capture.h5");
  const auto refused = [&](const RigCapture& capture) {
    const std::string message = io_test::InputErrorMessage([&] { WriteCapture(path, capture); });
    EXPECT_FALSE(std::filesystem::exists(path));
    EXPECT_TRUE(Listing().empty());
    return message;
  };
  // Depth in millimetres written as float metres (a unit mistake): the median is beyond 100 m.
  RigCapture depth;
  depth.cameras = {DepthCamera("cam", 8, 6, rng)};
  for (float& z : depth.cameras[0].depth_m) z *= 1000.0f;
  EXPECT_THAT(refused(depth), HasSubstr(path + ": cannot write: camera cam: depth: median valid "
                                               "depth"));
  EXPECT_THAT(refused(depth), HasSubstr("is beyond 100 m: depth must be float metres"));
  // Points beyond 1 km, and points or normals that are not finite.
  RigCapture points;
  points.cameras.resize(1);
  points.cameras[0].serial = "lidar";
  points.cameras[0].points = {Vec3(1.0, 2.0, 3.0), Vec3(0.0, 0.0, 1200.0)};
  EXPECT_THAT(refused(points), HasSubstr(path + ": cannot write: camera lidar: points: row 1 "
                                                "has length 1200, beyond 1000 m"));
  points.cameras[0].points[1] = Vec3(0.0, kNaN, 1.0);
  EXPECT_THAT(refused(points), HasSubstr("camera lidar: points: row 1 is not finite"));
  points.cameras[0].points[1] = Vec3(0.0, 0.0, 999.0);
  points.cameras[0].normals = {Vec3::UnitZ(), Vec3(kNaN, 0.0, 1.0)};
  EXPECT_THAT(refused(points), HasSubstr("camera lidar: normals: row 1 is not finite"));
  // Within the limits, the same captures write and read back.
  points.cameras[0].normals[1] = Vec3::UnitX();
  for (float& z : depth.cameras[0].depth_m) z /= 1000.0f;
  for (const RigCapture& capture : {points, depth}) {
    WriteCapture(path, capture);
    EXPECT_EQ(ReadCapture(path).cameras.size(), 1u);
    std::filesystem::remove(path);
  }
}

TEST_F(CaptureTest, DepthGlitchesBecomeInvalidAndAreCounted) {
  // A sensor glitch: a few absurd depths (1e7 m) in an otherwise sound image.
  std::mt19937 rng(3);
  const std::string path = Path("capture.h5");
  RigCapture capture;
  capture.cameras = {DepthCamera("cam", 8, 6, rng), DepthCamera("other", 8, 6, rng)};
  std::vector<float>& depth = capture.cameras[0].depth_m;
  depth[1] = 1e7f;
  depth[2] = 1000.5f;  // just beyond the 1000 m range
  depth[4] = 999.0f;   // within it: kept (region.max_depth_m leaves it unused)
  WriteCapture(path, capture);
  const RigCapture back = ReadCapture(path);
  EXPECT_TRUE(std::isnan(back.cameras[0].depth_m[1]));
  EXPECT_TRUE(std::isnan(back.cameras[0].depth_m[2]));
  EXPECT_EQ(back.cameras[0].depth_m[4], 999.0f);
  EXPECT_EQ(back.cameras[0].depth_m[5], depth[5]);
  EXPECT_EQ(back.cameras[0].glitch_depth_samples, 2);
  EXPECT_EQ(back.cameras[1].glitch_depth_samples, 0);
  EXPECT_THAT(CaptureWarnings(back, path),
              ElementsAre(path + ": camera cam: 2 depth samples beyond 1000 m read as invalid "
                                 "(sensor glitches)"));
  // The guarded read passes the count on.
  EXPECT_EQ(ReadCaptureGuarded(path).cameras[0].glitch_depth_samples, 2);
}

TEST_F(CaptureTest, MedianDepthDecidesTheUnitMistake) {
  // Half the valid samples beyond 100 m: the median is beyond it, the capture is refused;
  // one sample fewer and it is read (those beyond 1000 m as glitches).
  std::mt19937 rng(4);
  const std::string path = Path("capture.h5");
  for (const bool majority : {true, false}) {
    SCOPED_TRACE(majority);
    RigCapture capture;
    capture.cameras = {DepthCamera("cam", 4, 3, rng)};  // pixels 3 and 10 invalid
    capture.cameras[0].intrinsics = {50.0, 50.0, 1.5, 1.0};
    std::vector<float>& depth = capture.cameras[0].depth_m;
    const int far = majority ? 5 : 4;  // of 10 valid samples
    int made = 0;
    for (size_t i = 0; i < depth.size() && made < far; ++i) {
      if (std::isnan(depth[i])) continue;
      depth[i] = 5000.0f;
      ++made;
    }
    if (majority) {
      EXPECT_THAT(io_test::InputErrorMessage([&] { WriteCapture(path, capture); }),
                  HasSubstr("median valid depth 5000 m is beyond 100 m"));
    } else {
      WriteCapture(path, capture);
      EXPECT_EQ(ReadCapture(path).cameras[0].glitch_depth_samples, 4);
    }
  }
}

TEST_F(CaptureTest, BurstBecomesThePerPixelMedianOfValidSamples) {
  const std::string path = Path("burst.h5");
  io_test::WriteBurstCapture(path);
  const RigCapture capture = ReadCapture(path);
  ASSERT_THAT(capture.cameras, SizeIs(2));
  const CameraCapture& cam = capture.cameras[0];
  EXPECT_EQ(cam.width, 3);
  EXPECT_EQ(cam.height, 2);
  // Medians: {1,2,3} -> 2; {1,4} -> 2.5 (mean of the middle two); none valid -> NaN;
  // {5} (0 and -1 invalid) -> 5; {2} (+-inf invalid) -> 2; {7,7,1} -> 7.
  ExpectSameDepth(cam.depth_m, {2.0f, 2.5f, kNaN, 5.0f, 2.0f, 7.0f}, 0.0);
  ExpectSameDepth(capture.cameras[1].depth_m, {2.0f, kNaN}, 1e-6);
}

TEST_F(CaptureTest, AcceptsFloat64DepthIntegerConfidenceAndVariableLengthFormat) {
  const std::string path = Path("capture.h5");
  {
    H5Builder h5(path);
    h5.Root("rig-capture", 1, /*variable_length=*/true);
    h5.Dataset("/cameras/cam/depth", H5T_IEEE_F64LE, {2, 2},
               std::vector<double>{1.25, -3.0, 0.0, HUGE_VAL});
    h5.Intrinsics("cam", {5.0, 0.0, 1.0, 0.0, 5.0, 1.0, 0.0, 0.0, 1.0});
    h5.Dataset("/cameras/cam/confidence", H5T_STD_I32LE, {2, 2},
               std::vector<std::int32_t>{0, 1, 2, 100});
  }
  const RigCapture capture = ReadCapture(path);
  // <= 0 and infinity are invalid (a finite depth beyond 1 km would be an error).
  ExpectSameDepth(capture.cameras[0].depth_m, {1.25f, kNaN, kNaN, kNaN}, 0.0);
  EXPECT_EQ(capture.cameras[0].confidence, (std::vector<float>{0, 1, 2, 100}));
}

TEST_F(CaptureTest, ReadsFromMemoryLikeFromDisk) {
  std::mt19937 rng(11);
  RigCapture capture;
  capture.cameras = {DepthCamera("cam", 8, 6, rng)};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const std::string bytes = io_test::ReadText(path);
  const RigCapture back = ReadCaptureFromMemory(bytes.data(), bytes.size(), "memory.h5");
  ASSERT_THAT(back.cameras, SizeIs(1));
  ExpectSameDepth(back.cameras[0].depth_m, capture.cameras[0].depth_m, 0.0);
  const std::string garbage = "not an hdf5 file at all";
  EXPECT_THAT(io_test::InputErrorMessage(
                  [&] { ReadCaptureFromMemory(garbage.data(), garbage.size(), "fuzz.h5"); }),
              HasSubstr("fuzz.h5: not an HDF5 file"));
  EXPECT_THAT(io_test::InputErrorMessage(
                  [&] { ReadCaptureFromMemory(bytes.data(), bytes.size() / 2, "half.h5"); }),
              HasSubstr("half.h5"));
}

/// One malformed-input class: how to build the file and what the error must say.
struct MalformedCase {
  std::string name;
  std::function<void(H5Builder&)> build;
  std::string expected;
};

const char* kCam = "/cameras/31002234";

std::vector<MalformedCase> MalformedCases() {
  using Doubles = std::vector<double>;
  const std::string cam = kCam;
  return {
      {"missing format", [](H5Builder& h5) { h5.DepthCamera("31002234"); },
       "capture.h5: missing root attribute 'format'"},
      {"wrong format",
       [](H5Builder& h5) {
         h5.Root("rig-capture2");
         h5.DepthCamera("31002234");
       },
       "capture.h5: root attribute 'format': expected \"rig-capture\", got \"rig-capture2\""},
      {"format not a string",
       [](H5Builder& h5) {
         h5.NumberAttribute("/", "format", H5T_STD_I32LE, 1);
         h5.NumberAttribute("/", "version", H5T_STD_I32LE, 1);
       },
       "capture.h5: root attribute 'format': expected a string, got int32"},
      {"version 2",
       [](H5Builder& h5) {
         h5.Root("rig-capture", 2);
         h5.DepthCamera("31002234");
       },
       "capture.h5: root attribute 'version': unsupported version 2"},
      {"version float",
       [](H5Builder& h5) {
         h5.StringAttribute("/", "format", "rig-capture", false);
         h5.NumberAttribute("/", "version", H5T_IEEE_F64LE, 1.0);
       },
       "capture.h5: root attribute 'version': expected a single integer"},
      {"no cameras group", [](H5Builder& h5) { h5.Root(); }, "capture.h5: missing group /cameras"},
      {"cameras not a group",
       [](H5Builder& h5) {
         h5.Root();
         h5.Dataset("/cameras", H5T_IEEE_F32LE, {1}, std::vector<float>{1});
       },
       "capture.h5: /cameras: expected a group"},
      {"empty cameras",
       [](H5Builder& h5) {
         h5.Root();
         h5.Group("/cameras");
       },
       "capture.h5: /cameras: is empty"},
      {"camera not a group",
       [](H5Builder& h5) {
         h5.Root();
         h5.Dataset("/cameras/31002234", H5T_IEEE_F32LE, {1}, std::vector<float>{1});
       },
       "capture.h5: camera 31002234: expected a group under /cameras"},
      {"soft link camera",
       [](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31001117");
         H5Lcreate_soft("/cameras/31001117", h5.file(), "/cameras/31002234", H5P_DEFAULT,
                        H5P_DEFAULT);
       },
       "capture.h5: camera 31002234: must be a group or dataset, not a soft or external link"},
      {"neither depth nor points",
       [](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31001117");
         h5.Group("/cameras/31002234");
       },
       "capture.h5: camera 31002234: has neither depth nor points"},
      {"both depth and points",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/points", H5T_IEEE_F64LE, {1, 3}, std::vector<double>{0, 0, 1});
       },
       "capture.h5: camera 31002234: has both depth and points"},
      {"depth rank 1",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {12}, std::vector<float>(12, 1.0f));
       },
       "capture.h5: camera 31002234: depth: expected rank 2 or 3, got 1"},
      {"depth int32",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_STD_I32LE, {3, 4}, std::vector<std::int32_t>(12, 1));
       },
       "capture.h5: camera 31002234: depth: expected float32, float64 or uint16, got int32"},
      {"depth zero size",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {0, 4}, std::vector<float>{});
       },
       "capture.h5: camera 31002234: depth: has zero size [0, 4]"},
      {"uint16 without depth_scale",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_STD_U16LE, {3, 4}, std::vector<std::uint16_t>(12, 1));
       },
       "capture.h5: camera 31002234: depth attribute depth_scale: missing"},
      {"depth_scale zero",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_STD_U16LE, {3, 4}, std::vector<std::uint16_t>(12, 1));
         h5.NumberAttribute(cam + "/depth", "depth_scale", H5T_IEEE_F64LE, 0.0);
       },
       "capture.h5: camera 31002234: depth attribute depth_scale: must be > 0"},
      {"intrinsics missing",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
       },
       "capture.h5: camera 31002234: intrinsics: missing"},
      {"intrinsics shape",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Dataset(cam + "/intrinsics", H5T_IEEE_F64LE, {3, 4}, std::vector<double>(12, 1.0));
       },
       "capture.h5: camera 31002234: intrinsics: expected shape [3, 3], got [3, 4]"},
      {"intrinsics integer",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Dataset(cam + "/intrinsics", H5T_STD_I32LE, {3, 3},
                    std::vector<std::int32_t>{5, 0, 1, 0, 5, 1, 0, 0, 1});
       },
       "capture.h5: camera 31002234: intrinsics: expected float32 or float64, got int32"},
      {"intrinsics fx negative",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Intrinsics("31002234", {-5.0, 0.0, 1.5, 0.0, 5.0, 1.0, 0.0, 0.0, 1.0});
       },
       "capture.h5: camera 31002234: intrinsics: fx and fy must be > 0"},
      {"intrinsics skew",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Intrinsics("31002234", {5.0, 0.1, 1.5, 0.0, 5.0, 1.0, 0.0, 0.0, 1.0});
       },
       "capture.h5: camera 31002234: intrinsics: skew must be 0"},
      {"intrinsics last row",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Intrinsics("31002234", {5.0, 0.0, 1.5, 0.0, 5.0, 1.0, 0.0, 0.0, 2.0});
       },
       "capture.h5: camera 31002234: intrinsics: last row must be [0, 0, 1]"},
      {"intrinsics of another image size",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/depth", H5T_IEEE_F32LE, {3, 4}, std::vector<float>(12, 1.0f));
         h5.Intrinsics("31002234", {525.0, 0.0, 319.5, 0.0, 525.0, 239.5, 0.0, 0.0, 1.0});
       },
       "capture.h5: camera 31002234: intrinsics: principal point (319.5, 239.5) does not match "
       "the image size 4x3"},
      {"points shape",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/points", H5T_IEEE_F64LE, {3, 2}, Doubles({1, 2, 3, 4, 5, 6}));
       },
       "capture.h5: camera 31002234: points: expected shape [N, 3], got [3, 2]"},
      {"points integer",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/points", H5T_STD_I32LE, {1, 3}, std::vector<std::int32_t>{1, 2, 3});
       },
       "capture.h5: camera 31002234: points: expected float32 or float64, got int32"},
      {"points not finite",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/points", H5T_IEEE_F64LE, {2, 3}, Doubles({1, 2, 3, 4, NAN, 6}));
       },
       "capture.h5: camera 31002234: points: row 1 is not finite"},
      {"normals count",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/points", H5T_IEEE_F64LE, {2, 3}, Doubles({1, 2, 3, 4, 5, 6}));
         h5.Dataset(cam + "/normals", H5T_IEEE_F64LE, {1, 3}, Doubles({0, 0, 1}));
       },
       "capture.h5: camera 31002234: normals: 1 rows for 2 points"},
      {"normals beside depth",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/normals", H5T_IEEE_F64LE, {1, 3}, Doubles({0, 0, 1}));
       },
       "capture.h5: camera 31002234: normals: only allowed beside points"},
      {"color beside points",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.Dataset(cam + "/points", H5T_IEEE_F64LE, {1, 3}, Doubles({1, 2, 3}));
         h5.Dataset(cam + "/color", H5T_STD_U8LE, {1, 1, 3}, std::vector<std::uint8_t>(3, 0));
       },
       "capture.h5: camera 31002234: color: only allowed beside depth"},
      {"confidence shape",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/confidence", H5T_IEEE_F32LE, {4, 3}, std::vector<float>(12, 1.0f));
       },
       "capture.h5: camera 31002234: confidence: expected shape [3, 4] (the depth image), got "
       "[4, 3]"},
      {"confidence not finite",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         std::vector<float> confidence(12, 1.0f);
         confidence[4] = kNaN;
         h5.Dataset(cam + "/confidence", H5T_IEEE_F32LE, {3, 4}, confidence);
       },
       "capture.h5: camera 31002234: confidence: value at pixel 4 is not finite"},
      {"color dtype",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/color", H5T_IEEE_F32LE, {3, 4, 3}, std::vector<float>(36, 1.0f));
       },
       "capture.h5: camera 31002234: color: expected uint8, got float32"},
      {"color shape",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/color", H5T_STD_U8LE, {3, 4}, std::vector<std::uint8_t>(12, 1));
       },
       "capture.h5: camera 31002234: color: expected shape [3, 4, 3] (the depth image), got "
       "[3, 4]"},
      {"baseline not positive",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/baseline_m", H5T_IEEE_F64LE, {1}, std::vector<double>{-0.12});
       },
       "capture.h5: camera 31002234: baseline_m: must be finite and > 0, got -0.12"},
      {"baseline not a scalar",
       [cam](H5Builder& h5) {
         h5.Root();
         h5.DepthCamera("31002234");
         h5.Dataset(cam + "/baseline_m", H5T_IEEE_F64LE, {2}, std::vector<double>{0.1, 0.2});
       },
       "capture.h5: camera 31002234: baseline_m: expected a scalar, got shape [2]"},
  };
}

TEST_F(CaptureTest, EveryMalformedInputNamesFileCameraAndDataset) {
  const std::string path = Path("capture.h5");
  for (const MalformedCase& c : MalformedCases()) {
    SCOPED_TRACE(c.name);
    std::filesystem::remove(path);
    {
      H5Builder h5(path);
      c.build(h5);
    }
    EXPECT_THAT(io_test::InputErrorMessage([&] { ReadCapture(path); }), HasSubstr(c.expected));
    // The same bytes from memory give the same message under the name given.
    const std::string bytes = io_test::ReadText(path);
    std::string expected_memory = c.expected;
    expected_memory.replace(0, std::string("capture.h5").size(), "mem.h5");
    EXPECT_THAT(io_test::InputErrorMessage(
                    [&] { ReadCaptureFromMemory(bytes.data(), bytes.size(), "mem.h5"); }),
                HasSubstr(expected_memory));
    // Every HDF5 handle was closed on the way out of the throw.
    EXPECT_EQ(H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL), 0);
  }
}

TEST_F(CaptureTest, GuardedReadGivesTheSameCaptureAndTheSameMessages) {
  // Every field comes back from the child process: depth with NaN, confidence, colour,
  // intrinsics, and a points camera with normals.
  std::mt19937 rng(12);
  RigCapture capture;
  CameraCapture b = DepthCamera("b", 8, 6, rng);
  b.confidence.resize(48);
  b.color.resize(3 * 48);
  for (size_t i = 0; i < b.confidence.size(); ++i) b.confidence[i] = 0.25f * i;
  for (size_t i = 0; i < b.color.size(); ++i) b.color[i] = static_cast<std::uint8_t>(5 * i);
  CameraCapture p;
  p.serial = "points-camera";
  for (int i = 0; i < 7; ++i) {
    p.points.emplace_back(0.1 * i, -1.0 / 3.0, 2.0 + i);
    p.normals.push_back(Vec3(i, 1.0, 0.5).normalized());
  }
  capture.cameras = {b, DepthCamera("a", 5, 4, rng), p};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  const RigCapture guarded = ReadCaptureGuarded(path);
  const RigCapture plain = ReadCapture(path);
  ASSERT_THAT(guarded.cameras, SizeIs(3));
  io_test::ExpectSameCapture(guarded, plain);
  EXPECT_EQ(guarded.cameras[1].confidence, b.confidence);
  EXPECT_EQ(guarded.cameras[1].color, b.color);
  EXPECT_THAT(guarded.cameras[2].normals, SizeIs(7));
  // The child's InputError reaches the caller unchanged, for every malformed case.
  for (const MalformedCase& c : MalformedCases()) {
    SCOPED_TRACE(c.name);
    std::filesystem::remove(path);
    {
      H5Builder h5(path);
      c.build(h5);
    }
    EXPECT_EQ(io_test::InputErrorMessage([&] { ReadCaptureGuarded(path); }),
              io_test::InputErrorMessage([&] { ReadCapture(path); }));
  }
}

TEST_F(CaptureTest, GuardedReadThatDoesNotFinishInTimeIsAnError) {
  // A child that is still reading at the deadline is killed: with no time at all, a capture
  // of 16 cameras (milliseconds of reading) cannot be done by the first check.
  std::mt19937 rng(13);
  RigCapture capture;
  for (int i = 0; i < 16; ++i)
    capture.cameras.push_back(DepthCamera(std::to_string(i), 320, 180, rng));
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadCaptureGuarded(path, 0.0); }),
              HasSubstr(path + ": reading it did not finish in 0 s"));
}

TEST_F(CaptureTest, GuardedReadTimeoutIsCheckedAndMayBeInfinite) {
  std::mt19937 rng(14);
  RigCapture capture;
  capture.cameras = {DepthCamera("a", 6, 4, rng)};
  const std::string path = Path("capture.h5");
  WriteCapture(path, capture);
  EXPECT_THROW(ReadCaptureGuarded(path, std::nan("")), std::invalid_argument);
  const RigCapture read = ReadCaptureGuarded(path, std::numeric_limits<double>::infinity());
  ASSERT_THAT(read.cameras, SizeIs(1));
  ExpectSameDepth(read.cameras[0].depth_m, capture.cameras[0].depth_m, 0.0);
}

TEST_F(CaptureTest, UnreadableFilesNameTheFile) {
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadCapture(Path("missing.h5")); }),
              HasSubstr(Path("missing.h5") + ": cannot open"));
  io_test::WriteText(Path("text.h5"), "just some text\n");
  EXPECT_THAT(io_test::InputErrorMessage([&] { ReadCapture(Path("text.h5")); }),
              HasSubstr(Path("text.h5") + ": not an HDF5 file"));
}

}  // namespace
}  // namespace rigfit
