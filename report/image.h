// A minimal RGB raster: the pixels of a PNG (io/png.h) and of a drawn picture
// (report/canvas.h).
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

}  // namespace rigfit
