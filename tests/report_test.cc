// report/: PNG round trip, the Cairo canvas, the page's HTML escaping, and the refine report
// on a small simulated rig: its files exist, decode to the documented size and show every
// camera, and its page shows them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/errors.h"
#include "io/png.h"
#include "report/canvas.h"
#include "report/html.h"
#include "report/image.h"
#include "report/palette.h"
#include "report/plots.h"
#include "report/refine_report.h"
#include "sim/simulate_rig.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

/// More pixels than a legend swatch holds (a square of 22 pixels: one text line of 20 and 2,
/// report/plots.cc), so that a count above it includes the plot.
const int kMoreThanASwatch = 22 * 22 + 200;

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

TEST_F(ReportTest, CanvasDrawsWhereAsked) {
  Canvas rects(100, 60, kWhite);
  rects.FillRect(10, 10, 20, 15, kBlack);
  EXPECT_EQ(CountPixels(rects.ToImage(), kBlack), 50);
  rects.FillRect(95, 55, 200, 200, kBlack);  // clipped to 5 x 5
  EXPECT_EQ(CountPixels(rects.ToImage(), kBlack), 75);

  // A 1-pixel line at integer coordinates fills exactly its pixels (pixel centres are at
  // integer coordinates), ends included.
  Canvas lines(50, 50, kWhite);
  lines.Line(5, 20, 44, 20, kBlack);
  Image image = lines.ToImage();
  EXPECT_EQ(CountPixels(image, kBlack), 40);
  for (int x = 5; x <= 44; ++x) EXPECT_EQ(image.At(x, 20), kBlack) << x;

  // An anti-aliased diagonal 3 pixels wide: full colour on it, untouched 4 pixels to a side
  // (2.8 pixels from it).
  Canvas diagonal(50, 50, kWhite);
  diagonal.Line(0, 0, 49, 49, kBlack, 3);
  image = diagonal.ToImage();
  for (int i = 0; i < 50; ++i) {
    EXPECT_EQ(image.At(i, i), kBlack) << i;
    if (i + 4 < 50) {
      EXPECT_EQ(image.At(i + 4, i), kWhite) << i;
      EXPECT_EQ(image.At(i, i + 4), kWhite) << i;
    }
  }
  // Grey levels at the edges: the line is anti-aliased.
  int grey = 0;
  for (int y = 0; y < 50; ++y) {
    for (int x = 0; x < 50; ++x) grey += image.At(x, y) != kBlack && image.At(x, y) != kWhite;
  }
  EXPECT_GT(grey, 50);

  // A disc covers its centre, not beyond its radius.
  Canvas disc(40, 40, kWhite);
  disc.Disc(20, 20, 7.0, kBlack);
  image = disc.ToImage();
  EXPECT_EQ(image.At(20, 20), kBlack);
  EXPECT_EQ(image.At(20 + 5, 20), kBlack);
  EXPECT_EQ(image.At(20 + 9, 20), kWhite);
  EXPECT_NEAR(CountPixels(image, kBlack), M_PI * 7 * 7, 0.25 * M_PI * 7 * 7);

  // Text: ink where it is written, widths that grow with the text and its size.
  Canvas text(300, 40, kWhite);
  text.Text(5, 10, "x (m) 0.5", kBlack, 18);
  image = text.ToImage();
  int ink = 0, ink_outside = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      const bool inked = image.At(x, y) != kWhite;
      ink += inked;
      ink_outside += inked && (x < 4 || x > 5 + text.TextWidth("x (m) 0.5", 18) + 1 || y < 8);
    }
  }
  EXPECT_GT(ink, 100);
  EXPECT_EQ(ink_outside, 0);
  EXPECT_GT(text.TextWidth("x (m) 0.5", 18), text.TextWidth("x", 18));
  EXPECT_NEAR(text.TextWidth("camera", 36), 2.0 * text.TextWidth("camera", 18),
              0.1 * text.TextWidth("camera", 36));

  // Text Cairo would refuse (invalid UTF-8) is drawn with '?' in place of the bad bytes.
  EXPECT_NO_THROW(text.Text(5, 10, std::string("bad \xff\xfe utf-8"), kBlack, 18));
}

TEST(DrawableTextTest, ReplacesInvalidUtf8AndControlCharacters) {
  EXPECT_EQ(DrawableText("plain 0.5 m"), "plain 0.5 m");
  EXPECT_EQ(DrawableText("caf\xc3\xa9 \xe2\x86\x92"), "caf\xc3\xa9 \xe2\x86\x92");  // é →
  EXPECT_EQ(DrawableText("a\tb\nc\x7f"), "a?b?c?");
  EXPECT_EQ(DrawableText("\xff\xc3"), "??");       // not a lead byte; truncated
  EXPECT_EQ(DrawableText("\xc0\xaf"), "??");       // overlong '/'
  EXPECT_EQ(DrawableText("\xed\xa0\x80"), "???");  // a surrogate
  EXPECT_EQ(DrawableText("\xe2\x86x"), "??x");     // continuation missing
}

TEST(HtmlTest, EscapesTextAndAttributes) {
  EXPECT_EQ(HtmlEscape("a<b>&\"c\"'d'"), "a&lt;b&gt;&amp;&quot;c&quot;&#39;d&#39;");
  const std::string page =
      ReportIndexHtml("t<1>", "camera  <tab> & co\n", {{"a\".png", "cap & <x>", 10, 20}});
  EXPECT_NE(page.find("<title>t&lt;1&gt;</title>"), std::string::npos) << page;
  EXPECT_NE(page.find("<pre>camera  &lt;tab&gt; &amp; co\n</pre>"), std::string::npos) << page;
  EXPECT_NE(page.find("<img src=\"a&quot;.png\" width=\"10\" height=\"20\""), std::string::npos)
      << page;
  EXPECT_EQ(page.find("<script"), std::string::npos);
  EXPECT_EQ(page.find("http"), std::string::npos);  // nothing fetched from anywhere
  EXPECT_EQ(ReportIndexHtml("t", "", {}).find("<pre>"), std::string::npos);
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
  RefineOptions leveling_only;
  leveling_only.run_registration = false;
  const RefineResult leveling = Refine(rig.capture, rig.init, leveling_only);
  const fs::path report = dir_ / "report";  // created by the report
  const std::vector<std::string> files = WriteRefineReport(
      report.string(), rig.capture, leveling, rig.gt, RefineOptions{}, "camera 0 & <1>\n");
  // Three pictures, the 3-D view (three.js, OrbitControls, its data, the whole views, its
  // page), the page.
  ASSERT_EQ(files.size(), 9u);
  EXPECT_EQ(files.back(), (report / kReportIndexFile).string());
  std::ifstream in(files.back());
  const std::string page((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(page.find("camera 0 &amp; &lt;1&gt;"), std::string::npos) << page;
  for (const char* name : {kTopDownBeforeFile, kTopDownAfterFile, kResidualsFile}) {
    EXPECT_NE(page.find("<img src=\"" + std::string(name) + "\""), std::string::npos) << name;
  }
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
  // The "after" series is drawn in the first camera's colour as a 3-pixel outline (its
  // middle pixel in full colour).
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
