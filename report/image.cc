#include "report/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

// stb_easy_font defines every function static in the header; the ones not used here would
// warn.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#include <stb_easy_font.h>
#pragma GCC diagnostic pop

namespace rigfit {
namespace {

/// stb_easy_font's glyphs span 0..9 font units below the top of a line (descenders
/// included); a line is 12 units.
constexpr int kGlyphUnits = 10;

/// The text with every character outside printable ASCII (32..126) replaced by '?': the
/// font's tables cover only those.
std::string Printable(const std::string& text) {
  std::string out = text;
  for (char& c : out) {
    if (c < 32 || c > 126) c = '?';
  }
  return out;
}

}  // namespace

std::string HexColor(const Rgb& color) {
  char text[8];
  std::snprintf(text, sizeof(text), "#%02x%02x%02x", color.r, color.g, color.b);
  return text;
}

Rgb Mix(const Rgb& a, const Rgb& b, double t) {
  t = std::clamp(t, 0.0, 1.0);
  const auto channel = [t](std::uint8_t x, std::uint8_t y) {
    return static_cast<std::uint8_t>(std::lround(x + t * (static_cast<double>(y) - x)));
  };
  return {channel(a.r, b.r), channel(a.g, b.g), channel(a.b, b.b)};
}

Image::Image(int width, int height, const Rgb& background)
    : RgbRaster{width, height, std::vector<std::uint8_t>(static_cast<size_t>(width) * height * 3)} {
  for (size_t i = 0; i < rgb.size(); i += 3) {
    rgb[i] = background.r;
    rgb[i + 1] = background.g;
    rgb[i + 2] = background.b;
  }
}

Rgb Image::At(int x, int y) const {
  const size_t i = (static_cast<size_t>(y) * width + x) * 3;
  return {rgb[i], rgb[i + 1], rgb[i + 2]};
}

void Image::Set(int x, int y, const Rgb& color) {
  if (!Contains(x, y)) return;
  const size_t i = (static_cast<size_t>(y) * width + x) * 3;
  rgb[i] = color.r;
  rgb[i + 1] = color.g;
  rgb[i + 2] = color.b;
}

void FillRect(Image* image, int x0, int y0, int x1, int y1, const Rgb& color) {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, image->width);
  y1 = std::min(y1, image->height);
  for (int y = y0; y < y1; ++y) {
    for (int x = x0; x < x1; ++x) image->Set(x, y, color);
  }
}

void DrawLine(Image* image, double x0, double y0, double x1, double y1, const Rgb& color,
              int width) {
  // One sample per pixel along the longer axis (a DDA), each stamped with the brush.
  const int steps = static_cast<int>(std::ceil(std::max(std::abs(x1 - x0), std::abs(y1 - y0))));
  const int before = (width - 1) / 2;
  for (int s = 0; s <= steps; ++s) {
    const double t = steps == 0 ? 0.0 : static_cast<double>(s) / steps;
    const int x = static_cast<int>(std::lround(x0 + t * (x1 - x0))) - before;
    const int y = static_cast<int>(std::lround(y0 + t * (y1 - y0))) - before;
    FillRect(image, x, y, x + width, y + width, color);
  }
}

void FillDisc(Image* image, double cx, double cy, double radius, const Rgb& color) {
  const int r = static_cast<int>(std::ceil(radius));
  const int x0 = static_cast<int>(std::lround(cx)), y0 = static_cast<int>(std::lround(cy));
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      if (dx * dx + dy * dy <= radius * radius) image->Set(x0 + dx, y0 + dy, color);
    }
  }
}

int TextHeight(int scale) { return kGlyphUnits * scale; }

int TextWidth(const std::string& text, int scale) {
  std::string printable = Printable(text);
  return stb_easy_font_width(printable.data()) * scale;
}

void DrawText(Image* image, int x, int y, const std::string& text, const Rgb& color, int scale) {
  std::string printable = Printable(text);
  // Each quad is 4 vertices of 16 bytes (x, y, z as float, colour as 4 bytes); the font
  // builds glyphs from axis-aligned unit-wide segments, so each quad is a rectangle.
  struct Vertex {
    float x, y, z;
    std::uint8_t color[4];
  };
  static_assert(sizeof(Vertex) == 16, "stb_easy_font vertex layout");
  std::vector<Vertex> vertices(printable.size() * 4 * 32);
  const int quads = stb_easy_font_print(0.0f, 0.0f, printable.data(), nullptr, vertices.data(),
                                        static_cast<int>(vertices.size() * sizeof(Vertex)));
  for (int q = 0; q < quads; ++q) {
    const Vertex& a = vertices[4 * q];
    const Vertex& c = vertices[4 * q + 2];
    FillRect(image, x + static_cast<int>(a.x) * scale, y + static_cast<int>(a.y) * scale,
             x + static_cast<int>(c.x) * scale, y + static_cast<int>(c.y) * scale, color);
  }
}

}  // namespace rigfit
