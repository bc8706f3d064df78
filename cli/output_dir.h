// The output directory of the commands that write a set of files (`simulate`,
// `simulate-sequence`): created if missing, an earlier result kept unless --force.
#pragma once

#include <string>
#include <vector>

namespace rigfit::cli {

/// Creates dir if missing (its parent must exist) and, unless force, refuses to overwrite
/// an earlier result: throws InputError (prefixed "<command>: ") when dir exists and is not
/// a directory, cannot be created, or holds any of `outputs` (names relative to dir, files
/// or folders); with `outputs` empty, when dir holds anything at all.
void PrepareOutputDir(const std::string& command, const std::string& dir, bool force,
                      const std::vector<std::string>& outputs);

}  // namespace rigfit::cli
