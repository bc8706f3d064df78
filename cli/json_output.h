// JSON output shared by the commands that write a report file (`evaluate --json`,
// `compare --json`).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace rigfit::cli {

/// Writes `json` (indent 2, a final newline) to path, atomically (io/atomic_file.h).
/// Throws InputError naming the file when it cannot be written.
void WriteJsonFile(const std::string& path, const nlohmann::json& json);

}  // namespace rigfit::cli
