// What the report's pictures share (report/plots.h, report/map_view.h): the text sizes and
// colours, tick spacing and labels, titles, legend rows, a frame and a scale bar, drawn on a
// Canvas (report/canvas.h).
#pragma once

#include <string>
#include <vector>

#include "report/canvas.h"
#include "report/image.h"

namespace rigfit::plot {

inline constexpr Rgb kGrid{225, 225, 225};
inline constexpr Rgb kAxis{60, 60, 60};
inline constexpr Rgb kMuted{90, 90, 90};
inline constexpr double kTitleSize = 26.0;  ///< font size, pixels per em
inline constexpr double kTextSize = 18.0;
/// The rows one line of text takes in a layout.
inline constexpr int kTitleHeight = 30;
inline constexpr int kTextHeight = 20;

/// A pixel rectangle [x0, x1) x [y0, y1).
struct Rect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
};

/// A tick spacing of 1, 2 or 5 times a power of ten giving at most max_ticks intervals
/// over span.
double NiceStep(double span, int max_ticks);

/// A tick value with as many decimals as the step needs.
std::string TickLabel(double value, double step);

/// The multiples of step in [lo, hi].
std::vector<double> Ticks(double lo, double hi, double step);

/// A 1-pixel outline of r.
void DrawFrame(Canvas* canvas, const Rect& r, const Rgb& color);

/// The title (bold) and the subtitle under it, at the top left.
void DrawTitles(Canvas* canvas, const std::string& title, const std::string& subtitle);

/// Text of kTextSize with its capitals centred on row y.
void TextCentredOn(Canvas* canvas, double x, double y, const std::string& text, const Rgb& color);

/// A legend swatch and its text, one row at (x, y); returns the next row's y.
int LegendRow(Canvas* canvas, int x, int y, const Rgb& color, const std::string& text);

/// A black scale bar in the lower left corner of `plot`, a round length (1, 2 or 5 times a
/// power of ten metres, about a fifth of span_m) at px_per_m, with its length written above.
void DrawScaleBar(Canvas* canvas, const Rect& plot, double px_per_m, double span_m);

}  // namespace rigfit::plot
