// How a message names an option: as the CLI's flag (`--noise-corr-px`) or as the Python
// keyword and struct field (`noise_corr_px`). The checks the CLI and the Python module share
// (sim/simulate_rig.h, rgbd/tracking_options.h) take the spelling of their caller, so that
// each reads its own names in the same message.
#pragma once

#include <string>
#include <string_view>

namespace rigfit {

enum class OptionSpelling {
  kFlag,     ///< "--noise-corr-px"
  kKeyword,  ///< "noise_corr_px"
};

/// `key` (a keyword, words joined by '_') spelled as asked: "noise_corr_px" or
/// "--noise-corr-px".
inline std::string OptionName(std::string_view key, OptionSpelling spelling) {
  if (spelling == OptionSpelling::kKeyword) return std::string(key);
  std::string flag = "--";
  for (const char c : key) flag += c == '_' ? '-' : c;
  return flag;
}

}  // namespace rigfit
