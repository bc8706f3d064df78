// PNG files of the report, through libpng's simplified API (libpng 1.6).
#pragma once

#include <string>

#include "report/image.h"

namespace rigfit {

/// Writes an 8-bit RGB PNG. Atomic (temporary file + rename, io/atomic_file.h). Throws
/// InputError naming the file when it cannot be written.
void WritePng(const std::string& path, const Image& image);

/// Reads any PNG as 8-bit RGB (alpha composited onto black, palettes and grey expanded).
/// Throws InputError naming the file when it cannot be read or is not a PNG.
Image ReadPng(const std::string& path);

}  // namespace rigfit
