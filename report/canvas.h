// A picture drawn with Cairo (Debian libcairo2-dev) on an RGB image surface: anti-aliased
// lines and discs, filled rectangles, and text in DejaVu Sans through Cairo's toy text API.
// Coordinates are pixels with pixel centres at integer coordinates (the pixel at column x,
// row y covers [x - 0.5, x + 0.5] x [y - 0.5, y + 0.5]), so that a 1-pixel line at an
// integer coordinate fills exactly one row or column of pixels.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "report/image.h"

typedef struct _cairo_surface cairo_surface_t;
typedef struct _cairo cairo_t;

namespace rigfit {

class Canvas {
 public:
  /// A width x height picture filled with `background`.
  Canvas(int width, int height, const Rgb& background);
  ~Canvas();
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  /// Height of a capital letter in em (DejaVu Sans): text of size s has capitals
  /// kCapHeight * s pixels tall.
  static constexpr double kCapHeight = 0.729;

  int width() const { return width_; }
  int height() const { return height_; }

  /// Fills the pixels x in [x0, x1), y in [y0, y1) (integer bounds: no anti-aliased edge).
  void FillRect(int x0, int y0, int x1, int y1, const Rgb& color);
  /// A straight line from (x0, y0) to (x1, y1), `width` pixels wide, square ends (a
  /// 1-pixel line covers both end pixels).
  void Line(double x0, double y0, double x1, double y1, const Rgb& color, double width = 1.0);
  /// A polyline through the points, `width` pixels wide, round joins and ends.
  void Polyline(const std::vector<std::pair<double, double>>& points, const Rgb& color,
                double width);
  /// A filled disc of the given radius (pixels) centred at (cx, cy).
  void Disc(double cx, double cy, double radius, const Rgb& color);

  /// Width in pixels of one line of `text` at font size `size` (pixels per em).
  double TextWidth(const std::string& text, double size, bool bold = false);
  /// One line of text whose capital letters span rows [y, y + about 0.73 size] (descenders
  /// go below), starting at column x. Invalid UTF-8 and control characters are drawn as '?'.
  void Text(double x, double y, const std::string& text, const Rgb& color, double size,
            bool bold = false);

  /// The picture as an RGB image.
  Image ToImage() const;
  /// Replaces the picture's pixels by `image` (of the same size): for layers computed per
  /// pixel, such as a point density.
  void SetImage(const Image& image);

 private:
  void SetColor(const Rgb& color);
  void SetFont(double size, bool bold);
  /// Throws std::runtime_error if Cairo reports an error (a programming error: Cairo
  /// otherwise ignores every later call silently).
  void Check() const;

  int width_ = 0;
  int height_ = 0;
  cairo_surface_t* surface_ = nullptr;
  cairo_t* cr_ = nullptr;
};

/// `text` as valid UTF-8 without control characters: each byte of an invalid sequence and
/// each control character (below 32, and 127) replaced by '?'.
std::string DrawableText(const std::string& text);

}  // namespace rigfit
