// Small helpers of the tests that run programs through /bin/sh (tests/cli_test_util.h,
// tests/chromium_test_util.h): a file's text and shell quoting.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace rigfit::shell_test {

/// The whole file (empty when it cannot be read).
inline std::string ReadText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// Single-quoted for /bin/sh.
inline std::string ShellQuote(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

}  // namespace rigfit::shell_test
