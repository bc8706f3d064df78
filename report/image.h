// A minimal RGB raster and the drawing primitives the report's plots need: filled
// rectangles, lines, discs and text (stb_easy_font's bitmap font, Debian libstb-dev).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "io/png.h"

namespace rigfit {

/// An 8-bit sRGB colour.
struct Rgb {
  std::uint8_t r = 0;
  std::uint8_t g = 0;
  std::uint8_t b = 0;

  bool operator==(const Rgb& o) const { return r == o.r && g == o.g && b == o.b; }
  bool operator!=(const Rgb& o) const { return !(*this == o); }
};

inline constexpr Rgb kWhite{255, 255, 255};
inline constexpr Rgb kBlack{0, 0, 0};

/// "#rrggbb".
std::string HexColor(const Rgb& color);

/// `a` moved toward `b` by `t` in [0, 1] (0 gives a, 1 gives b), per channel, rounded.
Rgb Mix(const Rgb& a, const Rgb& b, double t);

/// An RGB image to draw on: the pixels of io/png.h (row-major from the top-left pixel, 3 bytes
/// per pixel, written and read by WritePng and ReadPng) with pixel access.
struct Image : RgbRaster {
  Image() = default;
  Image(int width, int height, const Rgb& background);
  /// The pixels of a PNG read by ReadPng.
  Image(RgbRaster pixels) : RgbRaster(std::move(pixels)) {}  // NOLINT: implicit on purpose

  bool Contains(int x, int y) const { return x >= 0 && y >= 0 && x < width && y < height; }
  /// The pixel at column x, row y (must be inside).
  Rgb At(int x, int y) const;
  /// Sets the pixel at column x, row y; pixels outside are ignored (clipping).
  void Set(int x, int y, const Rgb& color);
};

/// Fills the pixels x in [x0, x1), y in [y0, y1), clipped to the image.
void FillRect(Image* image, int x0, int y0, int x1, int y1, const Rgb& color);

/// A straight line from (x0, y0) to (x1, y1), pixel centres at integer coordinates,
/// `width` pixels wide (a square brush), clipped to the image.
void DrawLine(Image* image, double x0, double y0, double x1, double y1, const Rgb& color,
              int width = 1);

/// A filled disc of the given radius (pixels) centred at (cx, cy).
void FillDisc(Image* image, double cx, double cy, double radius, const Rgb& color);

/// Height in pixels of one line of text at `scale` (stb_easy_font's cell is 12 units).
int TextHeight(int scale);
/// Width in pixels of `text` at `scale`.
int TextWidth(const std::string& text, int scale);

/// Draws one line of printable ASCII text with its top-left corner at (x, y), each font
/// unit `scale` pixels (2 reads comfortably). Other characters are drawn as '?'.
void DrawText(Image* image, int x, int y, const std::string& text, const Rgb& color, int scale = 2);

}  // namespace rigfit
