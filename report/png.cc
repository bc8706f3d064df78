#include "report/png.h"

#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <memory>

#include "core/errors.h"
#include "io/atomic_file.h"

namespace rigfit {
namespace {

png_image NewPngImage() {
  png_image image;
  std::memset(&image, 0, sizeof(image));
  image.version = PNG_IMAGE_VERSION;
  return image;
}

/// A FILE* closed on scope exit.
using File = std::unique_ptr<std::FILE, int (*)(std::FILE*)>;

/// libpng's error callback: the message, then back to the setjmp point.
void OnPngError(png_structp png, png_const_charp message) {
  auto* error = static_cast<char*>(png_get_error_ptr(png));
  std::snprintf(error, 256, "%s", message);
  png_longjmp(png, 1);
}

void OnPngWarning(png_structp, png_const_charp) {}

/// PNG stores 16-bit samples big-endian; libpng swaps them to and from the host's order.
void UseHostByteOrder(png_structp png) {
  const std::uint16_t one = 1;
  if (*reinterpret_cast<const unsigned char*>(&one) == 1) png_set_swap(png);
}

/// Writes the rows with libpng's full API (the simplified one treats 16-bit samples as
/// linear light and adds a gAMA chunk). Returns false with *error set on failure.
bool WriteGray16(std::FILE* file, int width, int height, const std::vector<png_bytep>& rows,
                 char* error) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, error, OnPngError, OnPngWarning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 16,
               PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  UseHostByteOrder(png);
  png_write_image(png, const_cast<png_bytepp>(rows.data()));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

/// Reads a 16-bit grey PNG into *values (rows: scratch owned by the caller, as nothing with a
/// destructor may live between setjmp and longjmp); false with *error set on failure.
bool ReadGray16(std::FILE* file, int* width, int* height, std::vector<std::uint16_t>* values,
                std::vector<png_bytep>* rows, char* error) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, error, OnPngError, OnPngWarning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  png_init_io(png, file);
  png_read_info(png, info);
  if (png_get_bit_depth(png, info) != 16 || png_get_color_type(png, info) != PNG_COLOR_TYPE_GRAY) {
    std::snprintf(error, 256, "not a 16-bit greyscale PNG");
    png_destroy_read_struct(&png, &info, nullptr);
    return false;
  }
  *width = static_cast<int>(png_get_image_width(png, info));
  *height = static_cast<int>(png_get_image_height(png, info));
  UseHostByteOrder(png);
  values->assign(static_cast<size_t>(*width) * *height, 0);
  rows->resize(*height);
  for (int y = 0; y < *height; ++y) {
    (*rows)[y] = reinterpret_cast<png_bytep>(values->data() + static_cast<size_t>(y) * *width);
  }
  png_read_image(png, rows->data());
  png_read_end(png, nullptr);
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

}  // namespace

void WritePngGray16(const std::string& path, int width, int height,
                    const std::vector<std::uint16_t>& values) {
  if (width < 1 || height < 1 || values.size() != static_cast<size_t>(width) * height) {
    throw InputError(path + ": cannot write PNG: " + std::to_string(values.size()) +
                     " values for " + std::to_string(width) + "x" + std::to_string(height));
  }
  WriteFileAtomically(path, [&](const std::string& tmp_path) {
    std::vector<png_bytep> rows(height);
    for (int y = 0; y < height; ++y) {
      rows[y] = reinterpret_cast<png_bytep>(const_cast<std::uint16_t*>(values.data()) +
                                            static_cast<size_t>(y) * width);
    }
    char error[256] = "";
    File file(std::fopen(tmp_path.c_str(), "wb"), &std::fclose);
    if (!file || !WriteGray16(file.get(), width, height, rows, error)) {
      throw InputError(path + ": cannot write PNG: " + (file ? error : std::strerror(errno)));
    }
    if (std::fclose(file.release()) != 0) {
      throw InputError(path + ": cannot write PNG: " + std::strerror(errno));
    }
  });
}

std::vector<std::uint16_t> ReadPngGray16(const std::string& path, int* width, int* height) {
  char error[256] = "";
  std::vector<std::uint16_t> values;
  std::vector<png_bytep> rows;
  const File file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file || !ReadGray16(file.get(), width, height, &values, &rows, error)) {
    throw InputError(path + ": cannot read PNG: " + (file ? error : std::strerror(errno)));
  }
  return values;
}

void WritePng(const std::string& path, const Image& image) {
  WriteFileAtomically(path, [&](const std::string& tmp_path) {
    png_image png = NewPngImage();
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    if (!png_image_write_to_file(&png, tmp_path.c_str(), 0, image.rgb.data(), 0, nullptr)) {
      throw InputError(path + ": cannot write PNG: " + png.message);
    }
  });
}

Image ReadPng(const std::string& path) {
  png_image png = NewPngImage();
  if (!png_image_begin_read_from_file(&png, path.c_str())) {
    throw InputError(path + ": cannot read PNG: " + png.message);
  }
  png.format = PNG_FORMAT_RGB;
  Image image;
  image.width = static_cast<int>(png.width);
  image.height = static_cast<int>(png.height);
  image.rgb.resize(PNG_IMAGE_SIZE(png));
  if (!png_image_finish_read(&png, nullptr, image.rgb.data(), 0, nullptr)) {
    png_image_free(&png);
    throw InputError(path + ": cannot read PNG: " + png.message);
  }
  return image;
}

}  // namespace rigfit
