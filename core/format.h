// Numbers as text for progress messages and reports.
#pragma once

#include <cstdarg>
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

/// Appends printf(format, ...) to *text: a command's output assembled before it is printed
/// (and shown again in a report's page).
inline void Appendf(std::string* text, const char* format, ...)
    __attribute__((format(printf, 2, 3)));
inline void Appendf(std::string* text, const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(nullptr, 0, format, copy);
  va_end(copy);
  if (n > 0) {
    const size_t old = text->size();
    text->resize(old + static_cast<size_t>(n) + 1);
    std::vsnprintf(&(*text)[old], static_cast<size_t>(n) + 1, format, args);
    text->resize(old + static_cast<size_t>(n));
  }
  va_end(args);
}

/// The items separated by `separator`.
inline std::string Join(const std::vector<std::string>& items,
                        const std::string& separator = ", ") {
  std::string text;
  for (size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

}  // namespace rigfit
