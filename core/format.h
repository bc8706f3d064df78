// Numbers as text for progress messages and reports.
#pragma once

#include <cstdio>
#include <string>

namespace rigfit {

/// `value` in fixed notation with `digits` decimals.
inline std::string Fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof(text), "%.*f", digits, value);
  return text;
}

}  // namespace rigfit
