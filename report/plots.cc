#include "report/plots.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/format.h"
#include "prepare/region.h"
#include "report/canvas.h"
#include "report/plot_parts.h"

namespace rigfit {
namespace {

using plot::DrawFrame;
using plot::DrawTitles;
using plot::kAxis;
using plot::kGrid;
using plot::kMuted;
using plot::kTextHeight;
using plot::kTextSize;
using plot::LegendRow;
using plot::NiceStep;
using plot::Rect;
using plot::TextCentredOn;
using plot::TickLabel;
using plot::Ticks;

/// The grid line and tick label of value `label` at column c, under the plot.
void XTick(Canvas* canvas, const Rect& plot, int c, const std::string& label) {
  canvas->Line(c, plot.y0, c, plot.y1 - 1, kGrid);
  canvas->Text(c - 0.5 * canvas->TextWidth(label, kTextSize), plot.y1 + 8, label, kAxis, kTextSize);
}

/// The grid line and tick label of value `label` at row r, left of the plot.
void YTick(Canvas* canvas, const Rect& plot, int r, const std::string& label) {
  canvas->Line(plot.x0, r, plot.x1 - 1, r, kGrid);
  TextCentredOn(canvas, plot.x0 - 10 - canvas->TextWidth(label, kTextSize), r, label, kAxis);
}

/// The axis labels: x centred under the tick labels, y above the plot's top left corner.
void AxisLabels(Canvas* canvas, const Rect& plot, const std::string& x_label,
                const std::string& y_label) {
  canvas->Text(0.5 * (plot.x0 + plot.x1 - canvas->TextWidth(x_label, kTextSize)),
               plot.y1 + 16 + kTextHeight, x_label, kBlack, kTextSize);
  canvas->Text(10, plot.y0 - 8 - kTextHeight, y_label, kBlack, kTextSize);
}

}  // namespace

GroundWindow FitGroundWindow(const std::vector<const std::vector<TopDownCamera>*>& views) {
  constexpr double kMarginFraction = 0.05;
  double min_x = INFINITY, max_x = -INFINITY, min_z = INFINITY, max_z = -INFINITY;
  const auto include = [&](double x0, double x1, double z0, double z1) {
    min_x = std::min(min_x, x0);
    max_x = std::max(max_x, x1);
    min_z = std::min(min_z, z0);
    max_z = std::max(max_z, z1);
  };
  for (const std::vector<TopDownCamera>* view : views) {
    for (const TopDownCamera& camera : *view) {
      const GroundBox box = RobustGroundBox(camera.points_world);
      if (!box.empty) include(box.min_x, box.max_x, box.min_z, box.max_z);
      const Vec3& c = camera.T_world_camera.translation();
      include(c.x(), c.x(), c.z(), c.z());
    }
  }
  GroundWindow window;
  if (!(min_x <= max_x && min_z <= max_z)) return window;
  const double margin = kMarginFraction * std::max({max_x - min_x, max_z - min_z, 1.0});
  return {min_x - margin, max_x + margin, min_z - margin, max_z + margin};
}

namespace {

constexpr int kLegendWidth = 260;

/// The top-down plot's rectangle and its scale: x to columns, z to rows.
struct TopDownFrame {
  GroundWindow window;
  Rect plot;
  double px_per_m = 1.0;
  int width = 0;
  int height = 0;

