// A bad setting, apart from how a front end names it. The checks the CLI and the Python module
// share (sim/simulate_rig.h, rgbd/tracking_options.h, rgbd/slam_options.h,
// io/rgbd_sequence.h, core/trajectory.h) throw SettingError: the setting's key (words joined by
// '_', as the options structs and Python name it: "noise_corr_px") and the problem, with any
// setting it names written {key}. Each front end spells them its own way: the CLI as flags
// ("simulate: --noise-corr-share > 0 needs --noise-corr-px > 0", cli/commands.cc), Python as
// keywords (python/keywords.h); what() spells them as keys.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "core/errors.h"

namespace rigfit {

class SettingError : public InputError {
 public:
  /// `key` is wrong as `problem` says: the message "{key} <problem>".
  SettingError(const std::string& key, const std::string& problem)
      : SettingError(key, "{" + key + "} " + problem, 0) {}

  /// A message worded freely, the settings in it written {key}: "need 0 <= {min_depth} <
  /// {max_depth}".
  static SettingError Worded(const std::string& key, const std::string& message) {
    return SettingError(key, message, 0);
  }

  const std::string& key() const { return key_; }

  /// The message with every {key} spelled by `spell`.
  std::string Spelled(const std::function<std::string(std::string_view key)>& spell) const {
    return Spell(message_, spell);
  }

  /// A key as a CLI flag: "noise_corr_px" -> "--noise-corr-px".
  static std::string Flag(std::string_view key) {
    std::string flag = "--";
    for (const char c : key) flag += c == '_' ? '-' : c;
    return flag;
  }

  /// A key as itself (Python's keywords, the options' fields).
  static std::string Key(std::string_view key) { return std::string(key); }

 private:
  SettingError(const std::string& key, const std::string& message, int /*worded*/)
      : InputError(Spell(message, Key)), key_(key), message_(message) {}

  /// `message` with each {key} (lower-case letters, digits and '_') spelled by `spell`; other
  /// braces (a user's value) kept.
  static std::string Spell(const std::string& message,
                           const std::function<std::string(std::string_view key)>& spell) {
    std::string out;
    std::size_t at = 0;
    for (std::size_t open = message.find('{'); open != std::string::npos;
         open = message.find('{', open + 1)) {
      const std::size_t close = message.find('}', open);
      if (close == std::string::npos) break;
      const std::string_view key = std::string_view(message).substr(open + 1, close - open - 1);
      const bool is_key =
          !key.empty() &&
          key.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") == std::string_view::npos;
      if (!is_key) continue;
      out += message.substr(at, open - at) + spell(key);
      at = close + 1;
      open = close;
    }
    return out + message.substr(at);
  }

  std::string key_;
  std::string message_;
};

}  // namespace rigfit
