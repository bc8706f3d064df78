// Numbers as text for progress messages and reports.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

namespace rigfit {

/// `value` in fixed notation with `digits` decimals.
inline std::string Fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

/// The items separated by `separator`.
inline std::string Join(const std::vector<std::string>& items,
                        const std::string& separator = ", ") {
  std::string text;
  for (size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

}  // namespace rigfit
