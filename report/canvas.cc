#include "report/canvas.h"

#include <cairo.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace rigfit {
namespace {

/// The typeface of every text (fonts-dejavu-core; fontconfig substitutes a sans-serif face
/// when it is missing).
constexpr char kFontFamily[] = "DejaVu Sans";

/// Cairo's pixel edges are at integer coordinates; ours are at half-integers.
constexpr double kHalf = 0.5;

/// The length of the valid UTF-8 sequence starting at text[i] (at least 2 bytes), or 0.
size_t Utf8SequenceLength(const std::string& text, size_t i) {
  const auto byte = [&](size_t k) { return static_cast<unsigned char>(text[k]); };
  const unsigned char lead = byte(i);
  size_t length = 0;
  std::uint32_t code = 0;
  if (lead >= 0xC2 && lead <= 0xDF) {
    length = 2;
    code = lead & 0x1F;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    length = 3;
    code = lead & 0x0F;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    length = 4;
    code = lead & 0x07;
  } else {
    return 0;
  }
  if (i + length > text.size()) return 0;
  for (size_t k = 1; k < length; ++k) {
    if ((byte(i + k) & 0xC0) != 0x80) return 0;
    code = (code << 6) | (byte(i + k) & 0x3F);
  }
  const bool overlong = (length == 3 && code < 0x800) || (length == 4 && code < 0x10000);
  const bool surrogate = code >= 0xD800 && code <= 0xDFFF;
  if (overlong || surrogate || code > 0x10FFFF || (code >= 0x80 && code < 0xA0)) return 0;
  return length;
}

}  // namespace

std::string DrawableText(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (size_t i = 0; i < text.size();) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x80) {
      out += c < 32 || c == 127 ? '?' : static_cast<char>(c);
      ++i;
    } else if (const size_t n = Utf8SequenceLength(text, i); n > 0) {
      out.append(text, i, n);
      i += n;
    } else {
      out += '?';
      ++i;
    }
  }
  return out;
}

Canvas::Canvas(int width, int height, const Rgb& background)
    : width_(width),
      height_(height),
      surface_(cairo_image_surface_create(CAIRO_FORMAT_RGB24, width, height)),
      cr_(cairo_create(surface_)) {
  try {
    Check();  // e.g. a size Cairo cannot allocate
  } catch (...) {
    cairo_destroy(cr_);
    cairo_surface_destroy(surface_);
    throw;
  }
  FillRect(0, 0, width, height, background);
}

Canvas::~Canvas() {
  cairo_destroy(cr_);
  cairo_surface_destroy(surface_);
}

void Canvas::Check() const {
  const cairo_status_t status = cairo_status(cr_);
  if (status != CAIRO_STATUS_SUCCESS) {
    throw std::runtime_error(std::string("cairo: ") + cairo_status_to_string(status));
  }
}

void Canvas::SetColor(const Rgb& color) {
  cairo_set_source_rgb(cr_, color.r / 255.0, color.g / 255.0, color.b / 255.0);
}

void Canvas::SetFont(double size, bool bold) {
  cairo_select_font_face(cr_, kFontFamily, CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr_, size);
}

void Canvas::FillRect(int x0, int y0, int x1, int y1, const Rgb& color) {
  if (x1 <= x0 || y1 <= y0) return;
  SetColor(color);
  cairo_rectangle(cr_, x0, y0, x1 - x0, y1 - y0);
  cairo_fill(cr_);
  Check();
}

void Canvas::Line(double x0, double y0, double x1, double y1, const Rgb& color, double width) {
  SetColor(color);
  cairo_set_line_width(cr_, width);
  cairo_set_line_cap(cr_, CAIRO_LINE_CAP_SQUARE);
  cairo_move_to(cr_, x0 + kHalf, y0 + kHalf);
  cairo_line_to(cr_, x1 + kHalf, y1 + kHalf);
  cairo_stroke(cr_);
  Check();
}

void Canvas::Polyline(const std::vector<std::pair<double, double>>& points, const Rgb& color,
                      double width) {
  if (points.empty()) return;
  SetColor(color);
  cairo_set_line_width(cr_, width);
  cairo_set_line_cap(cr_, CAIRO_LINE_CAP_ROUND);
  cairo_set_line_join(cr_, CAIRO_LINE_JOIN_ROUND);
  cairo_move_to(cr_, points.front().first + kHalf, points.front().second + kHalf);
  for (size_t i = 1; i < points.size(); ++i) {
    cairo_line_to(cr_, points[i].first + kHalf, points[i].second + kHalf);
  }
  cairo_stroke(cr_);
  Check();
}

void Canvas::Disc(double cx, double cy, double radius, const Rgb& color) {
  SetColor(color);
  cairo_new_path(cr_);
  cairo_arc(cr_, cx + kHalf, cy + kHalf, radius, 0.0, 2.0 * M_PI);
  cairo_fill(cr_);
  Check();
}

double Canvas::TextWidth(const std::string& text, double size, bool bold) {
  SetFont(size, bold);
  cairo_text_extents_t extents;
  cairo_text_extents(cr_, DrawableText(text).c_str(), &extents);
  Check();
  return extents.x_advance;
}

void Canvas::Text(double x, double y, const std::string& text, const Rgb& color, double size,
                  bool bold) {
  // The baseline goes a capital's height below y.
  SetFont(size, bold);
  SetColor(color);
  cairo_move_to(cr_, x, y + kCapHeight * size);
  cairo_show_text(cr_, DrawableText(text).c_str());
  cairo_new_path(cr_);
  Check();
}

Image Canvas::ToImage() const {
  cairo_surface_flush(surface_);
  const unsigned char* data = cairo_image_surface_get_data(surface_);
  const int stride = cairo_image_surface_get_stride(surface_);
  Image image(width_, height_, kBlack);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      std::uint32_t pixel;  // 0x00RRGGBB in the host's byte order
      std::memcpy(&pixel, data + static_cast<size_t>(y) * stride + 4 * x, sizeof(pixel));
      image.Set(x, y,
                Rgb{static_cast<std::uint8_t>(pixel >> 16), static_cast<std::uint8_t>(pixel >> 8),
                    static_cast<std::uint8_t>(pixel)});
    }
  }
  return image;
}

void Canvas::SetImage(const Image& image) {
  if (image.width != width_ || image.height != height_) {
    throw std::invalid_argument("Canvas::SetImage: the image is not the canvas' size");
  }
  cairo_surface_flush(surface_);
  unsigned char* data = cairo_image_surface_get_data(surface_);
  const int stride = cairo_image_surface_get_stride(surface_);
  for (int y = 0; y < height_; ++y) {
    for (int x = 0; x < width_; ++x) {
      const Rgb c = image.At(x, y);
      const std::uint32_t pixel = (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
      std::memcpy(data + static_cast<size_t>(y) * stride + 4 * x, &pixel, sizeof(pixel));
    }
  }
  cairo_surface_mark_dirty(surface_);
}

}  // namespace rigfit
