#include "report/png.h"

#include <png.h>

#include <cstring>

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

}  // namespace

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
