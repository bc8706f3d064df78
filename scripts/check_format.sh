#!/usr/bin/env bash
# Fails, naming each file and line, when a tracked C++ file is not formatted as the repository's
# .clang-format says (clang-format --dry-run --Werror); `clang-format -i FILE` fixes it.
# Run by ctest as the test clang_format (tests/CMakeLists.txt).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
command -v clang-format >/dev/null || {
  echo "check_format.sh: clang-format is missing (scripts/setup.sh installs it)" >&2
  exit 2
}
if git rev-parse --is-inside-work-tree >/dev/null 2>&1; then
  files=$(git ls-files '*.cc' '*.h')
else  # a source tree without git: every C++ file outside build folders
  files=$(find . -path './build*' -prune -o \( -name '*.cc' -o -name '*.h' \) -print)
fi
# shellcheck disable=SC2086 # one file name per word (no spaces in the repository's names)
clang-format --dry-run --Werror $files
echo "check_format.sh: $(echo "$files" | wc -l) files formatted as .clang-format says"
