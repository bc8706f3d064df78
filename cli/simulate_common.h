// What the simulators' commands (`simulate`, `simulate-sequence`) share: the output
// directory (created if missing, an earlier result kept unless --force), the image size
// limits and the --seed option.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

namespace rigfit::cli {

/// Creates dir if missing (its parent must exist) and, unless force, refuses to overwrite
/// an earlier result: throws InputError (prefixed "<command>: ") when dir exists and is not
/// a directory, cannot be created, or holds any of `outputs` (names relative to dir, files
/// or folders); with `outputs` empty, when dir holds anything at all.
void PrepareOutputDir(const std::string& command, const std::string& dir, bool force,
                      const std::vector<std::string>& outputs);

inline constexpr int kMinImageSize = 16;  ///< pixels, width or height
inline constexpr int kMaxImageSize = 8192;

/// Throws InputError ("<command>: --width must be in [16, 8192] pixels, got ...") unless
/// both sides are within [kMinImageSize, kMaxImageSize].
void CheckImageSize(const std::string& command, int width, int height);

/// Adds --seed to sub: any unsigned 64-bit value, a negative one refused (CLI11 would wrap it
/// around into the unsigned seed).
CLI::Option* AddSeedOption(CLI::App* sub, std::uint64_t* seed, const std::string& description);

}  // namespace rigfit::cli
