// report/: PNG round trip, the drawing primitives, and the refine report on a small
// simulated rig: its files exist, decode to the documented size and show every camera.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "core/errors.h"
#include "io/png.h"
#include "report/image.h"
#include "report/palette.h"
#include "report/plots.h"
#include "report/refine_report.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// More pixels than a legend swatch holds (a square of one text line, report/plots.cc), so
/// that a count above it includes the plot.
const int kMoreThanASwatch = (TextHeight(2) + 2) * (TextHeight(2) + 2) + 200;

int CountPixels(const Image& image, const Rgb& color) {
  int n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) n += image.At(x, y) == color ? 1 : 0;
  }
  return n;
}

class ReportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("rigfit_report_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  fs::path dir_;
};

TEST_F(ReportTest, PngRoundTripIsExact) {
  Image image(37, 21, kWhite);
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      image.Set(x, y,
                Rgb{static_cast<std::uint8_t>(7 * x), static_cast<std::uint8_t>(11 * y),
                    static_cast<std::uint8_t>(x * y)});
    }
  }
  const std::string path = (dir_ / "a.png").string();
  WritePng(path, image);
  const Image read = ReadPng(path);
  EXPECT_EQ(read.width, image.width);
  EXPECT_EQ(read.height, image.height);
  EXPECT_EQ(read.rgb, image.rgb);
}

TEST_F(ReportTest, ReadingANonPngNamesTheFile) {
  const std::string path = (dir_ / "not.png").string();
  std::ofstream(path) << "hello";
  try {
    ReadPng(path);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_THROW(WritePng((dir_ / "missing" / "a.png").string(), Image(2, 2, kWhite)), InputError);
}

TEST_F(ReportTest, PrimitivesDrawWhereAsked) {
  Image image(100, 60, kWhite);
  FillRect(&image, 10, 10, 20, 15, kBlack);
  EXPECT_EQ(CountPixels(image, kBlack), 50);
  FillRect(&image, 95, 55, 200, 200, kBlack);  // clipped to 5 x 5
  EXPECT_EQ(CountPixels(image, kBlack), 75);

  Image line(50, 50, kWhite);
  DrawLine(&line, 0, 0, 49, 49, kBlack);
  EXPECT_EQ(CountPixels(line, kBlack), 50);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(line.At(i, i), kBlack);

  Image text(200, 40, kWhite);
  DrawText(&text, 5, 5, "x (m) 0.5", kBlack, 2);
  EXPECT_GT(CountPixels(text, kBlack), 50);
  EXPECT_GT(TextWidth("x (m) 0.5", 2), TextWidth("x", 2));
  EXPECT_EQ(TextWidth("ab", 3), 3 * TextWidth("ab", 1));
}

TEST(PaletteTest, FirstTwentyCamerasHaveDistinctColours) {
  for (int i = 0; i < kCameraColors; ++i) {
    for (int j = i + 1; j < kCameraColors; ++j) EXPECT_NE(CameraColor(i), CameraColor(j));
    EXPECT_NE(CameraColor(i), kWhite);
  }
  EXPECT_EQ(CameraColor(kCameraColors), CameraColor(0));
  EXPECT_EQ(HexColor(CameraColor(0)), "#1f77b4");
}

TEST_F(ReportTest, RefineReportShowsEveryCamera) {
  SimOptions sim;
  sim.cameras = 3;
  sim.width = 320;
  sim.height = 180;
  const SimulatedRig rig = SimulateRig(sim);
  const RefineResult leveling = Refine(rig.capture, rig.init, RefineOptions{}, false, 2, {});
  const fs::path report = dir_ / "report";  // created by the report
  const std::vector<std::string> files =
      WriteRefineReport(report.string(), rig.capture, leveling, rig.gt, RefineOptions{}, 2);
  ASSERT_EQ(files.size(), 3u);
  for (const char* name : {kTopDownBeforeFile, kTopDownAfterFile}) {
    SCOPED_TRACE(name);
    const Image image = ReadPng((report / name).string());
    EXPECT_EQ(image.width, kTopDownWidth);
    EXPECT_EQ(image.height, kTopDownHeight);
    for (int i = 0; i < sim.cameras; ++i) {
      EXPECT_GT(CountPixels(image, CameraColor(i)), kMoreThanASwatch) << "camera " << i;
    }
  }
  const Image histogram = ReadPng((report / kResidualsFile).string());
  EXPECT_EQ(histogram.width, kHistogramWidth);
  EXPECT_EQ(histogram.height, kHistogramHeight);
  // The "after" series is drawn in the first camera's colour as a 3-pixel outline.
  EXPECT_GT(CountPixels(histogram, CameraColor(0)), kMoreThanASwatch);
}

TEST_F(ReportTest, ReportDirectoryNeedsAnExistingParent) {
  EXPECT_NO_THROW(CheckReportDirectory(dir_.string(), "test"));
  EXPECT_NO_THROW(CheckReportDirectory((dir_ / "new").string(), "test"));
  EXPECT_THROW(CheckReportDirectory((dir_ / "no" / "such").string(), "test"), InputError);
  const fs::path file = dir_ / "file";
  std::ofstream(file) << "x";
  EXPECT_THROW(CheckReportDirectory(file.string(), "test"), InputError);
}

}  // namespace
}  // namespace rigfit
