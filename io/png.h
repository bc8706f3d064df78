// PNG files through libpng 1.6: 8-bit RGB (the report's plots, TUM colour images) and 16-bit
// greyscale (the depth images of TUM RGB-D, ICL-NUIM and 7-Scenes). In io/ so that the
// sequence loaders and report/ share one libpng wrapper.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace rigfit {

/// 8-bit RGB pixels, row-major from the top-left pixel, 3 bytes per pixel.
struct RgbRaster {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;
};

/// 16-bit greyscale pixels as stored in the file (host byte order), row-major from the
/// top-left pixel.
struct Grey16Raster {
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> values;
};

/// Writes an 8-bit RGB PNG. Atomic (temporary file + rename, io/atomic_file.h). Throws
/// InputError naming the file when it cannot be written.
void WritePng(const std::string& path, const RgbRaster& image);

/// Reads any PNG as 8-bit RGB (alpha composited onto black, palettes and grey expanded).
/// Throws InputError naming the file when it cannot be read or is not a PNG.
RgbRaster ReadPng(const std::string& path);

/// Writes a 16-bit greyscale PNG, the values exactly (big-endian on disk, as PNG stores them).
/// Atomic. Throws InputError naming the file when it cannot be written.
void WritePngGrey16(const std::string& path, const Grey16Raster& image);

/// Reads a 16-bit greyscale PNG (colour type 0, bit depth 16: depth images) exactly, without
/// gamma or any other conversion. Throws InputError naming the file when it cannot be read,
/// is not a PNG, or has another colour type or bit depth (e.g. "d.png: expected a 16-bit
/// greyscale PNG (depth), got 8-bit RGB").
Grey16Raster ReadPngGrey16(const std::string& path);

}  // namespace rigfit
