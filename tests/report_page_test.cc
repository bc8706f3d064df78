// A report's index.html opened in headless Chromium (Debian package chromium, installed by
// scripts/setup.sh): every picture loads and decodes at its size, and the screenshot of the
// page shows the pictures' content. Skipped when chromium is not installed, failed in CI
// (CI=true).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "chromium_test_util.h"
#include "core/pose.h"
#include "core/trajectory.h"
#include "io/png.h"
#include "report/html.h"
#include "report/palette.h"
#include "report/plots.h"
#include "report/trajectory_report.h"

namespace rigfit {
namespace {

namespace fs = std::filesystem;

using testing::FileUrl;
using testing::ReadText;
using testing::ShellQuote;

/// A closed loop of 300 poses, 2 m x 1 m, one per 1/30 s.
Trajectory Loop(double scale) {
  Trajectory t;
  for (int i = 0; i < 300; ++i) {
    const double a = 2.0 * M_PI * i / 300;
    Pose T = Pose::Identity();
    T.translation() = Vec3(2.0 * scale * std::cos(a), 1.4, std::sin(a));
    t.timestamps.push_back(i / 30.0);
    t.poses.push_back(T);
  }
  return t;
}

class ReportPage : public ::testing::Test {
 protected:
  void SetUp() override {
    chromium_ = testing::FindChromium();
    if (chromium_.empty()) {
      if (testing::RunningInCi()) FAIL() << testing::kNoChromium;
      GTEST_SKIP() << testing::kNoChromium;
    }
    dir_ = fs::temp_directory_path() / ("rigfit_report_page_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const Trajectory gt = Loop(1.0);
    const Trajectory est = Loop(1.2);
    files_ = WriteTrajectoryReport((dir_ / "report").string(), est, gt,
                                   EvaluateTrajectory(est, gt, 0.02, 1), 0.02, "summary <text>\n");
  }
  void TearDown() override {
    if (!dir_.empty()) fs::remove_all(dir_);
  }

  /// Runs headless chromium on the page with `options`; returns its stdout. Fails the test
  /// on a non-zero exit.
  std::string RunChromium(const std::string& options, const fs::path& page) {
    const testing::ChromiumRun run = testing::RunChromium(chromium_, dir_, options, FileUrl(page));
    EXPECT_TRUE(run.Ok()) << run.command << "\n" << run.err;
    return run.out;
  }

  std::string chromium_;
  fs::path dir_;
  std::vector<std::string> files_;
};

// The page itself has no script; a copy with one inline script, run once the page has loaded,
// writes each picture's decoded size into the DOM that --dump-dom prints. A picture that did
// not load has naturalWidth 0.
TEST_F(ReportPage, EveryPictureLoadsAtItsSize) {
  ASSERT_EQ(files_.size(), 3u);
  const fs::path page = dir_ / "report" / kReportIndexFile;
  std::string html = ReadText(page);
  ASSERT_EQ(html.find("<script"), std::string::npos);
  const std::string probe =
      "<script>window.addEventListener('load', () => { document.body.setAttribute("
      "'data-pictures', Array.from(document.images).map(i => i.complete ? i.naturalWidth + 'x' "
      "+ i.naturalHeight : 'pending').join(',')); });</script>";
  html.insert(html.rfind("</body>"), probe);
  const fs::path probed = dir_ / "report" / "probe.html";
  std::ofstream(probed, std::ios::binary) << html;
  const std::string dom = RunChromium("--dump-dom", probed);
  const std::string expected =
      "data-pictures=\"" + std::to_string(kPlanViewWidth) + "x" + std::to_string(kPlanViewHeight) +
      "," + std::to_string(kTimePlotWidth) + "x" + std::to_string(kTimePlotHeight) + "\"";
  EXPECT_NE(dom.find(expected), std::string::npos) << dom;
  EXPECT_NE(dom.find("summary &lt;text&gt;"), std::string::npos) << dom;
}

// The screenshot shows the curves: the estimate's colour, which nothing else on the page
// uses, covers many pixels in each picture's place (the plan view first, the ATE plot
// under it).
TEST_F(ReportPage, ScreenshotShowsThePictures) {
  const fs::path shot = dir_ / "shot.png";
  RunChromium("--window-size=1400,2200 --screenshot=" + ShellQuote(shot.string()),
              dir_ / "report" / kReportIndexFile);
  ASSERT_TRUE(fs::exists(shot));
  const Image image = ReadPng(shot.string());
  const Rgb curve = CameraColor(0);
  const auto near = [&](const Rgb& c) {
    return std::abs(c.r - curve.r) <= 6 && std::abs(c.g - curve.g) <= 6 &&
           std::abs(c.b - curve.b) <= 6;
  };
  // The page's heading and summary push the plan view (kPlanViewHeight rows tall) down, so
  // the ATE plot under it starts below row kPlanViewHeight: the curve colour above that row
  // is the plan view's, below it the ATE plot's.
  int plan = 0, ate = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) {
      if (near(image.At(x, y))) ++(y < kPlanViewHeight ? plan : ate);
    }
  }
  EXPECT_GT(plan, 1000);
  EXPECT_GT(ate, 1000);
}

}  // namespace
}  // namespace rigfit
