#include "io/png.h"

#include <png.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <memory>

#include "core/errors.h"
#include "io/atomic_file.h"

namespace rigfit {
namespace {

/// Largest image read, in pixels (as io/capture_h5.cc's dataset bound): a damaged header
/// cannot make rigfit allocate more.
constexpr png_uint_32 kMaxPixels = png_uint_32{1} << 28;
/// Bytes of the PNG signature.
constexpr int kSignatureBytes = 8;

png_image NewPngImage() {
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  return image;
}

/// Writes `pixels` in the simplified API's `format`, atomically.
void WriteSimplified(const std::string& path, int width, int height, png_uint_32 format,
                     const void* pixels) {
  WriteFileAtomically(path, [&](const std::string& tmp_path) {
    png_image png = NewPngImage();
    png.width = static_cast<png_uint_32>(width);
    png.height = static_cast<png_uint_32>(height);
    png.format = format;
    if (!png_image_write_to_file(&png, tmp_path.c_str(), 0, pixels, 0, nullptr)) {
      throw InputError(path + ": cannot write PNG: " + png.message);
    }
  });
}

/// The message of the libpng error that ended a classic-API read.
struct PngError {
  std::string text;
};

void OnPngError(png_structp png, png_const_charp message) {
  static_cast<PngError*>(png_get_error_ptr(png))->text = message;
  png_longjmp(png, 1);
}

void OnPngWarning(png_structp, png_const_charp) {}

std::string DescribePixelFormat(int bit_depth, int color_type) {
  std::string kind;
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY:
      kind = "greyscale";
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      kind = "greyscale + alpha";
      break;
    case PNG_COLOR_TYPE_PALETTE:
      kind = "palette";
      break;
    case PNG_COLOR_TYPE_RGB:
      kind = "RGB";
      break;
    case PNG_COLOR_TYPE_RGB_ALPHA:
      kind = "RGBA";
      break;
    default:
      kind = "colour type " + std::to_string(color_type);
  }
  return std::to_string(bit_depth) + "-bit " + kind;
}

bool HostIsLittleEndian() {
  const std::uint16_t one = 1;
  std::uint8_t first = 0;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// The classic-API part of ReadPngGrey16 (the simplified API would apply a gamma conversion
/// to 16-bit files with a gAMA chunk). libpng reports errors by longjmp to the setjmp here,
/// so this function holds no object with a destructor: the pixels and the row pointers are
/// the caller's. Returns false with error->text set when the file is no 16-bit grey PNG.
bool ReadGrey16Pixels(std::FILE* file, PngError* error, Grey16Raster* out,
                      std::vector<png_bytep>* rows) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, error, OnPngError, OnPngWarning);
  if (png == nullptr) {
    error->text = "out of memory";
    return false;
  }
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_read_struct(&png, nullptr, nullptr);
    error->text = "out of memory";
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, file);
  png_set_sig_bytes(png, kSignatureBytes);
  png_read_info(png, info);
  const png_uint_32 width = png_get_image_width(png, info);
  const png_uint_32 height = png_get_image_height(png, info);
  const int bit_depth = png_get_bit_depth(png, info);
  const int color_type = png_get_color_type(png, info);
  if (bit_depth != 16 || color_type != PNG_COLOR_TYPE_GRAY) {
    error->text = "expected a 16-bit greyscale PNG (depth), got " +
                  DescribePixelFormat(bit_depth, color_type);
  } else if (width == 0 || height == 0 || width > kMaxPixels / height) {
    error->text = "image of " + std::to_string(width) + "x" + std::to_string(height) +
                  " pixels is empty or too large";
  }
  if (!error->text.empty()) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  if (HostIsLittleEndian()) png_set_swap(png);  // PNG stores 16-bit samples big-endian
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  out->width = static_cast<int>(width);
  out->height = static_cast<int>(height);
  out->values.resize(static_cast<size_t>(width) * height);
  rows->resize(height);
  for (png_uint_32 y = 0; y < height; ++y) {
    (*rows)[y] = reinterpret_cast<png_bytep>(out->values.data() + static_cast<size_t>(y) * width);
  }
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

void WritePng(const std::string& path, const RgbRaster& image) {
  WriteSimplified(path, image.width, image.height, PNG_FORMAT_RGB, image.rgb.data());
}

RgbRaster ReadPng(const std::string& path) {
  png_image png = NewPngImage();
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    throw InputError(path + ": cannot read PNG: " + png.message);
  }
  png.format = PNG_FORMAT_RGB;
  RgbRaster image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr)) {
    png_image_free(&png);
    throw InputError(path + ": cannot read PNG: " + png.message);
  }
  return image;
}

void WritePngGrey16(const std::string& path, const Grey16Raster& image) {
  // The simplified API writes linear 16-bit grey as given (no alpha, so no conversion).
  WriteSimplified(path, image.width, image.height, PNG_FORMAT_LINEAR_Y, image.values.data());
}

Grey16Raster ReadPngGrey16(const std::string& path) {
  const std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                             &std::fclose);
  if (!file) throw InputError(path + ": cannot open: " + std::strerror(errno));
  png_byte signature[kSignatureBytes];
  if (std::fread(signature, 1, kSignatureBytes, file.get()) != kSignatureBytes ||
      png_sig_cmp(signature, 0, kSignatureBytes) != 0) {
    throw InputError(path + ": cannot read PNG: not a PNG file");
  }
  PngError error;
  Grey16Raster image;
  std::vector<png_bytep> rows;
  if (!ReadGrey16Pixels(file.get(), &error, &image, &rows)) {
    throw InputError(path + ": cannot read PNG: " + error.text);
  }
  return image;
}

}  // namespace rigfit
