// Headless Chromium (Debian package chromium, installed by scripts/setup.sh) for the tests
// that open a report's pages: finding it, and running it on a page.
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "shell_test_util.h"

namespace rigfit::testing {

using rigfit::shell_test::ReadText;
using rigfit::shell_test::ShellQuote;

/// Why a test without chromium does not run.
inline constexpr const char* kNoChromium =
    "chromium is not installed (scripts/setup.sh installs Debian's chromium): the report's "
    "pages are not opened in a browser";

/// The chromium executable on PATH, or empty.
inline std::string FindChromium() {
  const char* path = std::getenv("PATH");
  std::string dirs = path ? path : "/usr/bin";
  for (size_t start = 0; start <= dirs.size();) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::filesystem::path candidate =
        std::filesystem::path(dirs.substr(start, end - start)) / "chromium";
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
    start = end + 1;
  }
  return "";
}

/// True in continuous integration (CI=true), where a missing chromium fails the tests that
/// need it instead of skipping them.
inline bool RunningInCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) == "true";
}

/// A run of headless chromium: its exit status, stdout and stderr.
struct ChromiumRun {
  int status = -1;
  std::string command;
  std::string out;
  std::string err;
  bool Ok() const { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }
};

/// Runs headless chromium on `url` with `options`, its profile and output files in `work_dir`
/// (a profile of its own, so that runs in parallel do not share one). WebGL is drawn by
/// SwiftShader (no GPU). A timeout of 60 s guards against a browser that never exits.
inline ChromiumRun RunChromium(const std::string& chromium, const std::filesystem::path& work_dir,
                               const std::string& options, const std::string& url) {
  const std::filesystem::path out = work_dir / "chromium_stdout.txt";
  const std::filesystem::path err = work_dir / "chromium_stderr.txt";
  ChromiumRun run;
  run.command = "timeout 60 " + ShellQuote(chromium) +
                " --headless --no-sandbox --hide-scrollbars --no-first-run "
                "--use-angle=swiftshader --enable-unsafe-swiftshader --user-data-dir=" +
                ShellQuote((work_dir / "profile").string()) + " " + options + " " +
                ShellQuote(url) + " >" + ShellQuote(out.string()) + " 2>" +
                ShellQuote(err.string());
  run.status = std::system(run.command.c_str());
  run.out = ReadText(out);
  run.err = ReadText(err);
  return run;
}

/// file:// URL of a page.
inline std::string FileUrl(const std::filesystem::path& page) {
  return "file://" + std::filesystem::absolute(page).string();
}

}  // namespace rigfit::testing
