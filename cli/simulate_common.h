// What the simulators' commands (`simulate`, `simulate-sequence`) share: the output
// directory (created if missing, an earlier result kept unless --force) and the --seed
// option. The image size limits are sim/simulate_rig.h's (CheckSimImageSize), shared with
// rigfit.simulate.
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

/// Adds --seed to sub: any unsigned 64-bit value, a negative one refused (CLI11 would wrap it
/// around into the unsigned seed).
CLI::Option* AddSeedOption(CLI::App* sub, std::uint64_t* seed, const std::string& description);

}  // namespace rigfit::cli
