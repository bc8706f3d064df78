#include "cli/simulate_common.h"

#include <filesystem>

#include "core/errors.h"

namespace rigfit::cli {

namespace fs = std::filesystem;

void PrepareOutputDir(const std::string& command, const std::string& dir_name, bool force,
                      const std::vector<std::string>& outputs) {
  const fs::path dir(dir_name);
  std::error_code ec;
  if (fs::exists(dir, ec)) {
    if (!fs::is_directory(dir, ec)) {
      throw InputError(command + ": --out " + dir_name + " exists and is not a directory");
    }
  } else {
    const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
    if (!fs::is_directory(parent, ec)) {
      throw InputError(command + ": --out " + dir_name + ": parent directory " + parent.string() +
                       " does not exist");
    }
    if (!fs::create_directory(dir, ec) && ec) {
      throw InputError(command + ": cannot create --out " + dir_name + ": " + ec.message());
    }
  }
  if (force) return;
  if (outputs.empty()) {
    if (!fs::is_empty(dir, ec)) {
      throw InputError(command + ": --out " + dir_name +
                       " is not empty; pass --force to write into it");
    }
    return;
  }
  for (const std::string& name : outputs) {
    const fs::path file = dir / name;
    if (fs::exists(file, ec)) {
      throw InputError(command + ": " + file.string() +
                       " already exists; pass --force to overwrite it");
    }
  }
}

CLI::Option* AddSeedOption(CLI::App* sub, std::uint64_t* seed, const std::string& description) {
  return sub->add_option("--seed", *seed, description)
      ->check([](const std::string& value) {
        return value.find('-') == std::string::npos ? std::string() : "must not be negative";
      })
      ->capture_default_str();
}

}  // namespace rigfit::cli
