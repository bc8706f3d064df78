#include "report/plot_parts.h"

#include <algorithm>
#include <cmath>

#include "core/format.h"

namespace rigfit::plot {

double NiceStep(double span, int max_ticks) {
  const double raw = span / max_ticks;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0}) {
    if (m * magnitude >= raw) return m * magnitude;
  }
  return 10.0 * magnitude;
}

std::string TickLabel(double value, double step) {
  const int digits = std::max(0, static_cast<int>(std::ceil(-std::log10(step) - 1e-9)));
  return Fixed(std::abs(value) < 0.5 * step ? 0.0 : value, digits);
}

std::vector<double> Ticks(double lo, double hi, double step) {
  std::vector<double> ticks;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1.0) {
    ticks.push_back(k * step);
  }
  return ticks;
}

void DrawFrame(Canvas* canvas, const Rect& r, const Rgb& color) {
  canvas->Line(r.x0, r.y0, r.x1 - 1, r.y0, color);
  canvas->Line(r.x0, r.y1 - 1, r.x1 - 1, r.y1 - 1, color);
  canvas->Line(r.x0, r.y0, r.x0, r.y1 - 1, color);
  canvas->Line(r.x1 - 1, r.y0, r.x1 - 1, r.y1 - 1, color);
}

void DrawTitles(Canvas* canvas, const std::string& title, const std::string& subtitle) {
  canvas->Text(20, 16, title, kBlack, kTitleSize, true);
  canvas->Text(20, 24 + kTitleHeight, subtitle, kMuted, kTextSize);
}

void TextCentredOn(Canvas* canvas, double x, double y, const std::string& text, const Rgb& color) {
  canvas->Text(x, y - 0.5 * Canvas::kCapHeight * kTextSize, text, color, kTextSize);
}

int LegendRow(Canvas* canvas, int x, int y, const Rgb& color, const std::string& text) {
  const int size = kTextHeight + 2;
  canvas->FillRect(x, y, x + size, y + size, color);
  TextCentredOn(canvas, x + size + 10, y + 0.5 * size, text, kBlack);
  return y + size + 10;
}

void DrawScaleBar(Canvas* canvas, const Rect& plot, double px_per_m, double span_m) {
  const double bar_m = NiceStep(span_m, 5);
  const int bar_px = static_cast<int>(std::lround(bar_m * px_per_m));
  const int bar_x = plot.x0 + 20, bar_y = plot.y1 - 24;
  canvas->FillRect(bar_x, bar_y, bar_x + bar_px, bar_y + 5, kBlack);
  for (int end : {bar_x, bar_x + bar_px - 2})
    canvas->FillRect(end, bar_y - 8, end + 2, bar_y + 5, kBlack);
  const std::string bar_label = TickLabel(bar_m, bar_m) + " m";
  canvas->Text(bar_x + 0.5 * (bar_px - canvas->TextWidth(bar_label, kTextSize)),
               bar_y - 12 - kTextHeight, bar_label, kBlack, kTextSize);
}

}  // namespace rigfit::plot
