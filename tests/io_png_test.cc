// io/png.h: 16-bit greyscale PNG (depth images) read back exactly, and files of another pixel
// format refused naming the file. The byte order on disk is checked against values read by
// another tool from a real TUM depth image (tests/io_rgbd_sequence_test.cc); the 8-bit RGB
// round trip is tested with the report (tests/report_test.cc).
#include <gtest/gtest.h>

#include "io/png.h"
#include "io_test_util.h"

namespace rigfit {
namespace {

class PngTest : public io_test::TempDirTest {};

TEST_F(PngTest, Grey16RoundTripIsExact) {
  const Grey16Raster image{3, 2, {0, 1, 0x1234, 5000, 65534, 65535}};
  const std::string path = Path("d.png");
  WritePngGrey16(path, image);
  const Grey16Raster read = ReadPngGrey16(path);
  EXPECT_EQ(read.width, 3);
  EXPECT_EQ(read.height, 2);
  EXPECT_EQ(read.values, image.values);
}

TEST_F(PngTest, Grey16ReaderRefusesOtherFormatsNamingTheFile) {
  const std::string rgb_path = Path("rgb.png");
  WritePng(rgb_path, RgbRaster{2, 1, {1, 2, 3, 4, 5, 6}});
  EXPECT_EQ(io_test::InputErrorMessage([&] { ReadPngGrey16(rgb_path); }),
            rgb_path + ": cannot read PNG: expected a 16-bit greyscale PNG (depth), got 8-bit RGB");
  const std::string text_path = Path("not.png");
  io_test::WriteText(text_path, "hello, not a png");
  EXPECT_EQ(io_test::InputErrorMessage([&] { ReadPngGrey16(text_path); }),
            text_path + ": cannot read PNG: not a PNG file");
  const std::string missing = Path("missing.png");
  EXPECT_EQ(io_test::InputErrorMessage([&] { ReadPngGrey16(missing); }),
            missing + ": cannot open: No such file or directory");
}

TEST_F(PngTest, TruncatedGrey16FileIsAnErrorNamingTheFile) {
  Grey16Raster image;
  image.width = 64;
  image.height = 64;
  image.values.resize(64 * 64);
  for (size_t i = 0; i < image.values.size(); ++i) image.values[i] = static_cast<uint16_t>(i * 37);
  const std::string path = Path("d.png");
  WritePngGrey16(path, image);
  const std::string bytes = io_test::ReadText(path);
  io_test::WriteText(path, bytes.substr(0, bytes.size() / 2));
  const std::string message = io_test::InputErrorMessage([&] { ReadPngGrey16(path); });
  EXPECT_EQ(message.rfind(path + ": cannot read PNG: ", 0), 0u) << message;
}

}  // namespace
}  // namespace rigfit
