#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>

#include "io/capture_bytes.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

/// A depth camera with NaN, confidence and colour, and a points camera with normals: every
/// field of CameraCapture set.
RigCapture SmallCapture() {
  RigCapture capture;
  CameraCapture depth;
  depth.serial = "31002234";
  depth.width = 3;
  depth.height = 2;
  depth.intrinsics = {520.5, 519.25, 1.0, 0.5};
  depth.depth_m = {1.5f, std::nanf(""), 2.25f, 3.0f, 0.75f, 4.5f};
  depth.confidence = {0.0f, 1.0f, 2.0f, 3.0f, 4.0f, 5.0f};
  for (int i = 0; i < 18; ++i) depth.color.push_back(static_cast<std::uint8_t>(13 * i));
  depth.baseline_m = 0.12;
  CameraCapture points;
  points.serial = "scan";
  points.points = {Vec3(0.1, -1.0 / 3.0, 2.0), Vec3(-4.0, 0.5, 1e-9)};
  points.normals = {Vec3(0.0, 1.0, 0.0), Vec3(0.6, 0.0, 0.8)};
  capture.cameras = {depth, points};
  return capture;
}

TEST(CaptureBytes, EveryFieldRoundTrips) {
  const RigCapture capture = SmallCapture();
  io_test::ExpectSameCapture(DecodeCapture(EncodeCapture(capture)), capture);
  io_test::ExpectSameCapture(DecodeCapture(EncodeCapture(RigCapture{})), RigCapture{});
}

TEST(CaptureBytes, BytesCutShortAnywhereAreRefused) {
  const std::string bytes = EncodeCapture(SmallCapture());
  ASSERT_GT(bytes.size(), 200u);
  for (size_t size = 0; size < bytes.size(); ++size) {
    EXPECT_THROW(DecodeCapture(bytes.substr(0, size)), std::runtime_error) << size;
  }
}

TEST(CaptureBytes, TrailingBytesAreRefused) {
  EXPECT_THROW(DecodeCapture(EncodeCapture(SmallCapture()) + "x"), std::runtime_error);
}

TEST(CaptureBytes, CountsLargerThanTheBytesAreRefusedBeforeAllocating) {
  // A camera count of 2^60, then a serial length of 2^60 in an otherwise valid capture:
  // refused as runtime_error, not bad_alloc or length_error.
  std::string huge_count = EncodeCapture(SmallCapture());
  const std::uint64_t count = std::uint64_t{1} << 60;
  std::memcpy(huge_count.data(), &count, sizeof(count));
  EXPECT_THROW(DecodeCapture(huge_count), std::runtime_error);
  std::string huge_serial = EncodeCapture(SmallCapture());
  std::memcpy(huge_serial.data() + sizeof(count), &count, sizeof(count));
  EXPECT_THROW(DecodeCapture(huge_serial), std::runtime_error);
}

}  // namespace
}  // namespace rigfit
