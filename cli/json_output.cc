#include "cli/json_output.h"

#include "io/atomic_file.h"

namespace rigfit::cli {

void WriteJsonFile(const std::string& path, const nlohmann::json& json) {
  const std::string text = json.dump(2) + "\n";
  WriteTextFileAtomically(path, text);
}

}  // namespace rigfit::cli
