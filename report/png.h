// PNG files of the report, through libpng's simplified API (libpng 1.6).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "report/image.h"

namespace rigfit {

/// Writes an 8-bit RGB PNG. Atomic (temporary file + rename, io/atomic_file.h). Throws
/// InputError naming the file when it cannot be written.
void WritePng(const std::string& path, const Image& image);

/// Reads any PNG as 8-bit RGB (alpha composited onto black, palettes and grey expanded).
/// Throws InputError naming the file when it cannot be read or is not a PNG.
Image ReadPng(const std::string& path);

/// Writes a 16-bit greyscale PNG of width x height row-major values (e.g. a TUM RGB-D depth
/// image: metres x 5000, 0 invalid), stored as given: no gamma or colour chunk. Atomic.
/// Throws InputError naming the file when it cannot be written.
void WritePngGray16(const std::string& path, int width, int height,
                    const std::vector<std::uint16_t>& values);

/// Reads a 16-bit greyscale PNG exactly as stored (no gamma conversion), row-major; sets
/// *width and *height. Throws InputError naming the file when it cannot be read or is not a
/// 16-bit greyscale PNG.
std::vector<std::uint16_t> ReadPngGray16(const std::string& path, int* width, int* height);

}  // namespace rigfit