  double Column(double x) const { return plot.x0 + (x - window.min_x) * px_per_m; }
  double Row(double z) const { return plot.y0 + (z - window.min_z) * px_per_m; }
};

TopDownFrame FrameOf(const GroundWindow& window, const Rect& available) {
  TopDownFrame f;
  f.window = window;
  const double span_x = window.max_x - window.min_x;
  const double span_z = window.max_z - window.min_z;
  f.px_per_m =
      std::min((available.x1 - available.x0) / span_x, (available.y1 - available.y0) / span_z);
  f.width = static_cast<int>(span_x * f.px_per_m);
  f.height = static_cast<int>(span_z * f.px_per_m);
  f.plot = {available.x0, available.y0, available.x0 + f.width, available.y0 + f.height};
  return f;
}

/// Point density per camera and pixel, then one colour per pixel, mixed into the canvas.
void DrawDensity(const std::vector<TopDownCamera>& cameras, const TopDownFrame& f,
                 double point_size_m, Canvas* canvas) {
  const size_t n = cameras.size();
  const int width = f.width, height = f.height;
  const int splat = std::max(1, static_cast<int>(std::lround(point_size_m * f.px_per_m)));
  std::vector<std::uint16_t> counts(static_cast<size_t>(width) * height * n, 0);
  for (size_t k = 0; k < n; ++k) {
    for (const Vec3& p : cameras[k].points_world) {
      const int c0 = static_cast<int>(std::floor(f.Column(p.x()) - 0.5 * splat)) - f.plot.x0;
      const int r0 = static_cast<int>(std::floor(f.Row(p.z()) - 0.5 * splat)) - f.plot.y0;
      for (int r = std::max(r0, 0); r < std::min(r0 + splat, height); ++r) {
        for (int c = std::max(c0, 0); c < std::min(c0 + splat, width); ++c) {
          std::uint16_t& count = counts[(static_cast<size_t>(r) * width + c) * n + k];
          if (count < UINT16_MAX) ++count;
        }
      }
    }
  }
  Image image = canvas->ToImage();
  for (int r = 0; r < height; ++r) {
    for (int c = 0; c < width; ++c) {
      const std::uint16_t* pixel = &counts[(static_cast<size_t>(r) * width + c) * n];
      double total = 0.0, red = 0.0, green = 0.0, blue = 0.0;
      for (size_t k = 0; k < n; ++k) {
        total += pixel[k];
        red += pixel[k] * cameras[k].color.r;
        green += pixel[k] * cameras[k].color.g;
        blue += pixel[k] * cameras[k].color.b;
      }
      if (total == 0.0) continue;
      const Rgb mixed{static_cast<std::uint8_t>(std::lround(red / total)),
                      static_cast<std::uint8_t>(std::lround(green / total)),
                      static_cast<std::uint8_t>(std::lround(blue / total))};
      image.Set(f.plot.x0 + c, f.plot.y0 + r,
                Mix(image.At(f.plot.x0 + c, f.plot.y0 + r), mixed, total / kSaturationPoints));
    }
  }
  canvas->SetImage(image);
}

/// Camera centres and viewing directions (the camera z axis on the ground).
void DrawCameraMarks(const std::vector<TopDownCamera>& cameras, const TopDownFrame& f,
                     Canvas* canvas) {
  constexpr double kHeadingPx = 45.0;
  for (const TopDownCamera& camera : cameras) {
    const Vec3& centre = camera.T_world_camera.translation();
    const Vec3 forward = camera.T_world_camera.linear().col(2);
    const double cx = f.Column(centre.x()), cy = f.Row(centre.z());
    const double norm = std::hypot(forward.x(), forward.z());
    if (norm > 1e-9) {
      canvas->Line(cx, cy, cx + kHeadingPx * forward.x() / norm,
                   cy + kHeadingPx * forward.z() / norm, kBlack, 3);
    }
    canvas->Disc(cx, cy, 10.0, kBlack);
    canvas->Disc(cx, cy, 7.0, camera.color);
  }
}

void DrawTopDownLegend(const std::vector<TopDownCamera>& cameras, int top, Canvas* canvas) {
  const int legend_x = kTopDownWidth - kLegendWidth + 10;
  int y = top;
  canvas->Text(legend_x, y, "cameras", kBlack, kTextSize);
  y += kTextHeight + 14;
  for (const TopDownCamera& camera : cameras)
    y = LegendRow(canvas, legend_x, y, camera.color, camera.label);
  y += 16;
  for (const char* line : {"disc: camera centre", "line: viewing direction", "pale: floor points",
                           "strong: walls, objects", "(many points over", " one spot)"}) {
    canvas->Text(legend_x, y, line, kMuted, kTextSize);
    y += kTextHeight + 8;
  }
}

}  // namespace

Image DrawTopDown(const std::vector<TopDownCamera>& cameras, const GroundWindow& window,
                  double point_size_m, const std::string& title, const std::string& subtitle) {
  Canvas canvas(kTopDownWidth, kTopDownHeight, kWhite);
  DrawTitles(&canvas, title, subtitle);
  const Rect available{90, 110, kTopDownWidth - kLegendWidth - 20, kTopDownHeight - 80};
  const TopDownFrame f = FrameOf(window, available);
  const double span_x = window.max_x - window.min_x;
  const double span_z = window.max_z - window.min_z;
  // Grid and tick labels, in metres.
  const double step = NiceStep(std::max(span_x, span_z), 10);
  for (double x : Ticks(window.min_x, window.max_x, step)) {
    XTick(&canvas, f.plot, static_cast<int>(std::lround(f.Column(x))), TickLabel(x, step));
  }
  for (double z : Ticks(window.min_z, window.max_z, step)) {
    YTick(&canvas, f.plot, static_cast<int>(std::lround(f.Row(z))), TickLabel(z, step));
  }
  AxisLabels(&canvas, f.plot, "x (m)", "z (m)");
  DrawDensity(cameras, f, point_size_m, &canvas);
  DrawCameraMarks(cameras, f, &canvas);
  DrawFrame(&canvas, f.plot, kAxis);
  plot::DrawScaleBar(&canvas, f.plot, f.px_per_m, span_x);
  DrawTopDownLegend(cameras, available.y0, &canvas);
  return canvas.ToImage();
}

Image DrawHistogram(const std::vector<HistogramSeries>& series, double half_range, double bin_width,
                    const std::string& title, const std::string& x_label,
                    const std::string& y_label) {
  Canvas canvas(kHistogramWidth, kHistogramHeight, kWhite);
  DrawTitles(&canvas, title, "");
  const Rect plot{110, 90, kHistogramWidth - 330, kHistogramHeight - 80};
  const int bins = std::max(1, static_cast<int>(std::lround(2.0 * half_range / bin_width)));
  std::vector<std::vector<int>> counts(series.size(), std::vector<int>(bins, 0));
  int highest = 1;
  for (size_t s = 0; s < series.size(); ++s) {
    for (double v : series[s].values) {
      const int b = static_cast<int>(std::floor((v + half_range) / bin_width));
      if (b < 0 || b >= bins) continue;
      highest = std::max(highest, ++counts[s][b]);
    }
  }
  const double y_step = NiceStep(highest, 6);
  const double y_max = std::ceil(highest / y_step) * y_step;
  const auto column = [&](double v) {
    return plot.x0 + (v + half_range) / (2.0 * half_range) * (plot.x1 - plot.x0);
  };
  const auto row = [&](double count) {
    return plot.y1 - 1 - count / y_max * (plot.y1 - plot.y0 - 1);
  };
  const double x_step = NiceStep(2.0 * half_range, 10);
  for (double v : Ticks(-half_range, half_range, x_step)) {
    XTick(&canvas, plot, static_cast<int>(std::lround(column(v))), TickLabel(v, x_step));
  }
  for (double count : Ticks(0.0, y_max, y_step)) {
    YTick(&canvas, plot, static_cast<int>(std::lround(row(count))),
          TickLabel(count, std::max(1.0, y_step)));
  }
  AxisLabels(&canvas, plot, x_label, y_label);
  for (size_t s = 0; s < series.size(); ++s) {
    const Rgb& color = series[s].color;
    // The first series as bars, the others as a step outline from 0 to 0.
    std::vector<std::pair<double, double>> outline = {{column(-half_range), row(0.0)}};
    for (int b = 0; b < bins; ++b) {
      const double left = column(-half_range + b * bin_width);
      const double right = column(-half_range + (b + 1) * bin_width);
      const double top = row(counts[s][b]);
      if (s == 0) {
        canvas.FillRect(static_cast<int>(std::lround(left)), static_cast<int>(std::lround(top)),
                        static_cast<int>(std::lround(right)), plot.y1, Mix(kWhite, color, 0.45));
      }
      outline.emplace_back(left, top);
      outline.emplace_back(right, top);
    }
    outline.emplace_back(column(half_range), row(0.0));
    if (s > 0) canvas.Polyline(outline, color, 3);
  }
  DrawFrame(&canvas, plot, kAxis);
  int y = plot.y0;
  for (size_t s = 0; s < series.size(); ++s) {
    const Rgb swatch = s == 0 ? Mix(kWhite, series[s].color, 0.45) : series[s].color;
    size_t start = 0;
    // Multi-line labels: the first line beside the swatch, the others under it.
    for (size_t end = series[s].label.find('\n');; end = series[s].label.find('\n', start)) {
      const std::string line = series[s].label.substr(start, end - start);
      if (start == 0) {
        y = LegendRow(&canvas, plot.x1 + 20, y, swatch, line);
      } else {
        canvas.Text(plot.x1 + 20 + kTextHeight + 12, y - 4, line, kMuted, kTextSize);
        y += kTextHeight + 8;
      }
      if (end == std::string::npos) break;
      start = end + 1;
    }
    y += 14;
  }
  return canvas.ToImage();
}

PlotFrame FitPlotFrame(const std::vector<PlotCurve>& curves, int width, int height,
                       bool equal_scale, bool y_from_zero) {
  constexpr double kMarginFraction = 0.05;
  constexpr double kZeroSpan = 1e-9;  // relative
  constexpr int kLegendWidth = 280;
  double min_x = INFINITY, max_x = -INFINITY, min_y = INFINITY, max_y = -INFINITY;
  for (const PlotCurve& curve : curves) {
    for (size_t i = 0; i < std::min(curve.x.size(), curve.y.size()); ++i) {
      if (!std::isfinite(curve.x[i]) || !std::isfinite(curve.y[i])) continue;
      min_x = std::min(min_x, curve.x[i]);
      max_x = std::max(max_x, curve.x[i]);
      min_y = std::min(min_y, curve.y[i]);
      max_y = std::max(max_y, curve.y[i]);
    }
  }
  if (!(min_x <= max_x)) min_x = max_x = min_y = max_y = 0.0;
  if (y_from_zero) min_y = std::min(min_y, 0.0);
  const auto widen = [&](double* lo, double* hi, bool from_zero) {
    // A span within rounding of 0 (e.g. errors of 1e-13) is 0: no noise blown up to fill
    // the plot.
    if (*hi - *lo <= kZeroSpan * std::max({1.0, std::abs(*lo), std::abs(*hi)})) {
      const double mid = 0.5 * (*lo + *hi);
      if (from_zero && *lo == 0.0) {
        *hi = 1.0;
      } else {
        *lo = mid - 0.5;
        *hi = mid + 0.5;
      }
    }
    const double margin = kMarginFraction * (*hi - *lo);
    *lo -= margin;
    *hi += margin;
  };
  widen(&min_x, &max_x, false);
  widen(&min_y, &max_y, y_from_zero);
  PlotFrame frame;
  frame.width = width;
  frame.height = height;
  frame.x0 = 110;
  frame.y0 = 110;
  frame.x1 = width - kLegendWidth;
  frame.y1 = height - 80;
  if (equal_scale) {
    // The larger span fills its side; the other window grows about its centre to fill its
    // side at the same scale, so the plot keeps the whole rectangle.
    const double px_per_unit = std::min((frame.x1 - frame.x0 - 1) / (max_x - min_x),
                                        (frame.y1 - frame.y0 - 1) / (max_y - min_y));
    const double half_x = 0.5 * (frame.x1 - frame.x0 - 1) / px_per_unit;
    const double half_y = 0.5 * (frame.y1 - frame.y0 - 1) / px_per_unit;
    const double cx = 0.5 * (min_x + max_x), cy = 0.5 * (min_y + max_y);
    min_x = cx - half_x;
    max_x = cx + half_x;
    min_y = cy - half_y;
    max_y = cy + half_y;
  }
  frame.min_x = min_x;
  frame.max_x = max_x;
  frame.min_y = min_y;
  frame.max_y = max_y;
  return frame;
}

Image DrawCurves(const std::vector<PlotCurve>& curves, const PlotFrame& frame,
                 const std::string& title, const std::string& subtitle, const std::string& x_label,
                 const std::string& y_label) {
  Canvas canvas(frame.width, frame.height, kWhite);
  DrawTitles(&canvas, title, subtitle);
  const Rect plot{frame.x0, frame.y0, frame.x1, frame.y1};
  const double x_step = NiceStep(frame.max_x - frame.min_x, 10);
  for (double x : Ticks(frame.min_x, frame.max_x, x_step)) {
    XTick(&canvas, plot, static_cast<int>(std::lround(frame.Column(x))), TickLabel(x, x_step));
  }
  const double y_step = NiceStep(frame.max_y - frame.min_y, 8);
  for (double y : Ticks(frame.min_y, frame.max_y, y_step)) {
    YTick(&canvas, plot, static_cast<int>(std::lround(frame.Row(y))), TickLabel(y, y_step));
  }
  AxisLabels(&canvas, plot, x_label, y_label);
  for (const PlotCurve& curve : curves) {
    const size_t n = std::min(curve.x.size(), curve.y.size());
    // Each run of finite points is one polyline.
    std::vector<std::pair<double, double>> run;
    const auto flush = [&] {
      if (run.size() >= 2) canvas.Polyline(run, curve.color, curve.line_width);
      run.clear();
    };
    for (size_t i = 0; i < n; ++i) {
      if (!std::isfinite(curve.x[i]) || !std::isfinite(curve.y[i])) {
        flush();
        continue;
      }
      run.emplace_back(frame.Column(curve.x[i]), frame.Row(curve.y[i]));
    }
    flush();
    if (n == 1 && std::isfinite(curve.x[0]) && std::isfinite(curve.y[0])) {
      canvas.Disc(frame.Column(curve.x[0]), frame.Row(curve.y[0]), curve.line_width, curve.color);
    }
  }
  DrawFrame(&canvas, plot, kAxis);
  int y = plot.y0;
  for (const PlotCurve& curve : curves) {
    y = LegendRow(&canvas, plot.x1 + 20, y, curve.color, curve.label);
  }
  return canvas.ToImage();
}

}  // namespace rigfit
