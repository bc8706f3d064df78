// Fuzz target: the YAML config loader (io/config_yaml.h ParseConfig) on arbitrary text.
// Rejecting the text with InputError is correct behaviour; anything else (another exception,
// a crash, a sanitizer report, a leak, a hang) is a finding.
#include <cstddef>
#include <cstdint>
#include <string>

#include "core/errors.h"
#include "io/config_yaml.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const rigfit::RefineOptions options = rigfit::ParseConfig(text, "fuzz.yaml");
    // What loads must write back and load again to the same options.
    const std::string yaml = rigfit::ConfigToYaml(options);
    if (rigfit::ConfigToYaml(rigfit::ParseConfig(yaml, "fuzz-roundtrip.yaml")) != yaml) {
      __builtin_trap();
    }
  } catch (const rigfit::InputError&) {
  }
  return 0;
}
