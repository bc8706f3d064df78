#include "report/image.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rigfit {

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

}  // namespace rigfit
